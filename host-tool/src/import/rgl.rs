//! RGL-EPFL measured materials (Dupuy & Jakob, "An Adaptive Parameterization for
//! Efficient Material Acquisition and Rendering", 2018): an RGB or spectral
//! `tensor_file` evaluated as the reference reader rgl-epfl/brdf-loader's
//! `powitacq_rgb::BRDF::eval` (RGB) or `powitacq::BRDF::eval` (spectral) does, in the
//! plane of incidence.
//!
//! That `eval(wi, wo)` returns f_r * cos(theta_o) (Mitsuba's convention; wi toward the
//! source, wo toward the detector): `values(invert_vndf(u_wm)) * ndf(u_wm) / (4
//! sigma(u_wi))`, each a bilinear interpolant (`Marginal2D`) over the unit square,
//! u = (sqrt(2 theta / pi), (phi + pi) / 2 pi), the VNDF's inversion through its
//! marginal and conditional CDFs, the tables interpolated linearly between the
//! measured incidences. The values are the `rgb` field (3 channels, negative clamped to
//! 0) or the `spectra` field over the file's `wavelengths` (interpolated linearly along
//! the wavelength as along the incidence, not clamped). gonio divides by cos(theta_o)
//! to store f_r in 1/sr. `y` is Rec. 709 luminance (0.2126 R + 0.7152 G + 0.0722 B) of
//! an RGB file, CIE 1931 Y of a spectral one ([`super::cie`]). Arithmetic in f64 where
//! the reference uses f32 (differences near 1e-6 relative).

use std::collections::BTreeMap;
use std::f64::consts::PI;

use super::tensor::Field;

/// Which value to take from a file ([`RglBrdf::check`] says which a file has).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RglChannel {
    /// Red (RGB files).
    R,
    /// Green (RGB files).
    G,
    /// Blue (RGB files).
    B,
    /// Luminance: Rec. 709 of an RGB file's three, CIE 1931 Y of a spectral file.
    Y,
    /// A spectral file at this wavelength (nm): one of its wavelengths, or linear
    /// between the two around it.
    Nm(f64),
}

impl RglChannel {
    /// The name on the command line and in the sweep's `source:` line.
    pub fn name(self) -> String {
        match self {
            RglChannel::R => "r".into(),
            RglChannel::G => "g".into(),
            RglChannel::B => "b".into(),
            RglChannel::Y => "y".into(),
            RglChannel::Nm(nm) => format!("{nm} nm"),
        }
    }
}

/// Least share of the integral of the CIE ybar that a spectral file's wavelengths must
/// span for its Y: a file missing more would give a luminance of part of the spectrum.
pub const Y_MIN_SHARE: f64 = 0.99;

/// Largest relative error of ybar's own integral over a spectral file's span by the
/// trapezoid rule on the file's wavelengths (against the CIE table's 1 nm steps): a
/// grid too coarse to integrate ybar (380 and 780 nm alone: 100 %) cannot give Y
/// either. A 50 nm grid from 380 nm gives 1.3 %.
pub const Y_MAX_ERROR: f64 = 0.02;

/// What the material's values are.
#[derive(Debug, Clone)]
enum Kind {
    /// The `rgb` field: three channels.
    Rgb,
    /// The `spectra` field over `wavelengths` (nm, increasing); the weights of its Y
    /// (summing to 1) when they span [`Y_MIN_SHARE`] of ybar and integrate it within
    /// [`Y_MAX_ERROR`], else why not.
    Spectral {
        wavelengths: Vec<f64>,
        y: Result<Vec<f64>, String>,
    },
}

/// The reference's `Marginal2D`: an `nx` x `ny` bilinear interpolant per slice of its
/// parameters (outermost first), with the CDFs its inversion needs when `normalize`.
#[derive(Debug, Clone)]
struct Warp {
    nx: usize,
    ny: usize,
    params: Vec<Vec<f64>>,
    strides: Vec<usize>,
    data: Vec<f64>,
    cond: Vec<f64>,
    marg: Vec<f64>,
}

impl Warp {
    fn new(
        nx: usize,
        ny: usize,
        data: &[f64],
        params: Vec<Vec<f64>>,
        normalize: bool,
    ) -> Result<Warp, String> {
        if nx < 2 || ny < 2 || params.iter().any(Vec::is_empty) {
            return Err(format!(
                "a table of {nx} x {ny} values: too small to interpolate"
            ));
        }
        let mut strides = vec![0; params.len()];
        let mut slices = 1usize;
        for i in (0..params.len()).rev() {
            strides[i] = if params[i].len() > 1 { slices } else { 0 };
            slices *= params[i].len();
        }
        let n = nx * ny;
        if data.len() != slices * n {
            return Err(format!(
                "a table holds {} values, its shape says {}",
                data.len(),
                slices * n
            ));
        }
        let mut w = Warp {
            nx,
            ny,
            params,
            strides,
            data: Vec::new(),
            cond: Vec::new(),
            marg: Vec::new(),
        };
        if !normalize {
            // As the reference: scaled by the patch area, which `eval` multiplies back.
            let k = 1.0 / ((nx - 1) * (ny - 1)) as f64;
            w.data = data.iter().map(|v| v * k).collect();
            return Ok(w);
        }
        for d in data.chunks_exact(n) {
            let mut cond = vec![0.0; n];
            for y in 0..ny {
                let (mut acc, i) = (0.0, y * nx);
                for x in 0..nx - 1 {
                    acc += 0.5 * (d[i + x] + d[i + x + 1]);
                    cond[i + x + 1] = acc;
                }
            }
            let (mut marg, mut acc) = (vec![0.0; ny], 0.0);
            for y in 0..ny - 1 {
                acc += 0.5 * (cond[(y + 1) * nx - 1] + cond[(y + 2) * nx - 1]);
                marg[y + 1] = acc;
            }
            if marg[ny - 1].partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                return Err("a VNDF slice integrates to zero: a damaged file".into());
            }
            let k = 1.0 / marg[ny - 1];
            w.cond.extend(cond.iter().map(|c| c * k));
            w.marg.extend(marg.iter().map(|m| m * k));
            w.data.extend(d.iter().map(|v| v * k));
        }
        Ok(w)
    }

    /// Interpolation weights per parameter and the slice offset (reference `find_interval`).
    fn weights(&self, param: &[f64]) -> (Vec<(f64, f64)>, usize) {
        let mut ws = Vec::with_capacity(self.params.len());
        let mut off = 0;
        for (dim, values) in self.params.iter().enumerate() {
            if values.len() == 1 {
                ws.push((1.0, 0.0));
                continue;
            }
            let i = find_interval(values.len(), |j| values[j] <= param[dim]);
            let w1 = ((param[dim] - values[i]) / (values[i + 1] - values[i])).clamp(0.0, 1.0);
            ws.push((1.0 - w1, w1));
            off += self.strides[dim] * i;
        }
        (ws, off)
    }

    fn lookup(&self, arr: &[f64], i0: usize, size: usize, ws: &[(f64, f64)], dim: usize) -> f64 {
        if dim == 0 {
            return arr[i0];
        }
        let i1 = i0 + self.strides[dim - 1] * size;
        let (w0, w1) = ws[dim - 1];
        let v0 = self.lookup(arr, i0, size, ws, dim - 1);
        // A zero weight may point past the table (stride 0 keeps it in).
        let v1 = if w1 == 0.0 {
            0.0
        } else {
            self.lookup(arr, i1, size, ws, dim - 1)
        };
        v0 * w0 + v1 * w1
    }

    fn corners(&self, arr: &[f64], off: usize, ws: &[(f64, f64)]) -> [f64; 4] {
        let (n, d) = (self.nx * self.ny, self.params.len());
        [0, 1, self.nx, self.nx + 1].map(|k| self.lookup(&arr[k..], off, n, ws, d))
    }

    fn cell(&self, pos: (f64, f64)) -> (usize, usize, f64, f64) {
        let (sx, sy) = (pos.0 * (self.nx - 1) as f64, pos.1 * (self.ny - 1) as f64);
        let px = (sx.max(0.0) as usize).min(self.nx - 2);
        let py = (sy.max(0.0) as usize).min(self.ny - 2);
        (px, py, sx - px as f64, sy - py as f64)
    }

    /// The reference's `eval`: the bilinear interpolant at `pos` (unit square).
    fn eval(&self, pos: (f64, f64), param: &[f64]) -> f64 {
        let (ws, so) = self.weights(param);
        let (px, py, wx, wy) = self.cell(pos);
        let [v00, v10, v01, v11] =
            self.corners(&self.data, px + py * self.nx + so * self.nx * self.ny, &ws);
        ((1.0 - wy) * ((1.0 - wx) * v00 + wx * v10) + wy * ((1.0 - wx) * v01 + wx * v11))
            * ((self.nx - 1) * (self.ny - 1)) as f64
    }

    /// The reference's `invert`: the unit-square sample that `sample` maps to `pos`.
    fn invert(&self, pos: (f64, f64), param: &[f64]) -> (f64, f64) {
        let (ws, so) = self.weights(param);
        let (nx, ny, d) = (self.nx, self.ny, self.params.len());
        let n = nx * ny;
        let (px, py, mut sx, mut sy) = self.cell(pos);
        let off = px + py * nx + so * n;
        let [v00, v10, v01, v11] = self.corners(&self.data, off, &ws);
        let c0 = (1.0 - sy) * v00 + sy * v01;
        let c1 = (1.0 - sy) * v10 + sy * v11;
        sx *= c0 + 0.5 * sx * (c1 - c0);
        let v0 = self.lookup(&self.cond, off, n, &ws, d);
        let v1 = self.lookup(&self.cond[nx..], off, n, &ws, d);
        sx += (1.0 - sy) * v0 + sy * v1;
        let off = py * nx + so * n;
        let r0 = self.lookup(&self.cond, off + nx - 1, n, &ws, d);
        let r1 = self.lookup(&self.cond, off + 2 * nx - 1, n, &ws, d);
        sx /= (1.0 - sy) * r0 + sy * r1;
        sy *= r0 + 0.5 * sy * (r1 - r0);
        sy += self.lookup(&self.marg, py + so * ny, ny, &ws, d);
        (sx, sy)
    }
}

/// The reference's `find_interval`: i with pred(i) and not pred(i + 1), clamped to
/// [0, size - 2].
fn find_interval(size: usize, pred: impl Fn(usize) -> bool) -> usize {
    let (mut len, mut first) = (size as isize - 2, 1isize);
    while len > 0 {
        let half = len >> 1;
        let middle = first + half;
        if pred(middle as usize) {
            first = middle + 1;
            len -= half + 1;
        } else {
            len = half;
        }
    }
    (first - 1).clamp(0, size as isize - 2) as usize
}

/// An RGL material (RGB or spectral) ready to evaluate.
#[derive(Debug, Clone)]
pub struct RglBrdf {
    ndf: Warp,
    sigma: Warp,
    vndf: Warp,
    values: Warp,
    kind: Kind,
    isotropic: bool,
    /// Measured incidences (radians), as the file lists them.
    pub theta_i: Vec<f64>,
    /// The file's `description` text.
    pub description: String,
}

impl RglBrdf {
    /// The material of a tensor file's fields: an RGB file (an `rgb` field) or a
    /// spectral one (`spectra` and `wavelengths`), with the fields and shapes the
    /// reference constructors require, else one line saying what is wrong.
    pub fn from_fields(f: &BTreeMap<String, Field>) -> Result<RglBrdf, String> {
        let spectral = !f.contains_key("rgb") && f.contains_key("spectra");
        let what = if spectral { "spectral" } else { "RGB" };
        let get = |name: &str, rank: usize| -> Result<&Field, String> {
            let field = f.get(name).ok_or_else(|| {
                format!("no '{name}' field: not an RGL {what} material (an RGB file has 'rgb', a spectral one 'spectra')")
            })?;
            if field.shape.len() != rank || field.dtype != 10 {
                return Err(format!(
                    "field '{name}' has shape {:?}, type {}: the reference reader wants rank {rank} f32",
                    field.shape, field.dtype
                ));
            }
            Ok(field)
        };
        let (theta_i, phi_i) = (get("theta_i", 1)?, get("phi_i", 1)?);
        let (ndf, sigma, vndf) = (get("ndf", 2)?, get("sigma", 2)?, get("vndf", 4)?);
        let values = get(if spectral { "spectra" } else { "rgb" }, 5)?;
        let (nt, np) = (theta_i.shape[0], phi_i.shape[0]);
        let (kind, third) = if spectral {
            let wl = get("wavelengths", 1)?;
            let nw = wl.shape[0];
            let s = &values.shape;
            let lum_ok = f.get("luminance").is_none_or(|l| {
                l.shape.len() == 4 && l.shape[..2] == [np, nt] && l.shape[2..] == s[3..]
            });
            if vndf.shape[..2] != [np, nt] || s[..3] != [np, nt, nw] || s[3] != s[4] || !lum_ok {
                return Err(format!(
                    "a spectral file whose fields do not match: vndf {:?}, spectra {s:?}, luminance {:?} for {np} phi_i x {nt} theta_i x {nw} wavelengths (the reference wants vndf [{np}, {nt}, .., ..], spectra [{np}, {nt}, {nw}, n, n], luminance [{np}, {nt}, n, n])",
                    vndf.shape,
                    f.get("luminance")
                        .map(|l| l.shape.clone())
                        .unwrap_or_default()
                ));
            }
            let w = &wl.values;
            if nw == 0 || w.windows(2).any(|p| p[1] <= p[0]) || w[0] <= 0.0 {
                return Err(format!(
                    "the file's {nw} wavelengths are not positive and increasing: a damaged file"
                ));
            }
            let kind = Kind::Spectral {
                wavelengths: w.clone(),
                y: y_weights(w),
            };
            (kind, w.clone())
        } else {
            let shapes_ok = vndf.shape[..2] == [np, nt] && values.shape[..3] == [np, nt, 3];
            if !shapes_ok {
                return Err(format!(
                    "vndf {:?} and rgb {:?} do not match {np} phi_i x {nt} theta_i (x 3 channels)",
                    vndf.shape, values.shape
                ));
            }
            (Kind::Rgb, vec![0.0, 1.0, 2.0])
        };
        if nt < 2 || np < 1 {
            return Err(format!(
                "{nt} incidences and {np} azimuths: the reference interpolates between at least 2 incidences"
            ));
        }
        let isotropic = np <= 2;
        if !isotropic {
            let span = phi_i.values[np - 1] - phi_i.values[0];
            if (2.0 * PI / span).round() != 1.0 {
                return Err("an anisotropic file with a reduced phi_i range: not supported by the reference reader".into());
            }
        }
        let params = vec![phi_i.values.clone(), theta_i.values.clone()];
        let description = f
            .get("description")
            .map(|d| {
                d.values
                    .iter()
                    .map(|&b| b as u8 as char)
                    .collect::<String>()
            })
            .unwrap_or_default();
        Ok(RglBrdf {
            ndf: Warp::new(ndf.shape[1], ndf.shape[0], &ndf.values, vec![], false)?,
            sigma: Warp::new(sigma.shape[1], sigma.shape[0], &sigma.values, vec![], false)?,
            vndf: Warp::new(
                vndf.shape[3],
                vndf.shape[2],
                &vndf.values,
                params.clone(),
                true,
            )?,
            values: Warp::new(
                values.shape[4],
                values.shape[3],
                &values.values,
                [params, vec![third]].concat(),
                false,
            )?,
            kind,
            isotropic,
            theta_i: theta_i.values.clone(),
            description,
        })
    }

    /// The file's wavelengths (nm) if it is spectral.
    pub fn wavelengths(&self) -> Option<&[f64]> {
        match &self.kind {
            Kind::Rgb => None,
            Kind::Spectral { wavelengths, .. } => Some(wavelengths),
        }
    }

    /// Whether the file has `channel`, else one line saying what it has: r, g, b for
    /// RGB files, a wavelength within the file's range for spectral ones, y for both
    /// (for a spectral file when its wavelengths span [`Y_MIN_SHARE`] of ybar).
    pub fn check(&self, channel: RglChannel) -> Result<(), String> {
        match (&self.kind, channel) {
            (Kind::Rgb, RglChannel::Nm(nm)) => Err(format!(
                "--wavelength {nm}: an RGB file has channels r, g, b and y, not wavelengths"
            )),
            (Kind::Rgb, _) => Ok(()),
            (Kind::Spectral { wavelengths: w, .. }, RglChannel::Nm(nm)) => {
                let (lo, hi) = (w[0], w[w.len() - 1]);
                if nm.is_finite() && nm >= lo && nm <= hi {
                    Ok(())
                } else {
                    Err(format!(
                        "--wavelength {nm}: outside the file's wavelengths {lo}..{hi} nm"
                    ))
                }
            }
            (Kind::Spectral { y, .. }, RglChannel::Y) => match y {
                Ok(_) => Ok(()),
                Err(why) => Err(format!("--channel y: {why}: choose --wavelength NM")),
            },
            (Kind::Spectral { wavelengths: w, .. }, c) => Err(format!(
                "--channel {}: a spectral file ({}..{} nm) has no r, g, b: choose --wavelength NM or --channel y",
                c.name(),
                w[0],
                w[w.len() - 1]
            )),
        }
    }

    /// The reference's `eval(wi, wo)` (f_r cos(theta_o)) for unit vectors toward the
    /// source and the detector, at each of `third`: channels 0, 1, 2 of an RGB file
    /// (clamped at zero as the reference: negative where spectra left the gamut), or
    /// wavelengths (nm) of a spectral one (not clamped, as the reference).
    fn eval_at(&self, wi: [f64; 3], wo: [f64; 3], third: &[f64]) -> Vec<f64> {
        if wi[2] <= 0.0 || wo[2] <= 0.0 {
            return vec![0.0; third.len()];
        }
        let h = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let len = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
        let wm = h.map(|x| x / len);
        let (t_i, p_i) = (wi[2].acos(), wi[1].atan2(wi[0]));
        let (t_m, p_m) = (wm[2].clamp(-1.0, 1.0).acos(), wm[1].atan2(wm[0]));
        let theta2u = |t: f64| (t * (2.0 / PI)).sqrt();
        let phi2u = |p: f64| (p + PI) / (2.0 * PI);
        let u_wi = (theta2u(t_i), phi2u(p_i));
        let uy = phi2u(if self.isotropic { p_m - p_i } else { p_m });
        let u_wm = (theta2u(t_m), uy - uy.floor());
        let params = [p_i, t_i];
        let sample = self.vndf.invert(u_wm, &params);
        let scale = self.ndf.eval(u_wm, &[]) / (4.0 * self.sigma.eval(u_wi, &[]));
        let clamp = matches!(self.kind, Kind::Rgb);
        third
            .iter()
            .map(|&c| {
                let v = self.values.eval(sample, &[p_i, t_i, c]);
                if clamp { v.max(0.0) } else { v }
            } * scale)
            .collect()
    }

    /// The reference's `eval(wi, wo)` (f_r cos(theta_o)) for unit vectors toward the
    /// source and the detector: R, G, B of an RGB file, or the spectrum at the file's
    /// wavelengths.
    pub fn eval(&self, wi: [f64; 3], wo: [f64; 3]) -> Vec<f64> {
        match &self.kind {
            Kind::Rgb => self.eval_at(wi, wo, &[0.0, 1.0, 2.0]),
            Kind::Spectral { wavelengths, .. } => self.eval_at(wi, wo, wavelengths),
        }
    }

    /// f_r (1/sr) of `channel` in the plane of incidence: theta_i and theta_r in
    /// degrees, theta_r signed positive on the specular side (wi = (sin theta_i, 0,
    /// cos theta_i), wo = (-sin theta_r, 0, cos theta_r)); 0 at or below the horizon.
    /// `channel` must pass [`RglBrdf::check`] (else this panics).
    pub fn in_plane(&self, channel: RglChannel, theta_i: f64, theta_r: f64) -> f64 {
        let (ti, tr) = (theta_i.to_radians(), theta_r.to_radians());
        let wo = [-tr.sin(), 0.0, tr.cos()];
        // cos(90 degrees) is 6e-17 in floating point, not 0: grazing exit is the horizon.
        if theta_r.abs() >= 90.0 || wo[2] <= 0.0 {
            return 0.0;
        }
        let wi = [ti.sin(), 0.0, ti.cos()];
        let dot = |v: Vec<f64>, w: &[f64]| v.iter().zip(w).map(|(a, b)| a * b).sum::<f64>();
        let v = match (&self.kind, channel) {
            (Kind::Spectral { .. }, RglChannel::Nm(nm)) => self.eval_at(wi, wo, &[nm])[0],
            (Kind::Spectral { wavelengths, y }, RglChannel::Y) => dot(
                self.eval_at(wi, wo, wavelengths),
                y.as_ref().expect("checked: the file spans ybar"),
            ),
            (Kind::Rgb, c) => {
                let rgb = self.eval_at(wi, wo, &[0.0, 1.0, 2.0]);
                match c {
                    RglChannel::R => rgb[0],
                    RglChannel::G => rgb[1],
                    RglChannel::B => rgb[2],
                    RglChannel::Y => dot(rgb, &[0.2126, 0.7152, 0.0722]),
                    RglChannel::Nm(_) => panic!("checked: an RGB file has no wavelengths"),
                }
            }
            (Kind::Spectral { .. }, c) => panic!("checked: a spectral file has no {}", c.name()),
        };
        v / wo[2]
    }
}

/// The weights of CIE 1931 Y over `wl` (nm, increasing): ybar(lambda_k) times the
/// trapezoid weight of lambda_k on the file's grid, normalised to sum 1 (the luminance
/// factor under an equal-energy illuminant: a flat spectrum gives its own value, as
/// Rec. 709 Y of a grey RGB value does). Refused, saying why, where the grid spans less
/// than [`Y_MIN_SHARE`] of ybar's integral, or integrates ybar over its span with an
/// error above [`Y_MAX_ERROR`].
fn y_weights(wl: &[f64]) -> Result<Vec<f64>, String> {
    let n = wl.len();
    let (lo, hi) = (wl[0], wl[n - 1]);
    let share = super::cie::ybar_share(lo, hi);
    if share < Y_MIN_SHARE {
        return Err(format!(
            "the file's wavelengths {lo}..{hi} nm span {:.1} % of the CIE 1931 ybar integral (Y needs {} %)",
            100.0 * share,
            100.0 * Y_MIN_SHARE
        ));
    }
    let w: Vec<f64> = (0..n)
        .map(|k| super::cie::ybar(wl[k]) * 0.5 * (wl[(k + 1).min(n - 1)] - wl[k.saturating_sub(1)]))
        .collect();
    let sum: f64 = w.iter().sum();
    let exact = super::cie::ybar_integral(lo, hi);
    let error = (sum / exact - 1.0).abs();
    if error.is_nan() || error > Y_MAX_ERROR {
        return Err(format!(
            "the file's {n} wavelengths {lo}..{hi} nm integrate the CIE 1931 ybar with an error of {:.1} % (the trapezoid rule on its grid; Y needs at most {} %)",
            100.0 * error.min(1.0),
            100.0 * Y_MAX_ERROR
        ));
    }
    Ok(w.iter().map(|x| x / sum).collect())
}

#[cfg(test)]
#[path = "rgl_tests.rs"]
mod tests;
