//! The three-component fit timed for the comparison with scipy (`gonio bench --fit-vs`):
//! one local LM from scipy's own start (like for like with `bench/fit_scipy.py`; its
//! solve alone and with the covariance and RMSE) and the default grid-and-LM fit (what
//! `gonio fit --models three` does).

use std::time::Instant;

use brdf_core::member::Member;
use serde::Serialize;

use super::study::on_one_thread;
use crate::fit::member_fit::{Layout, MemberFit, fit_member_from};
use crate::fit::{Dataset, FitOptions, Residual, fit_family};

/// One of the two timed fits.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VersusFit {
    /// Best wall time of one fit over the repeats (microseconds).
    pub microseconds: f64,
    /// Best wall time of its solve alone over the same repeats (microseconds; the
    /// one-LM fit only): LM without the covariance and the RMSE that `microseconds`
    /// includes, the same work as scipy's timed `least_squares` call.
    pub solve_microseconds: Option<f64>,
    /// The paper's Table-3 RMSE of the three-component fit ([`MemberFit::rmse`]).
    pub rmse: Option<f64>,
    /// Sum of squared log residuals at the optimum.
    pub ssr: f64,
    /// LM met a convergence test (for the default fit: the run that gave the optimum).
    pub converged: bool,
    /// The optimum in the member's [`Layout`] coordinates.
    pub x: Vec<f64>,
    /// LM steps tried (the one-LM fit only).
    pub iterations: Option<usize>,
    /// Passes over the readings, each giving the cost and the Jacobian (the one-LM fit
    /// only; scipy's `nfev` counts cost evaluations, its Jacobian costs one more per
    /// parameter).
    pub evaluations: Option<usize>,
}

/// Both fits on one sweep.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Versus {
    /// Readings fitted.
    pub readings: usize,
    /// Incidences.
    pub incidences: usize,
    /// Timed runs of each fit (after one untimed warm-up run).
    pub repeat: usize,
    /// The start of the one-LM fit (the member's [`Layout`] coordinates).
    pub start: Vec<f64>,
    /// Exactly one Levenberg–Marquardt run from `start`, nothing held, no grid.
    pub one_lm: VersusFit,
    /// The default three-component fit: the width grid, then LM from its best points
    /// (`gonio fit --models three`, without reading the file or writing the report).
    pub default_fit: VersusFit,
}

/// A start vector from the command line: a JSON array (`[-2.3, -0.69, ...]`, as
/// `bench/fit_scipy.py` prints its `x0`) or comma-separated numbers.
pub fn parse_start(text: &str) -> Result<Vec<f64>, String> {
    let t = text.trim();
    let x: Vec<f64> = if t.starts_with('[') {
        serde_json::from_str(t).map_err(|e| format!("--start: not a JSON array of numbers: {e}"))?
    } else {
        t.split(',')
            .map(|s| {
                let s = s.trim();
                s.parse::<f64>().map_err(|_| {
                    format!(
                        "--start: '{}' is not a number",
                        crate::text::escape_line(s, 30)
                    )
                })
            })
            .collect::<Result<_, _>>()?
    };
    if x.is_empty() {
        return Err("--start: no numbers".into());
    }
    Ok(x)
}

/// Checks that `x0` is a three-component start for `data`: one value per parameter of
/// the member's [`Layout`] (ln sigma, ln sigma_m, ln k_dd, ln k_id, then ln k_s per
/// incidence), every one finite.
pub fn check_start(data: &Dataset, x0: &[f64]) -> Result<(), String> {
    let n_inc = data.incidences.len();
    let want = Layout::new(Member::THREE_COMPONENT, n_inc).len();
    if x0.len() != want {
        return Err(format!(
            "--start has {} values; the three-component model on these data has {want} \
             (ln sigma, ln sigma_m, ln k_dd, ln k_id, then ln k_s for each of the {n_inc} incidences)",
            x0.len()
        ));
    }
    if let Some(i) = x0.iter().position(|u| !u.is_finite()) {
        return Err(format!(
            "--start: value {} is not finite ({})",
            i + 1,
            x0[i]
        ));
    }
    Ok(())
}

/// Best wall time of `f` over `repeat` runs after one untimed run, and that run's value.
fn best_of<T>(repeat: usize, mut f: impl FnMut() -> Result<T, String>) -> Result<(f64, T), String> {
    let mut out = f()?;
    let mut best = f64::INFINITY;
    for _ in 0..repeat {
        let t0 = Instant::now();
        out = f()?;
        best = best.min(t0.elapsed().as_secs_f64());
    }
    Ok((best * 1e6, out))
}

fn row(microseconds: f64, fit: &MemberFit) -> VersusFit {
    VersusFit {
        microseconds,
        solve_microseconds: None,
        rmse: fit.rmse,
        ssr: fit.ssr,
        converged: fit.converged,
        x: fit.x.clone(),
        iterations: None,
        evaluations: None,
    }
}

/// Times both three-component fits of `data` (log residuals, the sweep's aperture if
/// it has one), warm, best of `repeat` (at least 1), on a one-thread rayon pool.
pub fn fit_versus(data: &Dataset, x0: &[f64], repeat: usize) -> Result<Versus, String> {
    check_start(data, x0)?;
    let repeat = repeat.max(1);
    on_one_thread(|| {
        let member = Member::THREE_COMPONENT;
        // The solve's own time of every timed run (the first run is best_of's warm-up).
        let (mut runs, mut solve) = (0, f64::INFINITY);
        let (us, local) = best_of(repeat, || {
            let l = fit_member_from(data, member, Residual::Log, data.aperture, x0)
                .ok_or("the three-component model cannot be fitted from --start")?;
            if runs > 0 {
                solve = solve.min(l.solve_seconds);
            }
            runs += 1;
            Ok(l)
        })?;
        let one_lm = VersusFit {
            solve_microseconds: Some(solve * 1e6),
            iterations: Some(local.iterations),
            evaluations: Some(local.evaluations),
            ..row(us, &local.fit)
        };
        // Log residuals, as the one LM and scipy minimise: the same optimum.
        let opts = FitOptions {
            members: Some(vec![member]),
            residual: Residual::Log,
            ..FitOptions::default()
        };
        let (us, family) = best_of(repeat, || fit_family(data, &opts))?;
        let fit = family
            .member(member)
            .ok_or("the default fit did not fit the three-component model")?;
        Ok(Versus {
            readings: data.obs.len(),
            incidences: data.incidences.len(),
            repeat,
            start: x0.to_vec(),
            one_lm,
            default_fit: row(us, fit),
        })
    })?
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_start_is_a_json_array_or_a_comma_list() {
        assert_eq!(
            parse_start("[1, -2.5, 3e-1]").unwrap(),
            vec![1.0, -2.5, 0.3]
        );
        assert_eq!(parse_start(" 1,-2.5 , 0.3 ").unwrap(), vec![1.0, -2.5, 0.3]);
        assert!(
            parse_start("[1, \"a\"]")
                .unwrap_err()
                .contains("JSON array")
        );
        assert!(parse_start("1,,2").unwrap_err().contains("not a number"));
        assert!(parse_start("[]").unwrap_err().contains("no numbers"));
        // Rust parses "nan" and "inf": they are refused by check_start, with the value named.
        assert!(parse_start("nan,1").unwrap()[0].is_nan());
    }
}
