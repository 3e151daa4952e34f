//! The paper's material presets: sigma and the k_s(theta_i) table, interpolated linearly.

use crate::error::ModelError;
use crate::float::Real;
use crate::model::{Model, Params};

/// Incidence angles (degrees) at which the paper tabulates k_s: 0, 10, ..., 80.
pub const KS_TABLE_STEP_DEG: f64 = 10.0;

/// A material preset from the paper's tables (docs/model.md).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Preset {
    /// The preset's name, e.g. `"fe-0.115"`.
    pub name: &'static str,
    /// The sample's metal.
    pub metal: &'static str,
    /// Microfacet slope parameter sigma (the paper's roughness figure).
    pub sigma: f64,
    /// k_s at theta_i = 0, 10, ..., 80 degrees.
    pub ks_table: [f64; 9],
}

/// All presets, in the order of the table in docs/model.md.
pub const PRESETS: [Preset; 5] = [
    Preset {
        name: "al-0.087",
        metal: "Al",
        sigma: 0.087,
        ks_table: [
            508.0, 532.0, 565.0, 590.0, 615.0, 636.0, 660.0, 685.0, 711.0,
        ],
    },
    Preset {
        name: "al-0.142",
        metal: "Al",
        sigma: 0.142,
        ks_table: [
            280.0, 300.0, 350.0, 380.0, 400.0, 400.0, 400.0, 425.0, 475.0,
        ],
    },
    Preset {
        name: "al-0.782",
        metal: "Al",
        sigma: 0.782,
        ks_table: [50.0, 66.0, 80.0, 102.0, 125.0, 142.0, 160.0, 178.0, 198.0],
    },
    Preset {
        name: "cu-0.070",
        metal: "Cu",
        sigma: 0.070,
        ks_table: [
            100.0, 135.0, 165.0, 190.0, 215.0, 245.0, 260.0, 300.0, 320.0,
        ],
    },
    Preset {
        name: "fe-0.115",
        metal: "Fe",
        sigma: 0.115,
        ks_table: [
            115.0, 130.0, 145.0, 165.0, 185.0, 200.0, 215.0, 237.0, 260.0,
        ],
    },
];

impl Preset {
    /// Looks a preset up by name (e.g. `"cu-0.070"`).
    pub fn by_name(name: &str) -> Result<&'static Preset, ModelError> {
        PRESETS
            .iter()
            .find(|p| p.name == name)
            .ok_or(ModelError::UnknownPreset)
    }

    /// k_s at incidence `theta_i_deg` (degrees): linear between the tabulated angles,
    /// clamped to the end values outside 0..80. NaN is an error.
    pub fn ks<T: Real>(&self, theta_i_deg: T) -> Result<T, ModelError> {
        if theta_i_deg.is_nan() {
            return Err(ModelError::NotFinite { what: "theta_i" });
        }
        let last = self.ks_table.len() - 1;
        let pos = (theta_i_deg / T::lit(KS_TABLE_STEP_DEG))
            .max(T::zero())
            .min(T::lit(last as f64));
        // pos is in [0, 8]: truncation picks the segment, the top end uses the last one.
        let seg = pos.to_usize().unwrap_or(0).min(last - 1);
        let frac = pos - T::lit(seg as f64);
        let (a, b) = (T::lit(self.ks_table[seg]), T::lit(self.ks_table[seg + 1]));
        Ok(a + (b - a) * frac)
    }

    /// The paper's three-component parameters at incidence `theta_i_deg`.
    pub fn params<T: Real>(&self, theta_i_deg: T) -> Result<Params<T>, ModelError> {
        Ok(Params::paper(self.ks(theta_i_deg)?, T::lit(self.sigma)))
    }

    /// The paper's three-component model at incidence `theta_i_deg`.
    pub fn model<T: Real>(&self, theta_i_deg: T) -> Result<Model<T>, ModelError> {
        Model::three_component(self.params(theta_i_deg)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tabulated_angles_give_table_values() {
        for p in &PRESETS {
            for (i, &k) in p.ks_table.iter().enumerate() {
                assert_eq!(
                    p.ks(10.0 * i as f64).unwrap(),
                    k,
                    "{} at {}",
                    p.name,
                    10 * i
                );
            }
        }
    }

    #[test]
    fn interpolates_linearly_and_clamps() {
        let fe = Preset::by_name("fe-0.115").unwrap();
        assert_eq!(fe.ks(25.0f64).unwrap(), 155.0);
        assert_eq!(fe.ks(-5.0f64).unwrap(), 115.0);
        assert_eq!(fe.ks(85.0f64).unwrap(), 260.0);
        assert_eq!(fe.ks(f64::INFINITY).unwrap(), 260.0);
        assert_eq!(fe.ks(79.0f32).unwrap(), 237.0 + 0.9 * 23.0);
        assert_eq!(
            fe.ks(f64::NAN),
            Err(ModelError::NotFinite { what: "theta_i" })
        );
    }

    #[test]
    fn unknown_preset_is_an_error() {
        assert_eq!(Preset::by_name("gold"), Err(ModelError::UnknownPreset));
        assert_eq!(Preset::by_name("al-0.782").unwrap().sigma, 0.782);
    }
}
