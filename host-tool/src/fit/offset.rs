//! Instrument angles as parameters (`gonio fit --offset`): a detector zero offset in
//! theta_r and an in-plane sample tilt, given or fitted with standard errors.
//!
//! Geometry (degrees; theta_r signed, positive on the specular side). A detector zero
//! offset `d` means the detector sits at theta_r - d when it reads theta_r, so the
//! measured peak moves by +d. A sample tilted by `t` toward the specular side sees the
//! source at theta_i + t and the detector at theta_r - t from its own normal, so its
//! mirror direction moves by +2t and its local incidence by +t. Both together: the
//! surface is evaluated at (theta_i + t, theta_r - d - t); the peak moves by
//! s = d + 2t at every incidence.
//!
//! What the data can tell apart: s is fixed by where the peaks sit. d and t differ only
//! through the local incidence t changes (the lobes' shape and weight at theta_i + t),
//! which a member with a k_s per incidence mostly absorbs; so t is reported only where
//! the data determine it, and otherwise all of s is reported as a detector offset.
//!
//! How: the member the family selects without offsets is refitted (width grid, then
//! LM: the whole member fit) along s, then along t at that s, each minimum found by a
//! scan and golden-section search; the standard errors come from the curvature of the
//! profiled SSR, cov = 2 s^2 H^-1 with H its Hessian in (s, t) by central differences
//! and s^2 = SSR / (n - k - 2) (profiling keeps the other parameters at their optimum,
//! so their correlation with the angles is in H). The other parameters' standard
//! errors are conditional on the fitted angles.

use brdf_core::member::Member;

use super::data::Dataset;
pub use super::data::{MAX_OFFSET, OffsetSpec};
use super::goodness;
use super::options::Residual;
use crate::sweep_file::Row;

/// A standard error of the tilt above this (degrees) means the data do not tell a
/// tilt from a detector offset.
pub const TILT_UNDETERMINED: f64 = 0.5;

/// A shift this close (degrees) to the edge of its search is at the bound: not
/// determined by the peaks (the golden-section search ends within 1e-4 of it).
const BOUND_MARGIN: f64 = 1e-3;

/// The instrument's angles the fit used.
#[derive(Debug, Clone, PartialEq)]
pub struct Angles {
    /// Detector zero offset d (degrees).
    pub detector: f64,
    /// Its standard error (None: given, or not determined).
    pub detector_se: Option<f64>,
    /// In-plane sample tilt t (degrees).
    pub tilt: f64,
    /// Its standard error (None: not fitted, or not told apart from d).
    pub tilt_se: Option<f64>,
    /// The peak's shift s = d + 2t (degrees) and its standard error.
    pub shift: (f64, Option<f64>),
    /// Fitted (`--offset fit`), or given.
    pub fitted: bool,
    /// The data told the tilt apart from the detector offset.
    pub told_apart: bool,
    /// A tilt was not told apart because the member does not follow the readings
    /// within their stated noise (or they state none): its misfit could pass for one.
    pub tilt_hidden_by_misfit: bool,
    /// A tilt told apart but not applied: its estimate and standard error (degrees),
    /// within two standard errors of none.
    pub tilt_not_supported: Option<(f64, f64)>,
    /// The member whose fit placed them.
    pub member: Option<Member>,
    /// Readings whose local angle fell outside [-90, 90] degrees, left out.
    pub left_out: usize,
    /// `--offset fit` where the peaks do not determine an offset (the best shift at the
    /// search's bound, or without a standard error): why, and no offset is applied.
    pub not_determined: Option<String>,
}

impl Angles {
    /// Given angles (`--offset DEG`).
    pub fn given(detector: f64) -> Self {
        Angles {
            detector,
            detector_se: None,
            tilt: 0.0,
            tilt_se: None,
            shift: (detector, None),
            fitted: false,
            told_apart: false,
            tilt_hidden_by_misfit: false,
            tilt_not_supported: None,
            member: None,
            left_out: 0,
            not_determined: None,
        }
    }

    /// The report's lines on them.
    pub fn notes(&self) -> Vec<String> {
        let se = |x: Option<f64>| x.map_or(String::new(), |s| format!(" ± {s:.3}"));
        let mut out = Vec::new();
        if let Some(why) = &self.not_determined {
            out.push(format!(
                "instrument angles: not determined: the peaks do not fix an offset ({why}); fitted on the angles as read, no offset applied"
            ));
        } else if !self.fitted {
            out.push(format!(
                "instrument angles: detector zero offset {:+.3} deg (given), no tilt",
                self.detector
            ));
        } else if let Some((t, e)) = self.tilt_not_supported {
            out.push(format!(
                "instrument angles fitted (with {}): detector zero offset {:+.3}{} deg; no sample tilt (a tilt fitted beside it, {t:+.3} ± {e:.3} deg, is within two standard errors of none)",
                self.member.map_or(String::new(), |m| m.to_string()),
                self.detector,
                se(self.detector_se),
            ));
        } else if self.told_apart {
            out.push(format!(
                "instrument angles fitted (with {}): detector zero offset {:+.3}{} deg, sample tilt {:+.3}{} deg (peak shift {:+.3}{} deg)",
                self.member.map_or(String::new(), |m| m.to_string()),
                self.detector,
                se(self.detector_se),
                self.tilt,
                se(self.tilt_se),
                self.shift.0,
                se(self.shift.1)
            ));
        } else {
            let why = if self.tilt_hidden_by_misfit {
                " (a tilt shows only in the lobes' shape at the local incidence, and this member does not follow the readings within their stated noise, or they state none: its misfit could pass for a tilt)"
            } else {
                ""
            };
            out.push(format!(
                "instrument angles fitted (with {}): the peaks sit {:+.3}{} deg from the mirror direction; these data do not tell a detector offset from a sample tilt (which would be half of it){why}, so it is reported as a detector zero offset (give --offset DEG if you know the detector's)",
                self.member.map_or(String::new(), |m| m.to_string()),
                self.shift.0,
                se(self.shift.1)
            ));
        }
        if self.left_out > 0 {
            out.push(format!(
                "{} reading(s) fell beyond 90 deg once the angles were corrected and were left out",
                self.left_out
            ));
        }
        out
    }

    /// The readings of `data` at the sample's local angles: (theta_i + t,
    /// theta_r - d - t), mirrored where the local incidence is negative. Also the index
    /// in `data.obs` of each reading kept (those beyond 90 degrees are left out).
    pub fn apply(&self, data: &Dataset) -> Result<(Dataset, Vec<usize>), String> {
        shifted(data, self.detector, self.tilt)
    }
}

impl Angles {
    /// The `angles` entry of `gonio fit --json` (degrees).
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::json!({
            "detector_offset_deg": self.detector,
            "detector_offset_se": self.detector_se,
            "tilt_deg": self.tilt,
            "tilt_se": self.tilt_se,
            "peak_shift_deg": self.shift.0,
            "peak_shift_se": self.shift.1,
            "fitted": self.fitted,
            "told_apart": self.told_apart,
            "tilt_hidden_by_misfit": self.tilt_hidden_by_misfit,
            "tilt_not_supported": self.tilt_not_supported.map(|(t, e)| serde_json::json!({"tilt_deg": t, "tilt_se": e})),
            "member": self.member.map(|m| m.to_string()),
            "left_out": self.left_out,
            "not_determined": self.not_determined,
        })
    }
}

/// `data` seen at detector offset `d` and tilt `t` (see [`Angles::apply`]).
fn shifted(data: &Dataset, d: f64, t: f64) -> Result<(Dataset, Vec<usize>), String> {
    let mut rows = Vec::with_capacity(data.obs.len());
    let mut kept = Vec::with_capacity(data.obs.len());
    for (k, o) in data.obs.iter().enumerate() {
        let (mut ti, mut tr) = (o.theta_i + t, o.theta_r - d - t);
        if ti < 0.0 {
            // The plane seen from its other side.
            (ti, tr) = (-ti, -tr);
        }
        if ti > 90.0 || tr.abs() > 90.0 {
            continue;
        }
        rows.push(Row {
            theta_i: ti,
            theta_r: tr,
            brdf: o.y,
            std: o.sigma_y,
            n: o.sigma_y.map(|_| 1),
            seq: None,
            t_ms: None,
        });
        kept.push(k);
    }
    let mut out = Dataset::from_rows(&rows, false).map_err(|e| e.0)?;
    out.aperture = data.aperture;
    out.units = data.units;
    out.floor = data.floor;
    Ok((out, kept))
}

/// A member's fit to readings: its SSR and residual degrees of freedom (n - k), or
/// `None` where it cannot be fitted.
pub type FitSsr<'a> = dyn Fn(&Dataset) -> Option<(f64, usize)> + Sync + 'a;

/// The SSR of the member `fit` fits to `data` seen at (d, t), or infinity where it
/// cannot be.
fn ssr_at(data: &Dataset, fit: &FitSsr<'_>, d: f64, t: f64) -> (f64, usize) {
    shifted(data, d, t)
        .ok()
        .and_then(|(local, _)| fit(&local))
        .unwrap_or((f64::INFINITY, 0))
}

/// The minimum of `f` over [lo, hi]: a scan of `steps` points, then golden-section
/// search around the best to `tol`.
fn minimise(f: &mut dyn FnMut(f64) -> f64, lo: f64, hi: f64, steps: usize, tol: f64) -> f64 {
    let h = (hi - lo) / steps as f64;
    let best = (0..=steps)
        .map(|i| lo + h * i as f64)
        .map(|x| (x, f(x)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map_or(0.0, |b| b.0);
    let (mut a, mut b) = ((best - h).max(lo), (best + h).min(hi));
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut x1, mut x2) = (b - g * (b - a), a + g * (b - a));
    let (mut f1, mut f2) = (f(x1), f(x2));
    while b - a > tol {
        if f1 <= f2 {
            (b, x2, f2) = (x2, x1, f1);
            x1 = b - g * (b - a);
            f1 = f(x1);
        } else {
            (a, x1, f1) = (x1, x2, f2);
            x2 = a + g * (b - a);
            f2 = f(x2);
        }
    }
    if f1 <= f2 { x1 } else { x2 }
}

/// Whether the member `fit` fits to `data` seen at (d, t) follows the readings within
/// their stated noise under `residual` (false where they state none).
fn follows_within_noise(
    data: &Dataset,
    fit: &FitSsr<'_>,
    residual: Residual,
    d: f64,
    t: f64,
) -> bool {
    let Ok((local, _)) = shifted(data, d, t) else {
        return false;
    };
    let Some((ssr, dof)) = fit(&local) else {
        return false;
    };
    let k = local.obs.len().saturating_sub(dof);
    goodness::goodness_of_ssr(&local, ssr, residual.resolved(&local), k)
        .is_some_and(|g| g.within_noise())
}

/// Fits the detector offset and the tilt with `member` (the member the family selects
/// without them), fitted to readings by `fit` under `residual`, starting from the peak
/// shift `s0` (degrees) that the readings show.
///
/// A tilt is told apart from a detector offset only through the lobes' shape at the
/// local incidence, which is where a member that does not follow the readings misses:
/// so it is applied only where the member fits the readings within their stated noise.
/// Otherwise the misfit passes for a tilt: the iron sweep read 2 degrees high, fitted
/// under the noise rule by a member that is not the one it was made from, gave a
/// "significant" tilt of 0.11 degrees and a detector offset of 1.72 +- 0.07 degrees
/// where the peaks' shift at no tilt is 2.00.
pub fn fit_angles(
    data: &Dataset,
    member: Member,
    fit: &FitSsr<'_>,
    residual: Residual,
    s0: f64,
) -> Angles {
    // (s, t) -> (d, t): d = s - 2t.
    let cost = |s: f64, t: f64| ssr_at(data, fit, s - 2.0 * t, t);
    let span = 2.0;
    let s0 = s0.clamp(-MAX_OFFSET + span, MAX_OFFSET - span);
    let untilted = minimise(&mut |s| cost(s, 0.0).0, s0 - span, s0 + span, 16, 1e-4);
    let mut s = untilted;
    let mut t = minimise(&mut |t| cost(s, t).0, -span, span, 8, 1e-4);
    // s and t are correlated: Newton steps on the profiled SSR from there, by central
    // differences, until the step is below 1e-4 degrees; the last Hessian gives the
    // errors.
    let h = 0.02;
    let (mut f0, mut dof);
    let (mut hss, mut htt, mut hst);
    let mut rounds = 0;
    loop {
        let at = |ds: f64, dt: f64| cost(s + ds, t + dt).0;
        (f0, dof) = cost(s, t);
        let (sp, sm, tp, tm) = (at(h, 0.0), at(-h, 0.0), at(0.0, h), at(0.0, -h));
        let cross = at(h, h) - at(h, -h) - at(-h, h) + at(-h, -h);
        hss = (sp - 2.0 * f0 + sm) / (h * h);
        htt = (tp - 2.0 * f0 + tm) / (h * h);
        hst = cross / (4.0 * h * h);
        let (gs, gt) = ((sp - sm) / (2.0 * h), (tp - tm) / (2.0 * h));
        let det = hss * htt - hst * hst;
        rounds += 1;
        if !(det > 0.0 && hss > 0.0) || rounds > 6 {
            break;
        }
        let (ds, dt) = (-(htt * gs - hst * gt) / det, -(hss * gt - hst * gs) / det);
        // A step that does not lower the SSR, or a tiny one, ends the search.
        if ds.hypot(dt) < 1e-4 || cost(s + ds, t + dt).0 >= f0 {
            break;
        }
        (s, t) = (s + ds, t + dt);
    }
    let s2 = if dof > 2 {
        f0 / (dof - 2) as f64
    } else {
        f64::NAN
    };
    let det = hss * htt - hst * hst;
    // cov = 2 s^2 H^-1.
    let (vs, vt, cst) = if det > 0.0 && hss > 0.0 {
        (
            2.0 * s2 * htt / det,
            2.0 * s2 * hss / det,
            -2.0 * s2 * hst / det,
        )
    } else {
        (f64::NAN, f64::NAN, f64::NAN)
    };
    let se = |v: f64| (v.is_finite() && v >= 0.0).then(|| v.sqrt());
    let shift_se = if hss > 0.0 { se(2.0 * s2 / hss) } else { None };
    // A minimum at the search's edge is the bound, not the peaks' shift; one without a
    // curvature has no error: neither is an offset to report or apply.
    let (lo, hi) = (s0 - span, s0 + span);
    let at_bound = (untilted - lo).abs() < BOUND_MARGIN || (hi - untilted).abs() < BOUND_MARGIN;
    let why = if at_bound {
        Some(format!(
            "the best shift, {untilted:+.3} deg, lies at the search's bound ({lo:+.3} to {hi:+.3} deg)"
        ))
    } else if shift_se.is_none() {
        Some(format!(
            "the best shift, {untilted:+.3} deg, has no standard error: the SSR has no minimum there"
        ))
    } else {
        None
    };
    if let Some(why) = why {
        return Angles {
            fitted: true,
            member: Some(member),
            not_determined: Some(why),
            ..Angles::given(0.0)
        };
    }
    let tilt_se = se(vt).filter(|&e| e <= TILT_UNDETERMINED);
    let tilted = matches!(tilt_se, Some(e) if t.abs() >= 2.0 * e);
    // With no tilt, a shift within two standard errors of none is no offset the peaks
    // fix (as a tilt within two of none is not applied): two peaks alike on either
    // side of the mirror direction gave -0.14 +- 0.17 deg, applied as an offset.
    if let Some(e) = shift_se.filter(|&e| !tilted && untilted.abs() < 2.0 * e) {
        return Angles {
            fitted: true,
            member: Some(member),
            not_determined: Some(format!(
                "the peaks' shift, {untilted:+.3} ± {e:.3} deg, is within two standard errors of none"
            )),
            ..Angles::given(0.0)
        };
    }
    let hidden = tilted && !follows_within_noise(data, fit, residual, s - 2.0 * t, t);
    let tilt_se = tilt_se.filter(|_| !hidden);
    match tilt_se {
        Some(e) if t.abs() >= 2.0 * e => Angles {
            detector: s - 2.0 * t,
            detector_se: se(vs + 4.0 * vt - 4.0 * cst),
            tilt: t,
            tilt_se: Some(e),
            shift: (s, se(vs)),
            fitted: true,
            told_apart: true,
            tilt_hidden_by_misfit: false,
            tilt_not_supported: None,
            member: Some(member),
            left_out: left_out(data, s - 2.0 * t, t),
            not_determined: None,
        },
        // No tilt (not told apart, or within two standard errors of none): all of the
        // peak's shift is the detector's, at its optimum without a tilt.
        _ => Angles {
            detector: untilted,
            detector_se: shift_se,
            tilt: 0.0,
            tilt_se: None,
            shift: (untilted, shift_se),
            fitted: true,
            told_apart: tilt_se.is_some(),
            tilt_hidden_by_misfit: hidden,
            tilt_not_supported: tilt_se.map(|e| (t, e)),
            member: Some(member),
            left_out: left_out(data, untilted, 0.0),
            not_determined: None,
        },
    }
}

/// How many readings of `data` fall beyond 90 degrees at (d, t).
fn left_out(data: &Dataset, d: f64, t: f64) -> usize {
    shifted(data, d, t).map_or(0, |(_, kept)| data.obs.len() - kept.len())
}

#[cfg(test)]
mod tests {
    use super::super::options::FitOptions;
    use super::super::stages::member_ssr;
    use super::*;
    use brdf_core::Preset;

    /// Four incidences, 1-degree steps near the mirror and 10-degree steps elsewhere,
    /// of `f(theta_i, theta_r)` with relative noise `noise`, its std stated when
    /// `with_std`.
    fn sweep_of(f: impl Fn(f64, f64) -> f64, noise: f64, seed: u32, with_std: bool) -> Dataset {
        let mut rng = brdf_core::sim::XorShift32::new(seed);
        let mut rows = Vec::new();
        for ti in [10.0, 30.0, 50.0, 70.0] {
            for tr in (-80..=80).map(f64::from) {
                let near = (tr - ti).abs() <= 12.0;
                if !(near || tr % 10.0 == 0.0) || (tr + ti).abs() < 6.0 {
                    continue;
                }
                let v = f(ti, tr);
                let mut row = Row::new(ti, tr, v * (1.0 + noise * f64::from(rng.normal())));
                if with_std {
                    (row.std, row.n) = (Some(noise * v), Some(1));
                }
                rows.push(row);
            }
        }
        Dataset::from_rows(&rows, true).unwrap()
    }

    /// [`sweep_of`] preset `name` seen by an instrument with detector offset `d` and
    /// tilt `t`, the readings' std stated.
    fn sweep(name: &str, d: f64, t: f64, noise: f64, seed: u32) -> Dataset {
        let p = Preset::by_name(name).unwrap();
        // The surface at its local angles, read at the instrument's.
        let f = |ti: f64, tr: f64| {
            let (li, lr) = (ti + t, tr - d - t);
            p.model(li).unwrap().eval_in_plane(li, lr).unwrap().f
        };
        sweep_of(f, noise, seed, true)
    }

    #[test]
    fn a_detector_offset_and_a_tilt_are_fitted_within_0_05_degrees() {
        // Purely relative noise: log residuals are its exact weighting.
        let opts = FitOptions {
            residual: crate::fit::Residual::Log,
            ..FitOptions::default()
        };
        let fit = member_ssr(&opts, Member::THREE_COMPONENT);
        for (d, t, seed) in [(1.0, 0.0, 4), (0.0, 0.5, 5), (1.0, 0.5, 6), (-0.7, -0.3, 7)] {
            let data = sweep("fe-0.115", d, t, 0.002, seed);
            let a = fit_angles(
                &data,
                Member::THREE_COMPONENT,
                &fit,
                opts.residual,
                d + 2.0 * t,
            );
            assert!(a.told_apart, "d {d} t {t}: {a:?}");
            // Without a tilt, none is applied (the estimate is within 2 se of zero).
            assert_eq!(a.tilt_not_supported.is_some(), t == 0.0, "{a:?}");
            for (got, want, se) in [
                (a.detector, d, a.detector_se),
                (a.tilt, t, a.tilt_se.or(a.tilt_not_supported.map(|x| x.1))),
                (a.shift.0, d + 2.0 * t, a.shift.1),
            ] {
                let se = se.expect("determined");
                assert!(
                    (got - want).abs() < 0.05 && (got - want).abs() < 4.0 * se,
                    "d {d} t {t}: {got} for {want} ± {se}: {a:?}"
                );
            }
            // Corrected, the residuals are those of a sweep read at the true angles.
            let fit = |data: &Dataset| {
                let f = super::super::stages::fit_family(data, &opts).unwrap();
                f.member(Member::THREE_COMPONENT).unwrap().ssr
            };
            let (corrected, _) = a.apply(&data).unwrap();
            let straight = sweep("fe-0.115", 0.0, 0.0, 0.002, seed);
            let ratio = fit(&corrected) / fit(&straight);
            assert!(
                (0.8..1.25).contains(&ratio),
                "d {d} t {t}: SSR ratio {ratio}"
            );
        }
    }

    /// Issue 50 case 7: a flat sweep has no peak to place: `--offset fit` reported the
    /// search's bound (-2.000 deg, no standard error) as a detector offset and refitted
    /// on shifted angles. Now: not determined, nothing applied.
    #[test]
    fn a_flat_sweep_determines_no_offset() {
        let mut rng = brdf_core::sim::XorShift32::new(3);
        let mut rows = Vec::new();
        for ti in [10.0, 30.0, 50.0] {
            for tr in (-80..=80).step_by(5).map(f64::from) {
                rows.push(Row::new(
                    ti,
                    tr,
                    0.3 * (1.0 + 0.01 * f64::from(rng.normal())),
                ));
            }
        }
        let data = Dataset::from_rows(&rows, true).unwrap();
        let opts = FitOptions::default();
        let a = fit_angles(
            &data,
            Member::IDEAL_DIFFUSE,
            &member_ssr(&opts, Member::IDEAL_DIFFUSE),
            opts.residual,
            0.0,
        );
        assert!(a.not_determined.is_some(), "{a:?}");
        assert_eq!((a.detector, a.tilt, a.detector_se), (0.0, 0.0, None));
        let (applied, kept) = a.apply(&data).unwrap();
        assert_eq!(kept.len(), data.obs.len());
        assert!(
            applied
                .obs
                .iter()
                .zip(&data.obs)
                .all(|(a, b)| a.theta_r == b.theta_r)
        );
        let notes = a.notes().join("\n");
        assert!(
            notes.contains("not determined") && !notes.contains("detector zero offset"),
            "{notes}"
        );
    }

    /// The `--offset fit` of `data` under `residual`, as `gonio fit` runs it.
    fn fitted_angles(data: &Dataset, residual: Residual) -> Angles {
        let opts = FitOptions {
            residual,
            offset: Some(OffsetSpec::Fit),
            ..FitOptions::default()
        };
        super::super::stages::fit_family(data, &opts)
            .unwrap()
            .angles
            .unwrap()
    }

    /// Issue 50 case 7: the iron sweep with every theta_r read 2 degrees high, no std
    /// column, purely relative noise. Under the default objective (the noise rule) the
    /// member it selects is not the one the sweep was made from, and its misfit passed
    /// for a sample tilt: detector offset 1.72 +- 0.066 deg (tilt 0.11) against 2.00
    /// under log residuals. A tilt is now told apart only where the member follows the
    /// readings within their stated noise; both objectives find 2 deg within their
    /// standard errors.
    #[test]
    fn both_objectives_find_a_detector_offset_within_their_standard_errors() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../python/tests/data/fe-0.115.csv");
        let rows: Vec<Row> = crate::sweep_file::read_sweep(&path)
            .unwrap()
            .rows
            .iter()
            .map(|r| Row::new(r.theta_i, r.theta_r + 2.0, r.brdf))
            .collect();
        let data = Dataset::from_rows(&rows, true).unwrap();
        for residual in [FitOptions::default().residual, Residual::Log] {
            let a = fitted_angles(&data, residual);
            let se = a.detector_se.expect("determined");
            assert!(
                a.not_determined.is_none() && (a.detector - 2.0).abs() <= 2.0 * se.max(0.01),
                "{residual:?}: {a:?}"
            );
            assert_eq!(a.tilt, 0.0, "{residual:?}: {a:?}");
        }
    }

    /// Issue 50 case 7: two peaks alike at theta_i - 3 and theta_i + 3 deg at every
    /// incidence: symmetry says the peaks sit 0 from the mirror direction (the issue
    /// met +0.92 +- 0.08, later -0.12..-0.20 deg; the lobe's own skew in theta_r puts
    /// the best shift at -0.14 +- 0.17): no offset is applied.
    #[test]
    fn two_symmetric_peaks_give_no_offset() {
        let bump = |x: f64| 100.0 * (-(x / 1.5) * (x / 1.5)).exp();
        for seed in [1, 2, 3] {
            let data = sweep_of(
                |ti, tr| 1.0 + bump(tr - ti - 3.0) + bump(tr - ti + 3.0),
                0.01,
                seed,
                true,
            );
            for residual in [FitOptions::default().residual, Residual::Log] {
                let a = fitted_angles(&data, residual);
                // Before: -0.14 +- 0.17 deg, applied as a detector offset.
                assert!(
                    a.not_determined
                        .as_ref()
                        .is_some_and(|w| w.contains("within two standard errors of none")),
                    "seed {seed} {residual:?}: {a:?}"
                );
                assert_eq!((a.detector, a.tilt), (0.0, 0.0));
            }
        }
    }

    #[test]
    fn offsets_parse_and_refuse() {
        assert_eq!(OffsetSpec::parse("fit"), Ok(OffsetSpec::Fit));
        assert_eq!(OffsetSpec::parse(" -0.5 "), Ok(OffsetSpec::Detector(-0.5)));
        assert!(OffsetSpec::parse("11").unwrap_err().contains("within"));
        assert!(OffsetSpec::parse("x").unwrap_err().contains("'fit'"));
        assert!(OffsetSpec::parse("nan").is_err());
    }
}
