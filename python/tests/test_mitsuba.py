"""The Mitsuba 3 plugin: eval equals the core, sample and pdf agree, the sphere renders."""

import math

import numpy as np
import pytest

mi = pytest.importorskip("mitsuba")

import gonio  # noqa: E402
import gonio.mitsuba as gm  # noqa: E402

SCALE = 0.01


@pytest.fixture(scope="module")
def bsdf():
    mi.set_variant("scalar_rgb")
    gm.register()
    gm.add_model("fe", gonio.Model.preset("fe-0.115"))
    return mi.load_dict({"type": "gonio", "model": "fe", "scale": SCALE})


def _si(wi):
    si = mi.SurfaceInteraction3f()
    si.wi = mi.Vector3f(*wi)
    si.n = mi.Vector3f(0, 0, 1)
    si.sh_frame = mi.Frame3f(si.n)
    return si


def _dir(theta_deg, phi_deg):
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return [math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)]


def test_eval_equals_the_core_in_and_out_of_plane(bsdf):
    m = gonio.Model.preset("fe-0.115")
    ctx = mi.BSDFContext()
    worst = 0.0
    for ti in (0.0, 10.0, 25.0, 41.4, 60.0, 80.0):
        for tr in (-70.0, -20.0, 0.0, 5.0, 24.0, 41.0, 61.0, 80.0):
            # gonio's source w_i is Mitsuba's wo (towards the light), the detector w_r is si.wi.
            light, view = _dir(ti, 0.0), _dir(abs(tr), 180.0 if tr > 0 else 0.0)
            v = bsdf.eval(ctx, _si(view), mi.Vector3f(*light))[0]
            expect = SCALE * m.eval(ti, tr) * math.cos(math.radians(ti))
            worst = max(worst, abs(v / expect - 1))
    for light, view in ((_dir(30, 10), _dir(40, 200)), (_dir(55, -40), _dir(20, 90)), (_dir(5, 0), _dir(70, 135))):
        v = bsdf.eval(ctx, _si(view), mi.Vector3f(*light))[0]
        expect = SCALE * m.eval_vectors(light, view) * light[2]
        worst = max(worst, abs(v / expect - 1))
    assert worst < 1e-5, worst


def _chi2_sf(x, k):
    """Upper tail of chi-square (Wilson-Hilferty), accurate enough for a test level."""
    z = ((x / k) ** (1 / 3) - (1 - 2 / (9 * k))) / math.sqrt(2 / (9 * k))
    return 0.5 * math.erfc(z / math.sqrt(2))


@pytest.mark.parametrize("theta_view", [20.0, 60.0])
def test_sampled_directions_follow_pdf_chi_square(bsdf, theta_view):
    """As Mitsuba's own BSDF tests: histogram sampled directions over (cos theta, phi)
    cells, integrate pdf over each cell, pool cells expecting < 5, chi-square test."""
    rng = np.random.default_rng(7)
    ctx = mi.BSDFContext()
    si = _si(_dir(theta_view, 0.0))
    n, nc, nphi = 20000, 10, 20
    hist = np.zeros((nc, nphi))
    for u1, u2, u3 in rng.random((n, 3)):
        bs, _ = bsdf.sample(ctx, si, float(u1), mi.Point2f(float(u2), float(u3)))
        if bs.pdf > 0:
            wo = bs.wo
            c = min(int(wo.z * nc), nc - 1)
            p = min(int((math.atan2(wo.y, wo.x) % (2 * math.pi)) / (2 * math.pi) * nphi), nphi - 1)
            hist[c, p] += 1
    sub = 12
    expect = np.zeros_like(hist)
    for c in range(nc):
        for p in range(nphi):
            acc = 0.0
            for a in range(sub):
                z = (c + (a + 0.5) / sub) / nc
                for b in range(sub):
                    phi = (p + (b + 0.5) / sub) / nphi * 2 * math.pi
                    s = math.sqrt(max(0.0, 1 - z * z))
                    acc += bsdf.pdf(ctx, si, mi.Vector3f(s * math.cos(phi), s * math.sin(phi), z))
            expect[c, p] = acc / sub ** 2 * (1 / nc) * (2 * math.pi / nphi) * n
    assert abs(expect.sum() / n - 1) < 0.02  # pdf integrates to 1 over the hemisphere
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
    p = _chi2_sf(chi2, dof)
    assert p > 0.01, (chi2, dof, p)


@pytest.mark.parametrize("theta_view", [10.0, 45.0, 75.0])
def test_sampled_albedo_equals_the_quadrature(bsdf, theta_view):
    m = gonio.Model.preset("fe-0.115")
    ctx = mi.BSDFContext()
    si = _si(_dir(theta_view, 0.0))
    rng = np.random.default_rng(11)
    vals = []
    for u1, u2, u3 in rng.random((20000, 3)):
        _, w = bsdf.sample(ctx, si, float(u1), mi.Point2f(float(u2), float(u3)))
        vals.append(w[0])
    vals = np.array(vals)
    est, se = vals.mean(), vals.std() / math.sqrt(len(vals))
    rho, err = m.albedo(theta_view, reverse=True)
    assert abs(est - SCALE * rho) < 4 * se + SCALE * err, (est, se, SCALE * rho)
    assert se < 0.02 * est  # the importance sampling keeps the estimate tight


def test_sphere_renders_with_the_highlight_at_the_mirror_point():
    mi.set_variant("scalar_rgb")
    img = gm.render_sphere(gonio.Model.preset("fe-0.115"), resolution=64, spp=2, light_deg=40.0)
    assert img.shape == (64, 64, 3) and np.all(np.isfinite(img)) and img.max() > 0
    row, col = np.unravel_index(np.argmax(img[..., 0]), img.shape[:2])
    er, ec = gm.highlight_pixel(resolution=64, light_deg=40.0)
    assert abs(row + 0.5 - er) <= 2 and abs(col + 0.5 - ec) <= 2, ((row, col), (er, ec))
    # The highlight is off-centre, towards the light: the test can tell.
    assert ec - 32 > 8
