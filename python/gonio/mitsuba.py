"""A Mitsuba 3 BSDF for any gonio model (``gonio.Model``), evaluated by the Rust core.

``register()`` registers the plugin ``"gonio"`` with ``mi.register_bsdf`` for the
current variant (scalar variants; the class only uses Mitsuba's own types and warps).
A scene refers to a model by the key it was given with ``add_model``::

    import mitsuba as mi, gonio, gonio.mitsuba as gm
    mi.set_variant("scalar_rgb")
    gm.register()
    gm.add_model("fe", gonio.Model.preset("fe-0.115"))
    bsdf = mi.load_dict({"type": "gonio", "model": "fe"})

Directions: Mitsuba's ``si.wi`` points to the camera (gonio's detector, w_r) and ``wo``
to the light (gonio's source, w_i), so k_s(theta_i) is taken at the light's angle.
``eval`` returns ``scale * f * cos(theta_o)``; ``scale`` (default 1) converts the
model's relative units to 1/sr. Sampling: a mixture of each specular lobe's own
distribution (Mitsuba's Beckmann / GGX microfacet sampling of normals, reflected) and
cosine sampling for the diffuse terms, weighted by each component's directional albedo
(brdf-core's quadrature, tabulated at load over the camera's polar angle).
"""

from __future__ import annotations

import math


import numpy as np

import gonio

_MODELS: dict = {}
_TABLES: dict = {}

#: Polar angles (degrees) of the table of component albedos that sets the mixture.
TABLE_DEG = np.linspace(0.0, 88.0, 23)


def add_model(key: str, model: "gonio.Model") -> None:
    """Makes a model available to scenes as ``{"type": "gonio", "model": key}``."""
    _MODELS[key] = model
    _TABLES.pop(key, None)


def mixture_table(model: "gonio.Model"):
    """Per sampling strategy (each specular lobe, then the diffuse terms together): its
    directional albedo (reverse: over the source hemisphere) at ``TABLE_DEG``."""
    comps = model.components
    strategies = []
    for c in ("specular", "specular-haze"):
        if c in comps:
            strategies.append((c, model.component(c)))
    diffuse = [model.component(c) for c in ("directional-diffuse", "ideal-diffuse") if c in comps]
    table = []
    for _, m in strategies:
        table.append([m.albedo(t, reverse=True)[0] for t in TABLE_DEG])
    if diffuse:
        table.append([sum(m.albedo(t, reverse=True)[0] for m in diffuse) for t in TABLE_DEG])
    return [name for name, _ in strategies] + (["diffuse"] if diffuse else []), np.array(table)


def default_scale(model: "gonio.Model", target: float = 0.9) -> float:
    """A scale that makes the largest directional albedo (either direction) ``target``."""
    rho = max(max(model.albedo(t)[0], model.albedo(t, reverse=True)[0]) for t in TABLE_DEG[::2])
    return target / rho


def register() -> None:
    """Registers the ``gonio`` BSDF for the current Mitsuba variant."""
    import drjit as dr  # noqa: F401
    import mitsuba as mi

    class GonioBSDF(mi.BSDF):
        """A gonio model as a Mitsuba BSDF (see the module docs)."""

        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            key = props["model"]
            if key not in _MODELS:
                raise ValueError(f"gonio BSDF: no model '{key}' (gonio.mitsuba.add_model)")
            self.model = _MODELS[key]
            self.scale = props["scale"] if "scale" in props else 1.0
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
            """Mixture weights at the camera's polar angle."""
            t = math.degrees(math.acos(min(max(cos_view, 0.0), 1.0)))
            w = np.array([np.interp(t, TABLE_DEG, row) for row in self.table])
            s = w.sum()
            return w / s if s > 0 else np.full(len(w), 1.0 / len(w))

        def value(self, wi, wo):
            if wi.z <= 0 or wo.z <= 0:
                return 0.0
            f = self.model.eval_dir((wo.x, wo.y, wo.z), (wi.x, wi.y, wi.z))
            return self.scale * f * wo.z

        def density(self, wi, wo):
            if wi.z <= 0 or wo.z <= 0:
                return 0.0
            w = self.weights(wi.z)
            h = dr.normalize(wi + wo)
            pdf = 0.0
            for wk, lobe in zip(w, self.lobes):
                if lobe is None:
                    pdf += wk * wo.z / math.pi
                else:
                    pdf += wk * lobe.pdf(mi.Vector3f(0, 0, 1), h) / (4.0 * abs(dr.dot(wo, h)))
            return pdf

        def eval(self, ctx, si, wo, active=True):
            return mi.Spectrum(self.value(si.wi, wo))

        def pdf(self, ctx, si, wo, active=True):
            return mi.Float(self.density(si.wi, wo))

        def eval_pdf(self, ctx, si, wo, active=True):
            return mi.Spectrum(self.value(si.wi, wo)), mi.Float(self.density(si.wi, wo))

        def sample(self, ctx, si, sample1, sample2, active=True):
            bs = mi.BSDFSample3f()
            wi = si.wi
            if wi.z <= 0:
                return bs, mi.Spectrum(0.0)
            w = self.weights(wi.z)
            k = min(int(np.searchsorted(np.cumsum(w), sample1, side="right")), len(w) - 1)
            lobe = self.lobes[k]
            if lobe is None:
                wo = mi.warp.square_to_cosine_hemisphere(sample2)
                bs.sampled_type = mi.UInt32(+mi.BSDFFlags.DiffuseReflection)
            else:
                m, _ = lobe.sample(mi.Vector3f(0, 0, 1), sample2)
                wo = mi.reflect(wi, m)
                bs.sampled_type = mi.UInt32(+mi.BSDFFlags.GlossyReflection)
            pdf = self.density(wi, wo)
            bs.wo = wo
            bs.pdf = pdf
            bs.eta = 1.0
            bs.sampled_component = 0
            if pdf <= 0 or wo.z <= 0:
                bs.pdf = 0.0
                return bs, mi.Spectrum(0.0)
            return bs, mi.Spectrum(self.value(wi, wo) / pdf)

        def traverse(self, callback):
            pass

        def to_string(self):
            return f"GonioBSDF[{self.model.member}, scale={self.scale}]"

    mi.register_bsdf("gonio", lambda props: GonioBSDF(props))


def sphere_scene(key: str, *, scale: float, resolution: int = 96, spp: int = 4,
                 light_deg: float = 40.0, distance: float = 4.0, fov: float = 34.0) -> dict:
    """A sphere of radius 1 at the origin made of model ``key``, seen from +z at
    ``distance``, lit by a point light at the same distance ``light_deg`` degrees
    towards +x from the camera's axis."""
    a = math.radians(light_deg)
    import drjit as dr  # noqa: F401
    import mitsuba as mi

    return {
        "type": "scene",
        "integrator": {"type": "direct"},
        "sensor": {
            "type": "perspective",
            "fov": fov,
            "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, distance], target=[0, 0, 0], up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": resolution, "height": resolution,
                     "rfilter": {"type": "box"}, "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": spp},
        },
        "light": {"type": "point", "position": [distance * math.sin(a), 0.0, distance * math.cos(a)],
                  "intensity": {"type": "rgb", "value": [distance ** 2] * 3}},
        "sphere": {"type": "sphere", "center": [0, 0, 0], "radius": 1.0,
                   "bsdf": {"type": "gonio", "model": key, "scale": scale}},
    }


def highlight_pixel(*, resolution: int = 96, light_deg: float = 40.0, distance: float = 4.0,
                    fov: float = 34.0):
    """(row, column) where the mirror direction puts the highlight of ``sphere_scene``:
    the point whose normal bisects the directions to the light and to the camera."""
    a = math.radians(light_deg)
    L = np.array([distance * math.sin(a), 0.0, distance * math.cos(a)])
    C = np.array([0.0, 0.0, distance])
    unit = lambda v: v / np.linalg.norm(v)  # noqa: E731
    n = unit(unit(L) + unit(C))
    for _ in range(100):
        n = unit(unit(L - n) + unit(C - n))
    x, y, z = n
    t = math.tan(math.radians(fov) / 2)
    u = x / ((distance - z) * t)
    v = y / ((distance - z) * t)
    return (0.5 - 0.5 * v) * resolution, (0.5 + 0.5 * u) * resolution


def render_sphere(model: "gonio.Model", path=None, *, scale=None, **kw):
    """Renders ``sphere_scene`` for a model (scalar_rgb unless a variant is set) and
    returns the image as a float array (H, W, 3); writes a PNG when ``path`` is given."""
    import drjit as dr  # noqa: F401
    import mitsuba as mi

    if mi.variant() is None:
        mi.set_variant("scalar_rgb")
    register()
    add_model("_render", model)
    scale = default_scale(model) if scale is None else scale
    scene = mi.load_dict(sphere_scene("_render", scale=scale, **kw))
    img = mi.render(scene)
    if path is not None:
        mi.util.write_bitmap(str(path), img)
    return np.array(img)
