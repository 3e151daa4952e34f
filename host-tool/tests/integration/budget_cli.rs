//! `gonio budget` (issue 51): a simulated capture with every error source injected
//! (`gonio simulate --inject`), calibrated, and its budget in JSON; the solar-array
//! sweep's budget with its assumptions named.

use std::path::Path;

use crate::util::{gonio, repo_root, scratch};

const MODEL: &str = r#"noise = { floor = 0.5, prop = 0.005, source = "measured" }
linearity = { value = 0.0, u = 0.002, source = "stated" }
[source_arm]
step_deg = { value = 0.05, source = "stated" }
backlash_deg = { value = 0.05, source = "measured" }
home_deg = { value = 0.0, u = 0.02, source = "measured" }
[detector_arm]
step_deg = { value = 0.05, source = "stated" }
backlash_deg = { value = 0.05, source = "measured" }
home_deg = { value = 0.0, u = 0.02, source = "measured" }
"#;

fn s(p: &Path) -> String {
    p.to_str().unwrap().to_string()
}

#[test]
fn an_injected_simulation_gets_a_budget_with_every_source() {
    let dir = scratch("budget");
    let model = dir.join("model.toml");
    std::fs::write(&model, MODEL).unwrap();
    let sweep = dir.join("fe.csv");
    let out = gonio(&[
        "simulate",
        "--material",
        "fe-0.115",
        "--inject",
        &s(&model),
        "--reference",
        "lambertian:0.99",
        "--seed",
        "5",
        "--out",
        &s(&sweep),
        "-q",
    ]);
    assert!(out.ok(), "{}", out.stderr);
    let inst = dir.join("inst.toml");
    let refp = dir.join("fe.reference.csv");
    let out = gonio(&[
        "calibrate",
        &s(&refp),
        "--standard",
        "lambertian:0.99",
        "--out",
        &s(&inst),
    ]);
    assert!(out.ok(), "{}", out.stderr);
    // The instrument file carries the model as its [uncertainty] table.
    let mut text = std::fs::read_to_string(&inst).unwrap();
    text.push_str("\n[uncertainty]\n");
    text.push_str(
        &MODEL
            .replace("[source_arm]", "[uncertainty.source_arm]")
            .replace("[detector_arm]", "[uncertainty.detector_arm]"),
    );
    std::fs::write(&inst, text).unwrap();
    let out = gonio(&[
        "budget",
        &s(&sweep),
        "--instrument",
        &s(&inst),
        "--trials",
        "40",
        "--appearance",
        "--json",
    ]);
    assert!(out.ok(), "{}", out.stderr);
    let j: serde_json::Value = serde_json::from_str(&out.stdout).unwrap();
    assert_eq!(j["trials"], 40);
    assert_eq!(j["units"], "1/sr");
    assert_eq!(j["reference_in_k"], true);
    // Nothing assumed but the solid angle and beam (not given): the reference is in u(K).
    let assumed: Vec<&str> = j["assumptions"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| a.as_str().unwrap())
        .collect();
    assert!(
        assumed
            .iter()
            .all(|a| a.contains("solid angle") || a.contains("beam diameter")),
        "{assumed:?}"
    );
    let outputs = j["outputs"].as_array().unwrap();
    let u_k_rel = {
        let t = std::fs::read_to_string(&inst).unwrap();
        let get = |k: &str| -> f64 {
            t.lines()
                .find_map(|l| l.strip_prefix(k))
                .unwrap()
                .trim()
                .parse()
                .unwrap()
        };
        get("u_k = ") / get("k = ")
    };
    for o in outputs {
        let name = o["name"].as_str().unwrap();
        assert_eq!(o["budget"].as_array().unwrap().len(), 10, "{name}");
        let rel = o["expanded"].as_f64().unwrap() / o["value"].as_f64().unwrap().abs();
        assert!(rel.is_finite() && rel > 0.0, "{name}");
        if name.starts_with("k_") || name.starts_with("albedo") || name.starts_with("gloss") {
            // K's own share at k = 2, at least.
            assert!(rel >= 2.0 * u_k_rel * 0.999, "{name}: {rel} < 2 u(K)/K");
        }
        assert!(["law", "monte-carlo"].contains(&o["method"].as_str().unwrap()));
    }
    for figure in ["albedo(", "gloss 20", "gloss 60", "gloss 85", "haze (E430)"] {
        assert!(
            outputs
                .iter()
                .any(|o| o["name"].as_str().unwrap().starts_with(figure)),
            "{figure}"
        );
    }
    let readings = j["readings"].as_array().unwrap();
    assert!(readings.len() > 100);
    assert!(
        readings
            .iter()
            .all(|r| r["expanded"].as_f64().unwrap() > 0.0)
    );
}

#[test]
fn the_solar_arrays_budget_names_its_assumptions() {
    let data = repo_root().join("host-tool/tests/data/scatterworks-solar-array-532nm.sweep.csv");
    let out = gonio(&["budget", &s(&data), "--trials", "0"]);
    assert!(out.ok(), "{}", out.stderr);
    for what in [
        "Assumptions",
        "absolute scale (no K given): 2 % relative assumed",
        "detector arm home repeatability",
        "detector noise: the fit's model of the data assumed",
        "albedo(41.4)",
        "expanded U (k = 2)",
        "Monte Carlo not run",
        // The fit's own assumption: its core is narrower than the 1 deg step, and half
        // the step (0.5 deg) would make the 75 deg peak carry more than the incident
        // energy: the widest cone whose fit conserves energy.
        "detector aperture: a half-angle of 0.2563 deg assumed by the fit",
    ] {
        assert!(out.stdout.contains(what), "{what}:\n{}", out.stdout);
    }
    // --aperture 0 states point readings: nothing assumed.
    let point = gonio(&["budget", &s(&data), "--trials", "0", "--aperture", "0"]);
    assert!(point.ok(), "{}", point.stderr);
    assert!(
        !point.stdout.contains("detector aperture"),
        "{}",
        point.stdout
    );
    let out = gonio(&["budget", &s(&data), "--uncertainty", "/nonexistent.toml"]);
    assert_eq!(out.code, 2, "{}", out.stderr);
}
