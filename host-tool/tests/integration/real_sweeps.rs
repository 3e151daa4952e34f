//! The selected member against a two-lobe Beckmann fit on every real sweep we keep
//! (issue #36): the Scatterworks solar array as measured and with `--floor auto`, and
//! the RGL metallic paint imported per channel (r, g, b and luminance y), as a user
//! runs them. The figures are the report's own (`--json`'s ssr, n and Table-3 rmse),
//! checked against the residuals export's per-reading values; docs/fitting.md holds
//! the table this test prints (`--nocapture`). The residual is the fit's own (the
//! default objective's, not a logarithm: RMS ln against scipy's two-lobe fit is
//! `cargo xtask accuracy`'s).

use std::path::{Path, PathBuf};

use crate::util::{gonio, repo_root, scratch};

/// The two-lobe Beckmann member: the paper's lobe on a Beckmann haze over the ideal
/// diffuse (two specular lobes; the directional diffuse is a third, separate component).
const TWO_LOBE: &str = "specular:beckmann+specular-haze:beckmann+ideal-diffuse";

/// One fitted member as the report gives it.
struct Figures {
    /// RMS of the fit's own residual over the readings fitted: sqrt(SSR / n).
    rms: f64,
    /// The paper's Table-3 RMSE of normalised curves.
    rmse: f64,
}

fn figures(json: &serde_json::Value, name: &str) -> Option<Figures> {
    let m = json["models"]
        .as_array()?
        .iter()
        .find(|m| m["name"] == name)?;
    let (ssr, n) = (m["ssr"].as_f64()?, m["n"].as_f64()?);
    Some(Figures {
        rms: (ssr / n).sqrt(),
        rmse: m["rmse"].as_f64()?,
    })
}

/// RMS of the residuals export's `residual` column (the fit's own residual kind).
fn rms_of_export(path: &Path) -> f64 {
    let text = std::fs::read_to_string(path).unwrap();
    let r: Vec<f64> = text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("theta_i"))
        .map(|l| l.rsplit(',').next().unwrap().parse().unwrap())
        .collect();
    (r.iter().map(|x| x * x).sum::<f64>() / r.len() as f64).sqrt()
}

/// The numbers a note gives as angles: those followed by " deg" and those after
/// "theta_r " or ">= ", and each peak position theta_i + offset of the peak note's
/// "(per theta_i: t: +o, ...)". A width ("deg wide") or a step ("(1 deg)") is an angle
/// too, and no angle any note gives may exceed the measured span.
fn note_angles(note: &str) -> Vec<f64> {
    let num = |s: &str| -> Option<f64> {
        let t: String = s
            .chars()
            .take_while(|c| c.is_ascii_digit() || "+-.e".contains(*c))
            .collect();
        t.trim_end_matches(['.', 'e']).parse().ok()
    };
    let mut out = Vec::new();
    let words: Vec<&str> = note.split_whitespace().collect();
    for (i, w) in words.iter().enumerate() {
        let w = w.trim_start_matches(['(', '|']);
        let before_deg = words.get(i + 1).is_some_and(|n| n.starts_with("deg"));
        if before_deg || (i > 0 && ["theta_r", ">="].contains(&words[i - 1])) {
            out.extend(num(w));
        }
    }
    if let Some(per) = note.split("(per theta_i: ").nth(1) {
        let per = per.split(')').next().unwrap_or("");
        for pair in per.split(", ") {
            if let Some((t, o)) = pair.split_once(": ")
                && let (Ok(t), Ok(o)) = (t.parse::<f64>(), o.parse::<f64>())
            {
                out.push(t + o);
            }
        }
    }
    out
}

/// The largest |theta_r| of a sweep file's readings (degrees).
fn span(sweep: &Path) -> f64 {
    std::fs::read_to_string(sweep)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("theta_i"))
        .map(|l| l.split(',').nth(1).unwrap().parse::<f64>().unwrap().abs())
        .fold(0.0, f64::max)
}

struct Sweep {
    name: String,
    file: PathBuf,
    flags: Vec<&'static str>,
}

/// The real sweeps: Scatterworks as measured and without its floor readings, the RGL
/// file imported per channel (its zero readings at grazing exit left out by --floor 0).
fn sweeps(dir: &Path) -> Vec<Sweep> {
    let data = repo_root().join("host-tool/tests/data");
    let sw = data.join("scatterworks-solar-array-532nm.sweep.csv");
    let mut out = vec![
        Sweep {
            name: "scatterworks".into(),
            file: sw.clone(),
            flags: vec![],
        },
        Sweep {
            name: "scatterworks --floor auto".into(),
            file: sw,
            flags: vec!["--floor", "auto"],
        },
    ];
    let rgl = data.join("rgl_ilm_l3_37_metallic_rgb.bsdf");
    for ch in ["r", "g", "b", "y"] {
        let file = dir.join(format!("rgl-{ch}.csv"));
        let run = gonio(&[
            "import",
            "rgl",
            rgl.to_str().unwrap(),
            "--channel",
            ch,
            "--out",
            file.to_str().unwrap(),
        ]);
        assert!(run.ok(), "{}", run.stderr);
        out.push(Sweep {
            name: format!("rgl l3-37 {ch}"),
            file,
            flags: vec!["--floor", "0"],
        });
    }
    out
}

#[test]
fn the_selected_member_is_no_worse_than_two_lobe_beckmann_on_every_real_sweep() {
    let dir = scratch("real-sweeps");
    let mut table = vec![format!(
        "| sweep | selected | RMS residual (sel / 2-lobe) | Table-3 RMSE (sel / 2-lobe) |"
    )];
    let mut rmse_losses = Vec::new();
    for s in sweeps(&dir) {
        let file = s.file.to_str().unwrap();
        let (sel_res, two_res) = (dir.join("sel.csv"), dir.join("two.csv"));
        let sel_export = format!("residuals={}", sel_res.display());
        let mut args = vec!["fit", file, "--json", "--force", "--export", &sel_export];
        args.extend(&s.flags);
        let run = gonio(&args);
        assert!(run.ok(), "{}: {}", s.name, run.stderr);
        let json: serde_json::Value = serde_json::from_str(&run.stdout).unwrap();
        let selected = json["selected"].as_str().unwrap().to_string();
        let sel = figures(&json, &selected).unwrap();
        // The decision fits the two-lobe member itself: it is compared, not assumed.
        let two =
            figures(&json, TWO_LOBE).unwrap_or_else(|| panic!("{}: {TWO_LOBE} not fitted", s.name));
        // The same numbers per reading, from the residuals export of each member.
        let two_export = format!("residuals={}", two_res.display());
        let mut args = vec![
            "fit",
            file,
            "--force",
            "--export",
            &two_export,
            "--export-model",
            TWO_LOBE,
        ];
        args.extend(&s.flags);
        let run = gonio(&args);
        assert!(run.ok(), "{}: {}", s.name, run.stderr);
        for (f, path) in [(&sel, &sel_res), (&two, &two_res)] {
            let per_reading = rms_of_export(path);
            assert!(
                (per_reading / f.rms - 1.0).abs() < 1e-9,
                "{}: {per_reading} vs {}",
                s.name,
                f.rms
            );
        }
        table.push(format!(
            "| {} | `{selected}` | {:.3} / {:.3} | {:.4} / {:.4} |",
            s.name, sel.rms, two.rms, sel.rmse, two.rmse
        ));
        assert!(
            sel.rms <= two.rms * (1.0 + 1e-9),
            "{}: RMS residual {} against {TWO_LOBE}'s {}",
            s.name,
            sel.rms,
            two.rms
        );
        if sel.rmse > two.rmse {
            rmse_losses.push(s.name.clone());
        }
        let limit = span(&s.file);
        for note in json["notes"].as_array().unwrap() {
            let note = note.as_str().unwrap();
            for a in note_angles(note) {
                assert!(
                    a.abs() <= limit,
                    "{}: {a} deg beyond {limit}: {note}",
                    s.name
                );
            }
        }
    }
    eprintln!("{}", table.join("\n"));
    // No worse in Table-3 RMSE either (issue #53). Under log residuals with GGX lobes
    // the Scatterworks sweep was (0.0067 against 0.0052): docs/fitting.md.
    assert!(
        rmse_losses.is_empty(),
        "Table-3 RMSE worse than {TWO_LOBE} on {rmse_losses:?}"
    );
}

#[test]
fn note_angles_finds_what_a_note_claims() {
    let peak = "the measured specular peak sits +281.56 deg in theta_r from x's (per theta_i: 5: +227.22, 41.4: +250.96)";
    let got = note_angles(peak);
    let want = [281.56, 232.22, 292.36];
    assert_eq!(got.len(), want.len(), "{got:?}");
    assert!(
        got.iter().zip(want).all(|(g, w)| (g - w).abs() < 1e-9),
        "{got:?}"
    );
    let misses = "x misses the readings at |theta_r| >= 70 deg: they sit 44.3 % below it";
    assert_eq!(note_angles(misses), vec![70.0]);
    let core = "(sigma 5.46e-4, about 0.11 deg wide at half maximum in theta_r) is narrower than the readings' step at the peak (1 deg)";
    assert_eq!(note_angles(core), vec![0.11, 1.0]);
}
