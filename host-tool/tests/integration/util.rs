//! What every integration test shares: running `gonio` and reading what it said,
//! scratch directories that clean up after themselves, and reading a fit back as
//! brdf-core models to compare with the simulated truth.

use std::ops::Deref;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The `gonio` binary under test, ready for arguments (for tests that spawn it, signal
/// it or feed its stdin).
pub fn gonio_command() -> Command {
    Command::new(env!("CARGO_BIN_EXE_gonio"))
}

/// What one run of `gonio` did.
#[derive(Debug)]
pub struct Run {
    /// Exit status.
    pub code: i32,
    /// Everything on stdout.
    pub stdout: String,
    /// Everything on stderr.
    pub stderr: String,
}

impl Run {
    /// Exit status 0.
    pub fn ok(&self) -> bool {
        self.code == 0
    }

    /// The last line on stderr (after progress lines), or "".
    pub fn last_line(&self) -> &str {
        self.stderr.lines().last().unwrap_or("")
    }
}

impl From<std::process::Output> for Run {
    fn from(out: std::process::Output) -> Self {
        Run {
            code: out.status.code().expect("gonio ended by a signal"),
            stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
            stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
        }
    }
}

/// Asserts that `stderr` is exactly one `gonio: ...` line and returns it.
pub fn one_line(stderr: &str) -> &str {
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(
        lines.len(),
        1,
        "expected one line on stderr, got: {stderr:?}"
    );
    assert!(lines[0].starts_with("gonio: "), "{stderr:?}");
    lines[0]
}

/// Runs `gonio args...` to completion.
pub fn gonio(args: &[&str]) -> Run {
    gonio_command()
        .args(args)
        .output()
        .expect("run gonio")
        .into()
}

/// `gonio convert SAMPLE --instrument INST --out OUT` (to 1/sr); the run, whatever
/// its outcome (callers assert success or the refusal they expect).
pub fn convert(sample: &std::path::Path, inst: &std::path::Path, out: &std::path::Path) -> Run {
    let [a, b, c] = [sample, inst, out].map(|p| p.to_str().expect("UTF-8 path").to_string());
    gonio(&["convert", &a, "--instrument", &b, "--out", &c])
}

/// The three-component parameters of `fit --json` as brdf-core models per incidence.
pub fn fitted_models(json: &str) -> Vec<(f64, brdf_core::Model<f64>)> {
    let v: serde_json::Value = serde_json::from_str(json).unwrap();
    let m = v["models"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["name"] == "three-component")
        .expect("a three-component fit");
    let p = &m["params"];
    let f = |k: &str| p[k].as_f64().unwrap();
    p["k_s"]
        .as_array()
        .unwrap()
        .iter()
        .map(|pair| {
            let (ti, ks) = (pair[0].as_f64().unwrap(), pair[1].as_f64().unwrap());
            let params = brdf_core::model::Params {
                ks,
                sigma: f("sigma"),
                kdd: f("k_dd"),
                sigma_m: f("sigma_m"),
                kid: f("k_id"),
            };
            (
                ti,
                brdf_core::Model::new(params, brdf_core::model::Components::ALL).unwrap(),
            )
        })
        .collect()
}

/// Largest |f_fit / f_true - 1| over the paper's grid (away from retro-reflection),
/// f_true = preset / K in 1/sr.
pub fn worst_error(models: &[(f64, brdf_core::Model<f64>)], preset: &brdf_core::Preset) -> f64 {
    let k = f64::from(brdf_core::sim::SIM_K);
    let mut worst: f64 = 0.0;
    for (ti, m) in models {
        let truth = preset.model::<f64>(*ti).unwrap();
        for j in -8..=8 {
            let tr = 10.0 * j as f64;
            if (tr + ti).abs() < 5.0 {
                continue;
            }
            let got = m.eval_in_plane(*ti, tr).unwrap().f;
            let want = truth.eval_in_plane(*ti, tr).unwrap().f / k;
            worst = worst.max((got / want - 1.0).abs());
        }
    }
    worst
}

/// A fresh scratch directory, removed with everything in it when dropped; derefs to its
/// path.
pub struct Scratch(tempfile::TempDir);

impl Deref for Scratch {
    type Target = Path;

    fn deref(&self) -> &Path {
        self.0.path()
    }
}

/// A scratch directory named after what it is for.
pub fn scratch(what: &str) -> Scratch {
    Scratch(
        tempfile::Builder::new()
            .prefix(&format!("gonio-{what}-"))
            .tempdir()
            .expect("a scratch directory"),
    )
}

/// The repository root (for files the tests read, never write).
pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("workspace root")
        .to_path_buf()
}

/// A sweep file of `material` captured by `gonio simulate` into `dir`.
pub fn simulated(dir: &Path, material: &str) -> PathBuf {
    simulated_seed(dir, material, "1")
}

/// [`simulated`] with the simulation's noise seed.
pub fn simulated_seed(dir: &Path, material: &str, seed: &str) -> PathBuf {
    let f = dir.join(format!("{material}.csv"));
    let out = gonio(&[
        "simulate",
        "--material",
        material,
        "--seed",
        seed,
        "--out",
        f.to_str().unwrap(),
        "-q",
    ]);
    assert!(out.ok(), "{}", out.stderr);
    f
}

/// The `notes` of a `gonio fit --json` report, as strings.
pub fn notes(v: &serde_json::Value) -> Vec<String> {
    v["notes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| n.as_str().unwrap().to_string())
        .collect()
}
