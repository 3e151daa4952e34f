//! Issue #41's wild values in a sweep, as the user met them: one reading of 1e30 that
//! decided the selection without the report pointing at it, and a std of 1e29 (just
//! under the reader's bound) that made every model "fit within the readings' noise".

use std::path::{Path, PathBuf};

use serde_json::Value;

use crate::util::{gonio, notes, scratch, simulated};

/// `src` with the row at theta_i 30, theta_r 20 given `value` in column `col`
/// (0-based: 2 brdf, 3 std), or left out when `value` is `None`, written to `name`.
fn edited(src: &Path, name: &str, col: usize, value: Option<&str>) -> PathBuf {
    let text = std::fs::read_to_string(src).unwrap();
    let mut out = String::new();
    let mut found = 0;
    for line in text.lines() {
        if line.starts_with("30,20,") {
            found += 1;
            let Some(v) = value else { continue };
            let mut cells: Vec<&str> = line.split(',').collect();
            cells[col] = v;
            out.push_str(&cells.join(","));
        } else {
            out.push_str(line);
        }
        out.push('\n');
    }
    assert_eq!(found, 1, "one row at 30/20");
    let path = src.with_file_name(name);
    std::fs::write(&path, out).unwrap();
    path
}

fn fit_json(path: &Path) -> Value {
    let out = gonio(&["fit", path.to_str().unwrap(), "--json"]);
    assert!(out.ok(), "{}", out.stderr);
    serde_json::from_str(&out.stdout).expect("one JSON object")
}

#[test]
fn one_reading_of_1e30_is_named_by_the_report() {
    let d = scratch("wild-reading");
    let fe = simulated(&d, "fe-0.115");
    let clean = fit_json(&fe);
    assert_eq!(clean["selected"], "three-component");
    assert!(
        !notes(&clean)
            .iter()
            .any(|n| n.contains("sum of squared residuals")),
        "{:?}",
        notes(&clean)
    );
    let wild = fit_json(&edited(&fe, "wild.csv", 2, Some("1e30")));
    let selected = wild["selected"].as_str().unwrap();
    let named: Vec<String> = notes(&wild)
        .into_iter()
        .filter(|n| n.contains("sum of squared residuals"))
        .collect();
    assert_eq!(named.len(), 1, "{:?}", notes(&wild));
    let n = &named[0];
    assert!(
        n.starts_with("1 reading of 153 carries ")
            && n.contains(&format!(
                "of {selected}'s sum of squared residuals: theta_i 30 theta_r 20 brdf 1e30 (fitted "
            ))
            && n.contains("remove it from the file and fit again"),
        "{n}"
    );
    // Doing what the note says gives back the clean file's selection.
    let removed = fit_json(&edited(&fe, "removed.csv", 2, None));
    assert_eq!(removed["selected"], "three-component");
}

#[test]
fn a_std_of_1e29_makes_no_goodness_claim() {
    let d = scratch("wild-std");
    let fe = simulated(&d, "fe-0.115");
    let said = |v: &Value| {
        notes(v)
            .into_iter()
            .find(|n| n.starts_with("goodness of fit"))
            .unwrap()
    };
    let clean = fit_json(&fe);
    assert!(said(&clean).ends_with("fits within the readings' noise"));
    let wild = fit_json(&edited(&fe, "wild-std.csv", 3, Some("1e29")));
    let note = said(&wild);
    assert!(
        note.starts_with("goodness of fit against noise: not judged: the standard error std/sqrt(n) stated for the reading at theta_i 30 theta_r 20 (brdf ")
            && note.contains(") is 5e28 (")
            && note.contains("chi-square says nothing here"),
        "{note}"
    );
    for m in wild["models"].as_array().unwrap() {
        assert!(
            m["reduced_chi2"].is_null(),
            "{}: {}",
            m["name"],
            m["reduced_chi2"]
        );
    }
}
