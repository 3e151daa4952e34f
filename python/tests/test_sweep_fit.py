"""Sweep files and the fitter from Python: the CLI's reader, writer, fitter and JSON."""

import json
import subprocess

import numpy as np
import pytest

import gonio
from conftest import FE_SWEEP


def test_read_sweep_into_arrays():
    s = gonio.read_sweep(FE_SWEEP)
    assert s.meta["plan"] == "paper"
    assert s.columns[:3] == ["theta_i", "theta_r", "brdf"]
    assert s.theta_i.shape == s.brdf.shape == (153,)
    assert np.all(s.brdf > 0) and np.all(np.isfinite(s.std))
    assert s.points.shape == (153, 2)


def test_write_then_read_round_trips(tmp_path):
    m = gonio.Model.preset("cu-0.070")
    ti, tr = np.meshgrid([10.0, 30.0, 50.0], np.arange(-80.0, 81.0, 5.0), indexing="ij")
    y = m.eval(ti, tr)
    path = tmp_path / "cu.csv"
    gonio.write_sweep(path, ti, tr, y)
    s = gonio.read_sweep(path)
    np.testing.assert_array_equal(s.brdf, y.ravel())
    assert np.all(np.isnan(s.std))
    with pytest.raises(gonio.GonioError, match="exists"):
        gonio.write_sweep(path, ti, tr, y)
    gonio.write_sweep(path, ti, tr, y, force=True)


def test_write_sweep_writes_only_what_reads_back_the_same(tmp_path):
    # Issue 41 item 6: injected metadata lines, NaN, 1e35 and angles beyond any arm
    # are refused, nothing written; a file it writes reads back complete (seq = index).
    path = tmp_path / "w.csv"
    ti, tr, y = np.array([10.0, 10.0, 30.0]), np.array([-20.0, 20.0, 40.0]), np.array([1.0, 2.0, 3.0])
    with pytest.raises(gonio.GonioError, match="one line"):
        gonio.write_sweep(path, ti, tr, y, plan="paper\n# brdf: 1/sr\n# aperture: 10")
    for bad in ([np.nan, 2.0, 3.0], [1e35, 2.0, 3.0]):
        with pytest.raises(gonio.GonioError, match="nothing written"):
            gonio.write_sweep(path, ti, tr, np.array(bad))
    with pytest.raises(gonio.GonioError, match="not an angle"):
        gonio.write_sweep(path, np.array([1e300, 10.0, 30.0]), tr, y)
    assert not path.exists()
    gonio.write_sweep(path, ti, tr, y)
    s = gonio.read_sweep(path)
    np.testing.assert_array_equal(s.seq, [0, 1, 2])
    assert s.meta["status"].startswith("complete     readings=0000003 missing=0000000")


def test_bad_sweep_file_message(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("theta_i,theta_r,brdf\n10,20,x\n")
    with pytest.raises(gonio.GonioError, match="bad.csv:2"):
        gonio.read_sweep(bad)


def fit_as_cli(gonio_bin, path, argv, **kwargs):
    """gonio.fit(path, **kwargs) and `gonio fit path --json *argv`, their JSON the same
    but for fit_seconds: (the result, its JSON, the command's JSON)."""
    r = gonio.fit(path, **kwargs)
    cli = json.loads(subprocess.run([gonio_bin, "fit", str(path), "--json", *argv], check=True,
                                    capture_output=True, text=True).stdout)
    ours = json.loads(r.to_json())
    for d in (cli, ours):
        d.pop("fit_seconds")
    assert_same_json(ours, cli)
    return r, ours, cli


def test_fit_result_and_json_equal_the_cli(gonio_bin):
    fit_as_cli(gonio_bin, FE_SWEEP, [])


def assert_same_json(a, b, path="$"):
    """Equal keys, lists, strings and integers; floats equal to 1e-12 relative.

    The wheel is a release build and the CLI under test a debug build of the same
    code; their floating-point results may differ in the last bit (optimised code may
    evaluate a library function such as powi differently), never more.
    """
    assert type(a) is type(b), f"{path}: {a!r} vs {b!r}"
    if isinstance(a, dict):
        assert sorted(a) == sorted(b), f"{path}: keys {sorted(a)} vs {sorted(b)}"
        for k in a:
            assert_same_json(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, list):
        assert len(a) == len(b), f"{path}: length {len(a)} vs {len(b)}"
        for i, (x, y) in enumerate(zip(a, b)):
            assert_same_json(x, y, f"{path}[{i}]")
    elif isinstance(a, float):
        assert a == pytest.approx(b, rel=1e-12, abs=1e-300), f"{path}: {a!r} vs {b!r}"
    else:
        assert a == b, f"{path}: {a!r} vs {b!r}"


def test_fit_result_object():
    r = gonio.fit(FE_SWEEP)
    assert r.selected == "three-component"
    best = r.best
    assert best.params["sigma"] == pytest.approx(0.115, rel=0.05)
    assert best.std_errors["sigma"] > 0
    assert np.isfinite(best.aicc) and np.isfinite(best.bic)
    assert len(best.rmse_by_theta_i) == len(r.incidences)
    # Under log residuals the residual is ln(measured / fitted), the sign of the export
    # and the plots' panels (the default objective's is g(measured) - g(fitted)).
    res = gonio.fit(FE_SWEEP, residual="log").residuals()
    assert res["residual"].shape == (153,)
    np.testing.assert_allclose(res["residual"], np.log(res["measured"]) - np.log(res["fitted"]))
    # About the simulated 0.5 % noise (log residuals ~ relative).
    assert np.std(res["residual"]) < 0.02
    fitted = r.model()
    assert fitted.member == "three-component"
    np.testing.assert_allclose(fitted.eval(res["theta_i"], res["theta_r"]), res["fitted"], rtol=1e-12)


def test_fit_options_as_on_the_command_line(gonio_bin):
    r, _, _ = fit_as_cli(gonio_bin, FE_SWEEP,
                         ["--fix", "sigma_m=0.7", "--fix", "kdd=900", "--models", "ts,three",
                          "--loss", "cauchy:0.05"],
                         fix={"sigma_m": 0.7, "kdd": 900}, models="ts,three", loss="cauchy:0.05")
    assert set(r.models) == {"torrance-sparrow", "three-component"}
    assert r.models["three-component"].fixed == ["sigma_m", "k_dd"]


def test_fit_aperture_and_instrument_as_on_the_command_line(gonio_bin, tmp_path):
    inst = tmp_path / "inst.toml"
    inst.write_text('k = 2000.0\nu_k = 4.0\nstandard = "lambertian:0.99"\nreference_file = "ref.csv"\n'
                    'date = "2026-12-02T00:00:00Z"\nreadings = 150\n')
    for kw, argv in (({"aperture": 0.5}, ["--aperture", "0.5"]),
                     ({"instrument": inst}, ["--instrument", str(inst)])):
        r, _, cli = fit_as_cli(gonio_bin, FE_SWEEP, ["--models", "three", *argv], models="three", **kw)
    assert cli["brdf_units"] == "1/sr" and cli["instrument"]["k"] == 2000.0
    assert r.model().to_per_sr == 1.0
    aperture = json.loads(gonio.fit(FE_SWEEP, models="three", aperture=0.5).to_json())
    assert aperture["models"][0]["aperture_deg"] == 0.5
    # One pipeline: an aperture combines with a robust loss (it was refused).
    robust = json.loads(gonio.fit(FE_SWEEP, models="three", aperture=0.5, loss="cauchy:0.05").to_json())
    assert robust["models"][0]["aperture_deg"] == 0.5
    with pytest.raises(gonio.GonioError, match="no-such.toml"):
        gonio.fit(FE_SWEEP, instrument=tmp_path / "no-such.toml")


def test_fit_with_an_instrument_is_fitting_the_converted_file(gonio_bin, tmp_path):
    # The readings and their noise both in 1/sr: chi2/dof as the converted file's, to
    # 1e-9 (the noise was once left in relative units: ideal-diffuse "within noise").
    inst = tmp_path / "inst.toml"
    inst.write_text('k = 2000.0\nu_k = 4.0\nstandard = "lambertian:0.99"\nreference_file = "ref.csv"\n'
                    'date = "2026-12-02T00:00:00Z"\nreadings = 150\n')
    conv = tmp_path / "fe-abs.csv"
    subprocess.run([gonio_bin, "convert", str(FE_SWEEP), "--instrument", str(inst), "--out", str(conv)],
                   check=True, capture_output=True)
    with_inst = json.loads(gonio.fit(FE_SWEEP, instrument=inst).to_json())
    converted = json.loads(gonio.fit(conv).to_json())
    assert [m["name"] for m in with_inst["models"]] == [m["name"] for m in converted["models"]]
    for a, b in zip(with_inst["models"], converted["models"]):
        for key in ("reduced_chi2", "ssr"):
            assert a[key] == pytest.approx(b[key], rel=1e-9, abs=0), (a["name"], key)
    ideal = next(m for m in with_inst["models"] if m["name"] == "ideal-diffuse")
    assert ideal["reduced_chi2"] > 1e4


def test_fit_arrays_and_errors():
    s = gonio.read_sweep(FE_SWEEP)
    # Log residuals: the arrays carry no std column, whose noise the default objective
    # would weigh the file's readings by.
    r = gonio.fit(s.theta_i, s.theta_r, s.brdf, models=["three"], residual="log")
    assert (json.loads(r.to_json())["models"][0]["params"]
            == gonio.fit(FE_SWEEP, models=["three"], residual="log").best.params)
    with pytest.raises(gonio.GonioError, match="--loss 'l3'"):
        gonio.fit(FE_SWEEP, loss="l3")
    with pytest.raises(gonio.GonioError, match="--fix: unknown parameter 'q'"):
        gonio.fit(FE_SWEEP, fix=["q=1"])
    with pytest.raises(gonio.GonioError, match="--models 'four': unknown component"):
        gonio.fit(FE_SWEEP, models=["four"])
    with pytest.raises(gonio.GonioError, match="--residual 'lin': use noise, log, rel or abs"):
        gonio.fit(FE_SWEEP, residual="lin")
    with pytest.raises(gonio.GonioError, match="--aperture 11: expected a half-angle"):
        gonio.fit(FE_SWEEP, aperture=11.0)
    with pytest.raises(gonio.GonioError, match="at least 3"):
        gonio.fit([10.0], [10.0], [1.0])


def test_fit_floor_as_on_the_command_line(gonio_bin, tmp_path):
    # A copper sweep whose five farthest readings sit on a detection floor.
    m = gonio.Model.preset("cu-0.070")
    ti, tr = np.meshgrid([10.0, 30.0, 50.0], np.arange(-80.0, 81.0, 5.0), indexing="ij")
    y = m.eval(ti, tr)
    floor = float(y.min()) / 10
    y.ravel()[np.argsort(np.abs(tr.ravel()))[-5:]] = floor
    path = tmp_path / "cu-floor.csv"
    gonio.write_sweep(path, ti, tr, y)
    for value, argv in (("auto", ["--floor", "auto"]), (floor, ["--floor", repr(floor)])):
        _, ours, _ = fit_as_cli(gonio_bin, path, ["--models", "three", *argv], models="three", floor=value)
        assert any("5 reading" in n for n in ours["notes"]), ours["notes"]
    unfloored = json.loads(gonio.fit(path, models="three").to_json())
    assert unfloored["models"][0]["ssr"] > ours["models"][0]["ssr"]
    with pytest.raises(gonio.GonioError, match="--floor"):
        gonio.fit(path, floor="often")


def test_fit_all_starts_as_on_the_command_line(gonio_bin, tmp_path):
    # A simulated copper sweep on which a start the default stops early leads the
    # two-lobe member to an optimum ~10 % lower in SSR.
    path = tmp_path / "cu.csv"
    subprocess.run([gonio_bin, "simulate", "--material", "cu-0.070", "--seed", "2", "--out", str(path), "-q"],
                   check=True)
    _, ours, _ = fit_as_cli(gonio_bin, path, ["--all-starts"], all_starts=True)
    ssr = lambda d: {m["name"]: m["ssr"] for m in d["models"]}
    default = ssr(json.loads(gonio.fit(path).to_json()))
    two = "specular:beckmann+specular-haze:beckmann+directional-diffuse+ideal-diffuse"
    assert ssr(ours)[two] < 0.95 * default[two]
    assert all(ssr(ours)[m] <= s for m, s in default.items())
    # A flag, as on the command line: "no" is not read as true.
    with pytest.raises(TypeError):
        gonio.fit(path, all_starts="no")


def test_fit_offset_as_on_the_command_line(gonio_bin, tmp_path):
    # The iron sweep with every detector angle read 2 degrees high: a detector zero offset.
    s = gonio.read_sweep(FE_SWEEP)
    path = tmp_path / "fe-off.csv"
    gonio.write_sweep(path, s.theta_i, s.theta_r + 2.0, s.brdf)
    # Log residuals: the sweep written here has no std column, and its noise is purely
    # relative (the default objective's rule would count its lowest readings in
    # absolute terms).
    for value, argv in (("fit", ["--offset", "fit"]), (2.0, ["--offset", "2.0"])):
        _, ours, _ = fit_as_cli(gonio_bin, path, ["--residual", "log", *argv], offset=value, residual="log")
        assert abs(ours["angles"]["detector_offset_deg"] - 2.0) < 0.05, ours["angles"]
        assert ours["angles"]["fitted"] == (value == "fit")
    assert "angles" not in json.loads(gonio.fit(path).to_json())
    # Issue 50 case 7: the default (noise) objective finds it too, within its standard
    # error (it gave 1.72 +- 0.066: the selected member's misfit passed for a tilt).
    angles = json.loads(gonio.fit(path, offset="fit").to_json())["angles"]
    assert abs(angles["detector_offset_deg"] - 2.0) <= 2.0 * angles["detector_offset_se"], angles
    assert angles["tilt_deg"] == 0.0 and angles["tilt_hidden_by_misfit"], angles
    with pytest.raises(gonio.GonioError, match="--offset 'often': expected 'fit'"):
        gonio.fit(path, offset="often")
    with pytest.raises(gonio.GonioError, match="within"):
        gonio.fit(path, offset=11)


def test_eval_grid_refuses_a_grid_too_large_before_allocating():
    # Issue 41 item 4: 10^5 x 10^6 angles asked for 800 GB and aborted the interpreter.
    m = gonio.Model.preset("cu-0.070")
    for precision in ("f64", "f32"):
        with pytest.raises(gonio.GonioError, match="100000 x 1000000 angles"):
            m.eval_grid(np.zeros(100_000), np.zeros(1_000_000), precision=precision)
    assert m.eval_grid(np.array([10.0, 20.0]), np.array([0.0, 5.0, 10.0])).shape == (2, 3)


def test_fit_refuses_more_readings_than_the_cli_before_converting_them():
    # Issue 41 item 5: fit on 10^7 readings ran 240 s in 7.1 GB. The limit is the CLI's
    # (what a 64 MiB sweep file holds), checked before the arrays become lists.
    n = gonio.MAX_FIT_READINGS + 1
    assert gonio.MAX_FIT_READINGS == 2_097_152
    # Three columns of n readings each (views, no memory): scalars are refused since
    # nothing is broadcast (issue 50 case 1).
    ti, tr, f = (np.broadcast_to(np.float64(v), (n,)) for v in (20.0, 10.0, 1.0))
    with pytest.raises(gonio.GonioError, match=f"^{n} readings: more than one fit takes \\(2097152, what a 64 MiB sweep file holds\\)"):
        gonio.fit(ti, tr, f)


def test_readings_of_other_shapes_are_refused_never_broadcast(tmp_path):
    # Issue 50 case 1: a theta_r column against theta_i and brdf rows broadcast to
    # n x n fabricated readings, fitted and written without a word.
    s = gonio.read_sweep(FE_SWEEP)
    for args in ((s.theta_i, s.theta_r.reshape(-1, 1), s.brdf),
                 (s.theta_i, s.theta_r[:-1], s.brdf),
                 (s.theta_i[0], s.theta_r, s.brdf)):
        with pytest.raises(gonio.GonioError, match="shapes .* must be the same"):
            gonio.fit(*args, models="three")
        with pytest.raises(gonio.GonioError, match="nothing is broadcast"):
            gonio.write_sweep(tmp_path / "w.csv", *args)
    assert not (tmp_path / "w.csv").exists()


def test_keep_saturated_as_on_the_command_line(gonio_bin, tmp_path):
    # A capture's warning flags the reading seq 12 saturated: left out unless told.
    text = FE_SWEEP.read_text()
    lines = text.splitlines(keepends=True)
    k = next(i for i, line in enumerate(lines) if line.startswith("theta_i,"))
    lines.insert(k + 2, "# warning: saturated reading seq 12: 4 detector conversions at full scale\n")
    path = tmp_path / "clipped.csv"
    path.write_text("".join(lines))
    fits = {}
    for keep, argv in ((False, []), (True, ["--keep-saturated"])):
        _, fits[keep], _ = fit_as_cli(gonio_bin, path, ["--models", "three", *argv], models="three",
                                      keep_saturated=keep)
    assert fits[False] != fits[True]
