//! `gonio._gonio`: the Python extension over brdf-core and the gonio host library.
//! Python-facing classes and functions only; the model is brdf-core's ([`model`]), the
//! sweep files and the fitter the host library's ([`bind`]).
#![deny(missing_docs)]

pub mod bind;
pub mod model;

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use brdf_core::lobe::Distribution;
use brdf_core::member::{Component, KsForm, Member};
use brdf_core::model::{KDD_PAPER, KID_PAPER, SIGMA_M_PAPER};
use brdf_core::{ModelError, PRESETS, Preset};
use gonio::sweep_file::Row;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1};
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use model::{KsSrc, LobeDef, ModelDef};

create_exception!(
    _gonio,
    GonioError,
    PyValueError,
    "Bad input to the model, a sweep file or the fitter (the gonio command's message)."
);

fn err(e: impl ToString) -> PyErr {
    GonioError::new_err(e.to_string())
}

fn model_err(e: ModelError) -> PyErr {
    err(e)
}

/// A member of the BRDF model family with its parameters (brdf-core evaluates it).
#[pyclass(frozen, module = "gonio._gonio", name = "Model")]
pub struct PyModel {
    def: ModelDef,
}

/// A lobe's tail exponent `given` as keyword `name` (see `gonio::fit::paper::lobe_tail`).
fn tail(what: &str, name: &str, dist: Distribution, given: Option<f64>) -> PyResult<Option<f64>> {
    gonio::fit::paper::lobe_tail(what, &format!("{name}="), dist, given).map_err(err)
}

fn lobe_ks(what: &str, form: KsForm, ks: Option<&Bound<'_, PyAny>>) -> PyResult<KsSrc> {
    let ks = ks.ok_or_else(|| err(format!("{what} needs its k_s")))?;
    match form {
        KsForm::PerIncidence => {
            Ok(KsSrc::Const(ks.extract::<f64>().map_err(|_| {
                err(format!("{what}: k_s per incidence is one number"))
            })?))
        }
        KsForm::Smooth => {
            let c: Vec<f64> = ks.extract().map_err(|_| {
                err(format!("{what}: a smooth k_s is [c0, c1, c2] (ln k_s = c0 + c1 t + c2 t^2, t = theta_i/90)"))
            })?;
            let c: [f64; 3] = c
                .try_into()
                .map_err(|_| err(format!("{what}: a smooth k_s is [c0, c1, c2]")))?;
            Ok(KsSrc::Smooth(c))
        }
        KsForm::Fresnel => {
            let c: Vec<f64> = ks.extract().map_err(|_| {
                err(format!(
                    "{what}: a Fresnel k_s is [k0, n, k] (k_s = k0 F(beta; n, k))"
                ))
            })?;
            let c: [f64; 3] = c
                .try_into()
                .map_err(|_| err(format!("{what}: a Fresnel k_s is [k0, n, k]")))?;
            Ok(KsSrc::Fresnel(c))
        }
    }
}

/// Most values `Model.eval_grid` makes (theta_i x theta_r): 10^8 f64 are 800 MB. A
/// larger grid is refused before anything is allocated (10^5 x 10^6 angles asked for
/// 800 GB and aborted the interpreter).
const MAX_GRID_VALUES: usize = 100_000_000;

/// The number of values of a `ni` x `nr` grid, or the refusal of one too large.
fn grid_len(ni: usize, nr: usize) -> PyResult<usize> {
    match ni.checked_mul(nr) {
        Some(n) if n <= MAX_GRID_VALUES => Ok(n),
        _ => Err(err(format!(
            "eval_grid: {ni} x {nr} angles = {} values, more than {MAX_GRID_VALUES}: evaluate it in blocks of theta_i",
            ni as u128 * nr as u128
        ))),
    }
}

fn slice<'a, T: numpy::Element>(a: &'a PyReadonlyArray1<'_, T>, what: &str) -> PyResult<&'a [T]> {
    a.as_slice()
        .map_err(|_| err(format!("{what} must be a contiguous 1-D array")))
}

#[pymethods]
impl PyModel {
    /// Model(member, *, ks=None, sigma=None, gamma=None, ks_haze=None, sigma_haze=None,
    /// gamma_haze=None, kdd=900, sigma_m=0.7, kid=25): any member of the family by name
    /// (see `gonio.members()`). ks is a number (k_s per incidence) or [c0, c1, c2] for a
    /// ':smooth-ks' lobe; sigma, sigma_haze dimensionless, sigma_m in radians; gamma,
    /// gamma_haze the tail exponents (> 1) of ':student-t' lobes, required for them and
    /// refused for others; defaults are the paper's.
    #[new]
    #[pyo3(signature = (member, *, ks=None, sigma=None, gamma=None, ks_haze=None, sigma_haze=None, gamma_haze=None, kdd=None, sigma_m=None, kid=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        member: &str,
        ks: Option<&Bound<'_, PyAny>>,
        sigma: Option<f64>,
        gamma: Option<f64>,
        ks_haze: Option<&Bound<'_, PyAny>>,
        sigma_haze: Option<f64>,
        gamma_haze: Option<f64>,
        kdd: Option<f64>,
        sigma_m: Option<f64>,
        kid: Option<f64>,
    ) -> PyResult<Self> {
        let m = Member::parse(member).map_err(|e| err(format!("member '{member}': {e}")))?;
        if m.abg {
            return Err(err(
                "member 'abg': Model takes the paper family's parameters; an ABg model comes from a fit (models=['abg'])",
            ));
        }
        let absent = |given: bool, name: &str, comp: &str| -> PyResult<()> {
            if given {
                Err(err(format!(
                    "{name} belongs to {comp}, which {} does not have",
                    m
                )))
            } else {
                Ok(())
            }
        };
        let core = match m.core {
            Some(spec) => Some(LobeDef {
                dist: spec.dist,
                ks: lobe_ks("specular", spec.ks, ks)?,
                sigma: sigma.ok_or_else(|| err("specular needs sigma"))?,
                gamma: tail("specular", "gamma", spec.dist, gamma)?,
            }),
            None => {
                absent(
                    ks.is_some() || sigma.is_some() || gamma.is_some(),
                    "ks/sigma/gamma",
                    "specular",
                )?;
                None
            }
        };
        let haze = match m.haze {
            Some(spec) => Some(LobeDef {
                dist: spec.dist,
                ks: lobe_ks("specular-haze", spec.ks, ks_haze)?,
                sigma: sigma_haze.ok_or_else(|| err("specular-haze needs sigma_haze"))?,
                gamma: tail("specular-haze", "gamma_haze", spec.dist, gamma_haze)?,
            }),
            None => {
                absent(
                    ks_haze.is_some() || sigma_haze.is_some() || gamma_haze.is_some(),
                    "ks_haze/sigma_haze/gamma_haze",
                    "specular-haze",
                )?;
                None
            }
        };
        let directional = if m.directional {
            Some((kdd.unwrap_or(KDD_PAPER), sigma_m.unwrap_or(SIGMA_M_PAPER)))
        } else {
            absent(
                kdd.is_some() || sigma_m.is_some(),
                "kdd/sigma_m",
                "directional-diffuse",
            )?;
            None
        };
        let ideal = if m.ideal {
            Some(kid.unwrap_or(KID_PAPER))
        } else {
            absent(kid.is_some(), "kid", "ideal-diffuse")?;
            None
        };
        let def = ModelDef {
            core,
            haze,
            directional,
            ideal,
            abg: None,
            origin: "parameters".into(),
            to_per_sr: None,
        };
        def.at(0.0).map_err(model_err)?;
        Ok(PyModel { def })
    }

    /// The paper's three-component model of a preset (k_s(theta_i) from its table);
    /// sigma, kdd, sigma_m, kid override the preset's / paper's values.
    #[staticmethod]
    #[pyo3(signature = (name, *, sigma=None, kdd=None, sigma_m=None, kid=None))]
    fn preset(
        name: &str,
        sigma: Option<f64>,
        kdd: Option<f64>,
        sigma_m: Option<f64>,
        kid: Option<f64>,
    ) -> PyResult<Self> {
        let p = Preset::by_name(name).map_err(|e| err(format!("preset '{name}': {e}")))?;
        let def = model::preset_def(p, sigma, kdd, sigma_m, kid);
        def.at(0.0).map_err(model_err)?;
        Ok(PyModel { def })
    }

    /// A model saved by `gonio fit --export mitsuba=DIR` (its model.json): any member,
    /// with the file's units (`to_per_sr`).
    #[staticmethod]
    fn load(path: PathBuf) -> PyResult<Self> {
        let table = bind::load_table(&path).map_err(err)?;
        let def = model::table_def(table, format!("loaded from {}", path.display()));
        def.at(0.0).map_err(model_err)?;
        Ok(PyModel { def })
    }

    /// The factor from the model's BRDF unit to 1/sr, or None for relative units (a
    /// preset, a fit of relative data): such a model has no absolute scale.
    #[getter]
    fn to_per_sr(&self) -> Option<f64> {
        self.def.to_per_sr
    }

    /// The member's name, e.g. 'three-component' or 'specular:ggx+ideal-diffuse'.
    #[getter]
    fn member(&self) -> String {
        self.def.member().to_string()
    }

    /// The components that are on, in vocabulary order.
    #[getter]
    fn components(&self) -> Vec<&'static str> {
        self.def
            .member()
            .components()
            .map(Component::name)
            .collect()
    }

    /// The parameters as a dict (k_s: a number, [c0, c1, c2] for a smooth k_s, [k0, n, k]
    /// for a Fresnel k_s, or
    /// 'table' for a preset's / fit's per-incidence values: see `ks_at`).
    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        let lobe = |pre: &str, l: &LobeDef| -> PyResult<()> {
            d.set_item(format!("{pre}dist"), l.dist.name())?;
            d.set_item(format!("{pre}sigma"), l.sigma)?;
            if let Some(g) = l.gamma {
                d.set_item(format!("{pre}gamma"), g)?;
            }
            match &l.ks {
                KsSrc::Const(k) => d.set_item(format!("{pre}ks"), k),
                KsSrc::Smooth(c) | KsSrc::Fresnel(c) => d.set_item(format!("{pre}ks"), c.to_vec()),
                KsSrc::Preset(p) => {
                    d.set_item(format!("{pre}ks"), format!("table of preset {}", p.name))
                }
                KsSrc::Table(_) => d.set_item(format!("{pre}ks"), "table of the fit"),
            }
        };
        if let Some(l) = &self.def.core {
            lobe("", l)?;
        }
        if let Some(l) = &self.def.haze {
            lobe("haze_", l)?;
        }
        if let Some((kdd, sm)) = self.def.directional {
            d.set_item("kdd", kdd)?;
            d.set_item("sigma_m", sm)?;
        }
        if let Some(k) = self.def.ideal {
            d.set_item("kid", k)?;
        }
        Ok(d)
    }

    /// k_s of the core lobe (0: the haze) at incidence theta_i (degrees).
    #[pyo3(signature = (theta_i, haze=false))]
    fn ks_at(&self, theta_i: f64, haze: bool) -> PyResult<f64> {
        let l = if haze { &self.def.haze } else { &self.def.core };
        let l = l
            .as_ref()
            .ok_or_else(|| err("this member has no such lobe"))?;
        let m = self.def.at(theta_i).map_err(model_err)?;
        let a = m.amplitudes();
        match l.ks {
            KsSrc::Smooth(c) => brdf_core::lobe::SmoothKs { c }
                .ks(theta_i)
                .map_err(model_err),
            // On the mirror direction the facet's angle is theta_i.
            KsSrc::Fresnel(c) => Ok(brdf_core::member_model::FresnelKs {
                k0: c[0],
                n: c[1],
                k: c[2],
            }
            .ks(theta_i.to_radians().cos())),
            _ => Ok(if haze { a.haze } else { a.core }),
        }
    }

    /// The same parameters with only one component on ('specular', 'specular-haze',
    /// 'directional-diffuse', 'ideal-diffuse'; a haze keeps its core lobe at k_s = 0).
    fn component(&self, name: &str) -> PyResult<Self> {
        let c =
            Component::parse(name).ok_or_else(|| err(format!("component '{name}': unknown")))?;
        let def = self
            .def
            .only(c)
            .ok_or_else(|| err(format!("{} has no {name}", self.def.member())))?;
        Ok(PyModel { def })
    }

    /// Exact f64 in-plane evaluation of paired 1-D float64 arrays (degrees; theta_i in
    /// [0, 90], theta_r signed in [-90, 90]). Releases the GIL.
    fn _eval_f64<'py>(
        &self,
        py: Python<'py>,
        theta_i: PyReadonlyArray1<'py, f64>,
        theta_r: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let (a, b) = (slice(&theta_i, "theta_i")?, slice(&theta_r, "theta_r")?);
        let out = py.detach(|| {
            let mut out = vec![0.0; a.len()];
            self.def.eval_in_plane(a, b, &mut out).map(|_| out)
        });
        Ok(out.map_err(model_err)?.into_pyarray(py))
    }

    /// Fast f32 in-plane evaluation of paired 1-D float32 arrays. Releases the GIL.
    fn _eval_f32<'py>(
        &self,
        py: Python<'py>,
        theta_i: PyReadonlyArray1<'py, f32>,
        theta_r: PyReadonlyArray1<'py, f32>,
    ) -> PyResult<Bound<'py, PyArray1<f32>>> {
        let (a, b) = (slice(&theta_i, "theta_i")?, slice(&theta_r, "theta_r")?);
        let out = py.detach(|| {
            let mut out = vec![0.0; a.len()];
            self.def.eval_fast(a, b, &mut out).map(|_| out)
        });
        Ok(out.map_err(err)?.into_pyarray(py))
    }

    /// f64 grid (len(theta_i), len(theta_r)). Releases the GIL.
    fn _grid_f64<'py>(
        &self,
        py: Python<'py>,
        theta_i: PyReadonlyArray1<'py, f64>,
        theta_r: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let (a, b) = (slice(&theta_i, "theta_i")?, slice(&theta_r, "theta_r")?);
        let n = grid_len(a.len(), b.len())?;
        let out = py.detach(|| {
            let mut out = vec![0.0; n];
            self.def.grid(a, b, &mut out).map(|_| out)
        });
        let flat = out.map_err(model_err)?.into_pyarray(py);
        flat.reshape([a.len(), b.len()])
    }

    /// f32 grid by brdf-core's batch path (`FastModel::eval_grid`). Releases the GIL.
    fn _grid_f32<'py>(
        &self,
        py: Python<'py>,
        theta_i: PyReadonlyArray1<'py, f32>,
        theta_r: PyReadonlyArray1<'py, f32>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let (a, b) = (slice(&theta_i, "theta_i")?, slice(&theta_r, "theta_r")?);
        let n = grid_len(a.len(), b.len())?;
        let out = py.detach(|| {
            let mut out = vec![0.0; n];
            self.def.grid_fast(a, b, &mut out).map(|_| out)
        });
        let flat = out.map_err(err)?.into_pyarray(py);
        flat.reshape([a.len(), b.len()])
    }

    /// The Rust batch paths timed in Rust, on Rust vectors (copies of the arrays made
    /// before the clock starts; no numpy, no Python, one thread like the Python call):
    /// the fastest of `repeats` runs, in seconds, of the f32 grid (`kind = 'grid'`,
    /// the same function as `_grid_f32`) or of the f32 pairs (`'pairs'`, the same
    /// function as `_eval_f32`), into an output allocated and written once before. For
    /// the benchmark.
    fn _time_f32_rust(
        &self,
        py: Python<'_>,
        kind: &str,
        theta_i: PyReadonlyArray1<'_, f32>,
        theta_r: PyReadonlyArray1<'_, f32>,
        repeats: usize,
    ) -> PyResult<f64> {
        let ti = slice(&theta_i, "theta_i")?.to_vec();
        let tr = slice(&theta_r, "theta_r")?.to_vec();
        type Run = fn(&ModelDef, &[f32], &[f32], &mut [f32]) -> Result<(), String>;
        let (n, run): (usize, Run) = match kind {
            "grid" => (grid_len(ti.len(), tr.len())?, ModelDef::grid_fast),
            "pairs" if ti.len() == tr.len() => (ti.len(), ModelDef::eval_fast),
            _ => return Err(err("kind is 'grid', or 'pairs' of equal lengths")),
        };
        py.detach(|| {
            let mut out = vec![0.0f32; n];
            // Once untimed: the output's pages are touched before the clock starts.
            run(&self.def, &ti, &tr, &mut out)?;
            let mut best = f64::INFINITY;
            for _ in 0..repeats.max(1) {
                let t0 = Instant::now();
                run(&self.def, &ti, &tr, &mut out)?;
                std::hint::black_box(&out);
                best = best.min(t0.elapsed().as_secs_f64());
            }
            Ok::<f64, String>(best)
        })
        .map_err(err)
    }

    /// f64 evaluation for flattened (n, 3) float64 arrays of unit vectors (z along the
    /// normal; w_i towards the source, w_r towards the detector). Releases the GIL.
    fn _eval_vectors<'py>(
        &self,
        py: Python<'py>,
        w_i: PyReadonlyArray1<'py, f64>,
        w_r: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let (a, b) = (slice(&w_i, "w_i")?, slice(&w_r, "w_r")?);
        if a.len() % 3 != 0 || a.len() != b.len() {
            return Err(err(
                "w_i and w_r must be arrays of 3-vectors of the same shape",
            ));
        }
        let out = py.detach(|| {
            a.chunks_exact(3)
                .zip(b.chunks_exact(3))
                .map(|(x, y)| self.def.eval_dir([x[0], x[1], x[2]], [y[0], y[1], y[2]]))
                .collect::<Result<Vec<f64>, _>>()
        });
        Ok(out.map_err(model_err)?.into_pyarray(py))
    }

    /// f64 value for one pair of unit vectors given as 3-tuples (no numpy: for a
    /// renderer calling once per ray).
    fn eval_dir(&self, w_i: (f64, f64, f64), w_r: (f64, f64, f64)) -> PyResult<f64> {
        self.def
            .eval_dir([w_i.0, w_i.1, w_i.2], [w_r.0, w_r.1, w_r.2])
            .map_err(model_err)
    }

    /// Directional albedo by brdf-core's quadrature at polar angle theta (degrees):
    /// (rho, error bound), rho = integral of f cos theta_r over the detector hemisphere;
    /// with reverse=True the integral over the source hemisphere for a detector at
    /// theta (what a renderer tracing from the camera integrates).
    #[pyo3(signature = (theta, reverse=false))]
    fn albedo(&self, py: Python<'_>, theta: f64, reverse: bool) -> PyResult<(f64, f64)> {
        py.detach(|| self.def.albedo(theta, reverse))
            .map_err(model_err)
    }

    /// Appearance figures (docs/appearance.md) as the JSON of `gonio appearance`'s
    /// `appearance` object; `scale`: 1/sr per unit of a relative-unit model. Releases
    /// the GIL.
    #[pyo3(signature = (scale=None))]
    fn _appearance_json(&self, py: Python<'_>, scale: Option<f64>) -> PyResult<String> {
        let to = match (self.def.to_per_sr, scale) {
            (Some(_), Some(_)) => {
                return Err(err("scale: the model is already in 1/sr: leave scale out"));
            }
            (Some(t), None) => t,
            (None, Some(s)) if s.is_finite() && s > 0.0 => s,
            (None, Some(s)) => {
                return Err(err(format!(
                    "scale {s}: 1/sr per unit of the model, a finite number above 0"
                )));
            }
            (None, None) => {
                return Err(err(
                    "gloss, haze and DOI need the BRDF in 1/sr but this model is in relative units: give scale (1/sr per unit)",
                ));
            }
        };
        let def = &self.def;
        let model_at = |t: f64| def.at(t);
        let a = py
            .detach(|| {
                gonio::appearance::appearance(&gonio::appearance::Surface::model(&model_at, to))
            })
            .map_err(model_err)?;
        Ok(a.json().to_string())
    }

    fn __repr__(&self) -> String {
        format!("gonio.Model('{}', {})", self.def.member(), self.def.origin)
    }
}

/// The paper's material presets: a list of dicts (name, metal, sigma, ks_table at
/// theta_i = 0, 10, ..., 80 degrees).
#[pyfunction]
fn presets(py: Python<'_>) -> PyResult<Bound<'_, PyList>> {
    let l = PyList::empty(py);
    for p in &PRESETS {
        let d = PyDict::new(py);
        d.set_item("name", p.name)?;
        d.set_item("metal", p.metal)?;
        d.set_item("sigma", p.sigma)?;
        d.set_item("ks_table", p.ks_table.to_vec())?;
        l.append(d)?;
    }
    Ok(l)
}

/// The names of every member of the family (the fitter's lattice, 83 of them).
#[pyfunction]
fn members() -> Vec<String> {
    Member::lattice().map(|m| m.to_string()).collect()
}

/// The canonical name of a member name (raises on a bad name, with the CLI's message).
#[pyfunction]
fn member_name(name: &str) -> PyResult<String> {
    Member::parse(name)
        .map(|m| m.to_string())
        .map_err(|e| err(format!("member '{name}': {e}")))
}

/// The vocabulary: component names and distribution names.
#[pyfunction]
fn vocabulary() -> (Vec<&'static str>, Vec<&'static str>) {
    (
        Component::ALL.iter().map(|c| c.name()).collect(),
        [Distribution::Beckmann, Distribution::Ggx]
            .iter()
            .map(|d| d.name())
            .collect(),
    )
}

/// Reads a sweep file: (meta dict, columns, rows as an (n, 7) float64 array of
/// theta_i, theta_r, brdf, std, n, seq, t_ms with NaN where a column is empty,
/// plan points as an (m, 2) float64 array).
#[pyfunction]
#[allow(clippy::type_complexity)]
fn _read_sweep<'py>(
    py: Python<'py>,
    path: PathBuf,
) -> PyResult<(
    Bound<'py, PyDict>,
    Vec<String>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
)> {
    let s = py.detach(|| bind::read_sweep(&path)).map_err(err)?;
    let meta = PyDict::new(py);
    for (k, v) in &s.meta {
        meta.set_item(k, v)?;
    }
    let nan = f64::NAN;
    let rows: Vec<f64> = s
        .rows
        .iter()
        .flat_map(|r| {
            [
                r.theta_i,
                r.theta_r,
                r.brdf,
                r.std.unwrap_or(nan),
                r.n.map_or(nan, f64::from),
                r.seq.map_or(nan, f64::from),
                r.t_ms.map_or(nan, |t| t as f64),
            ]
        })
        .collect();
    let points: Vec<f64> = s
        .points
        .iter()
        .flat_map(|&(a, b)| [a as f64, b as f64])
        .collect();
    let (nr, np) = (s.rows.len(), s.points.len());
    Ok((
        meta,
        s.columns,
        rows.into_pyarray(py).reshape([nr, 7])?,
        points.into_pyarray(py).reshape([np, 2])?,
    ))
}

/// Writes a complete sweep file of (theta_i, theta_r, brdf) readings with the capture's
/// writer; refuses to overwrite unless force.
#[pyfunction]
#[pyo3(signature = (path, theta_i, theta_r, brdf, device, plan, settings, force))]
#[allow(clippy::too_many_arguments)]
fn _write_sweep(
    py: Python<'_>,
    path: PathBuf,
    theta_i: PyReadonlyArray1<'_, f64>,
    theta_r: PyReadonlyArray1<'_, f64>,
    brdf: PyReadonlyArray1<'_, f64>,
    device: &str,
    plan: &str,
    settings: &str,
    force: bool,
) -> PyResult<()> {
    let (a, b, c) = (
        slice(&theta_i, "theta_i")?,
        slice(&theta_r, "theta_r")?,
        slice(&brdf, "brdf")?,
    );
    if a.len() != b.len() || a.len() != c.len() {
        return Err(err("theta_i, theta_r and brdf must have the same length"));
    }
    let rows: Vec<_> = (0..a.len()).map(|k| Row::new(a[k], b[k], c[k])).collect();
    py.detach(|| bind::write_sweep(&path, &rows, device, plan, settings, force))
        .map_err(err)
}

/// A finished fit of the model family (see `gonio.fit`).
#[pyclass(frozen, module = "gonio._gonio", name = "FitResult")]
pub struct PyFit {
    outcome: Arc<bind::FitOutcome>,
}

#[pymethods]
impl PyFit {
    /// The model the data support (lowest AICc).
    #[getter]
    fn selected(&self) -> String {
        bind::model_names(&self.outcome).1
    }

    /// The models fitted, simplest first.
    #[getter]
    fn model_names(&self) -> Vec<String> {
        bind::model_names(&self.outcome).0
    }

    /// The data's incidence angles (degrees).
    #[getter]
    fn incidences(&self) -> Vec<f64> {
        self.outcome.data.incidences.clone()
    }

    /// The `gonio fit --json` text (the CLI's writer).
    fn to_json(&self) -> String {
        bind::to_json(&self.outcome)
    }

    /// Per reading: an (n, 5) array of theta_i, theta_r, measured, fitted, residual (of
    /// the kind minimised) for a model (the selected one by default).
    #[pyo3(signature = (name=None))]
    fn _residuals<'py>(
        &self,
        py: Python<'py>,
        name: Option<&str>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let fit = bind::get_fit(&self.outcome, name).map_err(err)?;
        let r = bind::residuals(&self.outcome, fit);
        let n = r.len();
        let flat: Vec<f64> = r.into_iter().flatten().collect();
        flat.into_pyarray(py).reshape([n, 5])
    }

    /// The fitted model (the selected one by default) as a `gonio.Model`: any member
    /// the family fitted, built from its parameters per incidence.
    #[pyo3(signature = (name=None))]
    fn model(&self, name: Option<&str>) -> PyResult<PyModel> {
        let (table, name) = bind::fitted_table(&self.outcome, name).map_err(err)?;
        let def = model::table_def(table, format!("fitted {name}"));
        def.at(0.0).map_err(model_err)?;
        Ok(PyModel { def })
    }

    /// Writes `gonio fit --export mitsuba=DIR` for a fitted model (the selected one by
    /// default): the plugin, model.json and the sphere scene. to_per_sr: the factor
    /// from the data's BRDF unit to 1/sr (an instrument calibration; None: relative).
    #[pyo3(signature = (dir, name=None, force=false, to_per_sr=None))]
    fn export_mitsuba(
        &self,
        py: Python<'_>,
        dir: PathBuf,
        name: Option<&str>,
        force: bool,
        to_per_sr: Option<f64>,
    ) -> PyResult<()> {
        py.detach(|| bind::export_mitsuba(&self.outcome, name, &dir, force, to_per_sr))
            .map_err(err)
    }
}

/// Fits the model family with `gonio fit`'s options: a sweep file path, or rows
/// (theta_i, theta_r, brdf arrays) when path is None; aperture in degrees (None: the
/// file's line), instrument an instrument file (None: relative units), floor `auto` or
/// a value (None: every reading fitted), all_starts `--all-starts`, offset `--offset`:
/// `fit` or a detector zero offset in degrees (None: the file's `# offset:` line),
/// keep_saturated `--keep-saturated`.
#[pyfunction]
#[pyo3(signature = (path, theta_i, theta_r, brdf, residual, loss, fix, models, aperture=None, instrument=None, floor=None, all_starts=false, offset=None, keep_saturated=false))]
#[allow(clippy::too_many_arguments)]
fn _fit(
    py: Python<'_>,
    path: Option<PathBuf>,
    theta_i: Vec<f64>,
    theta_r: Vec<f64>,
    brdf: Vec<f64>,
    residual: String,
    loss: String,
    fix: Vec<String>,
    models: Vec<String>,
    aperture: Option<f64>,
    instrument: Option<PathBuf>,
    floor: Option<String>,
    all_starts: bool,
    offset: Option<String>,
    keep_saturated: bool,
) -> PyResult<PyFit> {
    if theta_i.len() != theta_r.len() || theta_i.len() != brdf.len() {
        return Err(err("theta_i, theta_r and brdf must have the same length"));
    }
    let rows: Vec<_> = (0..theta_i.len())
        .map(|k| Row::new(theta_i[k], theta_r[k], brdf[k]))
        .collect();
    let req = bind::FitRequest {
        residual: &residual,
        loss: &loss,
        fix,
        models,
        aperture,
        instrument: instrument.as_deref(),
        floor: floor.as_deref(),
        all_starts,
        offset: offset.as_deref(),
        keep_saturated,
    };
    let outcome = py
        .detach(|| bind::fit(path.as_deref(), &rows, &req))
        .map_err(err)?;
    Ok(PyFit {
        outcome: Arc::new(outcome),
    })
}

/// Refuses more readings than one fit takes (`gonio::fit::data::MAX_FIT_READINGS`, the
/// CLI's limit), with the CLI's message: called by `gonio.fit` before its arrays are
/// converted.
#[pyfunction]
fn _check_fit_readings(n: usize) -> PyResult<()> {
    gonio::fit::data::check_reading_count(n).map_err(err)
}

/// The extension module.
#[pymodule]
fn _gonio(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("GonioError", m.py().get_type::<GonioError>())?;
    m.add_class::<PyModel>()?;
    m.add_class::<PyFit>()?;
    m.add_function(wrap_pyfunction!(presets, m)?)?;
    m.add_function(wrap_pyfunction!(members, m)?)?;
    m.add_function(wrap_pyfunction!(member_name, m)?)?;
    m.add_function(wrap_pyfunction!(vocabulary, m)?)?;
    m.add_function(wrap_pyfunction!(_read_sweep, m)?)?;
    m.add_function(wrap_pyfunction!(_write_sweep, m)?)?;
    m.add_function(wrap_pyfunction!(_fit, m)?)?;
    m.add_function(wrap_pyfunction!(_check_fit_readings, m)?)?;
    m.add("MAX_FIT_READINGS", gonio::fit::data::MAX_FIT_READINGS)?;
    Ok(())
}
