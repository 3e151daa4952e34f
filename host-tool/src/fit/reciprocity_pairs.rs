//! The geometry of every ordered pair of the reciprocity grid's directions, computed once per process and shared by every member checked.

use std::sync::OnceLock;

use brdf_core::ModelError;
use brdf_core::albedo::{Grid, Reciprocity, polar_deg, reciprocity_indexed};
use brdf_core::geometry::Geometry;
use brdf_core::member_model::MemberModel;

use super::member_fit::MemberFit;

/// [`Grid::DEFAULT`]'s directions: each one's polar angle (degrees) and each ordered
/// pair's geometry, row-major (`in * n + out`; 216 x 216, a direction with itself
/// unused). A member's check evaluates its model on the 46,440 pairs of distinct
/// directions; the geometry (square roots, an atan2) and the directions (sines,
/// cosines, an acos) are the same for every member.
struct Pairs {
    n: usize,
    polar: Vec<f64>,
    geometry: Vec<Result<Geometry<f64>, ModelError>>,
}

fn pairs() -> &'static Pairs {
    static PAIRS: OnceLock<Pairs> = OnceLock::new();
    PAIRS.get_or_init(|| {
        let grid = Grid::DEFAULT;
        let n = grid.directions();
        let units: Vec<[f64; 3]> = (0..n).map(|k| grid.unit(k)).collect();
        let geometry = units
            .iter()
            .flat_map(|&wi| units.iter().map(move |&wo| Geometry::from_vectors(wi, wo)))
            .collect();
        Pairs {
            n,
            polar: units.iter().map(polar_deg).collect(),
            geometry,
        }
    })
}

/// The reciprocity check of a fitted member on [`Grid::DEFAULT`]: the member at the
/// incoming direction's polar angle (per-incidence k_s interpolated as
/// [`MemberFit::model_at`]; each angle's model built once), evaluated on the pairs
/// shared by every member. The same values, bit for bit, as
/// [`brdf_core::albedo::reciprocity`] over the vectors (a test checks).
pub fn member_reciprocity(fit: &MemberFit) -> Result<Reciprocity, ModelError> {
    let p = pairs();
    let mut models: Vec<(f64, Option<MemberModel<f64>>)> = Vec::new();
    reciprocity_indexed(&Grid::DEFAULT, |i, o| {
        let t = p.polar[i];
        // Found by reference: copying the model out cost a sixth of the check.
        let k = match models.iter().position(|m| m.0 == t) {
            Some(k) => k,
            None => {
                models.push((t, fit.model_at(t)));
                models.len() - 1
            }
        };
        let m = models[k].1.as_ref().ok_or(ModelError::NotFinite {
            what: "fitted model",
        })?;
        m.eval(t, &p.geometry[i * p.n + o]?).map(|e| e.f)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::data::synthetic_paper_sweep;
    use crate::fit::{Dataset, FitOptions, fit_family};
    use brdf_core::albedo::reciprocity;
    use brdf_core::geometry::Geometry;

    /// The shared pairs give every fitted member's check bit for bit what the check
    /// over the grid's vectors gives (the model at w_i's polar angle, the geometry
    /// from the two vectors).
    #[test]
    fn the_shared_pairs_give_the_vectors_check_bit_for_bit() {
        let p = brdf_core::Preset::by_name("al-0.782").unwrap();
        let rows = synthetic_paper_sweep(|ti| p.model(ti).unwrap(), 0.005, 2);
        let data = Dataset::from_rows(&rows, true).unwrap();
        let family = fit_family(&data, &FitOptions::default()).unwrap();
        assert!(family.members.len() >= 5);
        for fit in &family.members {
            let by_vectors = reciprocity(&Grid::DEFAULT, |wi: &[f64; 3], wo: &[f64; 3]| {
                let t = polar_deg(wi);
                let m = fit.model_at(t).ok_or(ModelError::NotFinite {
                    what: "fitted model",
                })?;
                m.eval(t, &Geometry::from_vectors(*wi, *wo)?).map(|e| e.f)
            });
            let shared = member_reciprocity(fit);
            match (by_vectors, shared) {
                (Ok(a), Ok(b)) => {
                    assert_eq!(
                        a.max_ratio.to_bits(),
                        b.max_ratio.to_bits(),
                        "{}",
                        fit.member()
                    );
                    assert_eq!(
                        (a.worst_in, a.worst_out, a.pairs),
                        (b.worst_in, b.worst_out, b.pairs)
                    );
                    assert_eq!(a.pairs, 23_220);
                }
                (a, b) => assert_eq!(a, b, "{}", fit.member()),
            }
        }
    }
}
