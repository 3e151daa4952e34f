"""A Mitsuba 3 BSDF for any gonio model (``gonio.Model``), evaluated by the Rust core.

This one file is both ``gonio.mitsuba`` and the plugin that ``gonio fit --export
mitsuba=DIR`` writes (as ``DIR/gonio_bsdf.py``, beside ``model.json`` and
``sphere.xml``; ``python DIR/gonio_bsdf.py`` renders the sphere). It needs the gonio
package with Mitsuba 3 (``pip install './python[mitsuba]'``): the model is evaluated
only by brdf-core.

``register()`` registers the plugin ``"gonio"`` with ``mi.register_bsdf`` for the
current variant: the scalar variants, and the llvm ones (``llvm_ad_rgb``, ...) where the
machine has LLVM (``llvm_available()``). A scene names its model by a key given to
``add_model`` or by a ``model.json`` file::

    import mitsuba as mi, gonio, gonio.mitsuba as gm
    mi.set_variant("scalar_rgb")
    gm.register()
    gm.add_model("fe", gonio.Model.preset("fe-0.115"))
    bsdf = mi.load_dict({"type": "gonio", "model": "fe", "scale": "display"})

Units: ``eval`` returns ``scale * f * cos(theta_o)`` in 1/sr. ``scale`` is
``"absolute"`` (the default: the model's own factor to 1/sr, ``Model.to_per_sr``; a
model in relative units - a preset, a fit of relative data - has none and is refused),
``"display"`` (the brightest directional albedo made 0.9, for looking at a relative fit;
not photometric) or a number: 1/sr per unit of the model, from an instrument
calibration.

Directions: Mitsuba's ``si.wi`` points to the camera (gonio's detector, w_r) and ``wo``
to the light (gonio's source, w_i), so k_s(theta_i) is taken at the light's angle.
Sampling: a mixture of each specular lobe's own distribution (Mitsuba's Beckmann / GGX
microfacet sampling of normals, reflected) and cosine sampling for the diffuse terms,
weighted by each component's directional albedo (brdf-core's quadrature, tabulated at
load over the camera's polar angle).

In the llvm variants the plugin runs with Dr.Jit's symbolic loops and calls off (it
passes whole wavefronts to the core through numpy), which ``register()`` sets.
"""

from __future__ import annotations

import argparse
import math
import pathlib
import sys

import numpy as np

import gonio

_MODELS: dict = {}
_TABLES: dict = {}

#: Polar angles (degrees) of the table of component albedos that sets the mixture.
TABLE_DEG = np.linspace(0.0, 88.0, 23)
#: The scene beside this file (``gonio/sphere.xml``; ``DIR/sphere.xml`` of an export).
SCENE = pathlib.Path(__file__).resolve().with_name("sphere.xml")
#: The scene's geometry (as ``sphere.xml`` sets it): light angle from the camera's axis
#: (degrees), camera and light distance, field of view (degrees).
LIGHT_DEG, DISTANCE, FOV = 40.0, 4.0, 34.0


def _mitsuba():
    """The ``mitsuba`` and ``drjit`` modules, or an ImportError saying how to get them."""
    try:
        import drjit as dr
        import mitsuba as mi
    except ImportError as e:
        raise ImportError(f"gonio.mitsuba needs Mitsuba 3: pip install './python[mitsuba]' "
                          f"(or pip install 'mitsuba>=3.5'): {e}") from e
    return mi, dr


def add_model(key: str, model: "gonio.Model") -> None:
    """Makes a model available to scenes as ``{"type": "gonio", "model": key}``."""
    _MODELS[key] = model
    _TABLES.pop(key, None)


_LLVM_PROBE = """
import mitsuba as mi, drjit as dr
mi.set_variant("llvm_ad_rgb")
dr.eval(dr.maximum(dr.arange(mi.Float, 8) - 3.0, 0.5))
scene = mi.load_dict({"type": "scene", "integrator": {"type": "direct"}, "sphere": {"type": "sphere"},
    "light": {"type": "constant"},
    "sensor": {"type": "perspective", "film": {"type": "hdrfilm", "width": 8, "height": 8}}})
dr.eval(mi.render(scene, spp=1))
"""
_LLVM: list = []


def llvm_status():
    """(available, reason): whether Mitsuba's llvm variants run on this machine. Probed
    once per process in a child process, since Dr.Jit aborts the whole process when the
    libLLVM it finds cannot compile its kernels (LLVM 16 and older here)."""
    if not _LLVM:
        import subprocess

        try:
            run = subprocess.run([sys.executable, "-c", _LLVM_PROBE], capture_output=True, text=True,
                                 timeout=300)
            lines = [ln for ln in (run.stderr or "").splitlines() if ln.strip() and not ln.startswith(" ")]
            why = lines[-1] if lines else f"exit status {run.returncode}"
            _LLVM.append((run.returncode == 0, "" if run.returncode == 0 else why))
        except (OSError, subprocess.TimeoutExpired) as e:
            _LLVM.append((False, str(e)))
    return _LLVM[0]


def llvm_available() -> bool:
    """Whether Mitsuba's llvm variants run here (``llvm_status``)."""
    return llvm_status()[0]


def mixture_table(model: "gonio.Model"):
    """Per sampling strategy (each specular lobe, then the diffuse terms together): its
    directional albedo (reverse: over the source hemisphere) at ``TABLE_DEG``."""
    comps = model.components
    strategies = [(c, model.component(c)) for c in ("specular", "specular-haze") if c in comps]
    diffuse = [model.component(c) for c in ("directional-diffuse", "ideal-diffuse") if c in comps]
    table = [[m.albedo(t, reverse=True)[0] for t in TABLE_DEG] for _, m in strategies]
    if diffuse:
        table.append([sum(m.albedo(t, reverse=True)[0] for m in diffuse) for t in TABLE_DEG])
    return [name for name, _ in strategies] + (["diffuse"] if diffuse else []), np.array(table)


def default_scale(model: "gonio.Model", target: float = 0.9) -> float:
    """The display scale: the largest directional albedo (either direction) ``target``."""
    rho = max(max(model.albedo(t)[0], model.albedo(t, reverse=True)[0]) for t in TABLE_DEG[::2])
    return target / rho


def resolve_scale(model: "gonio.Model", scale) -> float:
    """The factor to 1/sr for ``scale`` ("absolute", "display" or a number; see the
    module docs)."""
    if scale is None or scale == "absolute":
        if model.to_per_sr is None:
            raise ValueError(
                f"gonio BSDF: {model!r} is in relative units (the instrument's, not 1/sr), so it "
                "cannot be rendered as absolute: give scale=S (1/sr per unit, from an instrument "
                "calibration) or scale='display' (brightest albedo 0.9, for viewing only)")
        return model.to_per_sr
    if scale == "display":
        return default_scale(model)
    try:
        s = float(scale)
    except (TypeError, ValueError):
        raise ValueError(f"gonio BSDF: scale '{scale}': use 'absolute', 'display' or a number") from None
    if not (s > 0 and math.isfinite(s)):
        raise ValueError(f"gonio BSDF: scale {scale}: must be a positive number")
    return s


def _model_of(key: str):
    """A registered model, else a model.json found by Mitsuba's file resolver (the
    scene's directory first) or as a path."""
    if key in _MODELS:
        return _MODELS[key]
    mi, _ = _mitsuba()

    resolver = mi.file_resolver() if hasattr(mi, "file_resolver") else mi.Thread.thread().file_resolver()
    path = pathlib.Path(str(resolver.resolve(key)))
    if not path.is_file():
        path = pathlib.Path(key)
    if not path.is_file():
        raise ValueError(f"gonio BSDF: model '{key}' is neither a key of gonio.mitsuba.add_model "
                         "nor a model.json file")
    model = gonio.Model.load(path)
    _MODELS[key] = model
    return model


def register() -> None:
    """Registers the ``gonio`` BSDF for the current Mitsuba variant."""
    mi, dr = _mitsuba()

    scalar = mi.variant().startswith("scalar")
    if not scalar:
        # The core is called on whole wavefronts through numpy: evaluated, not traced.
        dr.set_flag(dr.JitFlag.SymbolicLoops, False)
        dr.set_flag(dr.JitFlag.SymbolicCalls, False)

    def np1(x):
        """A Mitsuba value (Python scalar or JIT array) as a 1-D float64 array."""
        return np.atleast_1d(np.asarray(x, dtype=np.float64))

    def vec(v):
        return np.stack(np.broadcast_arrays(np1(v.x), np1(v.y), np1(v.z)), axis=-1)

    def back(a, kind=None):
        """A numpy array as the variant's Float (or Bool)."""
        kind = kind or mi.Float
        if scalar:
            return kind(a.reshape(-1)[0])
        return kind(a.astype(bool if kind is mi.Bool else np.float32))

    class GonioBSDF(mi.BSDF):
        """A gonio model as a Mitsuba BSDF (see the module docs)."""

        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            key = str(props["model"])
            self.model = _model_of(key)
            self.scale = resolve_scale(self.model, props["scale"] if "scale" in props else None)
            if key not in _TABLES:
                _TABLES[key] = mixture_table(self.model)
            self.names, self.table = _TABLES[key]
            self.lobes = []
            p = self.model.params
            for name in self.names:
                if name == "diffuse":
                    self.lobes.append(None)
                    continue
                pre = "" if name == "specular" else "haze_"
                kind = mi.MicrofacetType.Beckmann if p[pre + "dist"] == "beckmann" else mi.MicrofacetType.GGX
                # Mitsuba's alpha is the RMS slope m = sqrt(2) sigma (docs/model-components.md).
                self.lobes.append(mi.MicrofacetDistribution(kind, math.sqrt(2.0) * p[pre + "sigma"], False))
            flags = mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide
            self.m_components = [flags]
            self.m_flags = flags

        def weights(self, cos_view):
            """Mixture weights (strategies x lanes) at the camera's polar angles."""
            t = np.degrees(np.arccos(np.clip(cos_view, 0.0, 1.0)))
            w = np.array([np.interp(t, TABLE_DEG, row) for row in self.table])
            s = w.sum(axis=0)
            return np.where(s > 0, w / np.where(s > 0, s, 1.0), 1.0 / len(w))

        def value(self, wi, wo, active=True):
            """scale * f * cos(theta_o) per lane (0 below the horizon)."""
            cam, light = np.broadcast_arrays(vec(wi), vec(wo))
            ok = (cam[:, 2] > 0) & (light[:, 2] > 0) & np.isfinite(cam).all(1) & np.isfinite(light).all(1)
            ok &= np.broadcast_to(np.atleast_1d(np.asarray(active, dtype=bool)), ok.shape)
            up = np.array([0.0, 0.0, 1.0])
            f = self.model.eval_vectors(np.where(ok[:, None], light, up), np.where(ok[:, None], cam, up))
            return np.where(ok, self.scale * np.atleast_1d(f) * light[:, 2], 0.0)

        def density(self, wi, wo):
            """The mixture's pdf of wo (solid angle) per lane."""
            cam, light = np.broadcast_arrays(vec(wi), vec(wo))
            w = self.weights(cam[:, 2])
            h = dr.normalize(wi + wo)
            dot_oh = np.abs(np1(dr.dot(wo, h)))
            pdf = np.zeros(len(cam))
            with np.errstate(divide="ignore", invalid="ignore"):
                for wk, lobe in zip(w, self.lobes):
                    if lobe is None:
                        pdf = pdf + wk * light[:, 2] / math.pi
                    else:
                        d = np1(lobe.pdf(mi.Vector3f(0, 0, 1), h))
                        pdf = pdf + wk * np.broadcast_to(d, pdf.shape) / (4.0 * dot_oh)
            ok = (cam[:, 2] > 0) & (light[:, 2] > 0) & np.isfinite(pdf)
            return np.where(ok, pdf, 0.0)

        # The scalar variants call once per ray: plain floats, no numpy round trip.
        def value1(self, wi, wo):
            if not (wi.z > 0 and wo.z > 0):
                return 0.0
            return self.scale * self.model.eval_dir((wo.x, wo.y, wo.z), (wi.x, wi.y, wi.z)) * wo.z

        def weights1(self, cos_view):
            t = math.degrees(math.acos(min(max(cos_view, 0.0), 1.0)))
            w = [float(np.interp(t, TABLE_DEG, row)) for row in self.table]
            s = sum(w)
            return [x / s for x in w] if s > 0 else [1.0 / len(w)] * len(w)

        def density1(self, wi, wo):
            if not (wi.z > 0 and wo.z > 0):
                return 0.0
            h = dr.normalize(wi + wo)
            pdf = 0.0
            for wk, lobe in zip(self.weights1(wi.z), self.lobes):
                if lobe is None:
                    pdf += wk * wo.z / math.pi
                else:
                    pdf += wk * lobe.pdf(mi.Vector3f(0, 0, 1), h) / (4.0 * abs(dr.dot(wo, h)))
            return pdf

        def sample1(self, si, u1, u2):
            bs = mi.BSDFSample3f()
            wi = si.wi
            if wi.z <= 0:
                return bs, mi.Spectrum(0.0)
            cdf = np.cumsum(self.weights1(wi.z))
            k = min(int(np.searchsorted(cdf, u1, side="right")), len(cdf) - 1)
            lobe = self.lobes[k]
            if lobe is None:
                wo = mi.warp.square_to_cosine_hemisphere(u2)
                bs.sampled_type = mi.UInt32(+mi.BSDFFlags.DiffuseReflection)
            else:
                m, _ = lobe.sample(mi.Vector3f(0, 0, 1), u2)
                wo = mi.reflect(wi, m)
                bs.sampled_type = mi.UInt32(+mi.BSDFFlags.GlossyReflection)
            pdf = self.density1(wi, wo)
            bs.wo, bs.eta, bs.sampled_component = wo, 1.0, 0
            if not (pdf > 0 and wo.z > 0):
                bs.pdf = 0.0
                return bs, mi.Spectrum(0.0)
            bs.pdf = pdf
            return bs, mi.Spectrum(self.value1(wi, wo) / pdf)

        def eval(self, ctx, si, wo, active=True):
            if scalar:
                return mi.Spectrum(self.value1(si.wi, wo))
            return mi.Spectrum(back(self.value(si.wi, wo, active)))

        def pdf(self, ctx, si, wo, active=True):
            if scalar:
                return mi.Float(self.density1(si.wi, wo))
            return back(self.density(si.wi, wo))

        def eval_pdf(self, ctx, si, wo, active=True):
            if scalar:
                return mi.Spectrum(self.value1(si.wi, wo)), mi.Float(self.density1(si.wi, wo))
            return mi.Spectrum(back(self.value(si.wi, wo, active))), back(self.density(si.wi, wo))

        def sample(self, ctx, si, sample1, sample2, active=True):
            if scalar:
                return self.sample1(si, sample1, sample2)
            wi = si.wi
            cos_view = vec(wi)[:, 2]
            u = np1(sample1)
            n = max(len(u), len(cos_view), len(np1(sample2.x)))
            w = self.weights(np.broadcast_to(cos_view, (n,)))
            pick = np.minimum((np.broadcast_to(u, (n,))[None, :] >= np.cumsum(w, axis=0)).sum(axis=0), len(w) - 1)
            wo = mi.warp.square_to_cosine_hemisphere(sample2)
            glossy = np.zeros(n, dtype=bool)
            for k, lobe in enumerate(self.lobes):
                if lobe is not None:
                    m, _ = lobe.sample(mi.Vector3f(0, 0, 1), sample2)
                    wo = dr.select(back(pick == k, mi.Bool), mi.reflect(wi, m), wo)
                    glossy |= pick == k
            pdf = self.density(wi, wo)
            val = self.value(wi, wo, active)
            ok = pdf > 0
            bs = mi.BSDFSample3f()
            bs.wo = wo
            bs.pdf = back(np.where(ok, pdf, 0.0))
            bs.eta = 1.0
            bs.sampled_component = 0
            bs.sampled_type = dr.select(back(glossy, mi.Bool), mi.UInt32(+mi.BSDFFlags.GlossyReflection),
                                        mi.UInt32(+mi.BSDFFlags.DiffuseReflection))
            with np.errstate(divide="ignore", invalid="ignore"):
                weight = np.where(ok, val / np.where(ok, pdf, 1.0), 0.0)
            return bs, mi.Spectrum(back(weight))

        def traverse(self, callback):
            pass

        def to_string(self):
            return f"GonioBSDF[{self.model.member}, scale={self.scale}]"

    mi.register_bsdf("gonio", lambda props: GonioBSDF(props))


def scene_params(*, model: str = "model.json", scale="absolute", resolution: int = 128, spp: int = 4,
                 light_deg: float = LIGHT_DEG) -> dict:
    """The parameters of ``sphere.xml`` for ``mi.load_file(SCENE, **scene_params(...))``."""
    a = math.radians(light_deg)
    return {"model": model, "scale": str(scale), "res": str(resolution), "spp": str(spp),
            "lx": repr(DISTANCE * math.sin(a)), "lz": repr(DISTANCE * math.cos(a))}


def highlight_pixel(*, resolution: int = 128, light_deg: float = LIGHT_DEG):
    """(row, column) where the mirror direction puts the highlight of ``sphere.xml``:
    the point whose normal bisects the directions to the light and to the camera."""
    a = math.radians(light_deg)
    L = np.array([DISTANCE * math.sin(a), 0.0, DISTANCE * math.cos(a)])
    C = np.array([0.0, 0.0, DISTANCE])
    unit = lambda v: v / np.linalg.norm(v)  # noqa: E731
    n = unit(unit(L) + unit(C))
    for _ in range(100):
        n = unit(unit(L - n) + unit(C - n))
    x, y, z = n
    t = math.tan(math.radians(FOV) / 2)
    u = x / ((DISTANCE - z) * t)
    v = y / ((DISTANCE - z) * t)
    return (0.5 - 0.5 * v) * resolution, (0.5 + 0.5 * u) * resolution


def render_sphere(model: "gonio.Model", path=None, *, scale=None, resolution: int = 128, spp: int = 4,
                  light_deg: float = LIGHT_DEG):
    """Renders ``sphere.xml`` for a model (scalar_rgb unless a variant is set) and returns
    the image as a float array (H, W, 3); writes it when ``path`` is given (PNG: tone
    mapped). ``scale`` as the plugin takes it; by default "absolute" for a model in
    1/sr and "display" for one in relative units."""
    mi, _ = _mitsuba()

    if mi.variant() is None:
        mi.set_variant("scalar_rgb")
    register()
    add_model("_render", model)
    if scale is None:
        scale = "display" if model.to_per_sr is None else "absolute"
    params = scene_params(model="_render", scale=scale, resolution=resolution, spp=spp, light_deg=light_deg)
    img = mi.render(mi.load_file(str(SCENE), **params))
    if path is not None:
        mi.util.write_bitmap(str(path), img)
    return np.array(img)


def main(argv=None) -> int:
    """``python gonio_bsdf.py``: renders the sphere.xml beside this file."""
    ap = argparse.ArgumentParser(
        description="Render sphere.xml (beside this plugin) with the gonio BSDF: a sphere of the fitted "
                    "material lit 40 degrees off the camera's axis.")
    ap.add_argument("out", nargs="?", default=str(SCENE.with_name("sphere.png")),
                    help="output image (.png tone mapped, .exr linear) [default: sphere.png here]")
    ap.add_argument("--scale", default=None,
                    help="'absolute', 'display' or 1/sr per unit of the model [default: the scene's]")
    ap.add_argument("--variant", default=None, help="Mitsuba variant [default: llvm_ad_rgb if LLVM is "
                    "available, else scalar_rgb]")
    ap.add_argument("--spp", type=int, default=16, help="samples per pixel [default: 16]")
    ap.add_argument("--res", type=int, default=256, help="image width and height [default: 256]")
    args = ap.parse_args(argv)
    mi, _ = _mitsuba()

    variant = args.variant or ("llvm_ad_rgb" if llvm_available() else "scalar_rgb")
    mi.set_variant(variant)
    register()
    params = {"res": str(args.res), "spp": str(args.spp)}
    if args.scale is not None:
        params["scale"] = args.scale
    try:
        scene = mi.load_file(str(SCENE), **params)
    except Exception as e:  # noqa: BLE001 - Mitsuba wraps the plugin's message
        print(f"gonio_bsdf: {str(e).strip().splitlines()[-1]}", file=sys.stderr)
        return 2
    mi.util.write_bitmap(args.out, mi.render(scene))
    print(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
