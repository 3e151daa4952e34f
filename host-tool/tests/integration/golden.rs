//! The fit's behaviour pinned: `gonio fit --json` on a corpus of committed sweeps
//! (`host-tool/tests/golden/inputs/`, see its README) under every option that changes
//! what is fitted, compared byte for byte with the committed answers
//! (`host-tool/tests/golden/expected/`) once `fit_seconds` is taken out. A change to
//! any number fails here; a change meant to change answers rewrites them with
//! `GONIO_BLESS=1 cargo test -p host-tool --test integration golden` and says why in
//! its commit.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::util::{Run, scratch};

/// One pinned run: its name (the expected file's) and `gonio fit`'s arguments, run in
/// the inputs folder (so file names in the answers are relative).
struct Case {
    name: &'static str,
    args: &'static [&'static str],
}

const fn case(name: &'static str, args: &'static [&'static str]) -> Case {
    Case { name, args }
}

/// The corpus: 5 presets x 2 noise levels and seeds, adaptive plans, a retro gap, a
/// 2-degree grid, the real Scatterworks sweep; `--fix`, each `--loss`, each
/// `--residual`, `--aperture`, `--floor`, `--models`, `--all-starts`, `--instrument`.
const CASES: &[Case] = &[
    case("fe-s1", &["fe-0.115-s1.csv"]),
    case("fe-s2", &["fe-0.115-s2.csv"]),
    case("cu-s1", &["cu-0.070-s1.csv"]),
    case("cu-s2", &["cu-0.070-s2.csv"]),
    case("al087-s1", &["al-0.087-s1.csv"]),
    case("al087-s2", &["al-0.087-s2.csv"]),
    case("al142-s1", &["al-0.142-s1.csv"]),
    case("al142-s2", &["al-0.142-s2.csv"]),
    case("al782-s1", &["al-0.782-s1.csv"]),
    case("al782-s2", &["al-0.782-s2.csv"]),
    case("al142-adaptive", &["al-0.142-adaptive.csv"]),
    case("cu-adaptive", &["cu-0.070-adaptive.csv"]),
    case("fe-retro", &["fe-0.115-retro.csv"]),
    case("cu-fine", &["cu-0.070-fine.csv"]),
    case(
        "scatterworks",
        &["../../data/scatterworks-solar-array-532nm.sweep.csv"],
    ),
    case(
        "scatterworks-aperture",
        &[
            "../../data/scatterworks-solar-array-532nm.sweep.csv",
            "--aperture",
            "0.5",
        ],
    ),
    case(
        "scatterworks-rel",
        &[
            "../../data/scatterworks-solar-array-532nm.sweep.csv",
            "--residual",
            "rel",
        ],
    ),
    // --fix: each parameter, alone and together, right and wrong.
    case("fe-fix-sigma", &["fe-0.115-s1.csv", "--fix", "sigma=0.115"]),
    case(
        "fe-fix-sigma-off",
        &["fe-0.115-s1.csv", "--fix", "sigma=0.3"],
    ),
    case(
        "cu-fix-sigma-m",
        &["cu-0.070-s1.csv", "--fix", "sigma_m=0.7"],
    ),
    case("cu-fix-kdd", &["cu-0.070-s2.csv", "--fix", "kdd=500"]),
    case("al142-fix-kid", &["al-0.142-s1.csv", "--fix", "kid=20"]),
    case("al087-fix-kd", &["al-0.087-s1.csv", "--fix", "kd=100"]),
    case(
        "fe-fix-two",
        &[
            "fe-0.115-s2.csv",
            "--fix",
            "sigma=0.12",
            "--fix",
            "sigma_m=0.7",
        ],
    ),
    case(
        "fe-fix-models",
        &[
            "fe-0.115-s1.csv",
            "--fix",
            "sigma=0.115",
            "--models",
            "ts,three",
        ],
    ),
    // Robust losses, each residual kind.
    case("fe-huber", &["fe-0.115-s1.csv", "--loss", "huber:0.01"]),
    case("cu-huber", &["cu-0.070-s2.csv", "--loss", "huber:0.05"]),
    case(
        "al142-cauchy",
        &["al-0.142-s2.csv", "--loss", "cauchy:0.02"],
    ),
    case("al782-cauchy", &["al-0.782-s1.csv", "--loss", "cauchy:0.1"]),
    case(
        "fe-abs-cauchy",
        &["fe-0.115-s1.csv", "--residual", "abs", "--loss", "cauchy:1"],
    ),
    case(
        "cu-rel-huber",
        &[
            "cu-0.070-s1.csv",
            "--residual",
            "rel",
            "--loss",
            "huber:0.02",
        ],
    ),
    case(
        "fe-fix-huber",
        &[
            "fe-0.115-s2.csv",
            "--fix",
            "sigma=0.115",
            "--loss",
            "huber:0.05",
        ],
    ),
    // Residual kinds, the aperture, the floor, member lists, every start.
    case("fe-rel", &["fe-0.115-s1.csv", "--residual", "rel"]),
    case("cu-abs", &["cu-0.070-s1.csv", "--residual", "abs"]),
    case("al087-abs", &["al-0.087-s2.csv", "--residual", "abs"]),
    case("fe-aperture", &["fe-0.115-s1.csv", "--aperture", "1.5"]),
    case("al087-aperture", &["al-0.087-s1.csv", "--aperture", "2"]),
    case(
        "cu-aperture-abs",
        &["cu-0.070-s2.csv", "--aperture", "1", "--residual", "abs"],
    ),
    case("fe-floor", &["fe-0.115-s1.csv", "--floor", "200"]),
    case("al782-floor", &["al-0.782-s2.csv", "--floor", "auto"]),
    case(
        "cu-models",
        &["cu-0.070-s1.csv", "--models", "ideal,ts,three,three-smooth"],
    ),
    case("al142-all-starts", &["al-0.142-s1.csv", "--all-starts"]),
    case(
        "fe-checks-selected",
        &["fe-0.115-s1.csv", "--checks", "selected"],
    ),
    case(
        "fe-instrument",
        &["fe-0.115-abs.csv", "--instrument", "instrument.toml"],
    ),
];

fn inputs() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden/inputs")
}

fn expected() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden/expected")
}

/// A JSON answer with every `fit_seconds` line taken out (the one field that differs
/// between runs); the rest as written, so a change in a number's last bit shows (the
/// text, not a parse of it: a parse may round).
fn pinned(json: &str, what: &str) -> String {
    assert!(
        serde_json::from_str::<serde_json::Value>(json).is_ok(),
        "{what}: not JSON: {json:.300}"
    );
    json.lines()
        .filter(|l| !l.trim_start().starts_with("\"fit_seconds\":"))
        .map(|l| format!("{l}\n"))
        .collect()
}

/// Compares `got` with the expected file `name`, or writes it under GONIO_BLESS=1.
/// Returns the difference, if any, as a message.
fn check(name: &str, got: &str) -> Option<String> {
    let path = expected().join(format!("{name}.json"));
    if std::env::var_os("GONIO_BLESS").is_some() {
        std::fs::create_dir_all(expected()).unwrap();
        std::fs::write(&path, got).unwrap();
        return None;
    }
    let want = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| format!("(cannot read {}: {e})", path.display()));
    if want == got {
        return None;
    }
    let line = want
        .lines()
        .zip(got.lines())
        .position(|(a, b)| a != b)
        .unwrap_or_else(|| want.lines().count().min(got.lines().count()));
    Some(format!(
        "{name}: differs from {} at line {}: expected {:?}, got {:?}",
        path.display(),
        line + 1,
        want.lines().nth(line).unwrap_or("(end)"),
        got.lines().nth(line).unwrap_or("(end)")
    ))
}

fn fit(args: &[&str], dir: &Path) -> Run {
    Command::new(env!("CARGO_BIN_EXE_gonio"))
        .arg("fit")
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run gonio")
        .into()
}

#[test]
fn every_fit_of_the_corpus_answers_as_pinned() {
    assert!(CASES.len() >= 40, "the corpus holds at least 40 runs");
    let dir = inputs();
    let mut wrong = Vec::new();
    for c in CASES {
        let mut args = c.args.to_vec();
        args.push("--json");
        let run = fit(&args, &dir);
        assert!(
            run.ok(),
            "{}: gonio fit {args:?} failed: {}",
            c.name,
            run.stderr
        );
        wrong.extend(check(c.name, &pinned(&run.stdout, c.name)));
    }
    assert!(
        wrong.is_empty(),
        "{} of {} runs changed:\n{}",
        wrong.len(),
        CASES.len(),
        wrong.join("\n")
    );
}

#[test]
fn a_campaigns_summary_answers_as_pinned() {
    let out = scratch("golden-campaign");
    let out_arg = out.to_str().expect("UTF-8 path");
    let run = fit(
        &[
            "fe-0.115-s1.csv",
            "cu-0.070-s2.csv",
            "al-0.142-adaptive.csv",
            "fe-0.115-retro.csv",
            "--out",
            out_arg,
        ],
        &inputs(),
    );
    assert!(run.ok(), "campaign failed: {}", run.stderr);
    let summary = std::fs::read_to_string(out.join("summary.json")).expect("summary.json");
    let diff = check("campaign-summary", &pinned(&summary, "summary.json"));
    assert!(diff.is_none(), "{}", diff.unwrap_or_default());
}

/// `gonio fit SWEEP` of every sweep of the corpus and the repository's real one prints
/// its verdict first, in at most 40 lines: the member the pinned `--json` answer
/// selects, the fit against the noise, the notes; `--all` has the rest.
#[test]
fn the_text_report_leads_with_its_verdict() {
    let mut failures = Vec::new();
    for c in CASES.iter().filter(|c| c.args.len() == 1) {
        let expected = std::fs::read_to_string(expected().join(format!("{}.json", c.name)))
            .expect("expected answer");
        let v: serde_json::Value = serde_json::from_str(&expected).unwrap();
        let selected = v["selected"].as_str().unwrap();
        let out: Run = Command::new(env!("CARGO_BIN_EXE_gonio"))
            .arg("fit")
            .args(c.args)
            .current_dir(inputs())
            .output()
            .unwrap()
            .into();
        assert!(out.ok(), "{}: {}", c.name, out.stderr);
        let lines: Vec<&str> = out.stdout.lines().collect();
        if lines.len() > 40 {
            failures.push(format!("{}: {} lines", c.name, lines.len()));
        }
        if !lines
            .first()
            .is_some_and(|l| l.starts_with(&format!("selected: {selected} (")))
        {
            failures.push(format!("{}: does not lead with {selected}", c.name));
        }
        for want in ["fit: ", "notes:", "--all"] {
            if !out.stdout.contains(want) {
                failures.push(format!("{}: no '{want}'", c.name));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
