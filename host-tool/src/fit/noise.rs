//! The noise objective's model (`--residual noise`): each reading's standard error
//! sqrt(a^2 + (b y)^2), a floor `a` and a proportional part `b`, from the readings' std/n,
//! stated, or by rule; the residual is the difference of its variance-stabilising transform.

use super::data::Dataset;

/// Where a [`NoiseModel`]'s floor and proportional part come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoiseFrom {
    /// Not yet resolved: taken from the data when the fit starts ([`NoiseModel::of_data`]).
    Data,
    /// Stated by the user (`gonio fit --noise FLOOR,PROP`).
    Stated,
    /// Fitted to the readings' own standard errors (std / sqrt(n)).
    Std,
    /// The stated rule for sweeps without noise: [`RULE_PROPORTIONAL`] and
    /// [`RULE_FLOOR_QUANTILE`].
    Rule,
}

/// A reading's standard error sqrt(floor^2 + (prop y)^2), in the data's brdf units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseModel {
    /// The floor a (brdf units): the noise-equivalent BRDF.
    pub floor: f64,
    /// The proportional part b (a fraction of the reading).
    pub prop: f64,
    /// Where they come from.
    pub from: NoiseFrom,
}

/// The rule's proportional noise: 3 % of the reading, of the order of a lab
/// gonioreflectometer's repeatability (national labs reach 0.2-1 %, lab rigs 2-5 %). Only the ratio floor / prop moves the fit (a common factor of every
/// residual is the fit's scale, estimated from the misfit as under any other residual);
/// this sets the absolute scale of the noise the notes compare with.
pub const RULE_PROPORTIONAL: f64 = 0.03;

/// The rule's floor: the level of the sweep's lowest readings, the quantile
/// [`RULE_FLOOR_QUANTILE`] of the readings. A sweep's lowest readings are where its
/// detector reads its own floor (dark signal, stray light, the noise-equivalent BRDF)
/// or close above it, so the floor is of their order; readings below about
/// floor / prop (50 times the level of the lowest tenth) are compared in absolute
/// terms, those above in logarithmic ones. Chosen on the real sweeps (MERL aluminium,
/// the chrome film, the solar array): see docs/fitting.md, which gives the figures of
/// the others tried.
pub const RULE_FLOOR_QUANTILE: f64 = 0.1;

impl NoiseModel {
    /// The model to resolve from the data (the default objective).
    pub const FROM_DATA: NoiseModel = NoiseModel {
        floor: 0.0,
        prop: 0.0,
        from: NoiseFrom::Data,
    };

    /// A stated floor (brdf units, >= 0) and proportional part (>= 0), not both 0.
    pub fn stated(floor: f64, prop: f64) -> Result<NoiseModel, String> {
        let ok = |v: f64| v.is_finite() && v >= 0.0;
        if !(ok(floor) && ok(prop) && (floor > 0.0 || prop > 0.0)) {
            return Err(format!(
                "--noise {floor},{prop}: the floor and proportional part must be finite, >= 0 and not both 0"
            ));
        }
        Ok(NoiseModel {
            floor,
            prop,
            from: NoiseFrom::Stated,
        })
    }

    /// Parses `FLOOR,PROP` (`gonio fit --noise`): e.g. `0.002,0.03` for a floor of
    /// 0.002 in the file's brdf units and 3 % of each reading.
    pub fn parse(s: &str) -> Result<NoiseModel, String> {
        let bad = || format!("--noise '{s}': expected FLOOR,PROP (e.g. 0.002,0.03)");
        let (a, b) = s.split_once(',').ok_or_else(bad)?;
        let a: f64 = a.trim().parse().map_err(|_| bad())?;
        let b: f64 = b.trim().parse().map_err(|_| bad())?;
        Self::stated(a, b)
    }

    /// The reading `y`'s standard error.
    #[inline]
    pub fn sigma(&self, y: f64) -> f64 {
        let p = self.prop * y;
        (self.floor * self.floor + p * p).sqrt()
    }

    /// The noise's variance-stabilising transform g(v) = asinh(b v / a) / b, whose
    /// slope is 1 / [`NoiseModel::sigma`]: the residual is g(f) - g(y). Near the floor
    /// it is (f - y) / a, well above a / b it is ln(f / y) / b: a large miss counts as
    /// in log residuals (symmetric in the ratio), not as in relative ones, where a
    /// model far under the readings costs at most 1 / b a reading and the fit drops
    /// the peak (the chrome film's peaks came out 0.00 under `--residual rel`).
    /// With a = 0 (or a floor so far below b that b / a overflows): ln v / b; with
    /// b = 0: v / a.
    #[inline]
    pub fn transform(&self, v: f64) -> f64 {
        self.transform_and_slope(v).0
    }

    /// [`NoiseModel::transform`] g(v) and its slope 1 / [`NoiseModel::sigma`] at `v`,
    /// from one square root s = sqrt(1 + x^2), x = b v / a: g = sign(x) ln(|x| + s) / b
    /// (asinh) and the slope 1 / (a s). The row pass needs both at every reading: asinh
    /// and sigma apart (two square roots, `ln_1p` below x = 0.5, three divisions in one
    /// chain) were a tenth of a fit of the solar array. g's error is absolute, within
    /// 4 ulp of 1 / b (the logarithm's argument is at least 1, so well conditioned;
    /// its rounding near 1 is an absolute error of g): a few 1e-15 of a standard error
    /// at any reading, where LM resolves no finer than 1e-10 of the cost. The slope's
    /// error is relative, within 4 ulp. Beyond x = 2^27, where 1 + x^2 rounds to x^2,
    /// g = (ln |x| + ln 2) / b and s = |x|.
    #[inline]
    pub fn transform_and_slope(&self, v: f64) -> (f64, f64) {
        let (a, b) = (self.floor, self.prop);
        // The ratio and reciprocals depend on the model alone: a row pass computes them
        // once (hoisted out of its loop), and each reading multiplies.
        let c = b / a;
        // a = 0, or a floor so far below b that b / a overflows (x would be infinite,
        // or NaN at v = 0): the proportional part alone, g = ln v / b (asinh less the
        // constant ln 2c / b, which cancels in g(f) - g(y)).
        if !c.is_finite() {
            let v = v.max(1e-300);
            (v.ln() * (1.0 / b), 1.0 / (b * v))
        } else if b == 0.0 {
            (v * (1.0 / a), 1.0 / a)
        } else {
            let x = c * v;
            let ax = x.abs();
            // Beyond 2^27, 1 + x^2 rounds to x^2 (and squares overflow from 1e154).
            let (g, s) = if ax >= 134_217_728.0 {
                (ax.ln() + core::f64::consts::LN_2, ax)
            } else {
                let s = (ax * ax + 1.0).sqrt();
                ((ax + s).ln(), s)
            };
            (g.copysign(x) * (1.0 / b), (1.0 / a) / s)
        }
    }

    /// This model, or when it is to come from the data ([`NoiseFrom::Data`]),
    /// [`NoiseModel::of_data`].
    pub fn resolved(self, data: &Dataset) -> NoiseModel {
        match self.from {
            NoiseFrom::Data => Self::of_data(data),
            _ => self,
        }
    }

    /// The noise of `data`: fitted to the readings' standard errors where every
    /// reading states one ([`NoiseModel::of_std`]), else the rule (a floor at the
    /// level of the lowest readings, [`RULE_FLOOR_QUANTILE`] of their sizes, readings
    /// of exactly 0 left out, and [`RULE_PROPORTIONAL`] of each).
    /// Never estimated from a model's misfit: a noise model fitted to the residuals
    /// takes the model's error for noise (on the chrome film it gave a proportional
    /// part of 4-7 and moved the peaks further off).
    pub fn of_data(data: &Dataset) -> NoiseModel {
        if let Some(m) = Self::of_std(data) {
            return m;
        }
        // A reading of exactly 0 (clipped at zero, or below the file's resolution) says
        // nothing of the floor's level; a negative one (a dark level subtracted) does,
        // by its size. Where every reading is positive, this is every reading.
        let mut ys: Vec<f64> = data
            .obs
            .iter()
            .map(|o| o.y.abs())
            .filter(|&y| y > 0.0)
            .collect();
        ys.sort_by(f64::total_cmp);
        let at = ((ys.len() as f64 * RULE_FLOOR_QUANTILE) as usize).min(ys.len().max(1) - 1);
        NoiseModel {
            floor: ys.get(at).copied().unwrap_or(0.0).max(f64::MIN_POSITIVE),
            prop: RULE_PROPORTIONAL,
            from: NoiseFrom::Rule,
        }
    }

    /// A floor and proportional part fitted to the readings' standard errors s
    /// (std / sqrt(n)): weighted least squares of s^2 on (1, y^2), each weighted by
    /// its model variance's inverse square (a sample variance's spread is
    /// proportional to its mean), both parts >= 0. One reading's std from a few
    /// samples is too noisy to weight it alone (with 4 samples E[1 / s^2] is three
    /// times 1 / sigma^2); the two parts pool every reading. `None` unless every
    /// reading states one.
    pub fn of_std(data: &Dataset) -> Option<NoiseModel> {
        let pts: Vec<(f64, f64)> = data
            .obs
            .iter()
            .map(|o| o.sigma_y.map(|s| (o.y * o.y, s * s)))
            .collect::<Option<_>>()?;
        if pts.is_empty() {
            return None;
        }
        // Start: weights of a purely proportional model whose part is the median of
        // s^2 / y^2, not of each reading's own s^2 (1 / s^4): a wild reading (1e30 with
        // an ordinary std) would then carry its own huge weight and force b to 0.
        let (mut a2, mut b2) = (0.0, 0.0);
        let mut rel: Vec<f64> = pts
            .iter()
            .filter(|&&(y2, v)| y2 > 0.0 && v.is_finite())
            .map(|&(y2, v)| v / y2)
            .collect();
        rel.sort_by(f64::total_cmp);
        let b2_start = rel.get(rel.len() / 2).copied().unwrap_or(0.0);
        let mut w: Vec<f64> = pts
            .iter()
            .map(|&(y2, v)| {
                let m = if b2_start > 0.0 { b2_start * y2 } else { v };
                1.0 / m.max(v * 1e-6).max(f64::MIN_POSITIVE).powi(2)
            })
            .collect();
        for _ in 0..6 {
            (a2, b2) = nonneg_line(&pts, &w);
            w = pts
                .iter()
                .map(|&(y2, v)| {
                    let m = (a2 + b2 * y2).max(v * 1e-6).max(f64::MIN_POSITIVE);
                    1.0 / (m * m)
                })
                .collect();
        }
        let (floor, prop) = (a2.sqrt(), b2.sqrt());
        (floor.is_finite() && prop.is_finite() && (floor > 0.0 || prop > 0.0)).then_some(
            NoiseModel {
                floor,
                prop,
                from: NoiseFrom::Std,
            },
        )
    }

    /// Said in a note: the objective and its noise.
    pub fn describe(&self) -> String {
        let whence = match self.from {
            NoiseFrom::Data | NoiseFrom::Rule => format!(
                "by rule, as no reading states its noise: the floor at the level of the lowest {} % of the readings, b {} % of each reading; give the instrument's with --noise FLOOR,PROP",
                RULE_FLOOR_QUANTILE * 100.0,
                RULE_PROPORTIONAL * 100.0
            ),
            NoiseFrom::Stated => "as stated (--noise)".to_string(),
            NoiseFrom::Std => "fitted to the readings' std/sqrt(n)".to_string(),
        };
        format!(
            "objective: g(fitted) - g(measured), g(v) = asinh(b v / a) / b (each reading against its noise sqrt(a^2 + (b v)^2)) with a = {} (brdf units) and b = {} ({whence})",
            crate::text::sig(self.floor, 3),
            crate::text::sig(self.prop, 3),
        )
    }
}

/// Non-negative weighted least squares of v on (1, y2) over `pts` (y2, v) with
/// weights `w`: (intercept, slope), each >= 0.
fn nonneg_line(pts: &[(f64, f64)], w: &[f64]) -> (f64, f64) {
    let (mut s0, mut s1, mut s2, mut t0, mut t1) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (&(x, v), &w) in pts.iter().zip(w) {
        s0 += w;
        s1 += w * x;
        s2 += w * x * x;
        t0 += w * v;
        t1 += w * x * v;
    }
    let det = s0 * s2 - s1 * s1;
    if det > 0.0 {
        let a = (t0 * s2 - t1 * s1) / det;
        let b = (s0 * t1 - s1 * t0) / det;
        if a >= 0.0 && b >= 0.0 {
            return (a, b);
        }
    }
    // One part alone: the better of the two.
    let a_only = (t0 / s0).max(0.0);
    let b_only = if s2 > 0.0 { (t1 / s2).max(0.0) } else { 0.0 };
    let cost = |a: f64, b: f64| -> f64 {
        pts.iter()
            .zip(w)
            .map(|(&(x, v), &w)| w * (v - a - b * x).powi(2))
            .sum()
    };
    if cost(a_only, 0.0) <= cost(0.0, b_only) {
        (a_only, 0.0)
    } else {
        (0.0, b_only)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::Residual;
    use crate::fit::member_fit::{fit_member, fit_member_from};
    use brdf_core::member::Member;
    use brdf_core::sim::XorShift32;

    /// The transform and its slope against asinh and sigma from the standard library
    /// (`f64::asinh`, `f64::hypot`) over 1e-300..1e300, both signs, the branch's edge and
    /// the special values, for floors and proportional parts of several orders: g within
    /// 4 ulp of 1 / b absolutely (and of itself relatively where |g| > 1 / b), the slope
    /// within 4 ulp relatively.
    #[test]
    fn transform_and_slope_are_asinh_and_one_over_sigma() {
        let eps = f64::EPSILON;
        let (mut worst_g, mut worst_s): (f64, f64) = (0.0, 0.0);
        for (a, b) in [(1.0, 0.03), (2.5e-7, 0.03), (3e4, 0.2), (1e-3, 1e-4)] {
            let m = NoiseModel::stated(a, b).unwrap();
            let mut v = 1e-300_f64;
            while v < 1e300 {
                let edge = 134_217_728.0 * a / b;
                for v in [v, -v, v.next_up(), edge.next_down(), edge, -edge] {
                    let (g, slope) = m.transform_and_slope(v);
                    assert_eq!(g.to_bits(), m.transform(v).to_bits());
                    let x = b * v / a;
                    let want = x.asinh() / b;
                    worst_g = worst_g.max((g - want).abs() / (eps * (1.0 / b + want.abs())));
                    let sigma = a * x.hypot(1.0);
                    if sigma.is_finite() {
                        worst_s = worst_s.max((slope * sigma - 1.0).abs() / eps);
                    }
                }
                v *= 1.0137;
            }
        }
        assert!(worst_g <= 4.0, "g: worst {worst_g} ulp of 1 / b");
        assert!(worst_s <= 4.0, "slope: worst {worst_s} ulp");
        let m = NoiseModel::stated(1.0, 0.03).unwrap();
        assert_eq!(m.transform(0.0).to_bits(), 0.0_f64.to_bits());
        assert_eq!(m.transform(-0.0).to_bits(), (-0.0_f64).to_bits());
        assert_eq!(m.transform_and_slope(f64::INFINITY), (f64::INFINITY, 0.0));
        assert!(m.transform(f64::NAN).is_nan());
        // A floor so small that b / a overflows: the proportional part alone, finite at
        // a zero reading (b v / a would be infinity times zero there).
        let tiny = NoiseModel::stated(1e-310, 0.03).unwrap();
        assert!(tiny.transform(0.0).is_finite());
        assert_eq!(
            tiny.transform_and_slope(2.0),
            (2.0_f64.ln() * (1.0 / 0.03), 1.0 / 0.06)
        );
        // The two limits: the floor alone and the proportional part alone.
        let log = NoiseModel::stated(0.0, 0.5).unwrap();
        assert_eq!(log.transform_and_slope(2.0), (2.0_f64.ln() * 2.0, 1.0));
        let abs = NoiseModel::stated(4.0, 0.0).unwrap();
        assert_eq!(abs.transform_and_slope(2.0), (0.5, 0.25));
    }

    /// Simulated paper sweeps of fe-0.115 (153 readings, the three-component member's
    /// 13 parameters) with a known floor and proportional noise, each reading the mean
    /// of 4 samples with their std: the 95 % intervals the default objective reports
    /// (estimate +- 1.96 standard errors, in the fitter's log coordinates) cover the
    /// truth in 95 % +- 3 % of 2,600 intervals (200 sweeps), and each parameter's
    /// within 95 % +- 6 % of its 200 (3.9 binomial standard deviations: one of 13
    /// would fall outside +- 3 % by chance alone). Each fit is one LM run from the
    /// truth (the intervals are the subject, not the start search).
    #[test]
    fn the_default_objectives_intervals_cover_the_truth() {
        let p = brdf_core::Preset::by_name("fe-0.115").unwrap();
        let clean = super::super::data::synthetic_paper_sweep(|ti| p.model(ti).unwrap(), 0.0, 1);
        let m = Member::THREE_COMPONENT;
        let truth = fit_member(
            &Dataset::from_rows(&clean, true).unwrap(),
            m,
            Residual::Log,
            None,
        )
        .unwrap()
        .x;
        let least = clean.iter().map(|r| r.brdf).fold(f64::INFINITY, f64::min);
        // A floor that matters below 3x the least reading; 3 % above.
        let (floor, prop) = (0.1 * least, 0.03);
        let mut rng = XorShift32::new(7);
        let (trials, samples) = (200, 4);
        let mut covered = vec![0usize; truth.len()];
        for _ in 0..trials {
            let rows: Vec<_> = clean
                .iter()
                .map(|r| {
                    let s = (floor * floor + (prop * r.brdf).powi(2)).sqrt();
                    let v: Vec<f64> = (0..samples)
                        .map(|_| r.brdf + s * f64::from(rng.normal()))
                        .collect();
                    let mean = v.iter().sum::<f64>() / samples as f64;
                    let var =
                        v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (samples - 1) as f64;
                    let mut row = *r;
                    row.brdf = mean;
                    row.std = Some(var.sqrt());
                    row.n = Some(samples as u32);
                    row
                })
                .collect();
            let data = Dataset::from_rows(&rows, true).unwrap();
            let fit = fit_member_from(&data, m, Residual::NOISE, None, &truth)
                .unwrap()
                .fit;
            for (i, c) in covered.iter_mut().enumerate() {
                let se = fit.cov.get(i, i).sqrt();
                if (fit.x[i] - truth[i]).abs() <= 1.96 * se {
                    *c += 1;
                }
            }
        }
        let all = covered.iter().sum::<usize>() as f64 / (trials * truth.len()) as f64;
        assert!((0.92..=0.98).contains(&all), "{all}: {covered:?}");
        for c in &covered {
            let f = *c as f64 / trials as f64;
            assert!((0.89..=1.0).contains(&f), "{f}: {covered:?}");
        }
    }

    #[test]
    fn the_std_columns_give_the_floor_and_the_proportional_part() {
        let p = brdf_core::Preset::by_name("fe-0.115").unwrap();
        let mut rows = super::super::data::synthetic_paper_sweep(|ti| p.model(ti).unwrap(), 0.0, 5);
        // Exact standard errors of a floor 0.01 and 3 %: recovered exactly.
        for r in &mut rows {
            r.std = Some(2.0 * (0.01f64.powi(2) + (0.03 * r.brdf).powi(2)).sqrt());
            r.n = Some(4);
        }
        let data = Dataset::from_rows(&rows, true).unwrap();
        let m = NoiseModel::of_data(&data);
        assert_eq!(m.from, NoiseFrom::Std);
        assert!(
            (m.floor - 0.01).abs() < 1e-9 && (m.prop - 0.03).abs() < 1e-9,
            "{m:?}"
        );
        // Without a std column: the rule.
        for r in &mut rows {
            r.std = None;
        }
        let data = Dataset::from_rows(&rows, true).unwrap();
        let m = NoiseModel::FROM_DATA.resolved(&data);
        let mut ys: Vec<f64> = rows.iter().map(|r| r.brdf).collect();
        ys.sort_by(f64::total_cmp);
        assert_eq!(m.from, NoiseFrom::Rule);
        // 153 readings: the 16th smallest (index 15) is the lowest tenth's level.
        assert_eq!((m.floor, m.prop), (ys[15], RULE_PROPORTIONAL));
        // Stated stays stated.
        let s = NoiseModel::parse("0.5, 0.1").unwrap();
        assert_eq!(s.resolved(&data), s);
        for bad in ["0,0", "-1,0.1", "x,1", "1", "nan,0.1"] {
            assert!(NoiseModel::parse(bad).is_err(), "{bad}");
        }
    }

    /// Readings of exactly 0 (clipped) say nothing of the floor's level and are left out
    /// of the rule's quantile; negative ones (a dark level subtracted) count by their
    /// size. A noise model with a floor takes such readings; one stated without a floor
    /// (its transform ln v) does not.
    #[test]
    fn the_rules_floor_leaves_out_readings_of_zero() {
        let p = brdf_core::Preset::by_name("fe-0.115").unwrap();
        let mut rows = super::super::data::synthetic_paper_sweep(|ti| p.model(ti).unwrap(), 0.0, 5);
        for r in rows.iter_mut().step_by(4) {
            r.brdf = 0.0;
        }
        rows[1].brdf = -rows[1].brdf;
        let data = Dataset::from_rows(&rows, false).unwrap();
        let m = NoiseModel::of_data(&data);
        let mut ys: Vec<f64> = rows
            .iter()
            .map(|r| r.brdf.abs())
            .filter(|&y| y > 0.0)
            .collect();
        ys.sort_by(f64::total_cmp);
        assert_eq!(m.from, NoiseFrom::Rule);
        assert_eq!(
            m.floor,
            ys[(ys.len() as f64 * RULE_FLOOR_QUANTILE) as usize]
        );
        assert!(m.floor > 0.0);
        let (g, slope) = m.transform_and_slope(0.0);
        assert_eq!((g, slope), (0.0, 1.0 / m.floor));
        assert!(m.transform(rows[1].brdf) < 0.0);
        // Every reading 0: nothing to fit, and the data say so.
        for r in &mut rows {
            r.brdf = 0.0;
        }
        let e = Dataset::from_rows(&rows, false).unwrap_err().0;
        assert!(e.contains("all 153 readings are at or below 0"), "{e}");
        // Which objectives need readings > 0.
        let kinds = [
            (Residual::Noise(NoiseModel::FROM_DATA), false),
            (
                Residual::Noise(NoiseModel::stated(0.01, 0.03).unwrap()),
                false,
            ),
            (
                Residual::Noise(NoiseModel::stated(0.0, 0.03).unwrap()),
                true,
            ),
            (Residual::Log, true),
            (Residual::Relative, true),
            (Residual::Absolute, false),
        ];
        for (kind, positive) in kinds {
            assert_eq!(kind.needs_positive(), positive, "{kind:?}");
        }
    }
}
