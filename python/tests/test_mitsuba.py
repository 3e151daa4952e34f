"""The Mitsuba 3 plugin, in the scalar variant and (where LLVM is found) the llvm one:
eval equals the core, sample and pdf agree (chi-square), the sampled albedo equals the
quadrature, the sphere renders with its highlight at the mirror point; and the plugin
directory `gonio fit --export mitsuba=DIR` writes does the same from its model.json."""

import importlib.util
import json
import math
import subprocess
import sys

import numpy as np
import pytest

mi = pytest.importorskip("mitsuba")

import gonio  # noqa: E402
import gonio.mitsuba as gm  # noqa: E402
from conftest import FE_SWEEP  # noqa: E402

SCALE = 0.01
LLVM, WHY = gm.llvm_status()
VARIANTS = [
    "scalar_rgb",
    pytest.param("llvm_ad_rgb", marks=pytest.mark.skipif(
        not LLVM, reason=f"Mitsuba's llvm variants need a libLLVM Dr.Jit can use (19 works here; 15 and 16 do not): {WHY}")),
]


@pytest.fixture(scope="module", params=VARIANTS)
def variant(request):
    mi.set_variant(request.param)
    gm.register()
    yield request.param


#: The models the plugin is checked on: the paper's lobe (the demo's iron), a GGX lobe
#: with the directional diffuse, and a haze lobe beside a GGX core with a smooth k_s
#: (the member gonio selects for the Scatterworks metal).
MODELS = {
    "fe": lambda: gonio.Model.preset("fe-0.115"),
    "ggx": lambda: gonio.Model("specular:ggx+directional-diffuse+ideal-diffuse", ks=145.0, sigma=0.115,
                               kdd=900.0, sigma_m=0.7, kid=25.0),
    "haze": lambda: gonio.Model("specular:ggx:smooth-ks+specular-haze:beckmann+ideal-diffuse",
                                ks=[5.0, -0.5, 0.8], sigma=0.06, ks_haze=20.0, sigma_haze=0.25, kid=25.0),
}


@pytest.fixture(scope="module", params=list(MODELS))
def case(variant, request):
    """(model, its BSDF at SCALE) for each of MODELS."""
    model = MODELS[request.param]()
    gm.add_model(request.param, model)
    return model, mi.load_dict({"type": "gonio", "model": request.param, "scale": SCALE})


def _scalar():
    return mi.variant().startswith("scalar")


def _vec(a):
    """(n, 3) numpy -> the variant's Vector3f (one lane per row)."""
    a = np.asarray(a, dtype=np.float64)
    return mi.Vector3f(*(mi.Float(a[:, k].astype(np.float32)) for k in range(3)))


def _si(view):
    si = mi.SurfaceInteraction3f()
    si.wi = _vec(view) if not _scalar() else mi.Vector3f(*view)
    si.n = mi.Vector3f(0, 0, 1)
    si.sh_frame = mi.Frame3f(si.n)
    return si


def eval_batch(bsdf, views, lights):
    """eval per (view, light) row, as a numpy array (one call in a JIT variant)."""
    ctx = mi.BSDFContext()
    if _scalar():
        return np.array([bsdf.eval(ctx, _si(v), mi.Vector3f(*l))[0] for v, l in zip(views, lights)])
    return np.asarray(bsdf.eval(ctx, _si(views), _vec(lights))[0], dtype=np.float64)


def pdf_batch(bsdf, view, wos):
    ctx = mi.BSDFContext()
    if _scalar():
        si = _si(view)
        return np.array([bsdf.pdf(ctx, si, mi.Vector3f(*w)) for w in wos])
    views = np.broadcast_to(view, np.shape(wos))
    return np.asarray(bsdf.pdf(ctx, _si(views), _vec(wos)), dtype=np.float64)


def sample_batch(bsdf, view, u):
    """Directions (n, 3), pdfs and weights (first channel) for samples u (n, 3)."""
    ctx = mi.BSDFContext()
    if _scalar():
        si = _si(view)
        out = []
        for u1, u2, u3 in u:
            bs, w = bsdf.sample(ctx, si, float(u1), mi.Point2f(float(u2), float(u3)))
            out.append((bs.wo.x, bs.wo.y, bs.wo.z, bs.pdf, w[0]))
        out = np.array(out, dtype=np.float64)
        return out[:, :3], out[:, 3], out[:, 4]
    views = np.broadcast_to(view, (len(u), 3))
    f32 = lambda c: mi.Float(np.ascontiguousarray(c, dtype=np.float32))  # noqa: E731
    bs, w = bsdf.sample(ctx, _si(views), f32(u[:, 0]), mi.Point2f(f32(u[:, 1]), f32(u[:, 2])))
    wo = np.stack([np.asarray(c, dtype=np.float64) for c in (bs.wo.x, bs.wo.y, bs.wo.z)], axis=-1)
    return wo, np.asarray(bs.pdf, dtype=np.float64), np.asarray(w[0], dtype=np.float64)


def _dir(theta_deg, phi_deg):
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return [math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)]


def _pairs():
    """(light, view) pairs in the plane (both sides, grazing) and out of it."""
    pairs = []
    for ti in (0.0, 10.0, 25.0, 41.4, 60.0, 80.0):
        for tr in (-70.0, -20.0, 0.0, 5.0, 24.0, 41.0, 61.0, 80.0):
            # gonio's source w_i is Mitsuba's wo (towards the light), the detector w_r is si.wi.
            pairs.append((_dir(ti, 0.0), _dir(abs(tr), 180.0 if tr > 0 else 0.0)))
    pairs += [(_dir(30, 10), _dir(40, 200)), (_dir(55, -40), _dir(20, 90)), (_dir(5, 0), _dir(70, 135)),
              (_dir(33, 77), _dir(48, 250))]
    return np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs])


def _worst_vs_core(bsdf, model, scale):
    lights, views = _pairs()
    got = eval_batch(bsdf, views, lights)
    # The core at the directions Mitsuba holds (single precision in these variants).
    l32, v32 = (a.astype(np.float32).astype(np.float64) for a in (lights, views))
    expect = scale * model.eval_vectors(l32, v32) * l32[:, 2]
    return np.max(np.abs(got / expect - 1))


def test_eval_equals_the_core_in_and_out_of_plane(case):
    model, bsdf = case
    worst = _worst_vs_core(bsdf, model, SCALE)
    assert worst < 1e-5, worst


def _chi2_sf(x, k):
    """Upper tail of chi-square (Wilson-Hilferty), accurate enough for a test level."""
    z = ((x / k) ** (1 / 3) - (1 - 2 / (9 * k))) / math.sqrt(2 / (9 * k))
    return 0.5 * math.erfc(z / math.sqrt(2))


@pytest.mark.parametrize("theta_view", [20.0, 60.0])
def test_sampled_directions_follow_pdf_chi_square(case, theta_view):
    """As Mitsuba's own BSDF tests: histogram sampled directions over (cos theta, phi)
    cells, integrate pdf over each cell, pool cells expecting < 5, chi-square test."""
    _, bsdf = case
    rng = np.random.default_rng(7)
    view = _dir(theta_view, 0.0)
    n, nc, nphi, sub = 20000, 10, 20, 12
    wo, pdf, _ = sample_batch(bsdf, view, rng.random((n, 3)))
    wo = wo[pdf > 0]
    c = np.minimum((wo[:, 2] * nc).astype(int), nc - 1)
    p = np.minimum(((np.arctan2(wo[:, 1], wo[:, 0]) % (2 * math.pi)) / (2 * math.pi) * nphi).astype(int), nphi - 1)
    hist = np.zeros((nc, nphi))
    np.add.at(hist, (c, p), 1)
    # pdf integrated over each cell by the midpoint rule on a sub x sub grid.
    z = (np.arange(nc * sub) + 0.5) / (nc * sub)
    phi = (np.arange(nphi * sub) + 0.5) / (nphi * sub) * 2 * math.pi
    Z, PHI = np.meshgrid(z, phi, indexing="ij")
    s = np.sqrt(np.maximum(0.0, 1 - Z * Z))
    dirs = np.stack([s * np.cos(PHI), s * np.sin(PHI), Z], axis=-1).reshape(-1, 3)
    dens = pdf_batch(bsdf, view, dirs).reshape(nc, sub, nphi, sub).sum(axis=(1, 3))
    expect = dens / sub ** 2 * (1 / nc) * (2 * math.pi / nphi) * n
    # pdf integrates to the share of samples above the horizon (a lobe's facet normal
    # can reflect the camera's ray below it: GGX's tail does at 60 degrees).
    assert abs(expect.sum() - len(wo)) / n < 0.02, (expect.sum() / n, len(wo) / n)
    assert len(wo) > 0.9 * n
    order = np.argsort(expect.ravel())
    e, o = expect.ravel()[order], hist.ravel()[order]
    pool_e = pool_o = 0.0
    chi2, dof = 0.0, -1
    for ei, oi in zip(e, o):
        if ei < 5:
            pool_e += ei
            pool_o += oi
            continue
        chi2 += (oi - ei) ** 2 / ei
        dof += 1
    if pool_e > 0:
        chi2 += (pool_o - pool_e) ** 2 / max(pool_e, 1e-9)
        dof += 1
    assert _chi2_sf(chi2, dof) > 0.01, (chi2, dof)


@pytest.mark.parametrize("theta_view", [10.0, 45.0, 75.0])
def test_sampled_albedo_equals_the_quadrature(case, theta_view):
    m, bsdf = case
    rng = np.random.default_rng(11)
    _, _, vals = sample_batch(bsdf, _dir(theta_view, 0.0), rng.random((20000, 3)))
    est, se = vals.mean(), vals.std() / math.sqrt(len(vals))
    rho, err = m.albedo(theta_view, reverse=True)
    assert abs(est - SCALE * rho) < 4 * se + SCALE * err, (est, se, SCALE * rho)
    assert se < 0.02 * est  # the importance sampling keeps the estimate tight


def test_sphere_renders_with_the_highlight_at_the_mirror_point(variant):
    img = gm.render_sphere(gonio.Model.preset("fe-0.115"), resolution=64, spp=2)
    assert img.shape == (64, 64, 3) and np.all(np.isfinite(img)) and img.max() > 0
    row, col = np.unravel_index(np.argmax(img[..., 0]), img.shape[:2])
    er, ec = gm.highlight_pixel(resolution=64)
    assert abs(row + 0.5 - er) <= 2 and abs(col + 0.5 - ec) <= 2, ((row, col), (er, ec))
    # The highlight is off-centre, towards the light: the test can tell.
    assert ec - 32 > 8


def test_a_relative_model_needs_a_scale(variant):
    gm.add_model("rel", gonio.Model.preset("fe-0.115"))
    with pytest.raises(Exception, match="relative units.*cannot be rendered as absolute"):
        mi.load_dict({"type": "gonio", "model": "rel"})
    with pytest.raises(Exception, match="scale 'bright'"):
        mi.load_dict({"type": "gonio", "model": "rel", "scale": "bright"})
    shown = mi.load_dict({"type": "gonio", "model": "rel", "scale": "display"})
    assert "scale=" in str(shown)


@pytest.fixture(scope="module")
def exported(tmp_path_factory, request):
    """`gonio fit FE --export mitsuba=DIR` (the CLI), and the same fit in-process."""
    import conftest

    gonio_bin = conftest.find_gonio_bin()
    if gonio_bin is None:
        pytest.skip("no gonio binary (set GONIO_BIN or build the workspace)")
    out = tmp_path_factory.mktemp("export") / "fe"
    subprocess.run([gonio_bin, "fit", str(FE_SWEEP), "--export", f"mitsuba={out}"], check=True,
                   capture_output=True)
    return out, gonio.fit(str(FE_SWEEP))


def _load_plugin(path):
    spec = importlib.util.spec_from_file_location("gonio_bsdf", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_cli_export_is_the_packages_plugin_and_the_fitted_model(exported):
    out, result = exported
    assert sorted(p.name for p in out.iterdir()) == ["gonio_bsdf.py", "model.json", "sphere.xml"]
    assert (out / "gonio_bsdf.py").read_text() == pathlib_text(gm.__file__)
    meta = json.loads((out / "model.json").read_text())
    assert meta["member"] == result.selected and meta["to_per_sr"] is None
    assert meta["incidences"] == result.incidences
    loaded, fitted = gonio.Model.load(out / "model.json"), result.model()
    assert loaded.member == fitted.member and loaded.to_per_sr is None
    ti = np.array([0.0, 5.0, 20.0, 37.0, 60.0, 80.0])[:, None]
    tr = np.linspace(-80, 85, 34)[None, :]
    # The CLI under test is a debug build, the wheel a release build: last bits may differ.
    np.testing.assert_allclose(loaded.eval(ti, tr), fitted.eval(ti, tr), rtol=1e-12)
    assert 'value="display"' in (out / "sphere.xml").read_text()


def pathlib_text(p):
    import pathlib

    return pathlib.Path(p).read_text()


def test_cli_export_plugin_evaluates_the_fit(exported, variant):
    """The exported plugin, loaded from its directory, reads model.json and its eval is
    the core's value of the fitted model (between the fitted incidences too)."""
    out, result = exported
    plugin = _load_plugin(out / "gonio_bsdf.py")
    plugin.register()
    bsdf = mi.load_dict({"type": "gonio", "model": str(out / "model.json"), "scale": "0.02"})
    assert _worst_vs_core(bsdf, result.model(), 0.02) < 1e-5
    gm.register()  # the package's plugin again for the other tests


def test_cli_export_renders_and_states_its_units(exported, variant, tmp_path):
    out, _ = exported
    png = tmp_path / "sphere.png"
    run = subprocess.run([sys.executable, str(out / "gonio_bsdf.py"), str(png), "--res", "32", "--spp", "1",
                          "--variant", variant], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    assert png.stat().st_size > 500
    bad = subprocess.run([sys.executable, str(out / "gonio_bsdf.py"), str(tmp_path / "x.png"), "--scale",
                          "absolute", "--variant", variant], capture_output=True, text=True, timeout=600)
    assert bad.returncode == 2 and "relative units" in bad.stderr, bad.stderr
    assert len(bad.stderr.strip().splitlines()) == 1, bad.stderr


def test_package_export_with_an_instrument_scale(tmp_path):
    result = gonio.fit(str(FE_SWEEP))
    result.export_mitsuba(tmp_path / "abs", to_per_sr=0.02)
    m = gonio.Model.load(tmp_path / "abs" / "model.json")
    assert m.to_per_sr == 0.02
    assert 'value="absolute"' in (tmp_path / "abs" / "sphere.xml").read_text()
    with pytest.raises(gonio.GonioError, match="exists: use --force"):
        result.export_mitsuba(tmp_path / "abs", to_per_sr=0.02)
    with pytest.raises(gonio.GonioError, match="to_per_sr = -1"):
        result.export_mitsuba(tmp_path / "neg", to_per_sr=-1.0)


def test_cli_exports_any_member_of_the_lattice(gonio_bin, tmp_path):
    """A GGX core with a smooth k_s and a GGX haze lobe on the Scatterworks metal, not
    one of the paper's models: the export carries that member as fitted. (The member the
    default selects there has a Student-t haze, which the plugin cannot render.)"""
    from conftest import REPO

    sweep = REPO / "host-tool" / "tests" / "data" / "scatterworks-solar-array-532nm.sweep.csv"
    out = tmp_path / "sw"
    member = "specular:ggx:smooth-ks+specular-haze:ggx+ideal-diffuse"
    run = subprocess.run([gonio_bin, "fit", str(sweep), "--models", member, "--export", f"mitsuba={out}"],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    result = gonio.fit(str(sweep), models=[member])
    meta = json.loads((out / "model.json").read_text())
    assert meta["member"] == result.selected and "specular-haze" in meta["member"], meta["member"]
    loaded, fitted = gonio.Model.load(out / "model.json"), result.model()
    assert loaded.member == fitted.member and loaded.components == fitted.components
    ti = np.array([5.0, 20.0, 41.4, 60.0, 75.0])[:, None]
    tr = np.linspace(-80, 85, 67)[None, :]
    # The command (a debug build here) and the wheel may differ in a parameter's last bit.
    np.testing.assert_allclose(loaded.eval(ti, tr), fitted.eval(ti, tr), rtol=1e-12)
