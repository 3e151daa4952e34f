"""The model family from Python: the same values, validation and messages as brdf-core."""

import subprocess
import threading
import time

import numpy as np
import pytest

import gonio


def test_presets_and_members():
    names = [p["name"] for p in gonio.presets()]
    assert "fe-0.115" in names and len(names) == 5
    fe = next(p for p in gonio.presets() if p["name"] == "fe-0.115")
    assert fe["sigma"] == 0.115 and fe["ks_table"][0] == 115.0
    assert len(gonio.members()) == 83
    assert gonio.member_name("ideal-diffuse+specular") == "torrance-sparrow"
    comps, dists = gonio.vocabulary()
    # `abg`, the ABg scatter model, is a member name of its own (it stands alone).
    assert comps == ["specular", "specular-haze", "directional-diffuse", "ideal-diffuse", "abg"]
    assert dists == ["beckmann", "ggx"]


def _params_for(name):
    """Parameters every member of the family accepts (k_s form after its lobe's name)."""
    canon = gonio.member_name(name)
    paper = {"torrance-sparrow": "specular+ideal-diffuse",
             "three-component": "specular+directional-diffuse+ideal-diffuse",
             "three-component-smooth-ks": "specular:smooth-ks+directional-diffuse+ideal-diffuse",
             "ideal-diffuse": "ideal-diffuse"}
    parts = paper.get(canon, canon).split("+")
    kw = {}
    for part in parts:
        smooth = "smooth-ks" in part
        if part.startswith("specular-haze"):
            kw.update(ks_haze=[2.0, 0.1, 0.0] if smooth else 10.0, sigma_haze=0.4)
        elif part.startswith("specular"):
            kw.update(ks=[5.0, 0.1, 0.0] if smooth else 100.0, sigma=0.1)
    return canon, kw


def test_every_member_builds_and_evaluates():
    for name in gonio.members():
        canon, kw = _params_for(name)
        m = gonio.Model(name, **kw)
        assert m.member == canon
        f = m.eval([0.0, 30.0, 60.0], [0.0, 30.0, -45.0])
        assert f.shape == (3,) and np.all(np.isfinite(f)) and np.all(f >= 0)


def test_preset_matches_the_cli(gonio_bin):
    out = subprocess.run([gonio_bin, "eval", "--material", "fe-0.115", "--theta-i", "25", "--theta-r=-80:80:10"],
                         check=True, capture_output=True, text=True).stdout
    rows = np.array([[float(x) for x in line.split(",")] for line in out.splitlines()[1:]])
    m = gonio.Model.preset("fe-0.115")
    np.testing.assert_array_equal(m.eval(rows[:, 0], rows[:, 1]), rows[:, 2])


def test_shapes_broadcast_and_scalars():
    m = gonio.Model.preset("fe-0.115")
    ti = np.linspace(0, 80, 6).reshape(2, 3, 1)
    tr = np.linspace(-80, 80, 5)
    f = m.eval(ti, tr)
    assert f.shape == (2, 3, 5)
    assert f[1, 2, 4] == m.eval(float(ti[1, 2, 0]), 80.0)
    assert isinstance(m.eval(20.0, 20.0), float)
    g = m.eval_grid(ti.ravel(), tr)
    np.testing.assert_array_equal(g, f.reshape(6, 5))


def test_fast_f32_path_within_its_bound():
    m = gonio.Model.preset("fe-0.115")
    ti = np.linspace(0, 85, 86)
    tr = np.linspace(-85, 85, 341)
    exact = m.eval_grid(ti, tr)
    grid = m.eval_grid(ti, tr, precision="f32")
    assert grid.dtype == np.float32
    assert np.max(np.abs(grid / exact - 1)) < 1e-5
    ti2, tr2 = np.meshgrid(ti, tr, indexing="ij")
    scalar = m.eval(ti2.astype(np.float32), tr2.astype(np.float32), precision="f32")
    assert np.max(np.abs(scalar / exact - 1)) < 1e-5


def test_out_of_plane_vectors_agree_in_plane():
    m = gonio.Model.preset("cu-0.070")
    ti, tr = 35.0, 20.0
    a, b = np.radians(ti), np.radians(tr)
    wi = [np.sin(a), 0, np.cos(a)]
    wr = [-np.sin(b), 0, np.cos(b)]  # positive theta_r: the specular side
    assert m.eval_vectors(wi, wr) == pytest.approx(m.eval(ti, tr), rel=1e-12)
    assert m.eval_dir(wi, wr) == pytest.approx(m.eval(ti, tr), rel=1e-12)
    wr3 = np.array([[-0.3, 0.4, np.sqrt(1 - 0.25)]] * 4)
    assert m.eval_vectors(np.array([wi] * 4), wr3).shape == (4,)


def test_errors_are_the_cores_messages():
    m = gonio.Model.preset("fe-0.115")
    with pytest.raises(gonio.GonioError, match=r"theta_i = 95 is outside \[0, 90\] degrees"):
        m.eval(95, 0)
    with pytest.raises(gonio.GonioError, match=r"theta_r = -91 is outside"):
        m.eval([10, 20], [0, -91], precision="f32")
    with pytest.raises(gonio.GonioError, match="theta_i must be a finite number"):
        m.eval(np.nan, 0)
    with pytest.raises(gonio.GonioError, match="preset 'gold'"):
        gonio.Model.preset("gold")
    with pytest.raises(gonio.GonioError, match="sigma must be > 0"):
        gonio.Model("three-component", ks=100, sigma=-1)
    with pytest.raises(gonio.GonioError, match="unknown component"):
        gonio.Model("specular+glitter")
    with pytest.raises(gonio.GonioError, match="belongs to specular-haze"):
        gonio.Model("three-component", ks=1, sigma=0.1, ks_haze=1)
    with pytest.raises(gonio.GonioError, match="fast f32 path"):
        gonio.Model("specular:ggx+ideal-diffuse", ks=1, sigma=0.1).eval(10, 10, precision="f32")
    assert issubclass(gonio.GonioError, ValueError)


def test_a_student_t_lobe_takes_its_tail_exponent():
    # The lobe gonio fit selects on real metals, checked against its formula written
    # out here: P22(r) = (1 + r^2/(k m^2))^-gamma / (pi m^2), D = P22(tan a)/cos^4 a,
    # f = k_s D G / (4 cos_i cos_r), m^2 = 2 sigma^2, k = gamma - 1, G = 1 this close
    # to the mirror. gamma 2.5 is neither GGX's 2 nor the fit's start of 1.5.
    ks, sigma, gamma = 3.0, 0.05, 2.5
    m = gonio.Model("specular:student-t", ks=ks, sigma=sigma, gamma=gamma)
    tr = np.array([0.0, 10.0])
    a = np.radians(tr / 2)
    m2 = 2 * sigma**2
    z = np.tan(a) ** 2 / ((gamma - 1) * m2)
    want = ks * (1 + z) ** -gamma / (np.pi * m2 * np.cos(a) ** 4) / (4 * np.cos(np.radians(tr)))
    np.testing.assert_allclose(m.eval([0.0, 0.0], tr), want, rtol=1e-12)
    with pytest.raises(gonio.GonioError, match="give its tail exponent with gamma="):
        gonio.Model("specular:student-t", ks=ks, sigma=sigma)
    with pytest.raises(gonio.GonioError, match="give its tail exponent with gamma_haze="):
        gonio.Model("specular+specular-haze:student-t", ks=1, sigma=0.01, ks_haze=1, sigma_haze=0.1)
    with pytest.raises(gonio.GonioError, match="specular is beckmann"):
        gonio.Model("three-component", ks=1, sigma=0.1, gamma=2)
    with pytest.raises(gonio.GonioError, match="belongs to specular-haze"):
        gonio.Model("three-component", ks=1, sigma=0.1, gamma_haze=2)
    with pytest.raises(gonio.GonioError, match="gamma - 1 must be > 0"):
        gonio.Model("specular:student-t", ks=ks, sigma=sigma, gamma=1.0)


def test_components_sum_to_the_model():
    m = gonio.Model.preset("al-0.142")
    ti, tr = np.meshgrid(np.linspace(0, 80, 9), np.linspace(-80, 80, 33), indexing="ij")
    total = sum(m.component(c).eval(ti, tr) for c in m.components)
    np.testing.assert_allclose(total, m.eval(ti, tr), rtol=1e-12)


def test_albedo_is_the_cores_quadrature():
    m = gonio.Model("ideal-diffuse", kid=1.0)
    rho, err = m.albedo(30.0)
    assert rho == pytest.approx(np.pi, rel=1e-12) and err < 1e-9


def test_batch_releases_the_gil():
    """While a worker thread is inside a batch evaluation, the main thread keeps
    running Python: it could not if the batch held the GIL."""
    m = gonio.Model.preset("fe-0.115")
    ti = np.linspace(0, 85, 1000)
    tr = np.linspace(-85, 85, 3000)

    done = threading.Thread(target=int)
    done.start()
    done.join()
    n, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < 0.1:  # the same loop body as below
        n += 1
        done.is_alive()
    rate = n / 0.1
    worker = threading.Thread(target=m.eval_grid, args=(ti, tr))
    t0 = time.perf_counter()
    worker.start()
    n = 0
    while worker.is_alive():
        n += 1
        time.perf_counter()
    elapsed = time.perf_counter() - t0
    worker.join()
    assert elapsed > 0.05, "the batch is too short to tell"
    # Held, the main thread would get one switch interval (5 ms) at most.
    assert n > 0.05 * rate * elapsed


@pytest.mark.parametrize("ti,tr", [("95", "0"), ("nan", "0"), ("10", "-91"), ("90", "90")])
def test_errors_equal_the_clis(gonio_bin, ti, tr):
    """The same bad angle gives `gonio eval`'s message on both paths (after a good pair,
    so a batch cannot stop at the first element)."""
    cli = subprocess.run([gonio_bin, "eval", "--material", "fe-0.115", "--theta-i", ti, f"--theta-r={tr}"],
                         capture_output=True, text=True)
    assert cli.returncode == 2, cli
    want = cli.stderr.strip().removeprefix("gonio: ")
    m = gonio.Model.preset("fe-0.115")
    for precision in ("f64", "f32"):
        with pytest.raises(gonio.GonioError) as e:
            m.eval([10.0, float(ti)], [0.0, float(tr)], precision=precision)
        assert str(e.value) == want, precision


def test_a_fresnel_lobe_takes_k0_n_k_and_reports_k0_f_on_the_mirror_direction():
    # Aluminium at 532 nm (Rakic 1995): F(0) = ((n-1)^2 + k^2) / ((n+1)^2 + k^2).
    n, k = 0.9387770491803277, 6.419537704918032
    m = gonio.Model("specular:beckmann:fresnel+ideal-diffuse", ks=[2.0, n, k], sigma=0.1, kid=0.01)
    assert m.member == "specular:beckmann:fresnel+ideal-diffuse"
    assert m.params["ks"] == [2.0, n, k]
    f0 = ((n - 1) ** 2 + k ** 2) / ((n + 1) ** 2 + k ** 2)
    assert abs(m.ks_at(0.0) - 2.0 * f0) < 1e-12
    # A metal's F first dips (its p reflectance: 0.864 at 80 degrees), then rises to 1
    # at grazing (0.983 at 89.5): k_s approaches k0.
    assert m.ks_at(80.0) < m.ks_at(0.0) < m.ks_at(89.5) < 2.0
    f = m.eval([0.0, 40.0, 80.0], [0.0, 40.0, 75.0])
    assert np.all(np.isfinite(f)) and np.all(f > 0)
    with pytest.raises(gonio.GonioError, match=r"a Fresnel k_s is \[k0, n, k\]"):
        gonio.Model("specular:fresnel", ks=2.0, sigma=0.1)


def test_appearance_of_a_lambertian_is_the_closed_form():
    """Gloss 20 of f = 0.2 / sr: 100 f (sin 20.9 - sin 19.1)(h/2 + sin(h)/2) / R(1.567, 20),
    h = 3.6 degrees, R the black glass's Fresnel reflectance (docs/appearance.md)."""
    m = gonio.Model("ideal-diffuse", kid=0.2)
    with pytest.raises(gonio.GonioError, match="1/sr"):
        m.appearance()
    a = m.appearance(scale=1.0)
    t, h, d = np.radians(20.0), np.radians(3.6), np.radians(0.9)
    frac = 0.2 * (np.sin(t + d) - np.sin(t - d)) * (h / 2 + np.sin(h) / 2)
    n, c = 1.567, np.cos(t)
    s = np.sqrt(n * n - 1 + c * c)
    r = 0.5 * ((c - s) / (c + s)) ** 2 + 0.5 * ((n * n * c - s) / (n * n * c + s)) ** 2
    g20 = a["gloss"][0]["gu"]["value"]
    assert g20 == pytest.approx(100 * frac / r, rel=1e-3)
    assert [g["geometry_deg"] for g in a["gloss"]] == [20.0, 60.0, 85.0]
    assert a["e430"]["doi"]["value"] == pytest.approx(0.0, abs=0.2)
