"""Folds of cycles: located between two points of a branch, and found again at nearby parameters.

Between two points of a branch whose tangents' speed components have opposite signs,
:func:`_locate_fold` finds the fold by secant iteration in the arclength. At a parameter
vector near one where a fold is known (the stability maps' fold curves, the fleet's fast
band path): :func:`solve_fold` (Newton on the fold's minimally augmented system),
:func:`locate_fold` (a march along the new branch, then the bracketed secant), and
:func:`fold_at`, which tries the first and falls back on the second; the guesses
:func:`recentred` and :func:`fold_parameter_tangent`, and :func:`fold_curvature`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from ..arclength import oriented
from ..collocation import Collocation, PeriodicOrbit, monodromy
from .branch import BranchPoint, ContinuationSettings
from .stepper import _secant_in_bracket, _Step, _Stepper, newton_converged

if TYPE_CHECKING:
    from ...models.base import Model

__all__ = ["MAX_MARCH", "MAX_STEP", "fold_curvature", "locate_fold", "FOLD_DIFFERENCE", "MAX_FOLD_CORRECTION",
           "SLOW_FOLD_CONTRACTION", "SLOW_FOLD_SIZE", "solve_fold", "PARAMETER_DIFFERENCE",
           "fold_parameter_tangent", "recentred", "fold_at", "on_adapted_mesh"]


def _locate_fold(start: _Step, ds: float, prev: BranchPoint, point: BranchPoint) -> BranchPoint | None:
    """The fold between two branch points: zero of the tangent's speed component in the arclength."""
    stepper, X0, t0, phase_ref = start
    return _fold_in_bracket(stepper, X0, t0, phase_ref, (0.0, prev.tangent_speed), (ds, point.tangent_speed))


def _fold_in_bracket(stepper: _Stepper, X0: np.ndarray, t0: np.ndarray, phase_ref: PeriodicOrbit,
                     a: tuple[float, float], b: tuple[float, float], max_iter: int = 30) -> BranchPoint | None:
    """Secant iteration on the arclength s from X0 (along t0) for dV/ds = 0 inside a bracket.

    ``a`` and ``b`` are ``(s, dV/ds)`` with dV/ds of opposite signs. Secant steps through
    the last two points; a step that leaves the bracket (kept up to date) is replaced by
    bisection. Returns the last point (within ``settings.fold_tol`` of the fold unless
    ``max_iter`` ran out or a corrector failed), or None if the first corrector fails.
    Regula falsi (through the bracket's ends) converges only linearly where ``dV/ds`` is
    curved over the bracket: measured on a map, about 3 more correctors per fold
    relocation; on the 61 folds of 9 axle4dof diagrams (``benchmarks/bench_pd_ns.py``'s
    samples) 4.7 correctors per fold instead of 6.5, the folds the same to 1e-12 relative.
    """
    (s_a, g_a), (s_b, _) = a, b
    (s_prev, g_prev), (s_cur, g_cur) = a, b
    best = None
    for _ in range(max_iter):
        s = _secant_in_bracket((s_prev, g_prev), (s_cur, g_cur), s_a, s_b)
        out = stepper.correct(X0, t0, s, phase_ref)
        if out is None:
            break
        X, t, iterations, multipliers = out
        g = float(t[-1])
        best = BranchPoint(stepper.coll.unpack(X), multipliers, t, iterations, "LP")
        if abs(g) < stepper.settings.fold_tol:
            return best
        if np.sign(g) == np.sign(g_a):
            s_a, g_a = s, g
        else:
            s_b = s
        s_prev, g_prev, s_cur, g_cur = s_cur, g_cur, s, g
    return best


# -- a fold of cycles near a fold at nearby parameters ------------------------------------------
MAX_MARCH = 40
"""Largest number of arclength steps (march and bracketed secant) of one :func:`locate_fold`."""
MAX_STEP = 0.5
"""Largest arclength step [scaled] of the march towards the fold."""


def fold_curvature(model: Model, p: np.ndarray, fold: BranchPoint, scales: np.ndarray,
                   settings: ContinuationSettings, h: float = 1e-3) -> float:
    """d(dV/ds)/ds at a fold [m/s per scaled arclength^2], by central difference along its branch
    (``scales``: the branch's state scales; NaN if a corrector fails)."""
    stepper = _Stepper.near(model, p, fold.orbit, fold.orbit.speed, scales, settings)
    X, t = stepper.coll.pack(fold.orbit), stepper.unit(fold.tangent)
    g = []
    for s in (-h, h):
        out = stepper.correct(X, t, s, fold.orbit)
        if out is None:
            return np.nan
        g.append(float(out[1][-1]))
    return (g[1] - g[0]) / (2.0 * h)


def locate_fold(model: Model, p: np.ndarray, guess: BranchPoint, speed: float, scales: np.ndarray,
                settings: ContinuationSettings, curvature: float = np.nan) -> BranchPoint | None:
    """The fold of cycles at ``p`` near ``guess`` (a fold at a nearby parameter vector).

    Newton onto the cycle branch at ``p`` from the guess with its speed replaced by
    ``speed`` [m/s] (the border row is the guess's tangent, so this lands on the branch
    near the fold, not on it). The speed component ``g = dV/ds`` of the branch tangent
    vanishes at the fold and is nearly linear in the arclength ``s`` there, so: steps of
    ``-1.2 g / (dg/ds)`` (``curvature``, e.g. the guess's :func:`fold_curvature`, first;
    without it a probe of 0.01 downhill; then the secant slope of the last two points,
    at most :data:`MAX_STEP`) until ``g`` changes sign, then secant iteration inside that
    bracket (:func:`_fold_in_bracket`, as for a fold between two points of a branch) to
    ``|g| < settings.fold_tol``. ``scales`` are the state scales of the norm.
    None if Newton fails or the fold is not found within :data:`MAX_MARCH` steps.
    """
    orbit = guess.orbit
    stepper = _Stepper.near(model, p, orbit, speed, scales, settings)
    c = stepper.coll
    X0 = c.pack(orbit)
    X0[-1] = speed
    out = stepper.correct(X0, stepper.unit(guess.tangent), 0.0, orbit)
    if out is None:
        return None
    X, t, g = out[0], out[1], float(out[1][-1])
    if abs(g) < settings.fold_tol:
        return BranchPoint(c.unpack(X), out[3], t, out[2], "LP")
    slope = curvature if np.isfinite(curvature) and curvature != 0.0 else -np.sign(g) / 1e-2
    limit = MAX_STEP  # halved at every failed step, grown by half at every good one
    step = float(np.clip(-1.2 * g / slope, -limit, limit))
    start = c.unpack(X)  # phase reference of the steps from X (X moves only while marching)
    for used in range(1, MAX_MARCH + 1):
        nxt = stepper.correct(X, t, step, start)
        if nxt is None:
            step *= 0.5
            limit = abs(step)
            if limit < settings.ds_min:
                return None
            continue
        limit = min(1.5 * limit, MAX_STEP)
        g_new = float(nxt[1][-1])
        if abs(g_new) < settings.fold_tol:
            return BranchPoint(c.unpack(nxt[0]), nxt[3], nxt[1], nxt[2], "LP")
        if np.sign(g_new) != np.sign(g):  # bracketed in [0, step] from X
            fold = _fold_in_bracket(stepper, X, t, start, (0.0, g), (step, g_new), MAX_MARCH - used)
            return fold if fold is not None and abs(fold.tangent_speed) < settings.fold_tol else None
        slope = (g_new - g) / step
        X, t, g = nxt[0], nxt[1], g_new
        start = c.unpack(X)
        if slope == 0.0 or -g / slope * np.sign(step) < 0:  # moving away from the fold: turn round
            step = -float(np.clip(2.0 * step, -limit, limit))
        else:
            step = float(np.clip(-1.2 * g / slope, -limit, limit))
    return None


FOLD_DIFFERENCE = 1e-7
"""Step of the forward difference of the collocation Jacobian along the null vector in
:func:`solve_fold`, relative to the largest scaled component of the null vector [-]."""


MAX_FOLD_CORRECTION = 1.0
"""Largest scaled Newton correction of :func:`solve_fold` [-]: a longer one is cut to this
length (damped Newton). Measured on 60 axle4dof samples 10 % from their references:
undamped, 36 of 113 fold solves failed and went to the marching locator; damped at 1.0,
27 of 110, and the fast path took 62-64 ms per sample instead of 83 ms."""


SLOW_FOLD_CONTRACTION = 0.3
""":func:`solve_fold` gives up after two successive corrections below :data:`SLOW_FOLD_SIZE` that
shrank by less than this factor each [-]: linear convergence where Newton should be quadratic.
Measured on 120 axle4dof samples 10 % from their references: of the 25 fold solves that
failed within 12 iterations (mostly folds of 4e-5-2.5e-4 m next to their Hopf points), 15
crept at ratios 0.5-0.7 from corrections of ~1e-2 on (the other 10 wandered or diverged);
with this exit the same 108 of 133 converge, and the marching locator takes over from the
creeping ones several iterations earlier (18.1 -> 16.3 assemblies per sample in the solver)."""
SLOW_FOLD_SIZE = 3e-2
"""Scaled correction below which :func:`solve_fold` expects quadratic convergence [-]."""


def solve_fold(model: Model, p: np.ndarray, guess: BranchPoint, speed: float, scales: np.ndarray,
               settings: ContinuationSettings, max_newton: int | None = None) -> BranchPoint | None:
    """The fold of cycles at ``p`` by Newton on its minimally augmented system.

    Unknowns: the collocated orbit, its period and the speed V (X). Equations: the
    collocation equations F(X) = 0, the integral phase condition relative to the guess,
    and ``g(X) = 0``, where ``g`` is the speed component of the null vector ``t`` of the
    collocation Jacobian bordered by the phase row and the guess's tangent ``c``
    (``M t = e_last``, ``M = [F_X; phase; c]``): g vanishes exactly at a fold. The
    Newton matrix is M with its last row replaced by the gradient of g, a rank-one
    update: only the products ``grad g . v = -(M^-1 [D_t F_X v; 0; 0])_V`` are needed
    (for the Newton direction y and for t), so every solve is a forward solve of M by
    the structured solver. ``D_t F_X``, the derivative of the collocation Jacobian along
    t, is a forward difference (:data:`FOLD_DIFFERENCE`); it sets only the rate of
    convergence, not the fold.

    Starts from ``guess`` (a fold at nearby parameters) with its speed replaced by
    ``speed`` [m/s]; ``scales`` are the state scales of its branch's norm. Converged when
    the scaled Newton correction, or the error estimated after it
    (:func:`newton_converged`), is below ``settings.newton_tol`` and the unit tangent's
    speed component below ``settings.fold_tol``. Returns the fold (multipliers, unit
    tangent oriented as the guess's) or None when Newton does not converge within
    ``max_newton`` iterations (default ``settings.max_newton``) or converges only linearly
    (:data:`SLOW_FOLD_CONTRACTION`); corrections longer than :data:`MAX_FOLD_CORRECTION` are
    cut to that length.
    """
    orbit = guess.orbit
    stepper = _Stepper.near(model, p, orbit, speed, scales, settings)
    c = stepper.coll
    X = c.pack(orbit)
    X[-1] = speed
    border = np.vstack([c.phase_row(orbit), stepper.weights * stepper.unit(guess.tangent)])
    previous, slow = np.inf, 0
    for iterations in range(1, (max_newton or settings.max_newton) + 1):
        res, blocks, tcol, vcol = c.evaluate(X)
        if not (np.all(np.isfinite(res)) and np.all(np.isfinite(blocks))):
            return None
        dX = _fold_newton_step(stepper, X, border, (res, blocks, tcol, vcol), -res, -(border[0] @ X))
        if dX is None:
            return None
        size = float(np.max(np.abs(dX * stepper.inv_scale)))
        if not np.isfinite(size):
            return None
        X = X + dX * min(1.0, MAX_FOLD_CORRECTION / size)  # damped far from the fold
        if newton_converged(size, previous, settings.newton_tol):
            final = c.solve(X, border, np.array([border[0] @ X, 0.0]))
            if final is None:
                return None
            tangent = oriented(stepper.unit(final[1]), guess.tangent, stepper.weights)
            if abs(tangent[-1]) >= settings.fold_tol:
                return None
            multipliers = np.linalg.eigvals(monodromy(final[2], final[3]))
            return BranchPoint(c.unpack(X), multipliers, tangent, iterations, "LP")
        slow = slow + 1 if SLOW_FOLD_SIZE > previous and size > SLOW_FOLD_CONTRACTION * previous else 0
        if slow == 2:
            return None
        previous = size
    return None


def _fold_newton_step(stepper: _Stepper, X: np.ndarray, border: np.ndarray, system: tuple, r_F: np.ndarray,
                      r_phase: float, parameter_blocks: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
                      ) -> np.ndarray | None:
    """The solution dX of the fold's minimally augmented system linearized at X (see
    :func:`solve_fold`): ``F_X dX = r_F``, ``phase . dX = r_phase`` and ``grad g . dX = -g``;
    or, with ``parameter_blocks`` (the derivative of the collocation Jacobian along a
    parameter direction, in the parts ``evaluate`` gives), ``grad g . dX = -g_theta``, minus
    the change of g along that direction (with ``r_F = -F_theta`` dX is then the fold's
    tangent in the parameters). ``system`` is ``evaluate(X)``. None where a solve fails."""
    c = stepper.coll
    _, blocks, tcol, vcol = system
    rhs = np.zeros((c.size, 2))
    rhs[:-2, 0], rhs[-2, 0], rhs[-1, 1] = r_F, r_phase, 1.0
    out = c.solve_system(blocks, tcol, vcol, border, rhs)
    if out is None:
        return None
    t = out[0][:, 1]  # M^-1 e_last: g is its speed component
    if parameter_blocks is None:
        g = float(t[-1])
    else:
        column = np.zeros((c.size, 1))
        column[:-2, 0] = c.product(*parameter_blocks, t)
        w = c.solve_system(blocks, tcol, vcol, border, column)
        if w is None:
            return None
        g = -float(w[0][-1, 0])  # g_theta = -(M^-1 [(dF_X/dtheta) t; 0; 0])_V
    y = out[0][:, 0] - g * t  # M^-1 [r_F; r_phase; -g]
    e = FOLD_DIFFERENCE / float(np.max(np.abs(t * stepper.inv_scale)))
    _, plus_b, plus_t, plus_v = c.evaluate(X + e * t)
    difference = ((plus_b - blocks) / e, (plus_t - tcol) / e, (plus_v - vcol) / e)
    products = np.zeros((c.size, 2))
    products[:-2, 0], products[:-2, 1] = c.product(*difference, y), c.product(*difference, t)
    z = c.solve_system(blocks, tcol, vcol, border, products)
    if z is None:
        return None
    grad_y, grad_t = -z[0][-1, 0], -z[0][-1, 1]
    if grad_t == 0.0:
        return None
    return y - t * ((grad_y + g) / grad_t)


PARAMETER_DIFFERENCE = 1e-7
"""Relative change of the parameters in the forward difference of :func:`fold_parameter_tangent` [-]."""


def fold_parameter_tangent(model: Model, p: np.ndarray, fold: BranchPoint, direction: np.ndarray,
                           scales: np.ndarray, settings: ContinuationSettings) -> np.ndarray | None:
    """dX/dtheta of the fold of cycles ``fold`` (converged at ``p``) along ``p + theta direction``:
    the orbit, period and speed of the fold to first order in the parameters, from the
    fold's minimally augmented system differentiated (``G_X dX = -G_theta``, one Newton
    step's solves; ``G_theta`` by a forward difference in the parameters). Its speed
    component is the fold speed's derivative. ``scales`` are the state scales of the
    fold's branch. None where a solve fails."""
    orbit = fold.orbit
    stepper = _Stepper.near(model, p, orbit, orbit.speed, scales, settings)
    c = stepper.coll
    X = c.pack(orbit)
    finite = np.isfinite(p) & (direction != 0.0)
    if not finite.any():
        return np.zeros_like(X)
    eps = PARAMETER_DIFFERENCE / float(np.max(np.abs(direction[finite]) / (np.abs(p[finite]) + 1e-300)))
    system = c.evaluate(X)
    shifted = Collocation(model, p + eps * direction, orbit.mesh, orbit.m).evaluate(X)
    F_theta = (shifted[0] - system[0]) / eps
    blocks = ((shifted[1] - system[1]) / eps, (shifted[2] - system[2]) / eps, (shifted[3] - system[3]) / eps)
    border = np.vstack([c.phase_row(orbit), stepper.weights * stepper.unit(fold.tangent)])
    return _fold_newton_step(stepper, X, border, system, -F_theta, 0.0, blocks)


def recentred(model: Model, orbit: PeriodicOrbit, p_from: np.ndarray, p_to: np.ndarray,
              speed: float) -> PeriodicOrbit:
    """``orbit`` (a cycle at ``p_from``) as a Newton guess at ``p_to`` and ``speed`` [m/s]: its
    deviation from the steady state kept, about the steady state of ``p_to`` at that speed.
    The steady state moves with the parameters by far more than a small cycle's amplitude
    (e.g. 4e-5 m for a fold next to its Hopf point), which a guess left where it was has to
    cover first."""
    shift = model.equilibrium(speed, p_to) - model.equilibrium(orbit.speed, p_from)
    return replace(orbit, nodes=orbit.nodes + shift, speed=speed)


def fold_at(model: Model, fold: BranchPoint, p_from: np.ndarray, p_to: np.ndarray, speed: float,
            scales: np.ndarray, settings: ContinuationSettings, curvature: float | Callable[[], float] = np.nan,
            max_newton: int = 12, tangent: bool = False) -> BranchPoint | None:
    """The fold of cycles at ``p_to`` near ``fold`` (one at ``p_from``), its speed predicted as
    ``speed`` [m/s]: :func:`solve_fold` from the :func:`recentred` guess, or with ``tangent``
    from the fold moved along its tangent in the parameters (:func:`fold_parameter_tangent`,
    the whole orbit to first order; its speed replaces ``speed``); where that Newton fails
    (its basin is smaller: e.g. a fold of tiny amplitude next to its Hopf point), the
    marching :func:`locate_fold` from the recentred guess. ``curvature`` is the fold's
    d(dV/ds)/ds for the march (a number, or a function evaluated only when the march is
    needed); ``scales`` the state scales of its branch; ``max_newton`` the iterations of
    :func:`solve_fold` (from folds 10 % away in the parameters it takes 5-10 from the
    recentred guess, 3-7 along the tangent). None if neither finds the fold."""
    guess = None
    if tangent:
        direction = np.where(np.isfinite(p_to) & np.isfinite(p_from), p_to - p_from, 0.0)  # NaN: no parameter
        dX = fold_parameter_tangent(model, p_from, fold, direction, scales, settings)
        if dX is not None and np.all(np.isfinite(dX)):
            o = fold.orbit
            guess = replace(fold, orbit=replace(o, nodes=o.nodes + dX[:-2].reshape(o.nodes.shape),
                                                period=o.period + float(dX[-2]), speed=o.speed + float(dX[-1])))
    def recentred_guess() -> BranchPoint:  # the march's start; solve_fold's without the tangent
        return replace(fold, orbit=recentred(model, fold.orbit, p_from, p_to, speed))

    guess = guess if guess is not None else recentred_guess()
    new = solve_fold(model, p_to, guess, guess.orbit.speed, scales, settings, max_newton)
    if new is None:
        guess = recentred_guess() if tangent else guess
        new = locate_fold(model, p_to, guess, speed, scales, settings, curvature() if callable(curvature) else curvature)
    return new


def on_adapted_mesh(model: Model, p: np.ndarray, fold: BranchPoint) -> BranchPoint:
    """The fold's orbit and tangent moved onto a mesh adapted to its orbit (same number of intervals)."""
    c = Collocation(model, p, fold.orbit.mesh, fold.orbit.m)
    mesh = c.adapted_mesh(fold.orbit)
    new = Collocation(model, p, mesh, fold.orbit.m)
    tangent = new.pack(c.unpack(fold.tangent).with_mesh(mesh))
    return BranchPoint(fold.orbit.with_mesh(mesh), fold.multipliers, tangent, fold.newton_iterations, "LP")
