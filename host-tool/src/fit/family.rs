//! The family's stages over brdf-core's component lattice: the default members, the
//! reference members a decision needs, the variants of a selection, and when a
//! smooth-k_s variant could be selected at all.

use brdf_core::member::{Component, KsForm, LobeSpec, Member};

use super::member_fit::{Layout, MemberFit};
use super::select::{Candidate, Criterion, Selection, reference};

/// The members whose comparisons decide each component, generated from brdf-core's
/// lattice: every member with the ideal diffuse on and the reference lobe (Beckmann,
/// one k_s per incidence) for whichever of the core and haze lobes are on (the six
/// component sets), plus the paper's members (which adds `three-component-smooth-ks`).
/// Simplest first.
pub fn reference_members() -> Vec<Member> {
    let reference = |l: Option<LobeSpec>| l.is_none_or(|l| l == LobeSpec::PAPER);
    let mut out: Vec<Member> = Member::lattice()
        .filter(|m| m.ideal && reference(m.core) && reference(m.haze))
        .chain(Member::PAPER.iter().map(|&(_, m)| m))
        .collect();
    out.sort_by_key(|m| (m.components().count(), m.haze.is_some(), *m));
    out.dedup();
    out
}

/// The first stage of the default family: of [`reference_members`], the paper's
/// members and those one component from the paper's three-component model
/// (`directional-diffuse+ideal-diffuse` and the member with every component). The
/// rest (a haze without the directional diffuse) is fitted only when the decision
/// needs it ([`needed`]). Simplest first.
pub fn default_members() -> Vec<Member> {
    reference_members()
        .into_iter()
        .filter(|m| m.paper_name().is_some() || apart(*m, Member::THREE_COMPONENT) == 1)
        .collect()
}

/// How many components are on in one of `a`, `b` but not in both.
fn apart(a: Member, b: Member) -> usize {
    Component::ALL
        .iter()
        .filter(|&&c| a.has(c) != b.has(c))
        .count()
}

/// The members of [`reference_members`] not in `tried` that the decision needs, given
/// the members fitted so far (`fits`, and their `cands`): for AICc and for BIC, each one
/// component from the selected member's component set (the selected member's claims
/// compare against it), and each whose criterion could still be lower than the
/// selected member's. A member nested in a fitted reference member (every component it
/// has is on there) fits no better than that member, so its criterion is at least the
/// one of that member's sum of squares with its own parameter count; a member nested in
/// none is needed. Fitting what this returns until it returns nothing selects the
/// member that fitting every reference member would, as far as each fit reaches its
/// optimum (the bound assumes the larger member's fit did; the tests check it on four
/// kinds of data).
pub fn needed(fits: &[MemberFit], cands: &[Candidate], tried: &[Member]) -> Vec<Member> {
    let Some(first) = fits.first() else {
        return Vec::new();
    };
    let (n, n_inc) = (first.n, first.incidences.len());
    let nested = |m: Member, big: Member| {
        big != m && big == reference(big) && m.components().all(|c| big.has(c))
    };
    let bests: Vec<(Criterion, Member, f64)> = Criterion::ALL
        .into_iter()
        .filter_map(|crit| {
            let b = Selection::new(cands, crit).best()?;
            Some((crit, reference(b.member), crit.of(b)))
        })
        .collect();
    reference_members()
        .into_iter()
        .filter(|m| !tried.contains(m))
        .filter(|&m| {
            let k = Layout::new(m, n_inc).len();
            let ssr_floor = fits
                .iter()
                .filter(|f| nested(m, f.member()))
                .map(|f| f.ssr)
                .min_by(f64::total_cmp);
            bests.iter().any(|&(crit, best, value)| {
                apart(m, best) == 1 || ssr_floor.is_none_or(|s| crit.of_ssr(s, n, k) <= value)
            })
        })
        .collect()
}

/// The second stage: the variants of the selected member's component set that decide
/// its core lobe's distribution (Beckmann, GGX or Student-t) and k_s form (per
/// incidence or smooth): the lattice's (same components, same haze lobe, any core
/// lobe) and the same with a Student-t core ([`STUDENT_T`]).
pub fn variants_of(selected: Member) -> Vec<Member> {
    if selected.core.is_none() {
        return Vec::new();
    }
    let student_t = STUDENT_T.iter().map(|&core| Member {
        core: Some(core),
        ..selected
    });
    Member::lattice()
        .filter(|m| {
            m.core.is_some()
                && m.haze == selected.haze
                && m.directional == selected.directional
                && m.ideal == selected.ideal
        })
        .chain(student_t)
        .collect()
}

/// The Student-t lobes the family's shape stages try beside the lattice's Beckmann and
/// GGX ones (its k_s per incidence, then smooth). Not in brdf-core's lattice (the
/// reference members and the first stage stay the paper's Beckmann), but in the
/// default family: its fitted tail (GGX one member, Beckmann the limit) is what lets a
/// real metal's narrow core and wide wings be followed at once (MERL aluminium's peaks
/// went from 0.16-0.74 to 0.84-1.24 of the readings; docs/accuracy.md).
pub const STUDENT_T: [LobeSpec; 2] = [
    LobeSpec {
        dist: brdf_core::lobe::Distribution::StudentT,
        ks: KsForm::PerIncidence,
    },
    LobeSpec {
        dist: brdf_core::lobe::Distribution::StudentT,
        ks: KsForm::Smooth,
    },
];

/// The third stage: the selected member with its haze lobe's distribution switched to
/// each of the others (of Beckmann, GGX and Student-t), none without a haze. A haze's
/// tail decides how a sharp core's wings fall (a Beckmann haze is Gaussian in slope, a
/// GGX one falls as a power law, a Student-t one with a fitted power), and the core's
/// shape was decided on the reference haze.
pub fn haze_variants_of(selected: Member) -> Vec<Member> {
    use brdf_core::lobe::Distribution;
    let Some(h) = selected.haze else {
        return Vec::new();
    };
    Distribution::ALL
        .into_iter()
        .chain([Distribution::StudentT])
        .filter(|&d| d != h.dist)
        .map(|dist| Member {
            haze: Some(LobeSpec { dist, ..h }),
            ..selected
        })
        .collect()
}

/// The member with `m`'s core k_s per incidence instead of smooth (`None` when `m`'s
/// core k_s is not smooth). It nests `m`: a smooth k_s (ln k_s quadratic in theta_i)
/// is one choice of k_s per incidence.
pub fn per_incidence_of(m: Member) -> Option<Member> {
    let core = m.core.filter(|c| c.ks == KsForm::Smooth)?;
    Some(Member {
        core: Some(LobeSpec {
            ks: KsForm::PerIncidence,
            ..core
        }),
        ..m
    })
}

/// What the fits so far say of a smooth-k_s variant ([`smooth_needed`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SmoothVariant {
    /// It could still be selected: fit it.
    Needed,
    /// Its member with k_s per incidence (`by`) is not fitted yet: ask again after it.
    Deferred,
    /// It cannot be selected: `by`, fitted, bounds its AICc from below at `aicc_above`
    /// above the selected member's (and its BIC above that member's BIC).
    Bounded {
        /// The member with k_s per incidence that nests it.
        by: Member,
        /// Its AICc's lower bound minus the selected member's AICc.
        aicc_above: f64,
    },
}

/// Whether the smooth-k_s variant `m` is needed, given the members fitted so far
/// (`fits`, their `cands`) and those still to be fitted (`pending`). Its member with k_s
/// per incidence ([`per_incidence_of`]) fits at least as well (as far as that fit
/// reaches its optimum), so that member's sum of squares with `m`'s parameter count
/// bounds `m`'s AICc and BIC from below. `m` is left out when, by both criteria, that
/// bound is above the selected member's by more than [`MARGIN`](super::select::MARGIN):
/// it could be neither selected nor within the margin of the selected member (the
/// report's ties).
pub fn smooth_needed(
    m: Member,
    fits: &[MemberFit],
    cands: &[Candidate],
    pending: &[Member],
) -> SmoothVariant {
    let Some(by) = per_incidence_of(m) else {
        return SmoothVariant::Needed;
    };
    let Some(f) = fits.iter().find(|f| f.member() == by) else {
        return if pending.contains(&by) {
            SmoothVariant::Deferred
        } else {
            SmoothVariant::Needed
        };
    };
    let k = Layout::new(m, f.incidences.len()).len();
    let mut aicc_above = f64::INFINITY;
    for crit in Criterion::ALL {
        let Some(best) = Selection::new(cands, crit).best() else {
            return SmoothVariant::Needed;
        };
        let above = crit.of_ssr(f.ssr, f.n, k) - crit.of(best);
        // NaN (a criterion that cannot be computed) proves nothing either.
        if above.is_nan() || above <= super::select::MARGIN {
            return SmoothVariant::Needed;
        }
        if crit == Criterion::Aicc {
            aicc_above = above;
        }
    }
    SmoothVariant::Bounded { by, aicc_above }
}
