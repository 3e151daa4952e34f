//! The factors of a member's value that many readings share: its directional-diffuse
//! term per detector angle, its smooth k_s per incidence (each an exponential).

use super::data::Dataset;
use brdf_core::member_model::{AtIncidence, MemberEval, MemberModel};

/// A member's directional-diffuse factor ([`MemberModel::directional_at`]) at each of a
/// sweep's detector angles ([`Dataset::detectors`]): the term has global parameters
/// and depends on |theta_r| alone, so one table serves every incidence's model.
#[derive(Debug, Clone, Default)]
pub struct Detectors(Vec<Option<(f64, f64)>>);

impl Detectors {
    /// The table of `m` (any incidence's model) over `data`'s detector angles, made in
    /// place; empty when `m` has no directional-diffuse term.
    pub fn fill(&mut self, data: &Dataset, m: &MemberModel<f64>) {
        self.0.clear();
        if m.member().directional {
            let d = data.detectors().iter().map(|&t| m.directional_at(t));
            self.0.extend(d);
        }
    }

    /// The table of `m` over `data`'s detector angles.
    pub fn of(data: &Dataset, m: &MemberModel<f64>) -> Self {
        let mut d = Detectors::default();
        d.fill(data, m);
        d
    }

    /// Empties the table (a model without the term, or one not evaluated at points).
    pub fn clear(&mut self) {
        self.0.clear();
    }

    /// The factor at reading `k` of the sweep the table was made for; `None` when the
    /// table is empty.
    #[inline]
    pub fn at(&self, data: &Dataset, k: usize) -> Option<(f64, f64)> {
        self.0.get(data.detector_of(k)).copied().flatten()
    }
}

/// [`MemberModel::at_incidence`] of one model at the last incidence asked, made again
/// only when the incidence changes (the readings of one incidence may differ in
/// theta_i within the sweep's grouping tolerance). One per model.
#[derive(Debug, Clone, Copy, Default)]
pub struct Incidence(Option<(f64, AtIncidence<f64>)>);

impl Incidence {
    /// The factors of `m` at `theta_i` (degrees); `None` outside [0, 90].
    #[inline]
    pub fn at(&mut self, m: &MemberModel<f64>, theta_i: f64) -> Option<AtIncidence<f64>> {
        match self.0 {
            Some((t, f)) if t == theta_i => Some(f),
            _ => {
                let f = m.at_incidence(theta_i).ok()?;
                self.0 = Some((theta_i, f));
                Some(f)
            }
        }
    }
}

/// `m`'s point value (no aperture) at reading `k` of `data`, read at incidence
/// `theta_i` (degrees), with `dd` made for `m`'s directional-diffuse term and `inc`
/// holding `m`'s factors: [`MemberModel::eval`] at the reading, bit for bit.
#[inline]
pub fn point_value(
    m: &MemberModel<f64>,
    inc: &mut Incidence,
    dd: &Detectors,
    data: &Dataset,
    k: usize,
    theta_i: f64,
) -> Option<MemberEval<f64>> {
    let f = inc.at(m, theta_i)?;
    m.eval_given(&f, dd.at(data, k), &data.obs[k].geom).ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep_file::Row;
    use brdf_core::lobe::{Distribution, SmoothKs};
    use brdf_core::member_model::{DirectionalParams, Ks, LobeParams, MemberParams};

    #[test]
    fn shared_factors_give_each_readings_value_bit_for_bit() {
        // Three incidences, one reading 4e-7 degrees off its incidence (grouped with
        // it, its own theta_i used), detector angles of both signs.
        let mut rows = Vec::new();
        for ti in [0.0, 30.0, 60.0] {
            for k in 0..33 {
                let tr = -80.0 + 5.0 * k as f64;
                rows.push(Row::new(ti, tr, 1.0 + k as f64));
            }
        }
        rows[40].theta_i = 30.0 + 4e-7;
        let data = Dataset::from_rows(&rows, true).unwrap();
        assert_eq!(data.incidences.len(), 3);
        let full = MemberParams {
            core: Some(LobeParams {
                dist: Distribution::Ggx,
                ks: Ks::Smooth(SmoothKs {
                    c: [1.2, 0.8, -0.5],
                }),
                sigma: 0.02,
                gamma: None,
            }),
            haze: Some(LobeParams {
                dist: Distribution::Beckmann,
                ks: Ks::PerIncidence(0.3),
                sigma: 0.2,
                gamma: None,
            }),
            directional: Some(DirectionalParams {
                kdd: 0.05,
                sigma_m: 0.6,
            }),
            ideal: Some(0.01),
            abg: None,
        };
        let no_dd = MemberParams {
            directional: None,
            ..full
        };
        for p in [full, no_dd] {
            let m = MemberModel::new(&p).unwrap();
            let dd = Detectors::of(&data, &m);
            assert_eq!(dd.0.is_empty(), p.directional.is_none());
            for j in 0..3 {
                let mut inc = Incidence::default();
                for &k in data.rows_of(j) {
                    let o = &data.obs[k];
                    let got = point_value(&m, &mut inc, &dd, &data, k, o.theta_i).unwrap();
                    assert_eq!(got, m.eval(o.theta_i, &o.geom).unwrap(), "reading {k}");
                }
            }
        }
        // Outside [0, 90] degrees there are no factors.
        let m = MemberModel::new(&full).unwrap();
        assert!(Incidence::default().at(&m, 90.5).is_none());
    }
}
