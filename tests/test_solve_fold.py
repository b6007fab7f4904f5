"""The direct fold solver (minimally augmented system) against the bracketed fold locator
(a second method), the toe law of tread1dof (a closed form) and the Floquet invariant of a
fold of cycles (a second multiplier at 1)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from polywear.dynamics.bifurcation import bifurcation
from polywear.studies.fast_band import _FIXED_RANGE, _difference, band_reference
from polywear.models import get_model
from polywear.params import Params, with_updates
from polywear.solvers.continuation import (ContinuationSettings, fold_curvature, locate_fold, newton_converged,
                                          solve_at_speed, solve_fold)

SETTINGS = ContinuationSettings()


def _reference(updates):
    params = with_updates(Params(), updates)
    return params, band_reference(bifurcation(params, **_FIXED_RANGE))


def _second_multiplier_gap(point) -> float:
    """|mu - 1| of the multiplier next closest to 1 after the trivial one."""
    return float(np.sort(np.abs(point.multipliers - 1.0))[1])


@pytest.fixture(scope="module")
def axle_reference():
    return _reference({"model": "axle4dof"})


@pytest.mark.parametrize("updates", [
    {"tread.lateral_damping_ns_per_m": 76.0, "operating.toe_deg": 0.47},
    {"friction.mu_static": 0.95, "tread.mass_kg": 0.93},
])
def test_agrees_with_the_bracketed_locator(axle_reference, updates):
    base, ref = axle_reference
    model = get_model("axle4dof")
    p = model.pack(with_updates(base, updates))
    fold, scales = ref.folds[0], ref.scales[0]
    V_pred = fold.orbit.speed + float(ref.fold_gradients[0] @ _difference(p, ref.p))
    direct = solve_fold(model, p, fold, V_pred, scales, SETTINGS, max_newton=12)
    bracketed = locate_fold(model, p, fold, V_pred, scales, SETTINGS, fold_curvature(model, ref.p, fold, scales,
                                                                                   SETTINGS))
    assert direct is not None and bracketed is not None
    assert abs(direct.orbit.speed - V_pred) > 1e-3 * V_pred  # a real move, not the guess
    np.testing.assert_allclose(direct.orbit.speed, bracketed.orbit.speed, rtol=1e-10)
    np.testing.assert_allclose(direct.orbit.period, bracketed.orbit.period, rtol=1e-9)
    assert abs(direct.tangent_speed) < SETTINGS.fold_tol
    assert _second_multiplier_gap(direct) < 1e-5  # a fold of cycles: a second multiplier at 1
    assert direct.n_unstable == bracketed.n_unstable


def test_toe_law():
    """tread1dof: the speed enters only as V sin(toe), so the fold speed scales with 1/sin(toe)."""
    base, ref = _reference({"model": "tread1dof"})
    model = get_model("tread1dof")
    for toe in (0.44, 0.58):
        p = model.pack(with_updates(base, {"operating.toe_deg": toe}))
        ratio = math.sin(math.radians(0.5)) / math.sin(math.radians(toe))
        for fold, scales, gradient in zip(ref.folds, ref.scales, ref.fold_gradients):
            V_pred = fold.orbit.speed + float(gradient @ _difference(p, ref.p))
            new = solve_fold(model, p, fold, V_pred, scales, SETTINGS, max_newton=12)
            assert new is not None
            np.testing.assert_allclose(new.orbit.speed, fold.orbit.speed * ratio, rtol=1e-10)
            np.testing.assert_allclose(new.orbit.amplitude(), fold.orbit.amplitude(), rtol=1e-8, atol=1e-12)


def test_converges_in_one_step_on_its_own_fold(axle_reference):
    _, ref = axle_reference
    model = get_model("axle4dof")
    fold = ref.folds[0]
    same = solve_fold(model, ref.p, fold, fold.orbit.speed, ref.scales[0], SETTINGS)
    assert same is not None and same.newton_iterations <= 2
    np.testing.assert_allclose(same.orbit.speed, fold.orbit.speed, rtol=1e-12)


def test_no_fold_near_the_guess_gives_none(axle_reference):
    """Parameters whose second Hopf point is supercritical (no fold on the branch): None, not a point."""
    base, ref = axle_reference
    model = get_model("axle4dof")
    params = with_updates(base, {"friction.mu_static": 0.82, "operating.vertical_load_n": 3700.0})
    diagram = bifurcation(params, **_FIXED_RANGE)
    assert not diagram.folds, "the sample must have no fold for this test"
    p = model.pack(params)
    fold = ref.folds[0]
    V_pred = fold.orbit.speed + float(ref.fold_gradients[0] @ _difference(p, ref.p))
    assert solve_fold(model, p, fold, V_pred, ref.scales[0], SETTINGS, max_newton=12) is None


def test_newton_stops_on_the_error_estimate():
    """``newton_converged``: a correction below tol, or one that left (by the contraction of
    the last two) an error below tol; never on the first iteration's estimate or without
    contraction."""
    tol = 1e-10
    assert newton_converged(5e-11, np.inf, tol)
    assert newton_converged(1e-8, 1e-4, tol)  # error left ~1e-12
    assert not newton_converged(1e-6, 1e-3, tol)  # ~1e-9 left: one more iteration
    assert not newton_converged(1e-9, np.inf, tol)
    assert not newton_converged(2e-9, 3e-9, tol)  # not contracting (round-off floor)


def test_stopping_early_loses_nothing(monkeypatch):
    """axle4dof, the nominal stable cycle at 130 km/h as the guess for other parameters: Newton
    stops on the estimate one iteration before its correction itself is below tol, and the
    cycle it stops at is within tol of the one iterated to 1e-13 from there (the estimate's
    error bound is honest)."""
    from polywear.solvers.continuation import stepper

    base = with_updates(Params(), {"model": "axle4dof"})
    diagram = bifurcation(base, **_FIXED_RANGE)
    model, V = get_model("axle4dof"), 130.0 / 3.6
    p = model.pack(with_updates(base, {"tread.lateral_damping_ns_per_m": 76.0, "operating.toe_deg": 0.47}))
    guess = next(c for c in diagram.cycles_at(130.0) if c.stable).orbit
    early = solve_at_speed(model, p, guess, V, SETTINGS)
    strict = solve_at_speed(model, p, early.orbit, V, ContinuationSettings(newton_tol=1e-13))
    with monkeypatch.context() as m:
        m.setattr(stepper, "newton_converged", lambda size, previous, tol: size < tol)  # solve_at_speed's
        plain = solve_at_speed(model, p, guess, V, SETTINGS)
    assert early.newton_iterations == plain.newton_iterations - 1
    scale = np.abs(strict.orbit.nodes).max(axis=0) + np.ptp(strict.orbit.nodes, axis=0)
    assert np.max(np.abs(early.orbit.nodes - strict.orbit.nodes) / scale) < SETTINGS.newton_tol
    assert early.orbit.period == pytest.approx(strict.orbit.period, rel=SETTINGS.newton_tol)


def test_parameter_tangent_is_the_fold_derivative(axle_reference):
    """The fold's tangent in the parameters (its augmented system differentiated, forward
    differences in the parameters and along the null vector): its speed component equals
    the exact fold-speed gradient (left null vector, another method) and the central
    difference of two folds solved at +-1e-4 of a 10 % step to 1e-5 (measured 3.5e-6: the
    speed needs the second differences), the orbit and period that central difference to
    1e-6 (measured 4e-8). Started along it, the fold 10 % away converges in fewer Newton
    iterations than from the recentred guess, to the same fold."""
    from polywear.solvers.continuation import fold_at, fold_parameter_tangent

    base, ref = axle_reference
    model = get_model("axle4dof")
    p = model.pack(with_updates(base, {"tread.lateral_damping_ns_per_m": 72.0, "operating.toe_deg": 0.55,
                                       "friction.mu_static": 0.95}))
    d = _difference(p, ref.p)
    fold, scales = ref.folds[0], ref.scales[0]
    dX = fold_parameter_tangent(model, ref.p, fold, d, scales, SETTINGS)
    np.testing.assert_allclose(dX[-1], float(ref.fold_gradients[0] @ d), rtol=1e-5)  # measured 3.5e-6
    h = 1e-4
    plus, minus = (solve_fold(model, ref.p + s * h * d, fold, fold.orbit.speed + s * h * dX[-1], scales, SETTINGS, 12)
                   for s in (1.0, -1.0))
    central = (np.concatenate([plus.orbit.nodes.ravel(), [plus.orbit.period, plus.orbit.speed]])
               - np.concatenate([minus.orbit.nodes.ravel(), [minus.orbit.period, minus.orbit.speed]])) / (2 * h)
    scale = np.max(np.abs(central[:-2]))
    assert np.max(np.abs(dX[:-2] - central[:-2])) < 1e-6 * scale  # measured 4e-8
    np.testing.assert_allclose(dX[-2], central[-2], rtol=1e-6)  # period, measured 3.4e-8
    np.testing.assert_allclose(dX[-1], central[-1], rtol=1e-5)
    V_pred = fold.orbit.speed + dX[-1]
    along, recentred_only = (fold_at(model, fold, ref.p, p, V_pred, scales, SETTINGS, tangent=t) for t in (True, False))
    np.testing.assert_allclose(along.orbit.speed, recentred_only.orbit.speed, rtol=1e-11)
    assert along.newton_iterations < recentred_only.newton_iterations
