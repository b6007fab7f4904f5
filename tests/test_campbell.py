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

from polywear.measured.campbell import MeasurementError, _remove_orders, campbell, order_frequency_hz, read_run
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
        assert any(abs(f["order"] - n) < 0.05 for f in orders), n
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
        cleaned = _remove_orders(order + tone, speed, fs, [12.0], radius)
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
