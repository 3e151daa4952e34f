//! `--until`: a capture that ends once the fit knows the parameters, its file's status
//! and the message, checked against `gonio fit` of the file it left.

use crate::util::{gonio, scratch};

/// The selected member's `name` and its standard error, as `gonio fit --json` gives them.
fn fitted(path: &std::path::Path, name: &str) -> (f64, f64) {
    let run = gonio(&["fit", "--json", path.to_str().unwrap()]);
    assert!(run.ok(), "{}", run.stderr);
    let v: serde_json::Value = serde_json::from_str(&run.stdout).unwrap();
    let sel = v["selected"].as_str().unwrap();
    let m = v["models"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["name"] == sel)
        .unwrap();
    (
        m["params"][name].as_f64().unwrap(),
        m["std_errors"][name].as_f64().unwrap(),
    )
}

/// Issue 50 case 6: the paper plan measures incidence by incidence, and one
/// incidence's fit cannot be stopped on (on al-0.782 `--until k_id:5%` stopped after 17
/// readings with k_id 14 standard errors from the full sweep's): the capture runs the
/// whole plan, says the targets were met with it, and `gonio fit` of the file meets
/// them. (Before issue 50 this test asked for fewer readings than the plan: that was
/// the early stop.)
#[test]
fn until_on_a_plan_measured_incidence_by_incidence_measures_every_incidence() {
    let d = scratch("until");
    let f = d.join("fe.csv");
    let p = f.to_str().unwrap();
    let run = gonio(&[
        "simulate",
        "--material",
        "fe-0.115",
        "--until",
        "sigma:0.5%",
        "--out",
        p,
    ]);
    assert!(run.ok(), "{}", run.stderr);
    let data = gonio::sweep_file::read_sweep(&f).unwrap();
    let incidences: std::collections::BTreeSet<u64> =
        data.rows.iter().map(|r| r.theta_i.to_bits()).collect();
    assert_eq!(incidences.len(), 9, "{}", run.stderr);
    assert_eq!(data.rows.len(), 153, "{}", run.stderr);
    assert!(
        run.stderr
            .contains("--until met with the whole plan measured"),
        "{}",
        run.stderr
    );
    // The file's own fit (gonio fit) meets the target.
    let (sigma, se) = fitted(&f, "sigma");
    assert!(se / sigma <= 0.005, "sigma {sigma} ± {se}");
    assert!(
        (sigma - 0.115).abs() < 3.0 * se + 1e-3,
        "sigma {sigma} ± {se}"
    );
}

/// Issue 50 case 6, as filed: `--until k_id:5%` on al-0.782 ends within 2 standard
/// errors of the full sweep's k_id, on several seeds.
#[test]
fn until_on_aluminium_ends_within_two_standard_errors_of_the_full_sweep() {
    let d = scratch("until-al");
    for seed in ["1", "2", "3"] {
        let sweep = |name: &str, until: bool| {
            let f = d.join(format!("{name}-{seed}.csv"));
            let p = f.to_str().unwrap().to_string();
            let mut args = vec!["simulate", "--material", "al-0.782", "--seed", seed];
            if until {
                args.extend(["--until", "k_id:5%"]);
            }
            args.extend(["--out", &p, "-q"]);
            let run = gonio(&args);
            assert!(run.ok(), "{}", run.stderr);
            fitted(&f, "k_id")
        };
        let (full, full_se) = sweep("full", false);
        let (k_id, se) = sweep("until", true);
        assert!(
            (k_id - full).abs() <= 2.0 * full_se.max(se),
            "seed {seed}: --until k_id {k_id} ± {se}, full sweep {full} ± {full_se}"
        );
    }
}

#[test]
fn a_target_the_plan_cannot_reach_is_said_not_met() {
    let d = scratch("until-unmet");
    let f = d.join("fe.csv");
    let run = gonio(&[
        "simulate",
        "--material",
        "fe-0.115",
        "--until",
        "sigma:0.001%",
        "--out",
        f.to_str().unwrap(),
    ]);
    assert!(run.ok(), "{}", run.stderr);
    assert!(
        run.last_line()
            .contains("the plan ended before --until was met: sigma:0.001%: sigma = "),
        "{}",
        run.stderr
    );
    let data = gonio::sweep_file::read_sweep(&f).unwrap();
    assert_eq!(
        (data.status_word(), data.rows.len()),
        (Some("complete"), 153)
    );
}

#[test]
fn a_sequential_plan_places_batches_until_the_target_or_its_budget() {
    let d = scratch("sequential");
    let f = d.join("seq.csv");
    let p = f.to_str().unwrap();
    let run = gonio(&[
        "simulate",
        "--material",
        "fe-0.115",
        "--plan",
        "sequential",
        "--budget",
        "300",
        "--until",
        "sigma:0.3%",
        "--out",
        p,
    ]);
    assert!(run.ok(), "{}", run.stderr);
    let data = gonio::sweep_file::read_sweep(&f).unwrap();
    assert_eq!(data.status_word(), Some("until"), "{}", run.stderr);
    let n = data.rows.len();
    assert!(n <= 300 && n < data.points.len(), "{n}");
    let (sigma, se) = fitted(&f, "sigma");
    assert!(se / sigma <= 0.003, "sigma {sigma} ± {se}");
    assert!(
        (sigma - 0.115).abs() < 3.0 * se + 1e-3,
        "sigma {sigma} ± {se}"
    );
    // A budget too small for the target: status budget, exactly that many readings.
    let g = d.join("small.csv");
    let run = gonio(&[
        "simulate",
        "--material",
        "fe-0.115",
        "--plan",
        "sequential",
        "--budget",
        "90",
        "--until",
        "sigma:0.01%",
        "--out",
        g.to_str().unwrap(),
    ]);
    assert!(run.ok(), "{}", run.stderr);
    assert!(
        run.last_line().contains("spent its budget: 90 readings"),
        "{}",
        run.stderr
    );
    assert!(
        run.last_line().contains("--until not met: sigma:0.01%"),
        "{}",
        run.stderr
    );
    let data = gonio::sweep_file::read_sweep(&g).unwrap();
    assert_eq!((data.status_word(), data.rows.len()), (Some("budget"), 90));
}

#[test]
fn a_sequential_plan_rehearsed_on_a_replay_stays_at_the_files_incidences() {
    let d = scratch("sequential-replay");
    let f = d.join("solar.csv");
    let solar = crate::util::repo_root()
        .join("host-tool/tests/data/scatterworks-solar-array-532nm.sweep.csv");
    let run = gonio(&[
        "simulate",
        "--replay",
        solar.to_str().unwrap(),
        "--plan",
        "sequential",
        "--budget",
        "60",
        "--out",
        f.to_str().unwrap(),
    ]);
    assert!(run.ok(), "{}", run.stderr);
    let data = gonio::sweep_file::read_sweep(&f).unwrap();
    assert_eq!((data.status_word(), data.rows.len()), (Some("budget"), 60));
    let incidences: std::collections::BTreeSet<String> =
        data.rows.iter().map(|r| r.theta_i.to_string()).collect();
    assert_eq!(
        incidences.into_iter().collect::<Vec<_>>(),
        ["41.4", "5", "60", "75"],
        "the coarse batch spreads over the file's incidences"
    );
}
