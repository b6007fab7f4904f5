"""The axle4dof bifurcation diagram against independent methods (integration, sweep)."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from polywear.dynamics.bifurcation import bifurcation
from polywear.models import get_model
from polywear.params import load_params
from polywear.solvers.integrate import integrate

MODEL = get_model("axle4dof")
PARAMS = load_params(overrides=["model=axle4dof"])


@pytest.fixture(scope="module")
def diagram():
    return bifurcation(PARAMS, (20.0, 300.0))


def test_axle_diagram_matches_model_md(diagram):
    s = diagram.summary()
    lo, hi = s["linear_band_kmh"][0]
    assert abs(lo - 79.0) < 2.0 and abs(hi - 155.0) < 2.0  # docs/model.md section 7: roughly 79 to 155 km/h
    assert all(h["mode"] == "x" for h in s["hopf_points"])  # the tread mode goes unstable
    assert all(105.0 < h["frequency_hz"] < 150.0 for h in s["hopf_points"])  # "about 110-145 Hz"
    (fold,) = s["folds"]
    assert hi < fold["speed_kmh"] < hi + 15.0  # hard excitation above the upper Hopf point
    assert s["second_bifurcation_speed_kmh"] == pytest.approx(fold["speed_kmh"])
    assert max(b["max_trivial_multiplier_error"] for b in s["branches"]) < 1e-7


def test_axle_cycle_agrees_with_long_time_integration(diagram):
    """Every coordinate's amplitude at 110 km/h, from a run started off the cycle."""
    (cycle,) = diagram.cycles_at(110.0)
    p = MODEL.pack(PARAMS)
    V = 110.0 / 3.6
    u0 = MODEL.equilibrium(V, p)
    u0[MODEL.index("x")] += 1e-4
    run = integrate(MODEL, u0, V, p, 2.0, rtol=1e-10, atol=1e-14, dense_from=1.8)
    u = run.dense(np.linspace(1.8, 2.0, 40001))
    amplitude = 0.5 * (u.max(axis=0) - u.min(axis=0))
    for name in ("x", "alpha", "beta", "gamma", "z"):
        i = MODEL.index(name)
        assert cycle.amplitude[i] == pytest.approx(amplitude[i], rel=1e-4), name


@pytest.mark.slow
def test_axle_sweep_agrees_in_the_soft_and_hard_regions(diagram):
    from polywear.dynamics.sweep import sweep

    fold = diagram.folds[0].speed_kmh
    h2 = diagram.hopf_points[1].speed_kmh
    speeds = [100.0, 140.0, 0.5 * (h2 + fold), fold + 3.0]
    result = sweep(PARAMS, speeds)
    for large, small in zip(result.runs["large"], result.runs["small"]):
        v = large.speed_kmh
        stable = [c for c in diagram.cycles_at(v) if c.stable]
        if v < fold:
            assert large.outcome == "cycle" and large.amplitude[3] == pytest.approx(stable[0].amplitude[3], rel=5e-3)
        else:
            assert not stable and large.outcome == "equilibrium"
        assert (small.outcome == "equilibrium") == (v > h2), v


@pytest.mark.slow
def test_axle_floquet_multipliers_agree_with_variational_equation(diagram):
    p = MODEL.pack(PARAMS)
    branch = diagram.branches[0]
    for point in (branch.points[len(branch.points) // 3], branch.points[-3]):  # a stable and an unstable cycle
        orbit = point.orbit

        def variational(tau, y):
            Phi = y.reshape(9, 9)
            return (orbit.period * MODEL.jacobian(orbit.evaluate(tau)[0], orbit.speed, p) @ Phi).ravel()

        sol = solve_ivp(variational, (0.0, 1.0), np.eye(9).ravel(), method="Radau", rtol=1e-10, atol=1e-12)
        mu = np.linalg.eigvals(sol.y[:, -1].reshape(9, 9))
        reference = np.sort(np.abs(mu))[::-1][:3]
        ours = np.sort(np.abs(point.multipliers))[::-1][:3]
        assert np.allclose(ours, reference, rtol=1e-5), (orbit.speed * 3.6, ours, reference)
        nontrivial = np.delete(mu, np.argmin(np.abs(mu - 1.0)))
        assert point.stable == bool(np.all(np.abs(nontrivial) < 1.0))
