"""gonio from Python: the BRDF model family for metals (Wang et al. 2016 and its
component family), sweep files and the fitter, all computed by the same Rust core as the
``gonio`` command (brdf-core and the gonio host library, through ``gonio._gonio``).

Units as everywhere in gonio: angles in degrees (theta_i in [0, 90], theta_r signed in
[-90, 90], positive on the specular side), sigma_m in radians, BRDF in the paper's
relative units (1/sr up to the instrument's scale).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from typing import Iterable, Mapping, Optional, Sequence, Union

import numpy as np

from . import _gonio
from ._gonio import MAX_FIT_READINGS, GonioError, member_name, members, presets, vocabulary

__all__ = [
    "MAX_FIT_READINGS",
    "GonioError",
    "Model",
    "FitResult",
    "Sweep",
    "fit",
    "member_name",
    "members",
    "presets",
    "vocabulary",
    "read_sweep",
    "write_sweep",
]

_PRECISIONS = {"f64": np.float64, "f32": np.float32}


def _dtype(precision: str):
    try:
        return _PRECISIONS[precision]
    except KeyError:
        raise GonioError(f"precision '{precision}': use 'f64' or 'f32'") from None


def _flat(x, dtype):
    return np.ascontiguousarray(x, dtype=dtype).reshape(-1)


def _readings(what, theta_i, theta_r, brdf):
    """The three arrays of readings as flat float64 arrays, one reading per element:
    their shapes must be the same. Nothing is broadcast: a column against a row would
    make n x n readings that were never measured."""
    arrays = [np.asarray(a, dtype=np.float64) for a in (theta_i, theta_r, brdf)]
    shapes = [a.shape for a in arrays]
    if shapes[1:] != shapes[:1] * 2:
        raise GonioError(
            f"{what}: theta_i, theta_r and brdf have shapes {shapes[0]}, {shapes[1]} and {shapes[2]}: "
            "one reading per element, so the three shapes must be the same (nothing is broadcast)")
    return [np.ascontiguousarray(a).reshape(-1) for a in arrays]


def _shaped(out, shape):
    out = out.reshape(shape)
    return out[()] if out.ndim == 0 else out


class Model:
    """A member of the model family with its parameters.

    ``Model(member, *, ks, sigma, gamma, ks_haze, sigma_haze, gamma_haze, kdd=900,
    sigma_m=0.7, kid=25)`` takes any name of ``gonio.members()`` (e.g.
    ``'three-component'``, ``'specular:student-t+specular-haze:ggx+ideal-diffuse'``);
    ``ks`` is a number (k_s per incidence) or ``[c0, c1, c2]`` for a ``:smooth-ks`` lobe;
    ``gamma`` (``gamma_haze``) is a ``:student-t`` lobe's tail exponent (> 1), required
    for one and refused for others.
    ``Model.preset('fe-0.115')`` is the paper's model of a preset, k_s(theta_i) from its
    table. Bad parameters raise :class:`GonioError` with brdf-core's message.
    """

    __slots__ = ("_m",)

    def __init__(self, member: str, **params):
        self._m = _gonio.Model(member, **params)

    @classmethod
    def _wrap(cls, raw) -> "Model":
        m = cls.__new__(cls)
        m._m = raw
        return m

    @classmethod
    def preset(cls, name: str, **overrides) -> "Model":
        """The paper's three-component model of a preset (``gonio.presets()``)."""
        return cls._wrap(_gonio.Model.preset(name, **overrides))

    @classmethod
    def load(cls, path: Union[str, os.PathLike]) -> "Model":
        """A model saved by ``gonio fit --export mitsuba=DIR`` (``DIR/model.json``): any
        member of the family, with the file's units (``to_per_sr``)."""
        return cls._wrap(_gonio.Model.load(os.fspath(path)))

    @property
    def member(self) -> str:
        """The member's canonical name."""
        return self._m.member

    @property
    def to_per_sr(self) -> Optional[float]:
        """The factor from the model's BRDF unit to 1/sr, or None for relative units (a
        preset, a fit of data in the instrument's units): such a model has no absolute
        scale."""
        return self._m.to_per_sr

    @property
    def components(self) -> list:
        """The components that are on."""
        return self._m.components

    @property
    def params(self) -> dict:
        """The parameters (see ``Model``)."""
        return self._m.params

    def ks_at(self, theta_i: float, haze: bool = False) -> float:
        """k_s of the core (or haze) lobe at incidence theta_i (degrees)."""
        return self._m.ks_at(theta_i, haze)

    def component(self, name: str) -> "Model":
        """The same parameters with only one component on."""
        return Model._wrap(self._m.component(name))

    def eval(self, theta_i, theta_r, precision: str = "f64"):
        """The BRDF in the plane of incidence, over numpy arrays of any (broadcast)
        shape: ``precision='f64'`` is the exact path, ``'f32'`` brdf-core's fast path
        (relative error < 1e-5 for |theta| <= 85 degrees). Returns a float for scalars."""
        dt = _dtype(precision)
        ti, tr = np.broadcast_arrays(np.asarray(theta_i, dtype=dt), np.asarray(theta_r, dtype=dt))
        f = self._m._eval_f64 if dt is np.float64 else self._m._eval_f32
        return _shaped(f(_flat(ti, dt), _flat(tr, dt)), ti.shape)

    def eval_grid(self, theta_i, theta_r, precision: str = "f64"):
        """The BRDF on the grid theta_i x theta_r (1-D arrays), shape
        (len(theta_i), len(theta_r)); with ``'f32'`` brdf-core's batch path
        (``FastModel::eval_grid``)."""
        dt = _dtype(precision)
        f = self._m._grid_f64 if dt is np.float64 else self._m._grid_f32
        return f(_flat(theta_i, dt), _flat(theta_r, dt))

    def eval_vectors(self, w_i, w_r):
        """The BRDF for unit vectors (arrays of shape (..., 3), z along the mean normal;
        w_i towards the source, w_r towards the detector; k_s at the polar angle of
        w_i)."""
        a, b = np.broadcast_arrays(np.asarray(w_i, dtype=np.float64), np.asarray(w_r, dtype=np.float64))
        if a.shape[-1:] != (3,):
            raise GonioError("w_i and w_r must have a last axis of length 3")
        return _shaped(self._m._eval_vectors(_flat(a, np.float64), _flat(b, np.float64)), a.shape[:-1])

    def eval_dir(self, w_i, w_r) -> float:
        """One value for two 3-tuples (no numpy; for per-ray callers)."""
        return self._m.eval_dir(tuple(w_i), tuple(w_r))

    def albedo(self, theta: float, reverse: bool = False):
        """Directional albedo by brdf-core's quadrature: ``(rho, error_bound)``; see
        ``brdf_core::albedo``. ``reverse=True`` integrates over the source hemisphere for
        a detector at theta."""
        return self._m.albedo(theta, reverse)

    def appearance(self, scale: Optional[float] = None) -> dict:
        """Gloss at 20, 60 and 85 degrees (ISO 2813 / ASTM D523, gloss units against the
        black glass of index 1.567), the ASTM D4039 haze index and ASTM E430's gloss, haze
        and DOI, each with its quadrature error, as ``gonio appearance --json`` gives them
        (docs/appearance.md). Needs the model in 1/sr (``to_per_sr``) or ``scale`` (1/sr per
        unit of a relative model)."""
        return json.loads(self._m._appearance_json(scale))

    def __repr__(self) -> str:
        return repr(self._m)


@dataclass
class Sweep:
    """A sweep file's contents. Optional columns are NaN where the file has no value."""

    meta: dict
    columns: list
    theta_i: np.ndarray
    theta_r: np.ndarray
    brdf: np.ndarray
    std: np.ndarray
    n: np.ndarray
    seq: np.ndarray
    t_ms: np.ndarray
    points: np.ndarray


def read_sweep(path: Union[str, os.PathLike]) -> Sweep:
    """Reads a sweep file (the ``gonio`` reader: same checks, same messages)."""
    meta, columns, rows, points = _gonio._read_sweep(os.fspath(path))
    cols = [rows[:, k].copy() for k in range(7)]
    return Sweep(meta, columns, *cols, points)


def write_sweep(path, theta_i, theta_r, brdf, *, device: str = "python", plan: str = "custom",
                settings: str = "", force: bool = False) -> None:
    """Writes a complete sweep file with the capture's writer (refuses to overwrite an
    existing file unless ``force``). The three arrays hold one reading per element:
    their shapes must be the same (nothing is broadcast)."""
    ti, tr, y = _readings("write_sweep", theta_i, theta_r, brdf)
    _gonio._write_sweep(os.fspath(path), ti, tr, y, device, plan, settings, force)


@dataclass
class ModelFit:
    """One fitted model, as ``gonio fit --json`` reports it."""

    name: str
    params: dict
    std_errors: dict
    aicc: float
    bic: float
    rmse: Optional[float]
    rmse_by_theta_i: list
    n: int
    k: int
    ssr: float
    converged: bool
    correlations: Optional[dict]  # {"names": [...], "matrix": [[...]]} of the fitted coordinates
    fixed: Optional[list] = None  # parameters held fixed (fix=...), None when none


class FitResult:
    """The model family fitted to a sweep (``gonio.fit``)."""

    def __init__(self, raw):
        self._r = raw
        self._json = json.loads(raw.to_json())
        self.models = {
            m["name"]: ModelFit(**{k: m.get(k) for k in ModelFit.__dataclass_fields__})
            for m in self._json["models"]
        }

    @property
    def selected(self) -> str:
        """The model the data support (lowest AICc)."""
        return self._r.selected

    @property
    def model_names(self) -> list:
        """Every fitted model's name (for ``model(name)``), simplest first; a member
        with a haze lobe the data support last."""
        return self._r.model_names

    @property
    def notes(self) -> list:
        """What the data support, what could not be fitted."""
        return self._json["notes"]

    @property
    def incidences(self) -> list:
        """The data's incidence angles (degrees)."""
        return self._r.incidences

    def __getitem__(self, name: str) -> ModelFit:
        return self.models[name]

    @property
    def best(self) -> ModelFit:
        """The selected model's fit."""
        return self.models[self.selected]

    def residuals(self, name: Optional[str] = None) -> dict:
        """Per reading, for a model (the selected one by default): arrays theta_i,
        theta_r, measured, fitted and residual (of the kind minimised, signed measured
        against fitted: ln(measured / fitted) for log)."""
        r = self._r._residuals(name)
        return {k: r[:, j].copy() for j, k in enumerate(("theta_i", "theta_r", "measured", "fitted", "residual"))}

    def model(self, name: Optional[str] = None) -> Model:
        """A fitted model (any member the family fitted: ``model_names``) as a
        :class:`Model` (evaluate it anywhere)."""
        return Model._wrap(self._r.model(name))

    def to_json(self) -> str:
        """Exactly what ``gonio fit --json`` prints."""
        return self._r.to_json()

    def export_mitsuba(self, dir: Union[str, os.PathLike], name: Optional[str] = None, *,
                       to_per_sr: Optional[float] = None, force: bool = False) -> None:
        """What ``gonio fit --export mitsuba=DIR`` writes, for a fitted model (the selected
        one by default): the plugin ``gonio_bsdf.py``, ``model.json`` and ``sphere.xml``.
        ``to_per_sr`` is the instrument's factor from the data's BRDF unit to 1/sr (None:
        relative units, rendered only with an explicit or display scale)."""
        self._r.export_mitsuba(os.fspath(dir), name, force, to_per_sr)

    def __repr__(self) -> str:
        return f"gonio.FitResult(selected={self.selected!r}, models={list(self.models)})"


def fit(source, theta_r=None, brdf=None, *, residual: str = "noise", loss: str = "l2",
        fix: Union[None, Mapping[str, float], Iterable[str]] = None,
        models: Union[None, str, Sequence[str]] = None, aperture: Optional[float] = None,
        instrument: Union[None, str, os.PathLike] = None,
        floor: Union[None, str, float] = None, all_starts: bool = False,
        offset: Union[None, str, float] = None, keep_saturated: bool = False) -> FitResult:
    """Fits the model family like ``gonio fit`` fits one sweep.

    ``source`` is a sweep file path, or the theta_i array with ``theta_r`` and ``brdf``
    (one reading per element: the three shapes must be the same, nothing is broadcast).
    Options as on the command line: ``residual`` noise (the default) | log | rel | abs; ``loss`` l2 |
    huber:C | cauchy:C; ``fix`` {'sigma_m': 0.7} or ['sigma_m=0.7']; ``models`` any
    names ``--models`` takes (ideal, ts, three, three-smooth or systematic member names;
    list or comma-separated); ``aperture`` the detector's acceptance half-angle in
    degrees (0 turns off the sweep's ``# aperture:`` line); ``instrument`` an instrument
    file of ``gonio calibrate`` (the readings are fitted in 1/sr); ``floor`` ``"auto"``
    or a value in the data's units: readings at or below a detection floor are left out
    (``"auto"``: the smallest value when at least 3 readings repeat it exactly);
    ``all_starts`` refines every one of each member's best grid starts to its end
    (``--all-starts``: slower, but no start is stopped near an optimum already found);
    ``offset`` ``"fit"`` fits a detector zero offset in theta_r and an in-plane sample
    tilt (``--offset fit``), a number is a known detector zero offset in degrees (``None``:
    the sweep's ``# offset:`` line, else none); ``keep_saturated`` fits the readings
    a sweep file's capture flagged saturated (detector conversions at full scale: clipped
    values) too (``--keep-saturated``; by default they are left out with a warning;
    arrays carry no such flags). At most ``MAX_FIT_READINGS`` readings
    (2,097,152, what the largest sweep file ``gonio fit`` reads holds), like the CLI:
    more raise a ``GonioError`` before anything is fitted.
    """
    if isinstance(fix, Mapping):
        fix = [f"{k}={v!r}" for k, v in fix.items()]
    fix = list(fix or [])
    if isinstance(models, str):
        models = [m for m in models.split(",") if m]
    models = list(models or [])
    extra = {"aperture": None if aperture is None else float(aperture),
             "instrument": None if instrument is None else os.fspath(instrument),
             "floor": None if floor is None else (floor if isinstance(floor, str) else repr(float(floor))),
             "all_starts": all_starts,
             "keep_saturated": bool(keep_saturated),
             "offset": None if offset is None else (offset if isinstance(offset, str) else repr(float(offset)))}
    if theta_r is None and brdf is None:
        raw = _gonio._fit(os.fspath(source), [], [], [], residual, loss, fix, models, **extra)
    else:
        if theta_r is None or brdf is None:
            raise GonioError("fit(theta_i, theta_r, brdf): give all three arrays, or a sweep file path")
        ti, tr, y = _readings("fit", source, theta_r, brdf)
        # The CLI's limit, before the arrays become lists.
        _gonio._check_fit_readings(ti.size)
        raw = _gonio._fit(None, ti.tolist(), tr.tolist(), y.tolist(),
                          residual, loss, fix, models, **extra)
    return FitResult(raw)
