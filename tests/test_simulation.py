"""Simulation, steady-state detection, amplitudes, phase portraits, results and the CLI."""

from __future__ import annotations

import json
import math
import sys

import matplotlib
import numpy as np
import pytest

from polywear.dynamics.simulation import (
    SimulationSettings,
    phase_pairs,
    frequency_order,
    simulate,
    simulate_disturbances,
    simulate_values,
)
from polywear.models import get_model
from polywear.params import ParameterError, Params, load_params, with_updates

matplotlib.use("Agg")

DEFAULTS = Params()


@pytest.fixture(scope="module")
def run110():
    return simulate(DEFAULTS, 110.0, 1.0, disturbance=1e-4)


def _crossing_times(t, s, level):
    """Upward crossings of ``s`` through ``level`` by linear interpolation (independent of
    the library's peak refinement)."""
    i = np.nonzero((s[:-1] < level) & (s[1:] >= level))[0]
    return t[i] + (level - s[i]) * (t[i + 1] - t[i]) / (s[i + 1] - s[i])


def test_cycle_at_110_kmh_amplitude_frequency_and_frequency_order(run110):
    st = run110.steady
    assert st.outcome == "cycle" and st.steady
    x = run110.model.index("x")
    assert 0.25e-3 < st.amplitude[x] < 0.29e-3  # docs/model.md section 7: near 0.27 mm
    # amplitude against the plain sample extremes of the last 0.2 s (grid 20 us): the
    # refined value can only be larger, by at most the grid's (omega dt)^2 / 2
    tail = run110.t > 0.8
    sample_amp = 0.5 * np.ptp(run110.u[tail, x])
    omega_dt = 2 * np.pi * st.frequency * run110.settings.dt_out
    assert sample_amp <= st.amplitude[x] <= sample_amp * (1 + omega_dt**2)
    # frequency against interpolated upward crossings of x' through 0
    up = _crossing_times(run110.t[tail], run110.u[tail, model_index("xdot")], 0.0)
    assert st.frequency == pytest.approx(1.0 / np.diff(up).mean(), rel=1e-6)
    # polygon order n = f / f_rot, f_rot = V / (2 pi R_e)
    f_rot = (110.0 / 3.6) / (2 * np.pi * DEFAULTS.operating.rolling_radius_m)
    assert run110.frequency_order == pytest.approx(st.frequency / f_rot, rel=1e-12)
    assert frequency_order(150.0, 110.0, 0.3) == pytest.approx(150.0 * 2 * np.pi * 0.3 * 3.6 / 110.0)


def model_index(name):
    return get_model("tread1dof").index(name)


def test_refined_amplitude_does_not_depend_on_output_grid(run110):
    coarse = simulate(DEFAULTS, 110.0, 1.0, disturbance=1e-4, settings=SimulationSettings(dt_out=2.5e-4))
    x = model_index("x")
    for q in range(3):
        assert coarse.steady.amplitude[q] == pytest.approx(run110.steady.amplitude[q], rel=1e-6)
    assert coarse.steady.frequency == pytest.approx(run110.steady.frequency, rel=1e-9)
    # whereas the sample maximum per period on that grid falls visibly short
    period, amp = coarse.steady.period, coarse.steady.amplitude[x]
    per_cycle = [coarse.u[(coarse.t > 1.0 - (k + 1) * period) & (coarse.t <= 1.0 - k * period), x].max()
                 for k in range(20)]
    assert coarse.steady.maximum[x] - np.mean(per_cycle) > 1e-4 * amp
    assert coarse.steady.maximum[x] == pytest.approx(run110.steady.maximum[x], abs=1e-6 * amp)


@pytest.mark.slow
def test_amplitude_agrees_with_scipy_dop853(run110):
    ref = simulate(DEFAULTS, 110.0, 1.0, disturbance=1e-4,
                   settings=SimulationSettings(method="dop853", rtol=1e-10, atol=1e-13))
    assert ref.steady.outcome == "cycle"
    assert np.allclose(ref.steady.amplitude, run110.steady.amplitude, rtol=1e-6, atol=0)
    assert ref.steady.frequency == pytest.approx(run110.steady.frequency, rel=1e-8)


def test_all_starts_converge_to_one_cycle_at_110_kmh():
    """The paper's Fig. 5: small and large disturbances end on the same limit cycle."""
    result = simulate_disturbances(DEFAULTS, [1e-5, 1e-4, 1e-3, -2e-3], 110.0, 0.6)
    amps = np.array([r.steady.amplitude for r in result.runs])
    freqs = np.array([r.steady.frequency for r in result.runs])
    assert all(r.steady.outcome == "cycle" for r in result.runs)
    assert np.ptp(amps, axis=0).max() / amps.mean(axis=0).min() < 1e-6
    assert np.ptp(freqs) / freqs.mean() < 1e-8
    # the starts really are different: the large one leaves through stick-slip
    vr_min = [r.aux[:, 0].min() for r in result.runs]
    assert vr_min[0] > 0.0 > vr_min[3]


def test_equilibrium_and_transient_are_recognized():
    # 230 km/h: above the upper Hopf speed a small disturbance dies out
    decays = simulate(DEFAULTS, 230.0, 1.0, disturbance=1e-5)
    assert decays.steady.outcome == "equilibrium" and math.isnan(decays.steady.frequency)
    assert np.abs(decays.u[-1] - decays.equilibrium).max() < 1e-4 * 1e-5 * 1e3
    # 40 km/h: below the lower Hopf speed
    assert simulate(DEFAULTS, 40.0, 0.5).steady.outcome == "equilibrium"
    # just above the soft Hopf point (58.1 km/h) the cycle grows slowly: 0.3 s is not enough
    growing = simulate(DEFAULTS, 60.0, 0.3)
    assert growing.steady.outcome == "transient" and not growing.steady.steady
    assert growing.summary()["steady_state"] is False


def test_large_disturbance_reaches_the_cycle_above_the_upper_hopf_speed():
    run = simulate(DEFAULTS, 230.0, 1.0, disturbance=1e-3)
    assert run.steady.outcome == "cycle"
    assert 0.47e-3 <= run.steady.amplitude[model_index("x")] <= 0.50e-3  # docs/model.md section 7


def test_stick_slip_cycle_is_analysed():
    params = with_updates(DEFAULTS, {"friction.mu_coulomb": 0.3})
    run = simulate(params, 80.0, 1.0, disturbance=5e-4)
    vr = run.aux[run.t > 0.5, 0]
    assert vr.min() < 0.0 < vr.max()
    assert run.steady.outcome == "cycle"
    # x' peaks at the stick velocity V sin(toe) with v_r = 0 on the cycle
    xd = model_index("xdot")
    assert run.steady.maximum[xd] >= 80.0 / 3.6 * math.sin(math.radians(0.5))


def test_amplitude_grows_with_toe_angle():
    """In kind the paper's Fig. 7: a larger toe angle, a larger vibration."""
    result = simulate_values(DEFAULTS, "operating.toe_deg", [0.3, 0.5, 0.7], 110.0, 0.6)
    amps = [r.steady.amplitude[model_index("x")] for r in result.runs]
    assert all(r.steady.outcome == "cycle" for r in result.runs)
    assert amps[0] < amps[1] < amps[2]
    assert [r.params.operating.toe_deg for r in result.runs] == [0.3, 0.5, 0.7]
    ds = result.to_dataset()
    assert list(ds.run.values) == [0.3, 0.5, 0.7] and ds.attrs["varied"] == "operating.toe_deg"
    assert ds["amplitude"].sel(state="x").values == pytest.approx(amps)


def test_dataset_round_trip(run110, tmp_path):
    import xarray as xr

    path = tmp_path / "run.nc"
    run110.save(path)
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        assert ds["x"].attrs["units"] == "m" and ds["xdot"].attrs["units"] == "m/s"
        assert ds["friction_force"].attrs["units"] == "N"
        assert ds["sliding_velocity"].attrs["units"] == "m/s"
        assert ds.time.attrs["units"] == "s"
        assert ds.attrs["outcome"] == "cycle" and ds.attrs["steady_state"] == 1
        assert ds.attrs["speed_kmh"] == 110.0
        assert ds["amplitude"].sel(state="x") == pytest.approx(run110.steady.amplitude[0])
        np.testing.assert_array_equal(ds["z"].values, run110.u[:, 2])
        toml_path = tmp_path / "p.toml"
        toml_path.write_text(ds.attrs["params_toml"])
        assert load_params(toml_path) == DEFAULTS
        assert json.loads(ds.attrs["settings"])["method"] == "rodas"
        assert "polywear_version" in ds.attrs


def test_phase_portrait_plot_returns_artists(run110):
    import matplotlib.pyplot as plt

    artists = run110.plot()
    assert artists and len(artists[0].figure.axes) == 1
    assert artists[0].figure.axes[0].get_xlabel() == "x − x_eq [mm]"
    plt.close("all")
    fig, ax = plt.subplots()
    assert run110.plot(ax=ax)[0].axes is ax
    plt.close(fig)


def test_bad_input():
    with pytest.raises(ValueError, match="duration"):
        simulate(DEFAULTS, 110.0, -1.0)
    with pytest.raises(ValueError, match="initial state"):
        simulate(DEFAULTS, 110.0, 0.1, initial=[0.0, 0.0])
    with pytest.raises(ParameterError, match="unknown key"):
        simulate_values(DEFAULTS, "operating.toe", [0.3], 110.0, 0.1)
    with pytest.raises(ValueError, match="rtol"):
        SimulationSettings(rtol=0.0)
    with pytest.raises(ValueError, match="method"):
        SimulationSettings(method="euler")


# -- axle4dof (when the model is present) ------------------------------------------------
def _axle_model():
    try:
        return get_model("axle4dof")
    except (ImportError, AttributeError) as exc:
        pytest.skip(f"axle4dof model not available yet: {exc}")


def test_axle4dof_phase_portraits_of_all_four_coordinates():
    import matplotlib.pyplot as plt

    model = _axle_model()
    assert phase_pairs(model) == [("alpha", "alphadot"), ("beta", "betadot"), ("gamma", "gammadot"),
                                  ("x", "xdot")]
    params = with_updates(DEFAULTS, {"model": "axle4dof"})
    run = simulate(params, 110.0, 0.3)
    assert run.u.shape[1] == 9 and np.all(np.isfinite(run.u))
    artists = run.plot()
    assert len([a for a in artists[0].figure.axes if a.get_visible()]) == 4
    plt.close("all")
    ds = run.to_dataset()
    assert set(model.state_names) <= set(ds.data_vars)
    assert run.summary()["contact_lost"] is False


# -- the command line --------------------------------------------------------------------
def _cli(args):
    from typer.testing import CliRunner

    from polywear.cli.app import app

    return CliRunner().invoke(app, args)


def test_cli_simulate_json_out_plot(tmp_path):
    out, fig = tmp_path / "run.nc", tmp_path / "phase.png"
    res = _cli(["simulate", "--speed", "110", "--duration", "0.5", "--out", str(out), "--plot", str(fig),
                "--json"])
    assert res.exit_code == 0, res.output
    summary = json.loads(res.stdout)
    assert summary["model"] == "tread1dof" and summary["speed_kmh"] == 110.0
    assert summary["steady_state"] is True and summary["outcome"] == "cycle"
    assert 0.25e-3 < summary["amplitude"]["x"] < 0.29e-3
    f_rot = (110.0 / 3.6) / (2 * np.pi * 0.3)
    assert summary["frequency_order"] == pytest.approx(summary["frequency_hz"] / f_rot)
    assert summary["polygon_order"] == summary["frequency_order"]  # the old name, until the next release
    assert out.stat().st_size > 0 and fig.stat().st_size > 0


def test_cli_simulate_sweep_and_disturbances(tmp_path):
    res = _cli(["simulate", "--duration", "0.3", "--sweep", "operating.toe_deg=0.3,0.5", "--json",
                "--out", str(tmp_path / "s.nc")])
    assert res.exit_code == 0, res.output
    summary = json.loads(res.stdout)
    assert summary["varied"] == "operating.toe_deg" and summary["values"] == [0.3, 0.5]
    res = _cli(["simulate", "--duration", "0.2", "-d", "1e-5,1e-3", "--json"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout)["values"] == [1e-5, 1e-3]


@pytest.mark.parametrize(
    "args",
    [
        ["--duration", "-1"],
        ["--speed", "0"],
        ["-d", "abc"],
        ["--sweep", "operating.toe_deg"],
        ["--sweep", "operating.toe=0.3"],
        ["--sweep", "operating.toe_deg=0.3", "-d", "1e-4,1e-3"],
        ["--rtol", "0"],
        ["--method", "euler"],
        ["--set", "tread.mass_kg=-1"],
    ],
)
def test_cli_bad_input_is_one_line_exit_2(args, capsys, monkeypatch):
    from polywear.cli.app import main

    monkeypatch.setattr(sys, "argv", ["polywear", "simulate", "--duration", "0.01", *args])
    with pytest.raises(SystemExit) as exc:
        main()
    assert exc.value.code == 2
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:") and "Traceback" not in err, err
