//! Issue #53's bar on the real sweeps in the repository, as `gonio fit` runs them by
//! default: every incidence's peak reading followed within a factor 1.5. The check is
//! reusable (`default_fit_peaks`, `peak_misses`); docs/accuracy.md (`cargo xtask
//! accuracy`) holds the full comparison with a two-lobe Beckmann fit.

use std::path::{Path, PathBuf};

use crate::util::{gonio, repo_root, scratch};

/// The bar: fitted / measured at the peak reading within [1/FACTOR, FACTOR].
pub const FACTOR: f64 = 1.5;

/// One incidence's highest reading and the selected member's value there.
#[derive(Debug, Clone, PartialEq)]
pub struct Peak {
    pub theta_i: f64,
    pub theta_r: f64,
    pub measured: f64,
    pub fitted: f64,
}

impl Peak {
    /// fitted / measured.
    pub fn ratio(&self) -> f64 {
        self.fitted / self.measured
    }
}

/// A real sweep of the repository as the accuracy report fits it.
pub struct RealSweep {
    pub name: &'static str,
    pub file: PathBuf,
    /// `gonio fit`'s flags beyond the default (the RGL paint's zero readings have no
    /// logarithm: `--floor 0`).
    pub flags: &'static [&'static str],
}

/// Imports an RGL file's in-plane sweep (channel g) into `dir`.
fn import_rgl(dir: &Path, file: &str, extra: &[&str], out: &str) -> PathBuf {
    let src = repo_root().join("host-tool/tests/data").join(file);
    let out = dir.join(out);
    let mut args = vec![
        "import",
        "rgl",
        src.to_str().unwrap(),
        "--channel",
        "g",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let run = gonio(&args);
    assert!(run.ok(), "{file}: {}", run.stderr);
    out
}

/// Every real sweep in the repository (the same five as xtask/src/accuracy.rs), the
/// RGL ones imported into `dir`.
pub fn real_sweeps(dir: &Path) -> Vec<RealSweep> {
    let data = repo_root().join("host-tool/tests/data");
    vec![
        RealSweep {
            name: "scatterworks",
            file: data.join("scatterworks-solar-array-532nm.sweep.csv"),
            flags: &[],
        },
        RealSweep {
            name: "merl aluminium",
            file: data.join("merl-aluminium-inplane.sweep.csv"),
            flags: &[],
        },
        RealSweep {
            name: "rgl l3-37 paint g",
            file: import_rgl(dir, "rgl_ilm_l3_37_metallic_rgb.bsdf", &[], "ilm.csv"),
            flags: &["--floor", "0"],
        },
        RealSweep {
            name: "rgl chrome film g, 1 deg",
            file: import_rgl(dir, "rgl_chm_mint_rgb.bsdf", &[], "chm.csv"),
            flags: &[],
        },
        RealSweep {
            name: "rgl chrome film g, 0.25 deg",
            file: import_rgl(
                dir,
                "rgl_chm_mint_rgb.bsdf",
                &["--theta-r=-89:89:0.25"],
                "chm-fine.csv",
            ),
            flags: &[],
        },
    ]
}

/// Per incidence (ascending), the highest reading of a residuals export (the first of
/// equals) and the fitted value there.
pub fn peaks(export: &str) -> Vec<Peak> {
    let mut out: Vec<Peak> = Vec::new();
    for line in export
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("theta_i"))
    {
        let f: Vec<&str> = line.split(',').collect();
        let num = |i: usize| f[i].parse::<f64>().unwrap_or(f64::NAN);
        let p = Peak {
            theta_i: num(0),
            theta_r: num(1),
            measured: num(2),
            fitted: num(3),
        };
        match out
            .iter_mut()
            .find(|q| (q.theta_i - p.theta_i).abs() < 1e-6)
        {
            Some(q) if p.measured > q.measured => *q = p,
            Some(_) => {}
            None => out.push(p),
        }
    }
    out.sort_by(|a, b| a.theta_i.total_cmp(&b.theta_i));
    out
}

/// The peaks outside the bar (a NaN ratio is outside).
pub fn peak_misses(peaks: &[Peak]) -> Vec<&Peak> {
    peaks
        .iter()
        .filter(|p| !(1.0 / FACTOR..=FACTOR).contains(&p.ratio()))
        .collect()
}

/// `gonio fit SWEEP` (the default family and objective) with the residuals export of
/// its selected member, into `dir`: the member's peaks, and the report.
pub fn default_fit_peaks(dir: &Path, s: &RealSweep) -> (Vec<Peak>, String) {
    let res = dir.join("peaks-residuals.csv");
    let export = format!("residuals={}", res.display());
    let mut args = vec![
        "fit",
        s.file.to_str().unwrap(),
        "--checks",
        "none",
        "--force",
        "--export",
        &export,
    ];
    args.extend_from_slice(s.flags);
    let run = gonio(&args);
    assert!(run.ok(), "{}: {}", s.name, run.stderr);
    (peaks(&std::fs::read_to_string(&res).unwrap()), run.stdout)
}

/// "theta_i: ratio" of each peak, for messages.
pub fn describe(peaks: &[&Peak]) -> String {
    peaks
        .iter()
        .map(|p| format!("{}: {:.2}", p.theta_i, p.ratio()))
        .collect::<Vec<_>>()
        .join(", ")
}

#[test]
fn peaks_are_the_highest_reading_of_each_incidence() {
    let export = "# gonio residuals v1\ntheta_i,theta_r,measured,fitted,residual\n\
                  41.4,40,2,1,0\n41.4,41,8,4,0\n5,5,3,4.5,0\n41.4,42,8,16,0\n5,6,1,,\n";
    let p = peaks(export);
    assert_eq!(p.len(), 2);
    assert_eq!((p[0].theta_i, p[0].theta_r, p[0].ratio()), (5.0, 5.0, 1.5));
    assert_eq!(
        (p[1].theta_i, p[1].theta_r, p[1].ratio()),
        (41.4, 41.0, 0.5)
    );
    let misses = peak_misses(&p);
    assert_eq!(misses.len(), 1);
    assert_eq!(describe(&misses), "41.4: 0.50");
}

/// The peaks the default fit follows within the bar (docs/accuracy.md; issue #53's
/// noise objective, Student-t lobes and the aperture assumed for an unresolved core):
/// that work must keep them. Every real sweep is
/// fitted; each peak it misses is named, with its factor, in the report's notes.
#[test]
fn the_default_fit_keeps_the_peaks_it_follows_and_names_those_it_misses() {
    let dir = scratch("accuracy-bar");
    let sweeps = real_sweeps(&dir);
    let kept: [(&str, &[f64]); 5] = [
        // MERL's every peak, at point readings, once the Student-t members refine more
        // of their grid's best points (their lowest optimum, a second narrow lobe, was
        // reached from the 6th; the 3 best missed it, and then needed an assumed
        // aperture and still missed 78.75 deg 1.7x).
        // 41.4 deg, 0.4 deg from its nearest reading, at 0.669x over the widest
        // physical cone assumed, 0.2563 deg (half the step, 0.5 deg, is above the 75
        // deg peak's energy bound; 0.2626 deg made the fit create energy); it was
        // 0.66x over the 0.25 deg that halving alone gave.
        ("scatterworks", &[5.0, 41.4, 60.0, 75.0]),
        (
            "merl aluminium",
            &[11.25, 22.5, 33.75, 45.0, 56.25, 67.5, 78.75],
        ),
        (
            "rgl l3-37 paint g",
            &[0.0, 30.16, 43.18, 53.59, 62.8, 71.41, 79.95],
        ),
        (
            "rgl chrome film g, 1 deg",
            &[0.0, 44.1, 54.81, 64.26, 81.47],
        ),
        (
            "rgl chrome film g, 0.25 deg",
            &[30.75, 44.1, 54.81, 64.26, 73.04, 81.47],
        ),
    ];
    for (name, incidences) in kept {
        let s = sweeps.iter().find(|s| s.name == name).unwrap();
        let (all, report) = default_fit_peaks(&dir, s);
        let peaks: Vec<Peak> = all
            .iter()
            .filter(|p| incidences.iter().any(|t| (p.theta_i - t).abs() < 0.01))
            .cloned()
            .collect();
        assert_eq!(peaks.len(), incidences.len(), "{name}: {all:?}");
        let misses = peak_misses(&peaks);
        assert!(
            misses.is_empty(),
            "{name}: peaks outside {FACTOR}x at theta_i {}",
            describe(&misses)
        );
        // Every claim about a component is backed by a fit the report names (MERL
        // aluminium's directional diffuse was "absent (not tested: ... was not
        // fitted)").
        assert!(!report.contains("not tested"), "{name}:\n{report}");
        // The RGL chrome film's peaks all sit 0.1-0.5 deg below the mirror direction:
        // the report says so (one incidence's 0.097 deg once hid the shift on the 1 deg
        // grid).
        if name.starts_with("rgl chrome film") {
            assert!(
                report.contains("the measured specular peak sits -0."),
                "{name}:\n{report}"
            );
        }
        // The others are named by the report, each with its factor.
        for p in peak_misses(&all) {
            let said = format!("({}x at theta_r ", sig2(p.ratio()));
            assert!(
                report.contains("misses the peak reading by more than a factor 1.5")
                    && report.contains(&said),
                "{name}: {} not named ({said}):\n{report}",
                p.theta_i
            );
        }
    }
}

/// Two significant digits, as the report prints a factor.
fn sig2(x: f64) -> String {
    format!("{x:.1e}").parse::<f64>().unwrap().to_string()
}
