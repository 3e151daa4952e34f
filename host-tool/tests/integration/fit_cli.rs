//! `gonio fit` and `gonio demo` as a user runs them: the JSON contract, the table, and
//! bad input; `gonio bench --fit-vs` (the fit timed against scipy's start).

use crate::util::{gonio, one_line, scratch, simulated};

#[test]
fn json_follows_the_contract() {
    let d = scratch("json");
    let f = simulated(&d, "cu-0.070");
    let out = gonio(&["fit", f.to_str().unwrap(), "--json"]);
    assert!(out.ok(), "{}", out.stderr);
    let v: serde_json::Value =
        serde_json::from_str(&out.stdout).expect("one JSON object on stdout");
    let models = v["models"].as_array().unwrap();
    let names: Vec<&str> = models.iter().map(|m| m["name"].as_str().unwrap()).collect();
    // The default family holds the paper's four members under their names, and more.
    for paper in [
        "ideal-diffuse",
        "torrance-sparrow",
        "three-component",
        "three-component-smooth-ks",
    ] {
        assert!(names.contains(&paper), "{names:?}");
    }
    // The member with every component (the haze's comparison with three-component);
    // torrance-sparrow with a haze is neither needed nor fitted on these data.
    assert!(
        names.contains(
            &"specular:beckmann+specular-haze:beckmann+directional-diffuse+ideal-diffuse"
        )
    );
    assert!(!names.contains(&"specular:beckmann+specular-haze:beckmann+ideal-diffuse"));
    let by_name = |n: &str| models.iter().find(|m| m["name"] == n).unwrap();
    // Every model names its components from the fixed vocabulary, and its lobes.
    for m in models {
        let comps = m["components"].as_array().unwrap();
        assert!(!comps.is_empty());
        for c in comps {
            assert!(
                [
                    "specular",
                    "specular-haze",
                    "directional-diffuse",
                    "ideal-diffuse"
                ]
                .contains(&c.as_str().unwrap())
            );
        }
        if comps.iter().any(|c| c == "specular") {
            let lobe = &m["lobes"]["specular"];
            assert!(
                ["beckmann", "ggx", "student-t"].contains(&lobe["distribution"].as_str().unwrap())
            );
            assert!(["per-incidence", "smooth"].contains(&lobe["ks"].as_str().unwrap()));
        }
    }
    let three = by_name("three-component");
    assert_eq!(
        three["components"],
        serde_json::json!(["specular", "directional-diffuse", "ideal-diffuse"])
    );
    for key in ["sigma", "sigma_m", "k_dd", "k_id"] {
        assert!(three["params"][key].as_f64().unwrap() > 0.0, "{key}");
        assert!(three["std_errors"][key].as_f64().unwrap() > 0.0, "{key}");
    }
    let ks = three["params"]["k_s"].as_array().unwrap();
    assert_eq!(ks.len(), 9);
    assert_eq!(ks[2][0].as_f64(), Some(20.0));
    assert!(
        (ks[2][1].as_f64().unwrap() / 165.0 - 1.0).abs() < 0.05,
        "{ks:?}"
    );
    assert_eq!(three["std_errors"]["k_s"].as_array().unwrap().len(), 9);
    assert_eq!(three["rmse_by_theta_i"].as_array().unwrap().len(), 9);
    for key in ["rmse", "aicc", "bic"] {
        assert!(three[key].is_number(), "{key}");
    }
    let ts = by_name("torrance-sparrow");
    assert!(ts["params"]["k_d"].as_f64().unwrap() > 0.0 && ts["params"].get("k_dd").is_none());
    assert_eq!(
        v["selected"]
            .as_str()
            .map(|s| s.starts_with("three-component")),
        Some(true)
    );
    assert!(v["fit_seconds"].as_f64().unwrap() > 0.0);
    // The simulated cu-0.070 sample's sigma comes back.
    assert!((three["params"]["sigma"].as_f64().unwrap() / 0.070 - 1.0).abs() < 0.02);
}

#[test]
fn table_shows_parameters_and_the_papers_rmse_table() {
    let d = scratch("table");
    let f = simulated(&d, "fe-0.115");
    let out = gonio(&[
        "fit",
        f.to_str().unwrap(),
        "--models",
        "ts,three",
        "--fix",
        "kdd=900",
        "--all",
    ]);
    assert!(out.ok(), "{}", out.stderr);
    let t = out.stdout;
    for needle in [
        "torrance-sparrow",
        "three-component",
        "k_dd",
        "(fixed)",
        "RMSE1 (T-S)",
        "RMSE2 (three)",
        "selected by AICc",
    ] {
        assert!(t.contains(needle), "missing {needle}:\n{t}");
    }
    assert!(!t.contains("ideal-diffuse ("), "only the models asked for");
}

/// What a lab shares: the files `fit --plot --export` writes get the user's umask (here
/// 027: group read, nothing for others), as a plain `touch` would, and each is named.
#[test]
fn written_files_follow_the_umask_and_are_listed() {
    use std::os::unix::fs::PermissionsExt;
    let d = scratch("umask");
    let f = simulated(&d, "fe-0.115");
    let plots = d.join("plots");
    let json = d.join("fe.json");
    let out: crate::util::Run = std::process::Command::new("sh")
        .arg("-c")
        .arg("umask 027 && exec \"$0\" \"$@\"")
        .arg(env!("CARGO_BIN_EXE_gonio"))
        .args([
            "fit",
            f.to_str().unwrap(),
            "--plot",
            plots.to_str().unwrap(),
        ])
        .arg(format!("--export=json={}", json.display()))
        .output()
        .unwrap()
        .into();
    assert!(out.ok(), "{}", out.stderr);
    let mut files: Vec<_> = std::fs::read_dir(&plots)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(files.len(), 20, "{files:?}");
    files.push(json.clone());
    for p in &files {
        let mode = std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o640, "{}: {mode:o}", p.display());
        let name = p.file_name().unwrap().to_str().unwrap();
        assert!(
            out.stderr.contains(name),
            "{name} not listed:\n{}",
            out.stderr
        );
    }
    assert!(
        out.stderr
            .contains(&format!("gonio: wrote {}", json.display())),
        "{}",
        out.stderr
    );
}

#[test]
fn demo_recovers_the_sample_it_simulated() {
    let d = scratch("demo");
    let out = gonio(&[
        "demo",
        "--dir",
        d.to_str().unwrap(),
        "-q",
        "--material",
        "al-0.782",
    ]);
    assert!(out.ok(), "{}", out.stderr);
    let t = out.stdout;
    assert!(
        t.contains("153 readings of a simulated al-0.782 sample"),
        "{t}"
    );
    // The verdict comes before the family's model blocks.
    let verdict = t
        .find("verdict: the fit selected three-component,")
        .expect(&t);
    assert!(verdict < t.find("free parameter").unwrap(), "{t}");
    let line = t
        .lines()
        .find(|l| l.trim_start().starts_with("sigma ") && l.contains("true"))
        .unwrap();
    let pct: f64 = line
        .split('(')
        .nth(1)
        .unwrap()
        .trim_end_matches(" %)")
        .parse()
        .unwrap();
    assert!(pct.abs() < 2.0, "{line}");
    assert!(d.join("al-0.782-sweep.csv").is_file());
}

/// A sweep of the ABg model in the plane, f = A / (B + |sin theta_r - sin theta_i|^g)
/// (docs/fitting.md), at theta_i 10, 30, 50 and theta_r -85..85 by 0.5 plus the
/// mirror, with 1 % relative noise (seeded, uniform).
fn abg_sweep(path: &std::path::Path, (a, b, g): (f64, f64, f64), seed: u32) {
    let mut rng = brdf_core::sim::XorShift32::new(seed);
    let mut s = String::from("# brdf: 1/sr\ntheta_i,theta_r,brdf\n");
    for ti in [10.0f64, 30.0, 50.0] {
        let mut trs: Vec<f64> = (0..=340).map(|k| -85.0 + 0.5 * k as f64).collect();
        trs.push(ti);
        trs.sort_by(f64::total_cmp);
        trs.dedup();
        for tr in trs {
            let x = (tr.to_radians().sin() - ti.to_radians().sin()).abs();
            let noise = 1.0 + 0.01 * 3f64.sqrt() * (2.0 * f64::from(rng.uniform()) - 1.0);
            s.push_str(&format!("{ti},{tr},{}\n", a / (b + x.powf(g)) * noise));
        }
    }
    std::fs::write(path, s).unwrap();
}

/// Issue #37: a campaign fitted with `--models abg` lists A, B, g and their standard
/// errors in summary.csv and summary.json, within 2 % of the values the sweeps were
/// made with.
#[test]
fn a_campaign_summary_lists_abg_parameters() {
    let d = scratch("campaign-abg");
    let truths = [(0.02, 1e-3, 1.5), (0.005, 0.1, 1.0)];
    let files: Vec<_> = truths
        .iter()
        .enumerate()
        .map(|(k, &t)| {
            let p = d.join(format!("abg{k}.csv"));
            abg_sweep(&p, t, 7 + k as u32);
            p
        })
        .collect();
    let out = d.join("reports");
    let o = gonio(&[
        "fit",
        files[0].to_str().unwrap(),
        files[1].to_str().unwrap(),
        "--models",
        "abg",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.ok(), "{}", o.stderr);
    let summary = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let rows: Vec<Vec<&str>> = summary.lines().map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 3, "{summary}");
    let col = |name: &str| rows[0].iter().position(|c| *c == name).unwrap();
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    for (k, (a, b, g)) in truths.into_iter().enumerate() {
        assert_eq!(rows[k + 1][col("selected_member")], "abg", "{summary}");
        assert_eq!(rows[k + 1][col("sigma")], "", "{summary}");
        for (name, truth) in [("A", a), ("B", b), ("g", g)] {
            let value: f64 = rows[k + 1][col(name)].parse().unwrap();
            let se: f64 = rows[k + 1][col(&format!("{name}_se"))].parse().unwrap();
            assert!(
                (value / truth - 1.0).abs() < 0.02 && se > 0.0 && se < 0.1 * value,
                "file {k} {name} = {value} +- {se} vs {truth}"
            );
            // The same numbers (serde_json's parser may round the last digit).
            let p = &json["files"][k]["params"][name];
            let same =
                |j: &serde_json::Value, x: f64| (j.as_f64().unwrap() / x - 1.0).abs() < 1e-14;
            assert!(same(&p["value"], value) && same(&p["se"], se), "{p}");
        }
    }
}

/// Issue #37: the ABg paste block's TIS line prints the numbers of the `--json` entry's
/// `tis` (one code path, the physical checks' albedo) and states their quadrature error.
#[test]
fn the_abg_tis_line_is_the_json_tis_with_its_error() {
    let d = scratch("abg-tis");
    let p = d.join("abg.csv");
    abg_sweep(&p, (0.02, 1e-3, 1.5), 11);
    let text = gonio(&["fit", p.to_str().unwrap(), "--models", "abg"]);
    assert!(text.ok(), "{}", text.stderr);
    let line = text
        .stdout
        .lines()
        .find(|l| l.contains("TIS(theta_i) implied"))
        .unwrap_or_else(|| panic!("{}", text.stdout));
    let (values, error) = line
        .split_once("):")
        .and_then(|(_, rest)| rest.split_once("(quadrature error <= "))
        .unwrap_or_else(|| panic!("{line}"));
    let error: f64 = error.trim_end_matches(" relative)").parse().unwrap();
    assert!(error > 0.0 && error < 1e-3, "{line}");
    let printed: Vec<(f64, f64)> = values
        .split_whitespace()
        .collect::<Vec<_>>()
        .chunks(2)
        .map(|c| {
            (
                c[0].trim_end_matches(':').parse().unwrap(),
                c[1].parse().unwrap(),
            )
        })
        .collect();
    let json = gonio(&["fit", p.to_str().unwrap(), "--models", "abg", "--json"]);
    let j: serde_json::Value = serde_json::from_str(&json.stdout).unwrap();
    let tis = j["models"][0]["tis"].as_array().unwrap();
    assert_eq!(tis.len(), printed.len(), "{line}");
    for (t, (ti, v)) in tis.iter().zip(printed) {
        assert_eq!(t[0].as_f64().unwrap(), ti, "{line}");
        assert!(
            (t[1].as_f64().unwrap() / v - 1.0).abs() < 1e-4,
            "{t} vs {v}"
        );
    }
}

#[test]
fn a_campaign_fits_every_sweep_and_skips_the_bad_one() {
    let d = scratch("campaign");
    let a = simulated(&d, "fe-0.115");
    let sweeps = d.join("sweeps");
    std::fs::create_dir_all(&sweeps).unwrap();
    std::fs::copy(simulated(&d, "cu-0.070"), sweeps.join("cu.csv")).unwrap();
    std::fs::write(sweeps.join("broken.csv"), b"theta_i,brdf\n1,2\n").unwrap();
    let out = d.join("reports");
    let o = gonio(&[
        "fit",
        a.to_str().unwrap(),
        sweeps.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = &o.stderr;
    assert_eq!(o.code, 1, "{err}");
    assert!(
        err.contains("broken.csv") && err.contains("missing column"),
        "{err}"
    );
    let table = &o.stdout;
    assert_eq!(table.lines().count(), 4, "{table}");
    let summary = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let rows: Vec<&str> = summary.lines().collect();
    assert_eq!(rows.len(), 4, "{summary}");
    assert!(
        rows[0].starts_with(
            "file,status,selected_member,readings,incidences,sigma,sigma_se,sigma_haze,sigma_haze_se"
        ),
        "{}",
        rows[0]
    );
    assert!(rows[1].contains(",ok,three-component"), "{}", rows[1]);
    assert!(rows[2].contains(",error,"), "{}", rows[2]);
    assert!(rows[3].contains(",ok,three-component"), "{}", rows[3]);
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let sigma = v["files"][0]["params"]["sigma"]["value"].as_f64().unwrap();
    assert!((sigma / 0.115 - 1.0).abs() < 0.02, "{sigma}");
    assert_eq!(v["files"][0]["selected_member"], "three-component");
    assert_eq!(
        v["files"][0]["selected_components"],
        serde_json::json!(["specular", "directional-diffuse", "ideal-diffuse"])
    );
    assert!(out.join("fe-0.115.txt").is_file() && out.join("cu.txt").is_file());
    // --plot needs one sweep.
    let o = gonio(&[
        "fit",
        a.to_str().unwrap(),
        a.to_str().unwrap(),
        "--plot",
        "x",
    ]);
    assert_eq!(o.code, 2);
}

#[test]
fn residuals_export_has_one_row_per_reading_in_file_order() {
    let d = scratch("residuals");
    let f = simulated(&d, "fe-0.115");
    let out_path = d.join("res.csv");
    // Log residuals, so that the column is ln(measured / fitted) itself.
    let out = gonio(&[
        "fit",
        f.to_str().unwrap(),
        "--residual",
        "log",
        "--export",
        &format!("residuals={}", out_path.display()),
    ]);
    assert!(out.ok(), "{}", out.stderr);
    let text = std::fs::read_to_string(&out_path).unwrap();
    let sweep = std::fs::read_to_string(&f).unwrap();
    // The sweep's readings, in its order: theta_i, theta_r, brdf.
    let readings: Vec<(f64, f64, f64)> = sweep
        .lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .map(|l| {
            let v: Vec<f64> = l.split(',').take(3).map(|x| x.parse().unwrap()).collect();
            (v[0], v[1], v[2])
        })
        .collect();
    assert!(text.contains("# model: three-component\n"), "{text}");
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    assert_eq!(
        lines.next(),
        Some("theta_i,theta_r,measured,fitted,residual")
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), readings.len());
    let mut ss = 0.0;
    for (r, (ti, tr, y)) in rows.iter().zip(&readings) {
        assert_eq!((r[0], r[1], r[2]), (*ti, *tr, *y));
        // The residual is ln(measured / fitted) of the two values beside it (issue 50
        // case 13: the sign the plots' panels show, stated in the header).
        assert!((r[4] - (r[2].ln() - r[3].ln())).abs() < 1e-12);
        ss += r[4] * r[4];
    }
    // 0.5 % noise per sample, 4 samples: the residuals are at that level.
    let rms = (ss / rows.len() as f64).sqrt();
    assert!(rms > 0.0005 && rms < 0.01, "rms {rms}");
    // Any fitted member can be exported by name; one not fitted is refused.
    let out = gonio(&[
        "fit",
        f.to_str().unwrap(),
        "--models",
        "ts,specular:ggx+ideal-diffuse",
        "--export-model",
        "specular:ggx+ideal-diffuse",
        "--export",
        &format!("residuals={}", d.join("ggx.csv").display()),
    ]);
    assert!(out.ok(), "{}", out.stderr);
    let ggx = std::fs::read_to_string(d.join("ggx.csv")).unwrap();
    assert!(ggx.contains("# model: specular:ggx+ideal-diffuse\n"));
    let out = gonio(&[
        "fit",
        f.to_str().unwrap(),
        "--models",
        "ts",
        "--export-model",
        "three",
        "--export",
        &format!("residuals={}", d.join("no.csv").display()),
    ]);
    assert!(!out.ok());
    assert!(
        out.stderr.contains("three-component") && out.stderr.contains("was not fitted"),
        "{}",
        out.stderr
    );
}

#[test]
fn a_detection_floor_is_asked_about_and_left_out_with_floor() {
    // The Scatterworks metal (real data, in 1/sr): seven readings of exactly 1e-4.
    let d = scratch("floor");
    let sweep = crate::util::repo_root()
        .join("host-tool/tests/data/scatterworks-solar-array-532nm.sweep.csv");
    let s = sweep.to_str().unwrap();
    let out = gonio(&["fit", s, "--json"]);
    assert!(out.ok(), "{}", out.stderr);
    let v: serde_json::Value = serde_json::from_str(&out.stdout).unwrap();
    assert_eq!(v["brdf_units"], "1/sr");
    let notes: Vec<&str> = v["notes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| n.as_str().unwrap())
        .collect();
    assert!(
        notes
            .iter()
            .any(|n| n.starts_with("7 readings equal the minimum 1e-4: a detection floor?")),
        "{notes:?}"
    );
    let res = d.join("res.csv");
    let out = gonio(&[
        "fit",
        s,
        "--floor",
        "auto",
        "--export",
        &format!("residuals={}", res.display()),
    ]);
    assert!(out.ok(), "{}", out.stderr);
    assert!(
        out.stdout
            .contains("7 reading(s) at or below the detection floor 1e-4 were left out")
    );
    let text = std::fs::read_to_string(&res).unwrap();
    assert!(
        text.contains("# left out of the fit: 7 reading(s)"),
        "{text}"
    );
    let rows = text.lines().filter(|l| !l.starts_with('#')).count() - 1;
    assert_eq!(rows, 716 - 7);
    // Bad values are refused with one line naming the option.
    let out = gonio(&["fit", s, "--floor", "lots"]);
    assert_eq!(out.code, 2, "{}", out.stderr);
    assert!(out.stderr.contains("--floor"), "{}", out.stderr);
    // --help documents it.
    let out = gonio(&["fit", "--help"]);
    assert!(
        out.stdout.contains("--floor <auto|VALUE>"),
        "{}",
        out.stdout
    );
}

/// bench/fit_scipy.py's start on the paper grid (9 incidences), as it prints `x0`.
const SCIPY_X0: &str = "[-2.302585, -0.693147, 4.605170, 2.302585, 4.605170, 4.605170, \
    4.605170, 4.605170, 4.605170, 4.605170, 4.605170, 4.605170, 4.605170]";

#[test]
fn bench_fit_vs_times_both_fits_to_the_same_optimum() {
    let d = scratch("fitvs");
    let f = simulated(&d, "fe-0.115");
    let f = f.to_str().unwrap();
    let out = gonio(&[
        "bench", "--fit-vs", f, "--start", SCIPY_X0, "--repeat", "2", "--json",
    ]);
    assert!(out.ok(), "{}", out.stderr);
    let v: serde_json::Value = serde_json::from_str(&out.stdout).unwrap();
    assert_eq!(v["readings"], 153);
    let (one, grid) = (&v["one_lm"], &v["default_fit"]);
    for fit in [one, grid] {
        assert!(fit["microseconds"].as_f64().unwrap() > 0.0, "{fit}");
        assert!(fit["rmse"].as_f64().unwrap() > 0.0, "{fit}");
    }
    let (s1, s2) = (one["ssr"].as_f64().unwrap(), grid["ssr"].as_f64().unwrap());
    assert!(((s1 - s2) / s2).abs() < 1e-8, "{s1} against {s2}");
    assert!(one["iterations"].as_u64().unwrap() > 0);
    // The solve alone is part of the one LM's time (best of the same runs); the
    // default fit has no such split.
    let solve = one["solve_microseconds"].as_f64().unwrap();
    assert!(
        solve > 0.0 && solve <= one["microseconds"].as_f64().unwrap(),
        "{one}"
    );
    assert!(grid["solve_microseconds"].is_null(), "{grid}");
    // The table names both fits.
    let t = gonio(&["bench", "--fit-vs", f, "--start", SCIPY_X0, "--repeat", "1"]);
    assert!(t.ok(), "{}", t.stderr);
    assert!(
        t.stdout.contains("one LM from --start")
            && t.stdout.contains("its solve")
            && t.stdout.contains("default"),
        "{}",
        t.stdout
    );
}

#[test]
fn bench_campaign_runs_gonio_fit_per_thread_count() {
    let out = gonio(&["bench", "--campaign", "6", "--threads", "1,2", "--json"]);
    assert!(out.ok(), "{}", out.stderr);
    let v: serde_json::Value = serde_json::from_str(&out.stdout).unwrap();
    let rows = v["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 2, "{v}");
    for (r, t) in rows.iter().zip([1, 2]) {
        assert_eq!(
            (r["threads"].as_u64(), r["sweeps"].as_u64()),
            (Some(t), Some(6))
        );
        let (wall, cpu) = (r["wall_s"].as_f64().unwrap(), r["cpu_s"].as_f64().unwrap());
        assert!(wall > 0.0 && cpu > 0.0, "{r}");
        let ratio = r["wall_over_cpu_per_thread"].as_f64().unwrap();
        assert!(
            (ratio - wall / (cpu / t as f64)).abs() < 1e-9 * ratio,
            "{r}"
        );
    }
    assert_eq!(rows[0]["speedup"].as_f64(), Some(1.0));
    // Reports and summaries were written (and removed with the scratch directory).
    assert!(v["output_mb"].as_f64().unwrap() > 0.0, "{v}");
    assert!(v["peak_rss_mb"].as_f64().unwrap() > 1.0, "{v}");
}

#[test]
fn bench_fit_vs_refuses_a_bad_start() {
    let d = scratch("fitvs-bad");
    let f = simulated(&d, "fe-0.115");
    let f = f.to_str().unwrap();
    for (start, says) in [
        (
            "[-2.3, -0.69, 4.6]",
            "--start has 3 values; the three-component model on these data has 13",
        ),
        (
            "-2.3,-0.69,4.6,2.3,nan,4.6,4.6,4.6,4.6,4.6,4.6,4.6,4.6",
            "value 5 is not finite",
        ),
        (
            "-2.3,-0.69,4.6,2.3,inf,4.6,4.6,4.6,4.6,4.6,4.6,4.6,4.6",
            "value 5 is not finite",
        ),
        ("[1, \"a\"]", "not a JSON array of numbers"),
        ("1,x,3", "'x' is not a number"),
    ] {
        let out = gonio(&["bench", "--fit-vs", f, "--start", start]);
        assert_eq!(out.code, 2, "{start}: {}", out.stderr);
        assert!(
            one_line(&out.stderr).contains(says),
            "{start}: {}",
            out.stderr
        );
    }
    // --fit-vs needs a start; --start and --repeat need --fit-vs.
    assert_eq!(gonio(&["bench", "--fit-vs", f]).code, 2);
    assert_eq!(gonio(&["bench", "--start", "1"]).code, 2);
    let out = gonio(&["bench", "--fit-vs", f, "--start", SCIPY_X0, "--repeat", "0"]);
    assert_eq!(out.code, 2);
    assert!(one_line(&out.stderr).contains("--repeat"), "{}", out.stderr);
}

#[test]
fn all_starts_finds_a_lower_optimum_the_default_stops_short_of() {
    // On this simulated copper sweep a start of the two-lobe member that the default
    // stops (its path comes near an optimum already reached) leads to an SSR ~10 %
    // lower; with every start refined no member can end higher.
    let d = scratch("all-starts");
    let f = d.join("cu.csv");
    let out = gonio(&[
        "simulate",
        "--material",
        "cu-0.070",
        "--seed",
        "2",
        "--out",
        f.to_str().unwrap(),
        "-q",
    ]);
    assert!(out.ok(), "{}", out.stderr);
    let ssr = |extra: &[&str]| {
        let mut args = vec!["fit", f.to_str().unwrap(), "--json", "--checks", "none"];
        args.extend(extra);
        let out = gonio(&args);
        assert!(out.ok(), "{}", out.stderr);
        let v: serde_json::Value = serde_json::from_str(&out.stdout).unwrap();
        v["models"]
            .as_array()
            .unwrap()
            .iter()
            .map(|m| {
                (
                    m["name"].as_str().unwrap().to_string(),
                    m["ssr"].as_f64().unwrap(),
                )
            })
            .collect::<std::collections::BTreeMap<_, _>>()
    };
    let (stopped, every) = (ssr(&[]), ssr(&["--all-starts"]));
    assert_eq!(
        stopped.keys().collect::<Vec<_>>(),
        every.keys().collect::<Vec<_>>()
    );
    for (m, s) in &stopped {
        assert!(
            every[m] <= *s,
            "{m}: every start {:e}, stopped {s:e}",
            every[m]
        );
    }
    let two = "specular:beckmann+specular-haze:beckmann+directional-diffuse+ideal-diffuse";
    assert!(
        every[two] < 0.95 * stopped[two],
        "{} against {}",
        every[two],
        stopped[two]
    );
}

/// Issue 42: the text table prints each parameter with its unit: weights in the data's
/// units (relative here, 1/sr after `gonio convert`), sigma_m in radians; the
/// dimensionless slope and the ln k_s coefficients bare.
#[test]
fn the_table_prints_parameters_with_their_units() {
    let d = scratch("units-table");
    let f = simulated(&d, "fe-0.115");
    let out = gonio(&["fit", f.to_str().unwrap(), "--models", "three"]);
    assert!(out.ok(), "{}", out.stderr);
    let line = |name: &str| {
        out.stdout
            .lines()
            .find(|l| l.split_whitespace().next() == Some(name))
            .unwrap_or_else(|| panic!("no {name} line: {}", out.stdout))
            .to_string()
    };
    assert!(line("sigma_m").ends_with(" rad"), "{}", line("sigma_m"));
    for k in ["k_dd", "k_id", "k_s(40)"] {
        assert!(line(k).ends_with(" relative"), "{}", line(k));
    }
    let sigma = line("sigma");
    assert!(sigma.ends_with(|c: char| c.is_ascii_digit()), "{sigma}");
}

#[test]
fn the_noise_objective_is_the_default_and_states_its_noise() {
    let d = scratch("noise-objective");
    let f = simulated(&d, "fe-0.115");
    let out = gonio(&["fit", f.to_str().unwrap(), "--json"]);
    assert!(out.ok(), "{}", out.stderr);
    let v: serde_json::Value = serde_json::from_str(&out.stdout).unwrap();
    assert_eq!(v["selected_paper"], "three-component");
    // The simulated capture states std (0.5 % a sample) and n = 4: the noise model
    // is fitted to them, about 0.25 % of each reading.
    let notes = crate::util::notes(&v);
    let said = notes
        .iter()
        .find(|n| n.starts_with("objective: g(fitted) - g(measured)"))
        .unwrap_or_else(|| panic!("{notes:?}"));
    assert!(
        said.ends_with("(fitted to the readings' std/sqrt(n))"),
        "{said}"
    );
    let b: f64 = said
        .split(" and b = ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("{said}"));
    assert!((0.0015..0.0035).contains(&b), "{said}");
    // --noise states the noise of the noise objective only.
    let bad = gonio(&[
        "fit",
        f.to_str().unwrap(),
        "--residual",
        "log",
        "--noise",
        "0.1,0.02",
    ]);
    assert_eq!(bad.code, 2, "{}", bad.stderr);
    assert!(bad.stderr.contains("--residual noise"), "{}", bad.stderr);
}

/// Issue 50 case 11: in a campaign `--aperture 0` means a point detector, over every
/// sweep's `# aperture:` line, as it does for one sweep (it was dropped and the lines
/// used); without the flag the lines hold.
#[test]
fn a_campaigns_aperture_0_turns_the_sweeps_aperture_lines_off() {
    let d = scratch("campaign-aperture");
    let sweeps = d.join("sweeps");
    std::fs::create_dir_all(&sweeps).unwrap();
    let text = std::fs::read_to_string(simulated(&d, "fe-0.115")).unwrap();
    for name in ["a.csv", "b.csv"] {
        std::fs::write(sweeps.join(name), format!("# aperture: 1.5\n{text}")).unwrap();
    }
    let apertures = |extra: &[&str], out: &str| {
        let out = d.join(out);
        let mut args = vec![
            "fit",
            sweeps.to_str().unwrap(),
            "--models",
            "ideal",
            "--json",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend(extra);
        let o = gonio(&args);
        assert!(o.ok(), "{}", o.stderr);
        ["a.json", "b.json"].map(|r| {
            let v: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(out.join(r)).unwrap()).unwrap();
            v["aperture_deg"].as_f64()
        })
    };
    assert_eq!(apertures(&[], "lines"), [Some(1.5); 2]);
    assert_eq!(apertures(&["--aperture", "0"], "off"), [None; 2]);
    assert_eq!(apertures(&["--aperture", "0.5"], "half"), [Some(0.5); 2]);
    // One sweep, the same request.
    let one = gonio(&[
        "fit",
        sweeps.join("a.csv").to_str().unwrap(),
        "--models",
        "ideal",
        "--json",
        "--aperture",
        "0",
    ]);
    let v: serde_json::Value = serde_json::from_str(&one.stdout).unwrap();
    assert_eq!(v["aperture_deg"], serde_json::Value::Null);
}
