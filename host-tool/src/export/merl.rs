//! The MERL export: the fitted model as a MERL BRDF database binary table, and a reader
//! of such tables (the reference code's lookup) to check it.

use std::fs::File;
use std::io::{self, Read, Write};
use std::path::Path;

use brdf_core::Geometry;

use super::mitsuba::MemberTable;

/// Table dimensions as the file header gives them: theta_half, theta_diff, phi_diff.
pub const MERL_DIMS: [usize; 3] = [90, 90, 180];

/// Values per channel.
pub const MERL_LEN: usize = MERL_DIMS[0] * MERL_DIMS[1] * MERL_DIMS[2];

/// What a MERL reader multiplies each stored channel by (R, G, B), as in the MERL
/// reference code; the writer stores `value / scale`.
pub const MERL_SCALE: [f64; 3] = [1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0];

/// The value written where the geometry has no BRDF: a direction below the horizon, no
/// half vector, or a model evaluation that fails.
pub const MERL_INVALID: f64 = 0.0;

/// theta_half (radians) of index `i`: the non-linear MERL mapping
/// theta_h = (i / 90)^2 * 90 degrees, the lower edge of the reader's bin.
pub(super) fn merl_theta_half(i: usize) -> f64 {
    let t = i as f64 / MERL_DIMS[0] as f64;
    t * t * std::f64::consts::FRAC_PI_2
}

/// theta_diff (radians) of index `j`: linear, j degrees.
pub(super) fn merl_theta_diff(j: usize) -> f64 {
    j as f64 / MERL_DIMS[1] as f64 * std::f64::consts::FRAC_PI_2
}

/// phi_diff (radians) of index `k`: linear over [0, 180) degrees, k degrees.
pub(super) fn merl_phi_diff(k: usize) -> f64 {
    k as f64 / MERL_DIMS[2] as f64 * std::f64::consts::PI
}

/// The MERL reference `rotate_vector`: `v` rotated by `angle` about the unit `axis`
/// (Rodrigues' formula, in the reference code's order of operations).
pub(super) fn rotate_vector(v: [f64; 3], axis: [f64; 3], angle: f64) -> [f64; 3] {
    let (s, c) = angle.sin_cos();
    let dot = (axis[0] * v[0] + axis[1] * v[1] + axis[2] * v[2]) * (1.0 - c);
    let cross = [
        axis[1] * v[2] - axis[2] * v[1],
        axis[2] * v[0] - axis[0] * v[2],
        axis[0] * v[1] - axis[1] * v[0],
    ];
    [
        v[0] * c + axis[0] * dot + cross[0] * s,
        v[1] * c + axis[1] * dot + cross[1] * s,
        v[2] * c + axis[2] * dot + cross[2] * s,
    ]
}

pub(super) const NORMAL: [f64; 3] = [0.0, 0.0, 1.0];
pub(super) const BI_NORMAL: [f64; 3] = [0.0, 1.0, 0.0];

/// Half/difference angles (radians) to the incoming and outgoing unit vectors, as the
/// MERL `half_diff_coords_to_std_coords`: the difference vector rotated by theta_h about
/// the bi-normal (y) and by phi_h about the normal (z) gives `in`; `out` is `in`
/// reflected about the half vector.
pub(super) fn half_diff_to_vectors(
    theta_h: f64,
    phi_h: f64,
    theta_d: f64,
    phi_d: f64,
) -> ([f64; 3], [f64; 3]) {
    let (sd, cd) = theta_d.sin_cos();
    let diff = [phi_d.cos() * sd, phi_d.sin() * sd, cd];
    let w_in = rotate_vector(rotate_vector(diff, BI_NORMAL, theta_h), NORMAL, phi_h);
    let (sh, ch) = theta_h.sin_cos();
    let h = [phi_h.cos() * sh, phi_h.sin() * sh, ch];
    let dot = h[0] * w_in[0] + h[1] * w_in[1] + h[2] * w_in[2];
    let w_out = [
        2.0 * dot * h[0] - w_in[0],
        2.0 * dot * h[1] - w_in[1],
        2.0 * dot * h[2] - w_in[2],
    ];
    (w_in, w_out)
}

/// The MERL `std_coords_to_half_diff_coords`: (theta_in, phi_in, theta_out, phi_out) to
/// (theta_half, phi_half, theta_diff, phi_diff), all radians.
pub(super) fn std_to_half_diff(
    theta_in: f64,
    phi_in: f64,
    theta_out: f64,
    phi_out: f64,
) -> [f64; 4] {
    let vec = |t: f64, p: f64| [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()];
    let normalize = |v: [f64; 3]| {
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        [v[0] / n, v[1] / n, v[2] / n]
    };
    let w_in = normalize(vec(theta_in, phi_in));
    let w_out = normalize(vec(theta_out, phi_out));
    let half = normalize([
        (w_in[0] + w_out[0]) / 2.0,
        (w_in[1] + w_out[1]) / 2.0,
        (w_in[2] + w_out[2]) / 2.0,
    ]);
    let theta_half = half[2].clamp(-1.0, 1.0).acos();
    let phi_half = half[1].atan2(half[0]);
    let temp = rotate_vector(w_in, NORMAL, -phi_half);
    let diff = rotate_vector(temp, BI_NORMAL, -theta_half);
    [
        theta_half,
        phi_half,
        diff[2].clamp(-1.0, 1.0).acos(),
        diff[1].atan2(diff[0]),
    ]
}

/// The MERL reference index of a (theta_half, theta_diff, phi_diff) triple (radians):
/// `theta_half_index`, `theta_diff_index`, `phi_diff_index` (phi_diff folded into
/// [0, pi) by reciprocity), each truncated and clamped.
pub(super) fn merl_index(theta_half: f64, theta_diff: f64, phi_diff: f64) -> usize {
    let clamp = |x: f64, n: usize| (x.max(0.0) as usize).min(n - 1);
    let ih = if theta_half <= 0.0 {
        0
    } else {
        let deg = theta_half / std::f64::consts::FRAC_PI_2 * MERL_DIMS[0] as f64;
        clamp((deg * MERL_DIMS[0] as f64).sqrt(), MERL_DIMS[0])
    };
    let id = clamp(
        theta_diff / std::f64::consts::FRAC_PI_2 * MERL_DIMS[1] as f64,
        MERL_DIMS[1],
    );
    let pd = if phi_diff < 0.0 {
        phi_diff + std::f64::consts::PI
    } else {
        phi_diff
    };
    let ip = clamp(
        pd / std::f64::consts::PI * MERL_DIMS[2] as f64,
        MERL_DIMS[2],
    );
    ip + id * MERL_DIMS[2] + ih * MERL_DIMS[2] * MERL_DIMS[1]
}

/// The model at one MERL sample: `w_in` is our w_i (toward the source; a k_s at its
/// polar angle through [`MemberTable::model_at`]), `w_out` our w_r (toward the
/// detector), evaluated by brdf-core's model of the member. [`MERL_INVALID`] below the
/// horizon (z < -1e-9; tiny negatives from rounding count as grazing) or where the
/// model cannot be evaluated.
pub(super) fn merl_sample(table: &MemberTable, w_in: [f64; 3], w_out: [f64; 3]) -> f64 {
    if w_in[2] < -1e-9 || w_out[2] < -1e-9 {
        return MERL_INVALID;
    }
    let theta_in = w_in[2].clamp(0.0, 1.0).acos().to_degrees();
    let Ok(g) = Geometry::from_vectors(w_in, w_out) else {
        return MERL_INVALID;
    };
    table
        .model_at(theta_in)
        .ok()
        .and_then(|m| m.eval(theta_in, &g).ok())
        .map(|e| e.f)
        .filter(|f| f.is_finite())
        .unwrap_or(MERL_INVALID)
}

/// Largest reciprocity ratio f(in->out)/f(out->in) over the table's cells for which the
/// MERL export still writes the reciprocal mean; beyond it the export is refused (the
/// mean would be more than a factor sqrt(limit) from what either direction measured).
/// The paper's presets reach 7.6 on brdf-core's reciprocity grid.
pub const MERL_MAX_RATIO: f64 = 20.0;

/// The grey table (one value per cell, in the fit's units), in file order: theta_half
/// slowest, phi_diff fastest; phi_half = 0 (the model is isotropic). Each cell holds
/// the reciprocal mean (f(in->out) + f(out->in)) / 2: MERL folds phi_diff by
/// reciprocity, so a lookup with the directions swapped lands on the same cell, and
/// the value must not depend on which of the two a rounding picked. Also returns the
/// largest ratio of the two over the cells (1 for a reciprocal model).
pub(super) fn merl_values(table: &MemberTable) -> (Vec<f64>, f64) {
    let mut out = Vec::with_capacity(MERL_LEN);
    let mut worst: f64 = 1.0;
    for i in 0..MERL_DIMS[0] {
        let th = merl_theta_half(i);
        for j in 0..MERL_DIMS[1] {
            let td = merl_theta_diff(j);
            for k in 0..MERL_DIMS[2] {
                let (w_in, w_out) = half_diff_to_vectors(th, 0.0, td, merl_phi_diff(k));
                let ab = merl_sample(table, w_in, w_out);
                let ba = merl_sample(table, w_out, w_in);
                // A direction without a value (below the horizon, no half vector) has
                // none either way; a single failed evaluation leaves the other.
                let v = match (ab > 0.0, ba > 0.0) {
                    (true, true) => {
                        worst = worst.max(ab.max(ba) / ab.min(ba));
                        0.5 * (ab + ba)
                    }
                    (true, false) => ab,
                    (false, true) => ba,
                    (false, false) => MERL_INVALID,
                };
                out.push(v);
            }
        }
    }
    (out, worst)
}

/// The MERL binary layout: three little-endian i32 dims (90, 90, 180), then the R, G
/// and B channels of 90*90*180 little-endian f64 each, each value divided by its
/// channel's [`MERL_SCALE`] (grey: the same BRDF in every channel).
pub(super) fn write_merl(w: &mut impl Write, values: &[f64]) -> io::Result<()> {
    for d in MERL_DIMS {
        w.write_all(&(d as i32).to_le_bytes())?;
    }
    for scale in MERL_SCALE {
        for &v in values {
            w.write_all(&(v / scale).to_le_bytes())?;
        }
    }
    Ok(())
}

/// A MERL table read back: BRDF values with the channel scales applied.
#[derive(Debug, Clone)]
pub struct MerlTable {
    /// R, G and B, each [`MERL_LEN`] values in file order.
    pub channels: [Vec<f64>; 3],
}

impl MerlTable {
    /// Reads a MERL file, checking its dims and length.
    pub fn read(path: &Path) -> io::Result<MerlTable> {
        let mut bytes = Vec::new();
        File::open(path)?.read_to_end(&mut bytes)?;
        let bad = |m: String| io::Error::new(io::ErrorKind::InvalidData, m);
        if bytes.len() < 12 {
            return Err(bad("shorter than the 12-byte header".into()));
        }
        let dims: Vec<i32> = bytes[..12]
            .chunks_exact(4)
            .map(|c| i32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        if dims.iter().zip(MERL_DIMS).any(|(&d, e)| d != e as i32) {
            return Err(bad(format!("dims {dims:?}, expected {MERL_DIMS:?}")));
        }
        if bytes.len() != 12 + 3 * 8 * MERL_LEN {
            return Err(bad(format!(
                "{} bytes, expected {}",
                bytes.len(),
                12 + 3 * 8 * MERL_LEN
            )));
        }
        let values: Vec<f64> = bytes[12..]
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
            .collect();
        let channel = |c: usize| {
            values[c * MERL_LEN..(c + 1) * MERL_LEN]
                .iter()
                .map(|v| v * MERL_SCALE[c])
                .collect::<Vec<f64>>()
        };
        Ok(MerlTable {
            channels: [channel(0), channel(1), channel(2)],
        })
    }

    /// The reference `lookup_brdf_val`: R, G, B for an incoming and an outgoing direction
    /// given as polar and azimuth angles in radians (no interpolation).
    pub fn lookup(&self, theta_in: f64, phi_in: f64, theta_out: f64, phi_out: f64) -> [f64; 3] {
        let [th, _, td, pd] = std_to_half_diff(theta_in, phi_in, theta_out, phi_out);
        let ind = merl_index(th, td, pd);
        [
            self.channels[0][ind],
            self.channels[1][ind],
            self.channels[2][ind],
        ]
    }
}
