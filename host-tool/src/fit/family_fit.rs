//! The result of fitting the family to one dataset: every member fitted, the
//! candidates selection used, the selection, and the notes.

use brdf_core::member::Member;

use super::data::Dataset;
use super::goodness::member_fitted;
use super::member_fit::MemberFit;
use super::offset::Angles;
use super::options::CheckScope;
use super::paper::Kind;
use super::physical::ModelCheck;
use super::select::Candidate;
use crate::sweep_file::BrdfUnits;

/// Every model of the family fitted to one dataset.
#[derive(Debug, Clone)]
pub struct FamilyFit {
    /// The data's incidence angles (degrees).
    pub incidences: Vec<f64>,
    /// Every member fitted, in the order fitted.
    pub members: Vec<MemberFit>,
    /// What selection used of every fitted member.
    pub candidates: Vec<Candidate>,
    /// The member selected (see [`select`]).
    pub selected_member: Member,
    /// The best of the paper's members by the same rule, for consumers that know only
    /// those (equal to `selected_member` when that is a paper member).
    pub selected: Kind,
    /// The member BIC would select by the same rule.
    pub selected_bic: Member,
    /// Plain statements: which components the data supports, what could not be fitted.
    pub notes: Vec<String>,
    /// Wall time of all fitting (seconds).
    pub fit_seconds: f64,
    /// Per incidence: the detector angle (degrees) the paper's RMSE is normalised at
    /// when there is no reading exactly at theta_r = theta_i (`None` when there is).
    pub rmse_nearest: Vec<Option<f64>>,
    /// The detector half-angle the models were averaged over (degrees).
    pub aperture: Option<f64>,
    /// [`FamilyFit::aperture`] was assumed (half the step: no aperture was stated and the
    /// readings do not resolve the core, [`super::assumed_aperture`]), not stated.
    pub aperture_assumed: bool,
    /// The sweep carries std and n: goodness of fit against the noise is known.
    pub has_noise: bool,
    /// The units of the data's brdf values, and so of every fitted amplitude.
    pub units: BrdfUnits,
    /// Which fitted models the reports' physical checks cover ([`FitOptions::checks`]).
    pub checks: CheckScope,
    /// The physical checks of the models [`FamilyFit::checks`] names, made once after
    /// the fit ([`super::job::run`]) for every report to format (until then empty, or,
    /// for a fit over an assumed cone, its selected member's check from the energy test,
    /// which [`super::job::run`] takes rather than makes again).
    pub physical: Vec<ModelCheck>,
    /// The instrument's angles the family was fitted at (`--offset`), if any: the
    /// members then describe the readings at the sample's local angles, and
    /// [`FamilyFit::incidences`] are local incidences.
    pub angles: Option<Angles>,
}

impl FamilyFit {
    /// The grid fit of a member, if it was fitted.
    pub fn member(&self, m: Member) -> Option<&MemberFit> {
        self.members.iter().find(|f| f.member() == m)
    }

    /// What selection knows of a member, if it was fitted.
    pub fn candidate(&self, m: Member) -> Option<&Candidate> {
        self.candidates.iter().find(|c| c.member == m)
    }

    /// The selected member's fit.
    pub fn selected_fit(&self) -> Option<&MemberFit> {
        self.member(self.selected_member)
    }
}

impl FamilyFit {
    /// The fitted value at every reading of `data` for `member` (as the fit compared
    /// it, [`member_fitted`]); `None` when the family did not fit it. The one source
    /// of "fitted" for the residuals export, the plots and the Python bind.
    /// With [`FamilyFit::angles`], each reading's fitted value is the member's at
    /// that reading's local angles (`None` for one left out beyond 90 degrees).
    pub fn fitted(&self, data: &Dataset, member: Member) -> Option<Vec<Option<f64>>> {
        let m = self.member(member)?;
        let Some(angles) = &self.angles else {
            return Some(member_fitted(m, data));
        };
        let (local, kept) = angles.apply(data).ok()?;
        let mut out = vec![None; data.obs.len()];
        for (k, v) in kept.into_iter().zip(member_fitted(m, &local)) {
            out[k] = v;
        }
        Some(out)
    }
}
