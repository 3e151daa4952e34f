//! Other tools' formats end to end: a capture rewritten as another instrument would
//! write it (renamed columns, `;`, decimal commas, radians, the other theta_r sign) is
//! imported back to the same readings and fits to the same parameters.

use crate::util::{gonio, scratch, simulated};

#[test]
fn another_instruments_table_imports_to_the_same_fit() {
    let d = scratch("formats");
    let sweep = simulated(&d, "fe-0.115");
    let data = std::fs::read_to_string(&sweep).unwrap();
    let mut table = String::from("Instrument export\nAOI [rad];AOS [rad];BRDF\n");
    let mut n = 0;
    for line in data
        .lines()
        .skip_while(|l| !l.starts_with("theta_i"))
        .skip(1)
    {
        let f: Vec<f64> = line
            .split(',')
            .take(3)
            .map(|x| x.parse().unwrap())
            .collect();
        // Radians with a decimal comma; theta_r positive on the source's side.
        let rad = |deg: f64| format!("{:.15}", deg.to_radians()).replace('.', ",");
        table.push_str(&format!(
            "{};{};{}\n",
            rad(f[0]),
            rad(-f[1]),
            f[2].to_string().replace('.', ",")
        ));
        n += 1;
    }
    let src = d.join("export.txt");
    std::fs::write(&src, table).unwrap();
    let back = d.join("back.csv");
    let out = gonio(&[
        "import",
        "table",
        src.to_str().unwrap(),
        "--out",
        back.to_str().unwrap(),
        "--skip-lines",
        "1",
        "--columns",
        "theta_i=aoi [rad],theta_r=AOS [RAD],brdf=brdf",
        "--decimal-comma",
        "--angles",
        "rad",
        "--theta-r-sign",
        "source",
        "--brdf",
        "relative",
    ]);
    assert!(
        out.ok() && !out.stderr.contains("warning"),
        "{}",
        out.stderr
    );
    let text = std::fs::read_to_string(&back).unwrap();
    assert!(text.contains("# brdf: relative\n") && text.contains("delimiter ';', decimal comma, angles in radians (converted), theta_r positive on the source's (negated) side"), "{text}");
    let rows: Vec<Vec<f64>> = text
        .lines()
        .skip_while(|l| !l.starts_with("theta_i"))
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), n);
    let orig: Vec<Vec<f64>> = data
        .lines()
        .skip_while(|l| !l.starts_with("theta_i"))
        .skip(1)
        .map(|l| l.split(',').take(3).map(|x| x.parse().unwrap()).collect())
        .collect();
    for (a, b) in rows.iter().zip(&orig) {
        // 15 decimals of a radian: about 1e-13 degrees.
        assert!(
            (a[0] - b[0]).abs() < 1e-9 && (a[1] - b[1]).abs() < 1e-9 && a[2] == b[2],
            "{a:?} vs {b:?}"
        );
    }
    // The same readings to about 1e-13 degrees: every fitted parameter agrees (in log
    // residuals: the table has no std column, whose noise the default objective would
    // weigh the original's readings by).
    let fit = |p: &std::path::Path| {
        let o = gonio(&["fit", p.to_str().unwrap(), "--residual", "log", "--json"]);
        assert!(o.ok(), "{}", o.stderr);
        let v: serde_json::Value = serde_json::from_str(&o.stdout).unwrap();
        v["models"].clone()
    };
    let (a, b) = (fit(&sweep), fit(&back));
    let (a, b) = (a.as_array().unwrap(), b.as_array().unwrap());
    assert_eq!(a.len(), b.len());
    let mut compared = 0;
    for (ma, mb) in a.iter().zip(b) {
        assert_eq!(ma["name"], mb["name"]);
        for (k, va) in ma["params"].as_object().unwrap() {
            // Scalars only (k_s is a table per incidence, the same readings either way).
            let Some(x) = va.as_f64() else { continue };
            let y = mb["params"][k].as_f64().unwrap();
            assert!(
                (x - y).abs() <= 1e-6 * x.abs().max(1e-9),
                "{} {k}: {x} vs {y}",
                ma["name"]
            );
            compared += 1;
        }
    }
    assert!(compared >= 3, "{compared} parameters compared");
}

/// An ASTM hemisphere grid (theta_i 30 degrees, theta_s 0..80 by 10, phi_s 0..350 by
/// 10, angles in radians) whose value tells where it was read: f = 1 + theta_s/100 +
/// phi_s/1000 (degrees; at theta_s = 0 without the phi_s term). In the plane: the 36
/// rows at theta_s = 0 (theta_r 0, f 1), phi_s = 180 (theta_r = +theta_s, f + 0.18) and
/// phi_s = 0 (theta_r = -theta_s): 36 + 2 * 8 = 52 of 324 rows; 272 are left out.
#[test]
fn an_astm_hemisphere_imports_its_plane_of_incidence() {
    let d = scratch("astm");
    let mut text =
        String::from("SOURCE hand-made\nNUM_POINTS 324\nVARS theta_i,phi_i,theta_s,phi_s,BRDF\n");
    for ts in (0..90).step_by(10) {
        for ps in (0..360).step_by(10) {
            let f = 1.0 + ts as f64 / 100.0 + if ts > 0 { ps as f64 / 1000.0 } else { 0.0 };
            let r = |deg: i32| (deg as f64).to_radians();
            text.push_str(&format!("{},0,{},{},{f}\n", r(30), r(ts), r(ps)));
        }
    }
    let src = d.join("grid.astm");
    std::fs::write(&src, text).unwrap();
    let out_path = d.join("grid.csv");
    let out = gonio(&[
        "import",
        "astm",
        src.to_str().unwrap(),
        "--out",
        out_path.to_str().unwrap(),
    ]);
    assert!(out.ok(), "{}", out.stderr);
    assert!(out.stderr.contains("272 of 324 rows"), "{}", out.stderr);
    let sweep = std::fs::read_to_string(&out_path).unwrap();
    assert!(
        sweep.contains("# brdf: 1/sr\n") && sweep.contains("# out-of-plane: 272 rows"),
        "{sweep}"
    );
    let rows: Vec<(f64, f64, f64)> = sweep
        .lines()
        .skip_while(|l| !l.starts_with("theta_i"))
        .skip(1)
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            (v[0], v[1], v[2])
        })
        .collect();
    // The normal (theta_s = 0) at each of 36 azimuths is one direction: one row
    // (issue 50 case 8: it weighed 36 times), said on stderr and in the file.
    assert_eq!(rows.len(), 52 - 35);
    assert!(
        out.stderr.contains("35 rows of") && sweep.contains("# repeats: 35 rows"),
        "{}",
        out.stderr
    );
    assert_eq!(rows.iter().filter(|r| r.1 == 0.0).count(), 1);
    for &(ti, tr, f) in &rows {
        assert!((ti - 30.0).abs() < 1e-9, "{ti}");
        let ts = tr.abs();
        let want = 1.0 + ts / 100.0 + if tr > 0.0 { 0.18 } else { 0.0 };
        assert!((f - want).abs() < 1e-9, "theta_r {tr}: {f} vs {want}");
    }
    assert_eq!(rows.iter().filter(|r| r.1 > 0.0).count(), 8);
    assert_eq!(rows.iter().filter(|r| r.1 < 0.0).count(), 8);
    let fit = gonio(&["fit", out_path.to_str().unwrap(), "--models", "ideal"]);
    assert!(fit.ok(), "{}", fit.stderr);
}

/// The committed RGL material imported on a few points gives the values the
/// independent Python evaluation printed (host-tool/tests/data/rgl_reference.py; the
/// same table as the unit test), in 1/sr.
#[test]
fn an_rgl_material_imports_as_the_reference_evaluates_it() {
    let d = scratch("rgl");
    let file =
        crate::util::repo_root().join("host-tool/tests/data/rgl_ilm_l3_37_metallic_rgb.bsdf");
    let out_path = d.join("l3.csv");
    let out = gonio(&[
        "import",
        "rgl",
        file.to_str().unwrap(),
        "--out",
        out_path.to_str().unwrap(),
        "--channel",
        "g",
        "--theta-i",
        "20",
        "--theta-r=-60,19.5,20",
    ]);
    assert!(
        out.ok() && !out.stderr.contains("warning"),
        "{}",
        out.stderr
    );
    let text = std::fs::read_to_string(&out_path).unwrap();
    assert!(
        text.contains("# brdf: 1/sr\n") && text.contains("channel g"),
        "{text}"
    );
    let got: Vec<f64> = text
        .lines()
        .skip_while(|l| !l.starts_with("theta_i"))
        .skip(1)
        .map(|l| l.rsplit(',').next().unwrap().parse().unwrap())
        .collect();
    let want = [0.0045988137576509335, 64.72360915251467, 72.0614879833187];
    assert_eq!(got.len(), 3);
    for (g, w) in got.iter().zip(want) {
        assert!((g - w).abs() <= 1e-9 * w, "{g} vs {w}");
    }
    // The default grid: the file's 7 incidences below 90 degrees x theta_r -89..89.
    let all = d.join("all.csv");
    let out = gonio(&[
        "import",
        "rgl",
        file.to_str().unwrap(),
        "--out",
        all.to_str().unwrap(),
    ]);
    assert!(out.ok(), "{}", out.stderr);
    let rows = std::fs::read_to_string(&all)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#'))
        .count()
        - 1;
    assert_eq!(rows, 7 * 179);
}

/// The committed hand-made spectral material imported at a wavelength between two of
/// the file's and as CIE Y gives the values the independent Python evaluation printed
/// (rgl_reference.py, the unit test's table), with the wavelength in the sweep's `#` lines.
#[test]
fn a_spectral_rgl_material_imports_as_the_reference_evaluates_it() {
    let d = scratch("rgl-spec");
    let file = crate::util::repo_root().join("host-tool/tests/data/rgl_spectral_handmade.bsdf");
    let import = |extra: &[&str], name: &str| {
        let out_path = d.join(name);
        let mut args = vec![
            "import",
            "rgl",
            file.to_str().unwrap(),
            "--out",
            out_path.to_str().unwrap(),
            "--theta-i",
            "20",
            "--theta-r=-40,15,50",
        ];
        args.extend(extra);
        let out = gonio(&args);
        assert!(out.ok(), "{}", out.stderr);
        let text = std::fs::read_to_string(&out_path).unwrap();
        let values: Vec<f64> = text
            .lines()
            .skip_while(|l| !l.starts_with("theta_i"))
            .skip(1)
            .map(|l| l.rsplit(',').next().unwrap().parse().unwrap())
            .collect();
        (text, values)
    };
    let (text, got) = import(&["--wavelength", "555"], "555.csv");
    assert!(
        text.contains("# brdf: 1/sr\n")
            && text.contains("# wavelength: 555 nm (linear between the file's 530 and 580 nm)\n")
            && text.contains("channel 555 nm")
            && text.contains("as powitacq BRDF::eval"),
        "{text}"
    );
    for (g, w) in got.iter().zip([0.34115161614594214, 0.14013134830404775]) {
        assert!((g - w).abs() <= 1e-9 * w, "{g} vs {w}");
    }
    // 530.0004 is the file's 530 (within 0.001 nm).
    let (text, got) = import(&["--wavelength", "530.0004"], "530.csv");
    assert!(
        text.contains("# wavelength: 530 nm (one of the file's)\n"),
        "{text}"
    );
    assert!(
        (got[1] - 0.15557315760727408).abs() <= 1e-9 * 0.156,
        "{got:?}"
    );
    let (text, got) = import(&[], "y.csv");
    assert!(
        text.contains("# wavelength: CIE 1931 Y over the file's 9 wavelengths 380..780 nm"),
        "{text}"
    );
    for (g, w) in got.iter().zip([0.34401653283857997, 0.1414720284202163]) {
        assert!((g - w).abs() <= 1e-9 * w, "{g} vs {w}");
    }
    // The sweep reads back and fits (1/sr, no warning about units).
    let fit = gonio(&[
        "fit",
        d.join("y.csv").to_str().unwrap(),
        "--models",
        "ideal",
    ]);
    assert!(fit.ok(), "{}", fit.stderr);
}

/// The 1/sr gate (issue #37): a relative-unit capture's MERL export is refused without
/// a scale (the bad-input table has that case), and with `--scale S` every cell is S
/// times the cell of `--scale 1`.
#[test]
fn a_scale_multiplies_the_merl_table() {
    let d = scratch("scale");
    let sweep = simulated(&d, "fe-0.115");
    let export = |scale: &str| {
        let path = d.join(format!("fe-{scale}.binary"));
        let out = gonio(&[
            "fit",
            sweep.to_str().unwrap(),
            "--models",
            "ideal",
            "--export-model",
            "ideal",
            "--export",
            &format!("merl={}", path.display()),
            "--scale",
            scale,
        ]);
        assert!(out.ok(), "{}", out.stderr);
        let bytes = std::fs::read(&path).unwrap();
        bytes[12..]
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
            .collect::<Vec<f64>>()
    };
    let (one, two) = (export("1"), export("2.5"));
    assert_eq!(one.len(), two.len());
    assert!(one.iter().any(|&v| v > 0.0));
    for (a, b) in one.iter().zip(&two) {
        assert!((b - 2.5 * a).abs() <= 1e-12 * b.abs(), "{a} {b}");
    }
}

/// `--export zemax=PATH` end to end: a relative capture with `--scale` writes a file
/// whose header says what the format needs and whose TIS lines are the albedos times
/// the scale (the lib tests read it back value by value).
#[test]
fn a_zemax_export_is_written_in_1_per_sr() {
    let d = scratch("zemax");
    let sweep = simulated(&d, "fe-0.115");
    let path = d.join("fe.zmx");
    let out = gonio(&[
        "fit",
        sweep.to_str().unwrap(),
        "--export",
        &format!("zemax={}", path.display()),
        "--scale",
        "0.0005",
        "--json",
    ]);
    assert!(out.ok(), "{}", out.stderr);
    let text = std::fs::read_to_string(&path).unwrap();
    for line in [
        "Symmetry\tPlaneSymmetrical",
        "ScatterType\tBRDF",
        "SampleRotation\t1",
        "DataBegin",
        "DataEnd",
    ] {
        assert!(text.contains(line), "{line}");
    }
    let tis: Vec<f64> = text
        .lines()
        .filter_map(|l| l.strip_prefix("TIS\t"))
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(tis.len(), 9);
    // The selected member's albedo (the physical checks' rho) times the scale: the
    // same quantity by the same code path.
    let v: serde_json::Value = serde_json::from_str(&out.stdout).unwrap();
    let sel = v["selected"].as_str().unwrap();
    let checks = v["physical_checks"].as_array().unwrap();
    let rho = checks.iter().find(|c| c["name"] == sel).unwrap()["albedo"]
        .as_array()
        .unwrap();
    assert_eq!(rho.len(), tis.len());
    for (t, r) in tis.iter().zip(rho) {
        let want = 0.0005 * r[1].as_f64().unwrap();
        // The file prints TIS as %.6E (7 significant digits).
        assert!((t - want).abs() <= 1e-6 * want, "{t} vs {want}");
    }
    assert!(tis.iter().all(|&t| t > 0.0 && t < 1.0), "{tis:?}");
}

/// Issue 50 case 5: a sweep whose theta_r is signed the other way (its peaks at
/// -theta_i) fitted as "ideal-diffuse", exit 0, no hint. Now one line says the sign
/// looks reversed and how to flip it; with the `# theta_r: source` line it says so
/// the fit is the original's.
#[test]
fn a_reversed_theta_r_is_pointed_out_and_flipped_by_one_line() {
    let d = scratch("sign");
    let sweep = simulated(&d, "fe-0.115");
    let text = std::fs::read_to_string(&sweep).unwrap();
    let mut flipped = String::new();
    let mut in_rows = false;
    for line in text.lines() {
        if in_rows {
            let (tr_start, rest) = line.split_once(',').unwrap();
            let (tr, rest) = rest.split_once(',').unwrap();
            let tr: f64 = tr.parse().unwrap();
            flipped.push_str(&format!("{tr_start},{},{rest}\n", -tr + 0.0));
        } else {
            flipped.push_str(line);
            flipped.push('\n');
            in_rows = line.starts_with("theta_i");
        }
    }
    let reversed = d.join("reversed.csv");
    std::fs::write(&reversed, &flipped).unwrap();
    let out = gonio(&["fit", reversed.to_str().unwrap(), "--json"]);
    assert_eq!(out.code, 0, "{}", out.stderr);
    let hints: Vec<&str> = out
        .stderr
        .lines()
        .filter(|l| l.contains("theta_r looks signed the other way"))
        .collect();
    assert_eq!(hints.len(), 1, "{}", out.stderr);
    assert!(hints[0].contains("'# theta_r: source'") && hints[0].contains("--theta-r-sign source"));
    let marked = d.join("marked.csv");
    std::fs::write(
        &marked,
        flipped.replacen(
            "# units: degrees\n",
            "# units: degrees\n# theta_r: source\n",
            1,
        ),
    )
    .unwrap();
    let selected = |p: &std::path::Path| {
        let out = gonio(&["fit", p.to_str().unwrap(), "--json"]);
        assert_eq!(out.code, 0, "{}", out.stderr);
        assert!(
            !out.stderr.contains("signed the other way"),
            "{}",
            out.stderr
        );
        let v: serde_json::Value = serde_json::from_str(&out.stdout).unwrap();
        v["selected"].clone()
    };
    assert_eq!(selected(&marked), selected(&sweep));
}

/// Issue 51: a sweep's measurement metadata (keys in any case) goes through a fit's
/// ASTM export and `gonio import astm` back into a sweep file, and into the JSON export;
/// the appearance figures of the saved fit of a flat (Lambertian) sweep are the closed
/// form's, from `gonio appearance` and `gonio fit --appearance` alike.
#[test]
fn measurement_metadata_and_appearance_go_through_the_exports() {
    let d = scratch("appearance");
    let c = 0.2; // BRDF, 1/sr: a Lambertian of albedo 0.2 pi
    let mut text = String::from(
        "# brdf: 1/sr\n# Wavelength: 632.8 nm\n# polarization: s\n# beam-diameter: 2.5 mm\n\
         # solid-angle: 0.0001 sr\n# NEBSDF: 0.00001\n# signature: sig-1.csv\n# sample: coupon 7\n\
         # operator: J. Doe\n# date: 2026-12-05\n# temperature: 21.5 C\ntheta_i,theta_r,brdf\n",
    );
    for ti in [10, 30, 50, 70] {
        for tr in (-80..=80).step_by(10) {
            text.push_str(&format!("{ti},{tr},{c}\n"));
        }
    }
    let sweep = d.join("flat.csv");
    std::fs::write(&sweep, text).unwrap();
    let (astm, json, back) = (d.join("flat.astm"), d.join("fit.json"), d.join("back.csv"));
    let zmx = d.join("flat.zmx");
    let fit = gonio(&[
        "fit",
        sweep.to_str().unwrap(),
        "--models",
        "ideal",
        "--export",
        &format!("astm={}", astm.display()),
        "--export",
        &format!("json={}", json.display()),
        "--export",
        &format!("zemax={}", zmx.display()),
    ]);
    assert!(fit.ok(), "{}", fit.stderr);
    let zemax = std::fs::read_to_string(&zmx).unwrap();
    assert!(zemax.contains("\n# wavelength: 632.8 nm\n"), "{zemax}");
    let table = std::fs::read_to_string(&astm).unwrap();
    for line in [
        "WAVELENGTH 632.8 nm",
        "NEBSDF 0.00001",
        "OPERATOR J. Doe",
        "DATE 2026-12-05",
    ] {
        assert!(table.contains(&format!("\n{line}\n")), "{line}");
    }
    let imported = gonio(&[
        "import",
        "astm",
        astm.to_str().unwrap(),
        "--out",
        back.to_str().unwrap(),
    ]);
    assert!(imported.ok(), "{}", imported.stderr);
    let back_text = std::fs::read_to_string(&back).unwrap();
    for line in [
        "# wavelength: 632.8 nm",
        "# polarization: s",
        "# beam-diameter: 2.5 mm",
        "# solid-angle: 0.0001 sr",
        "# nebsdf: 0.00001",
        "# signature: sig-1.csv",
        "# sample: coupon 7",
        "# operator: J. Doe",
        "# date: 2026-12-05",
        "# temperature: 21.5 C",
    ] {
        assert!(
            back_text.contains(&format!("{line}\n")),
            "{line}:\n{back_text}"
        );
    }
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["measurement"]["temperature"], "21.5 C");

    // Gloss 20 of a Lambertian: 100 c (sin(20.9) - sin(19.1)) (h/2 + sin(h)/2) / R(1.567, 20).
    let app = gonio(&["appearance", json.to_str().unwrap(), "--json"]);
    assert!(app.ok(), "{}", app.stderr);
    let a: serde_json::Value = serde_json::from_str(&app.stdout).unwrap();
    let g20 = a["appearance"]["gloss"][0]["gu"]["value"].as_f64().unwrap();
    let (t, h) = (20f64.to_radians(), 3.6f64.to_radians());
    let frac = c
        * ((t + 0.9f64.to_radians()).sin() - (t - 0.9f64.to_radians()).sin())
        * (h / 2.0 + h.sin() / 2.0);
    let want = 100.0 * frac / brdf_core::fresnel::reflectance(t.cos(), 1.567, 0.0);
    assert!((g20 - want).abs() < 1e-3 * want, "{g20} vs {want}");
    let fit_app = gonio(&[
        "fit",
        sweep.to_str().unwrap(),
        "--models",
        "ideal",
        "--appearance",
        "--json",
    ]);
    assert!(fit_app.ok(), "{}", fit_app.stderr);
    let f: serde_json::Value = serde_json::from_str(&fit_app.stdout).unwrap();
    // The same member fitted again (alone, not in the family): the same figure to
    // rounding.
    let g20_fit = f["appearance"]["gloss"][0]["gu"]["value"].as_f64().unwrap();
    assert!((g20_fit - g20).abs() <= 1e-12 * g20, "{g20_fit} vs {g20}");
    // A relative fit has no gloss without a scale.
    let rel = d.join("rel.csv");
    std::fs::write(
        &rel,
        std::fs::read_to_string(&sweep)
            .unwrap()
            .replace("# brdf: 1/sr", "# brdf: relative"),
    )
    .unwrap();
    let refused = gonio(&[
        "fit",
        rel.to_str().unwrap(),
        "--models",
        "ideal",
        "--appearance",
    ]);
    assert_eq!(refused.code, 2, "{}", refused.stderr);
    assert!(refused.stderr.contains("1/sr"), "{}", refused.stderr);
}
