"""Campbell maps of run-ups: synthetic run-ups from polywear's own ramp simulation, with
sensor noise and wheel-order features added; the detector must find the SEV onset
(ramp-corrected) near the model's Hopf speed, its frequency, and must not take the order
lines for SEV."""

from __future__ import annotations

import json
import math
import sys

import numpy as np
import pytest

from polywear.measured.campbell import campbell
from polywear.units import order_frequency_hz
from polywear.measured.run_file import MeasurementError, read_run
from polywear.measured.sev_detection import remove_orders
from polywear.measured.runup import simulate_ramp
from polywear.dynamics.stability import stability
from polywear.params import Params

from .cli_runner import run_main

FS = 2000.0
ORDERS = (8.0, 16.0)  # order 16 crosses the SEV frequency at about 54 km/h, just below the onset


@pytest.fixture(scope="module")
def runup(tmp_path_factory):
    """40 -> 80 km/h at 4 km/h/s, tread kicked by 1 um every 20 ms; lateral tread
    acceleration + white noise (0.5 m/s^2) + orders 8 and 16 (3 m/s^2 each), as CSV."""
    params = Params()
    sim = simulate_ramp(params, 40.0, 80.0, 4.0, FS, kick_m=1e-6, seed=1)
    rng = np.random.default_rng(5)
    radius = params.operating.rolling_radius_m
    signal = sim.acceleration + 0.5 * rng.standard_normal(sim.t.size)
    for n in ORDERS:
        signal += 3.0 * np.sin(2 * np.pi * np.cumsum(order_frequency_hz(n, sim.speed_kmh, radius)) / FS)
    path = tmp_path_factory.mktemp("runup") / "run.csv"
    np.savetxt(path, np.column_stack([sim.t * 1000.0, sim.speed_kmh / 3.6, signal]), delimiter=",",
               header="time [ms],speed [m/s],acc_y [m/s^2]", comments="")
    hopf = stability(params).hopf_points[0]
    return path, hopf


def _check_features(result, hopf):
    sev = [f for f in result.features if f["sev"]]
    assert len(sev) == 1
    assert sev[0]["kind"] == "constant_frequency"
    assert sev[0]["frequency_from_hz"] <= hopf.frequency_hz * 1.02
    orders = [f for f in result.features if f["kind"] == "order"]
    for n in ORDERS:
        assert any(abs(f["frequency_order"] - n) < 0.05 for f in orders), n
    assert not any(f["sev"] for f in orders)
    assert result.sev["frequency_hz"] == pytest.approx(hopf.frequency_hz, rel=0.01)
    assert result.sev["orders_removed"]


def test_map_features_and_sev_without_the_model(runup):
    path, hopf = runup
    run = read_run(path)
    assert run.sample_rate_hz == pytest.approx(FS)  # ms -> s
    assert run.speed_kmh.max() == pytest.approx(80.0)  # m/s -> km/h
    result = campbell(run, Params(), predict=False, correct_ramp=False)
    _check_features(result, hopf)
    onset = result.sev["onset"]
    assert "corrected_speed_kmh" not in onset
    assert abs(onset["speed_kmh"] - hopf.speed_kmh) < 6.0  # uncorrected: late by the ramp delay, at most
    assert result.power_db.shape[1:] == (result.frequencies_hz.size, result.times_s.size)


@pytest.mark.slow
def test_ramp_corrected_onset_within_2_kmh_of_the_hopf_speed(runup):
    path, hopf = runup
    result = campbell(read_run(path), Params())
    _check_features(result, hopf)
    onset = result.sev["onset"]
    assert abs(onset["corrected_speed_kmh"] - hopf.speed_kmh) < 2.0, onset
    assert onset["ramp_rate_kmh_per_s"] == pytest.approx(4.0, rel=1e-6)
    assert onset["corrected_uncertainty_kmh"] > 0.0
    assert "ramp-corrected" in onset["correction"]
    assert result.prediction["hopf_points"][0]["speed_kmh"] == pytest.approx(hopf.speed_kmh, rel=1e-6)
    # as calibration observations: the Hopf point's speed and frequency, truth within 2 sigma
    entries = {e["quantity"]: e for e in result.observations()}
    assert set(entries) == {"first_hopf_kmh", "hopf_frequency_hz"}
    for quantity, truth in (("first_hopf_kmh", hopf.speed_kmh), ("hopf_frequency_hz", hopf.frequency_hz)):
        assert abs(entries[quantity]["value"] - truth) < 2.0 * entries[quantity]["sigma"], (quantity, entries)


def test_order_removal_keeps_constant_frequency():
    """An order line (70-141 Hz over the ramp) is removed to 2 %; a 160 Hz tone beside it
    stays; a 130 Hz tone that the order line crosses keeps its power within 10 %."""
    fs, radius = 1000.0, 0.3
    t = np.arange(0, 8.0, 1 / fs)
    speed = 40.0 + 5.0 * t
    order = np.sin(2 * np.pi * np.cumsum(order_frequency_hz(12.0, speed, radius)) / fs)
    core = slice(1000, -1000)  # away from the filter's start and end transients
    for f_tone, tol in ((160.0, 0.02), (130.0, None)):
        tone = 0.5 * np.sin(2 * np.pi * f_tone * t)
        cleaned = remove_orders(order + tone, speed, fs, [12.0], radius)
        if tol is not None:
            assert np.std(cleaned[core] - tone[core]) < tol * np.std(order[core])
        assert np.std(cleaned[core]) == pytest.approx(np.std(tone[core]), rel=0.1)


def test_read_run_units_and_errors(tmp_path):
    t = np.arange(0, 1.0, 1e-3)
    wheel = np.full_like(t, 500.0)  # rpm
    path = tmp_path / "w.csv"
    np.savetxt(path, np.column_stack([t, wheel, np.sin(t)]), delimiter=",", header="t (s),wheel speed (rpm),a (g)",
               comments="")
    run = read_run(path, rolling_radius_m=0.3)
    assert run.speed_kmh[0] == pytest.approx(500 * 2 * math.pi / 60 * 0.3 * 3.6)
    assert run.channels["a"][1] == "g"
    with pytest.raises(MeasurementError, match="needs the rolling radius"):
        read_run(path)
    bad = tmp_path / "b.csv"
    np.savetxt(bad, np.column_stack([t, wheel, t]), delimiter=",", header="time,speed [km/h],a", comments="")
    with pytest.raises(MeasurementError, match="time column 'time' has unit ''"):
        read_run(bad)
    np.savetxt(bad, np.column_stack([t, t]), delimiter=",", header="time [s],acc [g]", comments="")
    with pytest.raises(MeasurementError, match="no speed column found"):
        read_run(bad)
    semicolons = tmp_path / "s.csv"
    semicolons.write_text("time [s];speed [km/h];acc [m/s^2]\n" + "".join(f"{k / 100};50;{k % 3}\n" for k in range(100)))
    assert read_run(semicolons).speed_kmh[0] == 50.0


def test_mdf4_run(tmp_path, monkeypatch):
    asammdf = pytest.importorskip("asammdf")
    t = np.arange(0, 2.0, 1e-3)
    mdf = asammdf.MDF(version="4.10")
    mdf.append([asammdf.Signal(20.0 + t, t, name="vehicle speed", unit="m/s"),
                asammdf.Signal(np.sin(2 * np.pi * 100 * t), t, name="acc_y", unit="m/s^2")])
    path = tmp_path / "run.mf4"
    mdf.save(path, overwrite=True)
    run = read_run(path)
    assert run.sample_rate_hz == pytest.approx(1000.0)
    assert run.speed_kmh[0] == pytest.approx(72.0)
    assert run.channels["acc_y"][1] == "m/s^2"
    assert run.channels["acc_y"][0][:50] == pytest.approx(np.sin(2 * np.pi * 100 * t[:50]), abs=1e-12)
    monkeypatch.setitem(sys.modules, "asammdf", None)  # as if the extra were not installed
    with pytest.raises(MeasurementError, match=r"polywear\[measure\]"):
        read_run(path)


def test_cli_json_plot_and_netcdf(runup, tmp_path):
    path, hopf = runup
    out, plot = tmp_path / "map.nc", tmp_path / "map.png"
    code, stdout, err = run_main(["measure", "campbell", str(path), "--no-predict", "--no-ramp-correction",
                                  "--json", "-q", "--out", str(out), "--plot", str(plot)])
    assert code == 0, err
    summary = json.loads(stdout)
    assert summary["sev"]["frequency_hz"] == pytest.approx(hopf.frequency_hz, rel=0.01)
    assert plot.stat().st_size > 10_000
    import xarray as xr

    with xr.open_dataset(out, engine="h5netcdf") as ds:
        assert ds["power_db"].dims == ("channel", "frequency_hz", "time_s")
        assert float(ds["speed_kmh"].max()) <= 80.0
    assert json.loads(out.with_suffix(".json").read_text()) == summary  # the summary next to the map
    assert sorted(f.name for f in tmp_path.iterdir() if f.name.startswith(".")) == []  # no temporary file left
    code, _, err = run_main(["measure", "campbell", str(tmp_path / "missing.csv")])
    assert code == 2 and err.count("\n") == 1


# -- no false SEV, and the SEV run-ups keep their accuracy ----------------------------------
RADIUS = Params().operating.rolling_radius_m


def _wheel_orders(speed_kmh, orders, fs=FS):
    """Sum of wheel-order lines ``(n, amplitude)`` along the speed trace."""
    return sum(a * np.sin(2 * np.pi * np.cumsum(order_frequency_hz(n, speed_kmh, RADIUS)) / fs) for n, a in orders)


def _synthetic(v0, v1, seed, orders=((8, 3.0), (16, 3.0)), rate=4.0):
    """Time [s], speed [km/h] and white noise (0.5 m/s^2) plus wheel orders, 4 km/h/s."""
    t = np.arange(0.0, abs(v1 - v0) / rate, 1.0 / FS)
    v = v0 + math.copysign(rate, v1 - v0) * t
    return t, v, 0.5 * np.random.default_rng(seed).standard_normal(t.size) + _wheel_orders(v, orders)


def _sev_line(t, v, f0, v_on, v_off, amplitude=5.0, tau_s=0.03):
    """A self-excited line at ``f0`` [Hz] between ``v_on`` and ``v_off`` [km/h]: outside, it
    decays with the time constant ``tau_s`` [s] (a fast-growing cycle switching on and off)."""
    inside_s = np.minimum(v - min(v_on, v_off), max(v_on, v_off) - v) / (abs(v[-1] - v[0]) / t[-1])
    return amplitude * np.exp(np.minimum(inside_s, 0.0) / tau_s) * np.sin(2 * np.pi * f0 * t)


def _run(t, v, x, name="synthetic"):
    from polywear.measured.run_file import Run

    return Run(name, t, v, {"acc_y": (x, "m/s^2")})


def _structural_mode():
    """35 -> 160 km/h: a 45 Hz mode present all along, crossed by order 8 at 38 km/h (its
    ridge starts after the crossing, as if it switched on there)."""
    t, v, x = _synthetic(35.0, 160.0, seed=3)
    return _run(t, v, x + 1.0 * np.sin(2 * np.pi * 45.0 * t + 0.3), "mode")


def _order_one_stretch():
    """20 -> 75 km/h with an imbalance (order 1, 4 m/s^2): order 1 enters the searched band
    (from 10 Hz) at 68 km/h, a short stretch at its lower edge."""
    t, v, x = _synthetic(20.0, 75.0, seed=4, orders=((1, 4.0), (8, 3.0), (16, 3.0)))
    return _run(t, v, x, "order 1")


def _orders_only():
    """30 -> 150 km/h, orders 1, 8, 16 and noise: order 1 below 10 Hz until 68 km/h leaks
    into the band's edge bin (it used to be taken for SEV at exactly 10.000 Hz)."""
    t, v, x = _synthetic(30.0, 150.0, seed=5, orders=((1, 4.0), (8, 3.0), (16, 3.0)))
    return _run(t, v, x, "orders")


@pytest.mark.parametrize("make", [_structural_mode, _order_one_stretch, _orders_only])
def test_no_sev_without_evidence(make):
    result = campbell(make(), Params(), predict=False, correct_ramp=False)
    assert result.sev is None
    assert not any(f["sev"] for f in result.features)
    summary = result.summary()
    assert summary["no_sev"].startswith("no constant-frequency feature")
    json.dumps(summary, allow_nan=False)  # no NaN anywhere


def test_a_mode_present_all_along_is_named_as_such():
    result = campbell(_structural_mode(), Params(), predict=False, correct_ramp=False)
    mode = [f for f in result.features if f["kind"] == "constant_frequency" and 44.0 < f["frequency_from_hz"] < 46.0]
    assert len(mode) == 1 and mode[0]["speed_from_kmh"] > 36.0  # the ridge starts inside the run
    assert "does not switch on or off" in mode[0]["not_sev"] and "45.0 Hz" in result.no_sev
    orders = [f["frequency_order"] for f in result.features if f["kind"] == "order"]
    assert any(abs(n - 8.0) < 0.05 for n in orders)


@pytest.mark.parametrize("v0, v1, v_on, v_off, kind", [
    (40.0, 160.0, 70.0, 130.0, "run-up"),
    (160.0, 40.0, 130.0, 70.0, "coast-down"),
    (120.0, 40.0, 200.0, 70.0, "coast-down starting inside the band"),
])
def test_sev_run_ups_keep_their_accuracy(v0, v1, v_on, v_off, kind):
    """A 90 Hz line switching on at ``v_on`` and off at ``v_off`` (orders 8 and 16 cross
    it): onset and offset within 0.6 km/h, frequency within 0.02 Hz; a side the run does
    not cover has no onset."""
    t, v, x = _synthetic(v0, v1, seed=6)
    result = campbell(_run(t, v, x + _sev_line(t, v, 90.0, v_on, v_off)), Params(), predict=False,
                      correct_ramp=False)
    sev = result.sev
    assert sev is not None, result.no_sev
    assert abs(sev["frequency_hz"] - 90.0) < 0.02
    if min(v0, v1) < v_on < max(v0, v1):
        assert abs(sev["onset"]["speed_kmh"] - v_on) < 0.6, sev["onset"]
    else:
        assert sev["onset"] is None and sev["switch_db"]["before"] is None
    assert abs(sev["offset"]["speed_kmh"] - v_off) < 0.6, sev["offset"]
    assert min(d for d in sev["switch_db"].values() if d is not None) > 30.0
    json.dumps(result.summary(), allow_nan=False)


def test_sev_run_up_from_a_semicolon_csv_in_ms_and_m_per_s(tmp_path):
    t, v, x = _synthetic(40.0, 160.0, seed=7)
    x = x + _sev_line(t, v, 90.0, 70.0, 130.0)
    path = tmp_path / "run.csv"
    np.savetxt(path, np.column_stack([t * 1000.0, v / 3.6, x]), delimiter=";", fmt="%.9g",
               header="time [ms];speed [m/s];acc_y [m/s^2]", comments="")
    sev = campbell(read_run(path), Params(), predict=False, correct_ramp=False).sev
    assert abs(sev["onset"]["speed_kmh"] - 70.0) < 0.6 and abs(sev["offset"]["speed_kmh"] - 130.0) < 0.6
    assert abs(sev["frequency_hz"] - 90.0) < 0.02


def _write(path, header, *columns):
    np.savetxt(path, np.column_stack(columns), delimiter=",", header=header, comments="", fmt="%.9g")
    return path


def test_read_run_direction_sign_and_units(tmp_path):
    t = np.arange(0.0, 10.0, 1e-3)
    v = 40.0 + 4.0 * t
    x = np.sin(2 * np.pi * 100.0 * t)
    header = "time [s],speed [km/h],a [g]"
    negated = read_run(_write(tmp_path / "neg.csv", header, t, -v, x))
    assert negated.speed_kmh == pytest.approx(v) and "negative throughout" in negated.notes[0]
    backwards = read_run(_write(tmp_path / "back.csv", header, t[::-1], v[::-1], x[::-1]))
    assert backwards.t == pytest.approx(t) and backwards.speed_kmh == pytest.approx(v)
    assert backwards.channels["a"][0] == pytest.approx(x) and "runs backwards throughout" in backwards.notes[0]
    half = slice(0, 5000)
    with pytest.raises(MeasurementError, match=r"runs backwards from 4\.999 s to 0 s"):
        read_run(_write(tmp_path / "two.csv", header, np.r_[t[half], t[half]], np.r_[v[half], v[half]],
                        np.r_[x[half], x[half]]))
    constant = read_run(_write(tmp_path / "const.csv", header, t, np.full_like(t, 80.0), x))
    assert "not a run-up or coast-down" in constant.notes[0]
    assert read_run(_write(tmp_path / "up.csv", header, t, v, x)).notes == []
    with pytest.raises(MeasurementError, match=r"sample rate of 1 Hz.*in ms rather than s"):
        read_run(_write(tmp_path / "ms.csv", header, t * 1000.0, v, x))
    with pytest.raises(MeasurementError, match=r"4000 km/h/s.*in s rather than ms"):
        read_run(_write(tmp_path / "s.csv", "time [ms],speed [km/h],a [g]", t, v, x))
    with pytest.raises(MeasurementError, match="changes sign"):
        read_run(_write(tmp_path / "sign.csv", header, t, v - 60.0, x))
    rest = read_run(_write(tmp_path / "rest.csv", header, t, np.maximum(4.0 * t - 0.3, -0.2), x))
    assert rest.speed_kmh.min() >= 0.0 and "at standstill" in rest.notes[0]


def test_cli_says_no_sev_and_json_has_no_nan(tmp_path):
    run = _orders_only()
    path = _write(tmp_path / "orders.csv", "time [s],speed [km/h],acc_y [m/s^2]", run.t, run.speed_kmh,
                  run.channels["acc_y"][0])
    code, stdout, err = run_main(["measure", "campbell", str(path), "--no-predict", "--no-ramp-correction", "--json",
                                  "-q"])
    assert code == 0, err
    summary = json.loads(stdout)  # strict: NaN would not parse
    assert summary["sev"] is None and "NaN" not in stdout
    code, stdout, err = run_main(["measure", "campbell", str(path), "--no-predict", "--no-ramp-correction", "-q"])
    assert code == 0, err
    assert stdout.splitlines()[-1].startswith("no SEV in this run: ") and "nan" not in stdout.lower()
    code, _, err = run_main(["measure", "campbell", str(_write(tmp_path / "ms.csv", "time [s],speed [km/h],a [g]",
                                                                  run.t * 1000.0, run.speed_kmh, run.t))])
    assert code == 2 and err.count("\n") == 1 and "rather than s" in err


@pytest.mark.slow
def test_ramp_correction_with_a_distant_hopf_point_warns(runup):
    """A model whose Hopf point lies 12 km/h above the run's onset (tread damping 140
    instead of 80 N s/m): the correction is flagged and gives no calibration observation."""
    path, hopf = runup
    params = Params().with_updates({"tread.lateral_damping_ns_per_m": 140.0})
    model_hopf = stability(params).hopf_points[0].speed_kmh
    assert model_hopf - hopf.speed_kmh > 10.0
    result = campbell(read_run(path), params, predict=False)
    onset = result.sev["onset"]
    assert onset["hopf_speed_kmh"] == pytest.approx(model_hopf, abs=0.1)
    assert abs(onset["corrected_speed_kmh"] - model_hopf) > 5.0
    assert "km/h from the ramp-corrected onset" in onset["warning"]
    assert result.observations() == []


def test_plot_marks_the_operating_speed_where_the_run_covers_it(runup):
    """The model's operating speed (part of the prediction) is drawn on the speed axis when
    the run covers it, and not otherwise."""
    import dataclasses

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path, _ = runup
    result = campbell(read_run(path), Params(), predict=False, correct_ramp=False)
    for speed, drawn in ((float(np.median(result.speeds_kmh)), True), (500.0, False)):
        fig, ax = plt.subplots()
        dataclasses.replace(result, prediction={"operating_speed_kmh": speed}).plot(ax)
        labels = [line.get_label() for line in ax.get_lines()]
        assert (f"operating speed {speed:g} km/h" in labels) is drawn
        plt.close(fig)
