//! The notes a family fit reports, in the order reported: what the selection says of
//! each component and of the lobe shape, BIC's choice when it differs, goodness against
//! the noise, the readings that carry most of the loss, the detection floor, the peak's
//! position, where the selected member misses and another follows, what could not be
//! fitted or determined, and how the data were compared.

use brdf_core::member::Member;

use super::data::Dataset;
use super::goodness;
use super::member_fit::MemberFit;
use super::options::{Compared, Residual};
use super::peak;
use super::report::member_params;
use super::select::MARGIN as AICC_MARGIN;
use super::select::{self, Candidate, Criterion, Selection};

/// The family's notes: the selection's (`selected` by AICc over `candidates`,
/// `selected_bic` by BIC), those
/// the fit itself made while fitting (`fitting`: members not fitted), each member's
/// flags, and the comparison's (readings normalised off the mirror direction, the
/// detector's aperture; see [`Compared`]).
pub fn family_notes(
    data: &Dataset,
    members: &[MemberFit],
    candidates: &[Candidate],
    selected_member: Member,
    selected_bic: Member,
    mut fitting: Vec<String>,
    compared: Compared,
) -> Vec<String> {
    let aperture = compared.aperture;
    let sel = Selection::new(candidates, Criterion::Aicc);
    let mut summary = select::component_notes(&sel, selected_member);
    summary.extend(variant_notes(candidates, selected_member));
    if selected_bic != selected_member {
        summary.push(format!(
            "BIC (stricter with many readings) would select {selected_bic} by the same rule"
        ));
    }
    summary.push(goodness_note(
        data,
        candidates,
        selected_member,
        compared.residual,
    ));
    // The selected member's fitted values, once, for the loss's, the peak's and the
    // misses' notes.
    let selected_fit = members.iter().find(|f| f.member() == selected_member);
    let fitted = selected_fit.map(|f| goodness::member_fitted(f, data));
    if let Some(fitted) = &fitted {
        summary.extend(super::misses::dominant_note(
            data,
            selected_member,
            fitted,
            compared,
        ));
    }
    summary.extend(data.floor.notes());
    if let (Some(f), Some(fitted)) = (selected_fit, fitted) {
        summary.extend(peak::offset_note(
            data,
            &fitted,
            &selected_member.to_string(),
        ));
        if let (Some(core), Some((sigma, _))) = (selected_member.core, f.sigma()) {
            summary.extend(peak::unresolved_core_note(
                data,
                core.dist,
                sigma,
                f.gamma(),
            ));
        }
        summary.extend(super::misses::peak_miss_note(
            data,
            selected_member,
            &fitted,
            match compared.residual {
                super::options::Residual::Noise(m) => Some(m),
                _ => None,
            },
            selected_member
                .core
                .zip(selected_fit.and_then(|f| f.sigma()))
                .map(|(core, (sigma, _))| {
                    peak::lobe_fwhm_deg(core.dist, sigma, selected_fit.and_then(|f| f.gamma()))
                }),
        ));
        summary.extend(super::misses::miss_notes(data, f, &fitted, members));
    }
    summary.append(&mut fitting);
    let mut notes = summary;
    for f in members {
        let singular = (0..f.x.len()).any(|i| {
            !f.identifiable[i] && !f.is_fixed(i) && f.layout.shape_at_bound(&f.x, i).is_none()
        });
        let at_bounds = shapes_at_bounds(f).join("; ");
        match (singular, at_bounds.is_empty()) {
            (true, true) => notes.push(format!(
                "{}: some parameters are not determined by these data (flagged)",
                f.member()
            )),
            (true, false) => notes.push(format!(
                "{}: some parameters are not determined by these data (flagged); {at_bounds}: a standard error is not defined at a bound of the fit",
                f.member()
            )),
            (false, false) => notes.push(format!(
                "{}: {at_bounds}: not determined by these data (a standard error is not defined at a bound of the fit)",
                f.member()
            )),
            (false, true) => {}
        }
        if !f.converged {
            notes.push(format!(
                "{}: the optimiser stopped before its tolerances were met",
                f.member()
            ));
        }
    }
    let nearest: Vec<String> = (0..data.incidences.len())
        .filter_map(|j| match data.specular_reference(j) {
            Some((k, false)) => Some(format!(
                "{} (at {})",
                crate::text::angle(data.incidences[j]),
                crate::text::angle(data.obs[k].theta_r)
            )),
            _ => None,
        })
        .collect();
    if !nearest.is_empty() {
        notes.push(format!(
            "no reading at theta_r = theta_i for theta_i {}: their paper RMSE is normalised at the nearest reading",
            nearest.join(", ")
        ));
    }
    let unnormalised: Vec<String> = (0..data.incidences.len())
        .filter(|&j| {
            data.specular_reference(j).is_some() && data.normalising_reference(j).is_none()
        })
        .map(|j| crate::text::angle(data.incidences[j]))
        .collect();
    if !unnormalised.is_empty() {
        notes.push(format!(
            "theta_i {}: the reading that normalises the paper RMSE (at or nearest theta_r = theta_i) is at or below 0: no paper RMSE there",
            unnormalised.join(", ")
        ));
    }
    if let Residual::Noise(m) = compared.residual {
        notes.push(m.describe());
    }
    if let Some(a) = aperture {
        notes.push(format!(
            "every model was averaged over the detector's aperture (half-angle {} deg) before comparison; parameters are the surface's",
            crate::text::sig(a, 4)
        ));
    }
    notes
}

/// The lobe shape of the selected component set: how its fitted variants compare.
fn variant_notes(cands: &[Candidate], sel: Member) -> Vec<String> {
    let Some(core) = sel.core else {
        return Vec::new();
    };
    let same = |m: Member| {
        m.core.is_some()
            && m.haze.is_some() == sel.haze.is_some()
            && m.directional == sel.directional
            && m.ideal == sel.ideal
    };
    let Some(best) = cands.iter().find(|c| c.member == sel) else {
        return Vec::new();
    };
    // Members of the same components with a lower AICc are there only when selection
    // passed them over (a component of theirs is not supported): said as such, never
    // as a tie or as higher.
    let selection = Selection::new(cands, Criterion::Aicc);
    let variants = || cands.iter().filter(|c| same(c.member) && c.member != sel);
    let others: Vec<String> = variants()
        .filter(|c| c.aicc >= best.aicc)
        .map(|c| format!("{} {:+.1}", c.member, c.aicc - best.aicc))
        .collect();
    let passed_over: Vec<String> = variants()
        .filter(|c| c.aicc < best.aicc)
        .map(|c| {
            let unsupported = c
                .member
                .components()
                .find(|&k| selection.test(c.member, k).is_some_and(|t| !t.supports()));
            let why = unsupported.map_or(String::new(), |k| {
                format!(
                    ", passed over: its {} is not supported by these data",
                    k.name()
                )
            });
            format!("{} {:.1} lower{why}", c.member, best.aicc - c.aicc)
        })
        .collect();
    if others.is_empty() && passed_over.is_empty() {
        return Vec::new();
    }
    let haze = sel
        .haze
        .map_or(String::new(), |h| format!(" on a {} haze", h.dist.name()));
    // A difference under the margin is no evidence for either shape: said, not implied.
    let ties: Vec<String> = variants()
        .filter(|c| (0.0..AICC_MARGIN).contains(&(c.aicc - best.aicc)))
        .map(|c| c.member.to_string())
        .collect();
    let tie = if ties.is_empty() {
        String::new()
    } else {
        format!(
            "; within {AICC_MARGIN} of it, so these data do not tell it from {}",
            ties.join(", ")
        )
    };
    let mut parts = Vec::new();
    if !others.is_empty() {
        parts.push(format!("AICc of the others: {}", others.join(", ")));
    }
    if !passed_over.is_empty() {
        parts.push(format!("AICc of {}", passed_over.join("; ")));
    }
    let lowest = if passed_over.is_empty() {
        "has the lowest AICc of these components"
    } else {
        "is selected among these components"
    };
    vec![format!(
        "specular lobe shape: {} with k_s {}{haze} {lowest} ({}){tie}",
        core.dist.name(),
        core.ks.name(),
        parts.join("; ")
    )]
}

/// Goodness of fit of the selected member against the readings' noise (in the
/// `residual`'s kind), said plainly; not judged when the stated noise is absurd.
fn goodness_note(data: &Dataset, cands: &[Candidate], sel: Member, residual: Residual) -> String {
    if !data.has_noise() {
        return "goodness of fit against noise: not known (the sweep has no std and n columns)"
            .into();
    }
    if let Some(a) = goodness::absurd_noise(data, residual) {
        return format!("goodness of fit against noise: not judged: {a}");
    }
    let Some(g) = cands
        .iter()
        .find(|c| c.member == sel)
        .and_then(|c| c.goodness)
    else {
        return "goodness of fit against noise: not known".into();
    };
    let within: Vec<&Candidate> = cands
        .iter()
        .filter(|c| c.goodness.is_some_and(|g| g.within_noise()))
        .collect();
    if g.within_noise() {
        format!(
            "goodness of fit: reduced chi-square {:.2} over {} degrees of freedom (limit {:.2}): {sel} fits within the readings' noise",
            g.reduced(),
            g.dof,
            g.limit()
        )
    } else if within.is_empty() {
        let best = cands
            .iter()
            .filter_map(|c| c.goodness.map(|g| (c.member, g.reduced())))
            .min_by(|a, b| a.1.total_cmp(&b.1));
        format!(
            "NO member fits these data within their noise: reduced chi-square {:.1} for {sel} (best {}, limit {:.2}); the residuals are larger than the readings' std/sqrt(n) say they should be",
            g.reduced(),
            best.map_or("n/d".into(), |(m, r)| format!("{r:.1}, {m}")),
            g.limit()
        )
    } else {
        format!(
            "goodness of fit: reduced chi-square {:.1} for {sel} is above the noise limit {:.2}; within noise: {}",
            g.reduced(),
            g.limit(),
            within
                .iter()
                .map(|c| c.member.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        )
    }
}

/// `f`'s shape parameters fitted to a bound of the fit's box
/// ([`super::member_fit::Layout::shape_at_bound`]), by the report's names and values,
/// each said as `name = value, its lower (upper) bound`, with what the bound means for
/// a tail exponent or a haze held beside the core.
fn shapes_at_bounds(f: &MemberFit) -> Vec<String> {
    let l = &f.layout;
    member_params(f)
        .into_iter()
        .filter(|p| !p.held && p.theta_i.is_none())
        .filter_map(|p| {
            let i = p.slot?;
            let upper = l.shape_at_bound(&f.x, i)?;
            let side = if upper { "upper" } else { "lower" };
            let meaning = match (l.is_gamma(i), upper) {
                (true, true) => ": the tail is Beckmann's to within 2 %",
                (true, false) => ": the heaviest tail the fit allows",
                (false, false) if Some(i) == l.sigma_haze && l.haze_ratio() => {
                    ": the haze as narrow as the family allows beside the core"
                }
                _ => "",
            };
            // Six significant digits: the bound itself, not its last bit of rounding
            // (gamma's 51 is 1 + exp(ln 50)).
            let shown: f64 = format!("{:.5e}", p.value).parse().unwrap_or(p.value);
            Some(format!(
                "{} = {}, its {side} bound{meaning}",
                p.base,
                brdf_core::error::Short(shown)
            ))
        })
        .collect()
}
