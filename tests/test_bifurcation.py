"""The bifurcation diagram of tread1dof: continuation against independent methods."""

import json

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from polywear.dynamics.bifurcation import bifurcation, branch_start
from polywear.dynamics.points import PointKind
from polywear.models import get_model
from polywear.params import Params, load_params
from polywear.solvers.continuation import ContinuationSettings, switching_times
from polywear.solvers.integrate import integrate

MODEL = get_model("tread1dof")


@pytest.fixture(scope="module")
def default_diagram():
    return bifurcation(Params(), (20.0, 300.0))


def steady_amplitude(params, speed_kmh, u0, t_end=1.5, window=0.15):
    """Half peak-to-peak of x over the last ``window`` seconds of a compiled Rodas4 run
    (rtol 1e-10), sampled densely from the integrator's continuous output."""
    p = MODEL.pack(params)
    run = integrate(MODEL, u0, speed_kmh / 3.6, p, t_end, rtol=1e-10, atol=1e-13, dense_from=t_end - window)
    x = run.dense(np.linspace(t_end - window, t_end, 60001))[:, 0]
    return 0.5 * (x.max() - x.min()), run


def test_default_diagram_matches_model_md(default_diagram):
    d = default_diagram
    s = d.summary()
    assert [round(h["speed_kmh"], 1) for h in s["hopf_points"]] == [58.1, 207.8]
    assert [h["criticality"] for h in s["hopf_points"]] == ["soft", "hard"]
    (fold,) = s["folds"]
    assert 250.0 < fold["speed_kmh"] < 260.0  # docs/model.md section 7: a fold of cycles near 255 km/h
    assert 0.40 < fold["amplitude_x_mm"] < 0.55
    assert fold["amplitude_x_m"] == pytest.approx(1e-3 * fold["amplitude_x_mm"], rel=1e-15)  # old key, next release
    assert s["first_bifurcation_speed_kmh"] == pytest.approx(s["hopf_points"][0]["speed_kmh"])
    assert s["second_bifurcation_speed_kmh"] == pytest.approx(fold["speed_kmh"])
    assert s["hard_regions_kmh"] == [[pytest.approx(207.7503, abs=1e-3), pytest.approx(fold["speed_kmh"])]]
    # one branch from H1 through the fold back to H2, accurate multipliers throughout
    (info,) = s["branches"]
    assert info["to_hopf_kmh"] == pytest.approx(s["hopf_points"][1]["speed_kmh"])
    assert info["max_trivial_multiplier_error"] < 1e-7
    # docs/model.md section 7: ~0.27 mm at 110 km/h; ~0.47-0.50 mm stable above 207.8 km/h
    (c110,) = d.cycles_at(110.0)
    assert c110.stable and c110.amplitude[0] == pytest.approx(0.27e-3, rel=0.05)
    small, large = d.cycles_at(230.0)
    assert not small.stable and large.stable
    assert 0.46e-3 < large.amplitude[0] < 0.51e-3
    json.dumps(s)  # serializable


def test_stable_cycle_amplitude_agrees_with_long_time_integration(default_diagram):
    (cycle,) = default_diagram.cycles_at(110.0)
    u_eq = MODEL.equilibrium(110 / 3.6, MODEL.pack(Params()))
    amp, _ = steady_amplitude(Params(), 110.0, u_eq + np.array([1e-4, 0, 0]))
    assert cycle.amplitude[0] == pytest.approx(amp, rel=2e-5)


def test_hard_region_attractors_agree_with_integration(default_diagram):
    """At 230 km/h: a start inside the unstable cycle decays, one outside ends on the stable cycle."""
    small, large = default_diagram.cycles_at(230.0)
    u_eq = MODEL.equilibrium(230 / 3.6, MODEL.pack(Params()))
    inside, _ = steady_amplitude(Params(), 230.0, u_eq + np.array([0.8 * small.amplitude[0], 0, 0]), t_end=1.0)
    outside, _ = steady_amplitude(Params(), 230.0, u_eq + np.array([1.3 * small.amplitude[0], 0, 0]), t_end=1.0)
    assert inside < 1e-3 * small.amplitude[0]
    assert outside == pytest.approx(large.amplitude[0], rel=2e-5)


@pytest.mark.slow
def test_floquet_multipliers_agree_with_variational_equation(default_diagram):
    p = MODEL.pack(Params())
    branch = default_diagram.branches[0]
    for point in (branch.points[10], branch.points[-10]):  # a stable and an unstable cycle
        orbit = point.orbit

        def variational(tau, y):
            u = orbit.evaluate(tau)[0]
            Phi = y.reshape(3, 3)
            return (orbit.period * MODEL.jacobian(u, orbit.speed, p) @ Phi).ravel()

        sol = solve_ivp(variational, (0.0, 1.0), np.eye(3).ravel(), method="Radau", rtol=1e-11, atol=1e-13)
        reference = np.sort(np.abs(np.linalg.eigvals(sol.y[:, -1].reshape(3, 3))))
        ours = np.sort(np.abs(point.multipliers))
        # the two multipliers near the unit circle; the third is tiny (stiff bristle state)
        assert np.allclose(ours[1:], reference[1:], rtol=1e-5), (orbit.speed * 3.6, ours, reference)


def test_mesh_refinement_moves_fold_and_amplitude_by_little():
    coarse = bifurcation(Params(), (20.0, 300.0), ContinuationSettings(n_intervals=40))
    fine = bifurcation(Params(), (20.0, 300.0), ContinuationSettings(n_intervals=80))
    assert coarse.folds[0].speed_kmh == pytest.approx(fine.folds[0].speed_kmh, rel=1e-8)
    assert coarse.folds[0].amplitude[0] == pytest.approx(fine.folds[0].amplitude[0], rel=1e-6)
    # cycles_at solves on the adapted mesh of a neighbouring branch point, so the amplitude
    # moves with where the steps landed: 40/80/160 intervals spread by 9e-10 (relative) with
    # the steps of half max_turn, by 2.3e-8 with those of turn_target 0.85 (no kink at 150 km/h;
    # a Newton tolerance of 1e-13 changes nothing)
    assert coarse.cycles_at(150.0)[0].amplitude[0] == pytest.approx(fine.cycles_at(150.0)[0].amplitude[0], rel=5e-8)


@pytest.fixture(scope="module")
def stick_slip_params():
    # a lower Coulomb level makes large cycles reach v_r = 0 (stick-slip) from ~81 km/h
    return load_params(overrides=["friction.mu_coulomb=0.3"])


@pytest.mark.slow
def test_stick_slip_cycles_kink_alignment_and_period_doubling(stick_slip_params):
    params = stick_slip_params
    p = MODEL.pack(params)
    aligned = bifurcation(params, (20.0, 150.0))
    # no alignment and no rescue by mesh refinement (an infinite tolerance accepts every step):
    # what the same mesh gives when polynomials straddle the kinks
    plain = bifurcation(params, (20.0, 150.0), ContinuationSettings(align_kinks=False, multiplier_tol=np.inf))
    (c110,) = aligned.cycles_at(110.0)
    # the cycle really slides backwards: v_r changes sign twice per period
    branch = aligned.branches[0]
    sticky = [pt for pt in branch.points if len(switching_times(MODEL, p, pt.orbit)) == 2]
    assert len(sticky) > 10
    # mesh points on the kinks keep the monodromy accurate; without them it is not
    err_aligned = max(pt.trivial_multiplier_error for pt in sticky)
    err_plain = max(pt.trivial_multiplier_error for pt in plain.branches[0].points)
    assert err_aligned < 1e-7 < 1e-4 < err_plain
    # amplitude against long-time integration at a stable stick-slip cycle
    u_eq = MODEL.equilibrium(110 / 3.6, p)
    amp, _ = steady_amplitude(params, 110.0, u_eq + np.array([3e-4, 0, 0]))
    assert c110.stable and c110.amplitude[0] == pytest.approx(amp, rel=2e-5)
    # a period doubling where stick-slip sets in; integration started on the unstable
    # period-1 cycle leaves it with alternating peak heights
    pds = [pt for pt in aligned.special if pt.kind is PointKind.PD]
    assert pds and 75.0 < pds[0].speed_kmh < 90.0
    (c90,) = aligned.cycles_at(90.0)
    assert not c90.stable and c90.max_multiplier > 1.2
    orbit_point = next(pt for pt in branch.points if abs(pt.orbit.speed * 3.6 - 90.0) < 3.0)
    run = integrate(MODEL, orbit_point.orbit.evaluate(0.0)[0], orbit_point.orbit.speed, p, 0.6,
                    rtol=1e-10, atol=1e-13, dense_from=0.3)
    x = run.dense(np.linspace(0.3, 0.6, 300001))[:, 0]
    peaks = x[1:-1][(x[1:-1] > x[:-2]) & (x[1:-1] > x[2:])]
    assert np.ptp(peaks) > 0.02 * peaks.mean()  # no longer a period-1 orbit


def test_dataset_and_csv_round_trip(default_diagram, tmp_path):
    import pandas as pd
    import xarray as xr

    default_diagram.save(tmp_path / "bif.nc")
    default_diagram.save(tmp_path / "bif.csv")
    ds = xr.open_dataset(tmp_path / "bif.nc", engine="h5netcdf")
    table = pd.read_csv(tmp_path / "bif.csv")
    assert ds.sizes["cycle"] == len(default_diagram.cycles) == len(table)
    assert np.allclose(ds["amplitude"].sel(state="x").values, table["amplitude_x"].values)
    assert json.loads(ds.attrs["summary_json"])["folds"][0]["speed_kmh"] == pytest.approx(
        default_diagram.folds[0].speed_kmh)


@pytest.mark.slow
def test_sweep_agrees_with_continuation_on_stable_branches_and_in_the_hard_region(default_diagram):
    """The paper's brute-force way as a cross-check: steady amplitudes from large
    disturbances match the stable cycles within 0.5 %, SEV persists beyond the subcritical
    Hopf point exactly up to the fold, and small disturbances die out in the hard region."""
    from polywear.dynamics.sweep import sweep

    speeds = [100.0, 150.0, 215.0, 235.0, 250.0, 253.5, 256.0, 270.0]
    result = sweep(Params(), speeds)
    fold = default_diagram.folds[0].speed_kmh
    for run_large, run_small in zip(result.runs["large"], result.runs["small"]):
        v = run_large.speed_kmh
        stable = [c for c in default_diagram.cycles_at(v) if c.stable]
        if v < fold:
            assert len(stable) == 1 and run_large.outcome == "cycle", v
            assert run_large.amplitude[0] == pytest.approx(stable[0].amplitude[0], rel=5e-3), v
        else:
            assert not stable and run_large.outcome == "equilibrium", v
        in_hard = 207.7503 < v < fold
        assert (run_small.outcome == "equilibrium") == (in_hard or v > fold), v


def test_cycles_at_finds_both_cycles_between_the_last_point_and_the_fold(default_diagram):
    """Beyond the fastest stored point and short of the fold, only the located fold point
    brackets the speed: both the stable and the unstable cycle are found there."""
    (fold,) = default_diagram.folds
    fastest = max(pt.orbit.speed for pt in default_diagram.branches[0].points) * 3.6
    assert fastest < fold.speed_kmh
    small, large = default_diagram.cycles_at(0.5 * (fastest + fold.speed_kmh))  # midway
    assert not small.stable and large.stable
    assert small.amplitude[0] < fold.amplitude[0] < large.amplitude[0]
    assert default_diagram.cycles_at(fold.speed_kmh + 0.01) == []


def test_cycles_at_finds_the_cycle_between_the_hopf_point_and_the_first_point(default_diagram):
    """Between a soft Hopf point and its branch's first stored point no two points bracket
    the speed: the cycle is found from the first point scaled by the square-root law, and
    equals the one reached along the branch from the Hopf point (a second method)."""
    from polywear.solvers.continuation import cycle_along_branch

    hopf = default_diagram.hopf_points[0]
    first = default_diagram.branches[0].points[0].orbit.speed * 3.6
    assert hopf.criticality == "soft" and first > hopf.speed_kmh
    speed = hopf.speed_kmh + 0.7 * (first - hopf.speed_kmh)
    (cycle,) = default_diagram.cycles_at(speed)
    assert cycle.stable and cycle.amplitude[0] > 0.0
    along = cycle_along_branch(MODEL, MODEL.pack(default_diagram.params), branch_start(hopf), speed / 3.6)
    assert along is not None
    np.testing.assert_allclose(cycle.amplitude[0], along.orbit.amplitude()[0], rtol=1e-6)
