//! The online fit: the family refitted to the readings captured so far, by the one fit
//! `gonio fit` makes ([`super::job::prepare`], [`super::fit_family`]), for the
//! live view, `--until` and the sequential plan alike.

use brdf_core::member::Member;

use super::data::Dataset;
use super::family_fit::FamilyFit;
use super::options::{CheckScope, FitOptions};
use super::report::{Param, member_params};
use crate::sweep_file::{BrdfUnits, Row};

/// The selected member's parameters after one refit.
#[derive(Debug, Clone)]
pub struct Estimate {
    /// Readings fitted.
    pub readings: usize,
    /// The data as fitted.
    pub data: Dataset,
    /// The family fitted to them (its selection as `gonio fit` reports it).
    pub family: FamilyFit,
    /// The selected member's parameters, in report order, with standard errors.
    pub params: Vec<Param>,
}

impl Estimate {
    /// The selected member.
    pub fn member(&self) -> Member {
        self.family.selected_member
    }

    /// The scalar parameter named `base` (report names: `sigma`, `sigma_haze`,
    /// `sigma_m`, `k_dd`, `k_id`; `k_id` also finds the Torrance–Sparrow `k_d`, the
    /// same ideal-diffuse weight), if the selected member has it.
    pub fn param(&self, base: &str) -> Option<&Param> {
        self.params
            .iter()
            .find(|p| p.theta_i.is_none() && (p.base == base || base == "k_id" && p.base == "k_d"))
    }

    /// The relative standard error se/|value| of parameter `base`: `None` when the
    /// member lacks it, it is held fixed, or the data do not determine it.
    pub fn rel_se(&self, base: &str) -> Option<f64> {
        let p = self.param(base)?;
        let se = p.se?;
        (!p.held && p.value != 0.0 && se.is_finite()).then(|| se / p.value.abs())
    }
}

/// Readings gathered during a capture and the latest refit of them.
#[derive(Debug, Clone)]
pub struct OnlineFit {
    rows: Vec<Row>,
    opts: FitOptions,
    last: Option<Estimate>,
}

impl Default for OnlineFit {
    fn default() -> Self {
        Self::new()
    }
}

impl OnlineFit {
    /// No readings yet; fits with `gonio fit`'s defaults, checks left out (the
    /// capture's refits need only parameters and their errors).
    pub fn new() -> Self {
        OnlineFit {
            rows: Vec::new(),
            opts: FitOptions {
                checks: CheckScope::None,
                ..FitOptions::default()
            },
            last: None,
        }
    }

    /// Starts from readings already captured (a resumed file).
    pub fn with_rows(rows: Vec<Row>) -> Self {
        OnlineFit {
            rows,
            ..Self::new()
        }
    }

    /// Starts from `rows`, fitting only `members` (as `gonio fit --models`).
    pub fn with_rows_of_members(rows: Vec<Row>, members: Vec<brdf_core::member::Member>) -> Self {
        let mut f = Self::with_rows(rows);
        f.opts.members = Some(members);
        f
    }

    /// One more reading (angles in degrees, brdf in the instrument's relative units).
    pub fn push(&mut self, row: Row) {
        self.rows.push(row);
    }

    /// The readings so far, in arrival order.
    pub fn rows(&self) -> &[Row] {
        &self.rows
    }

    /// The latest refit, if one succeeded.
    pub fn last(&self) -> Option<&Estimate> {
        self.last.as_ref()
    }

    /// Refits the family to every reading so far. An error (too few readings for any
    /// member, readings at or below zero) says why; the previous estimate is dropped
    /// then, since it no longer describes the data.
    pub fn refit(&mut self) -> Result<&Estimate, String> {
        self.last = None;
        let data = super::job::prepare(&self.rows, BrdfUnits::Relative, &self.opts, None)?;
        let family = super::fit_family(&data, &self.opts)?;
        let params = family
            .selected_fit()
            .map(member_params)
            .ok_or("no member could be fitted")?;
        Ok(self.last.insert(Estimate {
            readings: self.rows.len(),
            data,
            family,
            params,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_online_fit_is_the_fit_of_gonio_fit() {
        let fe = brdf_core::Preset::by_name("fe-0.115").unwrap();
        let rows = crate::fit::data::synthetic_paper_sweep(|t| fe.model(t).unwrap(), 0.005, 3);
        let mut online = OnlineFit::new();
        assert!(online.refit().is_err(), "no readings: no estimate");
        for r in &rows {
            online.push(*r);
        }
        let est = online.refit().unwrap().clone();
        // The same numbers as the fit command's path over the same rows.
        let opts = FitOptions::default();
        let data = crate::fit::job::prepare(&rows, BrdfUnits::Relative, &opts, None).unwrap();
        let fam = crate::fit::fit_family(&data, &opts).unwrap();
        assert_eq!(est.member(), fam.selected_member);
        let want = member_params(fam.selected_fit().unwrap());
        let sigma = want.iter().find(|p| p.base == "sigma").unwrap();
        assert_eq!(est.param("sigma").unwrap(), sigma);
        let rel = est.rel_se("sigma").unwrap();
        assert!(rel > 0.0 && rel < 0.05, "{rel}");
        assert!(est.rel_se("no_such").is_none());
    }
}
