"""The brute-force speed sweep: outcomes by start type, hysteresis, agreement with direct runs."""

from __future__ import annotations

import pickle

import matplotlib
import numpy as np
import pytest

from polywear.dynamics.simulation import SimulationSettings, simulate
from polywear.dynamics.sweep import START_TYPES, SweepSettings, settle, sweep
from polywear.models import get_model
from polywear.parallel import Executor
from polywear.params import Params

matplotlib.use("Agg")

DEFAULTS = Params()
X = get_model("tread1dof").index("x")
SPEEDS = [110.0, 200.0, 230.0, 260.0]


@pytest.fixture(scope="module")
def result():
    return sweep(DEFAULTS, SPEEDS)


def _run(result, start, speed):
    (run,) = [r for r in result.runs[start] if r.speed_kmh == speed]
    return run


def test_every_start_type_and_speed_is_run(result):
    assert set(result.runs) == set(START_TYPES)
    for start in START_TYPES:
        assert [r.speed_kmh for r in result.runs[start]] == SPEEDS
        assert all(r.steady for r in result.runs[start]), start


def test_hard_excitation_above_the_upper_hopf_speed(result):
    """docs/model.md section 7: at 230 km/h a small disturbance dies out, a large one ends on a
    cycle of ~0.47-0.50 mm; past the fold of cycles (~255 km/h) both die out."""
    assert _run(result, "small", 230.0).outcome == "equilibrium"
    large = _run(result, "large", 230.0)
    assert large.outcome == "cycle"
    assert 0.47e-3 <= large.amplitude[X] <= 0.50e-3
    assert _run(result, "large", 260.0).outcome == "equilibrium"
    # hysteresis: coming up on the cycle stays on it, coming down from 260 stays at rest
    assert _run(result, "up", 230.0).outcome == "cycle"
    assert _run(result, "down", 230.0).outcome == "equilibrium"
    assert _run(result, "up", 230.0).amplitude[X] == pytest.approx(large.amplitude[X], rel=1e-3)


def test_at_110_kmh_every_start_ends_on_the_same_cycle(result):
    amps = [_run(result, s, 110.0).amplitude[X] for s in START_TYPES]
    assert all(_run(result, s, 110.0).outcome == "cycle" for s in START_TYPES)
    assert 0.25e-3 < np.mean(amps) < 0.29e-3  # docs/model.md section 7: near 0.27 mm
    assert np.ptp(amps) < 1e-3 * np.mean(amps)


@pytest.mark.slow
@pytest.mark.parametrize(("speed", "start", "disturbance"), [(110.0, "small", 1e-5), (230.0, "large", 1e-3)])
def test_sweep_amplitudes_agree_with_a_long_direct_simulation(result, speed, start, disturbance):
    run = _run(result, start, speed)
    direct = simulate(DEFAULTS, speed, 3.0, disturbance=disturbance,
                      settings=SimulationSettings(rtol=1e-10, window_fraction=0.3))
    assert direct.steady.outcome == "cycle"
    np.testing.assert_allclose(run.amplitude, direct.steady.amplitude, rtol=1e-3)
    assert run.frequency_hz == pytest.approx(direct.steady.frequency, rel=1e-4)


def test_settle_continues_in_chunks_until_steady():
    model = get_model("tread1dof")
    p = model.pack(DEFAULTS)
    u0 = model.equilibrium(60.0 / 3.6, p)
    u0[X] += 1e-5
    # just above the soft Hopf point the cycle builds up over seconds: more than one chunk
    short = settle(DEFAULTS, 60.0, u0, settings=SweepSettings(chunk_s=0.25, max_duration_s=0.25))
    assert short.outcome == "transient" and not short.steady and short.duration_s == 0.25
    run = settle(DEFAULTS, 60.0, u0, settings=SweepSettings(chunk_s=0.25, max_duration_s=4.0))
    assert run.outcome == "cycle" and 0.25 < run.duration_s <= 4.0
    # continuing from where the short run stopped gives the same cycle
    resumed = settle(DEFAULTS, 60.0, short.final_state, settings=SweepSettings(chunk_s=0.25, max_duration_s=4.0))
    assert resumed.amplitude[X] == pytest.approx(run.amplitude[X], rel=2e-3)


@pytest.mark.slow
def test_runs_can_go_through_the_executor_interface():
    pooled = sweep(DEFAULTS, [110.0], executor=Executor("processes", workers=2),
                   settings=SweepSettings(max_duration_s=1.0))
    serial = sweep(DEFAULTS, [110.0], settings=SweepSettings(max_duration_s=1.0))
    for start in START_TYPES:
        np.testing.assert_array_equal(pooled.runs[start][0].amplitude, serial.runs[start][0].amplitude)
    pickle.loads(pickle.dumps(serial.runs["small"][0]))


def test_dataset_plot_and_summary(result, tmp_path):
    import xarray as xr

    path = tmp_path / "sweep.nc"
    result.save(path)
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        assert dict(ds.sizes) == {"start": 4, "speed_kmh": len(SPEEDS), "state": 3}
        assert ds["outcome"].sel(start="small", speed_kmh=230.0).item() == "equilibrium"
        assert ds["amplitude"].sel(start="large", speed_kmh=230.0, state="x").item() == pytest.approx(
            _run(result, "large", 230.0).amplitude[X])
        assert ds["frequency_hz"].attrs["units"] == "Hz"
        assert "params_toml" in ds.attrs and "polywear_version" in ds.attrs
    artists = result.plot()
    assert len(artists) >= 4
    summary = result.summary()
    assert summary["runs"]["small"][2]["outcome"] == "equilibrium"
    assert summary["runs"]["small"][2]["frequency_hz"] is None


def test_bad_input():
    with pytest.raises(ValueError, match="speeds"):
        sweep(DEFAULTS, [])
    with pytest.raises(ValueError, match="speeds"):
        sweep(DEFAULTS, [-10.0, 100.0])
    with pytest.raises(ValueError, match="large"):
        sweep(DEFAULTS, [100.0], settings=SweepSettings(large=0.0))
    with pytest.raises(ValueError, match="chunk"):
        settle(DEFAULTS, 100.0, np.zeros(3), settings=SweepSettings(chunk_s=1.0, max_duration_s=0.5))
