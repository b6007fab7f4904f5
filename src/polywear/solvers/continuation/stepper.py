"""The stepper: Newton corrector and tangent of the cycle continuation on one mesh, and the
solves of single cycles that need no branch.

:class:`_Stepper` corrects a pseudo-arclength step (collocation equations, integral phase
condition, arclength condition) and gives the next unit tangent from the same bordered
matrix, in a norm weighted by the state, period and speed scales; :func:`_align_to_kinks`
re-solves a step on a mesh with points at the orbit's kinks. Single cycles:
:func:`solve_at_speed` (Newton at a fixed speed [m/s]), :func:`solve_at_speed_on_kinks`,
:func:`cycle_along_branch` (arclength steps to a speed from a Hopf point or a branch
point), and the Newton guesses :func:`orbit_between` and :func:`orbit_from_hopf`.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from ..arclength import correct, next_step, oriented
from ..collocation import Collocation, PeriodicOrbit, monodromy
from .branch import BranchPoint, ContinuationSettings, HopfStart
from .kinks import _kinks_off_mesh, _with_kinks, switching_times

if TYPE_CHECKING:
    from ...models.base import Model

__all__ = ["newton_converged", "STALL_FACTOR", "solve_at_speed", "solve_at_speed_on_kinks", "orbit_between",
           "orbit_from_hopf", "MAX_STEPS_TO_SPEED", "cycle_along_branch"]


class _Stepper:
    """Newton corrector and tangent of the cycle continuation on one mesh.

    Owns the model, the parameter vector ``p``, the settings and the scales of the norm:
    ``scales`` (one per state), ``speed_scale`` [m/s] and ``period_scale`` [s] (the
    period at the Hopf point). :meth:`remesh` makes the stepper of a new mesh (or new
    state scales) with the last point mapped onto it.
    """

    def __init__(self, model: Model, p: np.ndarray, mesh: np.ndarray, settings: ContinuationSettings,
                 scales: np.ndarray, speed_scale: float, period_scale: float) -> None:
        self.model, self.p, self.settings = model, p, settings
        self.scales, self.speed_scale, self.period_scale = scales, speed_scale, period_scale
        self.coll = Collocation(model, p, mesh, settings.degree)
        c = self.coll
        node_w = np.repeat(c.node_weights, c.n) / np.tile(scales, c.N * c.m) ** 2
        self.weights = np.concatenate([node_w, [1.0 / period_scale**2, 1.0 / speed_scale**2]])
        self.inv_scale = np.concatenate(
            [np.tile(1.0 / scales, c.N * c.m), [1.0 / period_scale, 1.0 / speed_scale]]
        )
        self.kinks: tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray]] | None = None
        """(X, kink times, ``dense(KINK_SAMPLES)`` of its orbit) of the last point
        :func:`_align_to_kinks` left on this mesh (see :meth:`known`)."""

    @classmethod
    def near(cls, model: Model, p: np.ndarray, orbit: PeriodicOrbit, speed: float, scales: np.ndarray,
             settings: ContinuationSettings) -> _Stepper:
        """The stepper on ``orbit``'s mesh with the norm the branches use (0.1 ``speed`` [m/s], its period)."""
        return cls(model, p, orbit.mesh, settings, scales, 0.1 * speed, orbit.period)

    def norm(self, dX: np.ndarray) -> float:
        return float(np.sqrt(np.sum(self.weights * dX * dX)))

    def unit(self, t: np.ndarray) -> np.ndarray:
        return t / self.norm(t)

    def angle(self, t: np.ndarray, t0: np.ndarray) -> float:
        """Angle [rad] between two unit tangents in the scaled norm."""
        return 2.0 * float(np.arcsin(min(1.0, 0.5 * self.norm(t - t0))))

    def correct(self, X0: np.ndarray, t0: np.ndarray, ds: float, phase_ref: PeriodicOrbit,
                predicted: bool = False) -> _Out | None:
        """Newton from the predictor X0 + ds t0.

        Returns ``(X, tangent, iterations, multipliers)`` or None when Newton fails. With
        ``predicted``, Newton also stops once the correction is below :data:`PREDICTED_STOP`
        and the next one that quadratic convergence predicts from the last two is below
        ``newton_tol`` (that iteration is counted, not run): the point is within a few
        ``newton_tol`` of the discrete branch (not at the rounding floor), and the tangent
        and multipliers come from a Jacobian within :data:`PREDICTED_STOP` of it.
        """
        c = self.coll
        border = np.vstack([c.phase_row(phase_ref), self.weights * t0])
        tol = self.settings.newton_tol
        sizes: list[float] = []

        def newton_step(X: np.ndarray) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray, np.ndarray]] | None:
            out = c.solve(X, border, np.array([border[0] @ X, border[1] @ (X - X0) - ds]))
            return None if out is None else (out[0], out[1:])

        def converged(dX: np.ndarray) -> bool:
            size = float(np.max(np.abs(dX * self.inv_scale)))
            sizes.append(size)
            return size < tol or (predicted and len(sizes) > 1 and size < PREDICTED_STOP
                                  and size ** 3 < tol * sizes[-2] ** 2)

        done = correct(newton_step, X0, t0, ds, self.settings.max_newton, converged)
        if done is None:
            return None
        X, (t, CL, CR), iterations = done
        iterations += sizes[-1] >= tol  # the predicted iteration counts, so the steps are sized as before
        return X, oriented(self.unit(t), t0, self.weights), iterations, np.linalg.eigvals(monodromy(CL, CR))

    def remesh(self, mesh: np.ndarray, X0: np.ndarray, t0: np.ndarray,
               scales: np.ndarray | None = None) -> _Step:
        """The stepper on a new mesh (and new state ``scales`` if given), with the previous
        point ``X0``, tangent ``t0`` and phase reference mapped to it."""
        c = self.coll
        previous = c.unpack(X0)
        tangent = c.unpack(t0)
        new = _Stepper(self.model, self.p, mesh, self.settings, self.scales if scales is None else scales,
                       self.speed_scale, self.period_scale)
        # point and tangent interpolated in one evaluation, side by side
        both = replace(previous, nodes=np.hstack([previous.nodes, tangent.nodes])).with_mesh(mesh).nodes
        phase_ref = replace(previous, mesh=new.coll.mesh, nodes=both[:, :c.n].copy())
        moved = replace(tangent, mesh=new.coll.mesh, nodes=both[:, c.n:])
        return new, new.coll.pack(phase_ref), new.unit(new.coll.pack(moved)), phase_ref

    def adapted_mesh(self, orbit: PeriodicOrbit, n_intervals: int, X: np.ndarray | None = None) -> np.ndarray:
        """``n_intervals`` intervals equidistributed for ``orbit`` (AUTO's rule), kinks on mesh
        points (with ``settings.align_kinks``). ``X``: the packed ``orbit``, whose kink times
        :func:`_align_to_kinks` may have found already (``kinks``)."""
        mesh = self.coll.adapted_mesh(orbit, n_intervals)
        if not self.settings.align_kinks:
            return mesh
        known = self.known(X)
        return _with_kinks(mesh, known[1] if known else switching_times(self.model, self.p, orbit))

    def known(self, X: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray]] | None:
        """``kinks`` if they belong to the point ``X`` (the same array), else None."""
        return self.kinks if self.kinks is not None and X is not None and self.kinks[0] is X else None


PREDICTED_STOP = 1e-9
"""Largest Newton correction (scaled norm) after which a continuation step may stop on the
next correction predicted by quadratic convergence, ``|dX_k|^3 / |dX_{k-1}|^2`` (see
:meth:`_Stepper.correct`): where the study cars' branches take four iterations, the third
correction is 1e-10 to 5e-9 and the fourth only confirms it at the rounding floor (~1e-11).
The multipliers then come from a Jacobian up to this far from the point: on the normal
form's branch (``tests/test_collocation.py``) the trivial one stays within 3.9e-10 of 1
(6.2e-11 with every iteration run; 1e-8 here gave 3.6e-8)."""

KINK_SAMPLES = 8
"""Samples per mesh interval of the kink search (:func:`switching_times`) after a step; the
first harmonic of the branch's orbits takes the same samples."""

_Out = tuple[np.ndarray, np.ndarray, int, np.ndarray]
"""A converged corrector: point X, unit tangent, Newton iterations, Floquet multipliers."""
_Step = tuple[_Stepper, np.ndarray, np.ndarray, PeriodicOrbit]
"""Where a step starts from: stepper, point X0, tangent t0, phase reference."""


def _hopf_start(model: Model, p: np.ndarray, hopf: HopfStart, settings: ContinuationSettings,
                amplitude_ref: float) -> _Step:
    """The start of the branch born at ``hopf``: the steady state as a trivial orbit on a uniform
    mesh, the tangent along the critical eigenvector (x component ``amplitude_ref`` [m]) and the
    norm's scales (x: ``amplitude_ref``, other states: the eigenvector's, plus 0.1 of the steady state)."""
    q = hopf.eigenvector / hopf.eigenvector[model.index("x")]  # x component 1
    scales = np.maximum(np.abs(q), 1e-6 * np.abs(q).max()) * amplitude_ref + 0.1 * np.abs(hopf.equilibrium)
    period_scale = 2.0 * np.pi / hopf.omega
    speed_scale = 0.1 * hopf.speed_ms
    N = settings.n_intervals
    mesh = np.linspace(0.0, 1.0, N + 1)
    stepper = _Stepper(model, p, mesh, settings, scales, speed_scale, period_scale)
    c = stepper.coll
    tau = (mesh[:-1, None] + np.diff(mesh)[:, None] * c.sch.nodes[None, :-1]).ravel()
    psi = np.real(q[None, :] * np.exp(2j * np.pi * tau)[:, None]) * amplitude_ref
    trivial = PeriodicOrbit(mesh, np.tile(hopf.equilibrium, (N * c.m, 1)), period_scale, hopf.speed_ms, c.m)
    t0 = stepper.unit(np.concatenate([psi.ravel(), [0.0, 0.0]]))
    return stepper, c.pack(trivial), t0, PeriodicOrbit(mesh, psi, period_scale, hopf.speed_ms, c.m)


def _align_to_kinks(start: _Step, ds: float, out: _Out) -> tuple[
        _Stepper, np.ndarray, np.ndarray, PeriodicOrbit, _Out | None]:
    """Re-solve the step from ``start`` on a mesh with points at the orbit's kinks until they
    stay there; returns the new start and corrector output (None if Newton failed)."""
    stepper, X0, t0, phase_ref = start
    new: _Out | None = out
    for _ in range(4):
        if new is None:
            break
        orbit = stepper.coll.unpack(new[0])
        samples = orbit.dense(KINK_SAMPLES)
        times = switching_times(stepper.model, stepper.p, orbit, KINK_SAMPLES, samples=samples)
        mesh = stepper.coll.mesh
        if not _kinks_off_mesh(times, mesh):
            stepper.kinks = (new[0], times, samples)
            break
        stepper, X0, t0, phase_ref = stepper.remesh(_with_kinks(mesh, times), X0, t0)
        new = stepper.correct(X0, t0, ds, phase_ref)
    return stepper, X0, t0, phase_ref, new


def _secant_in_bracket(p: tuple[float, float], q: tuple[float, float], s_a: float, s_b: float) -> float:
    """The zero of the line through the points ``(s, g)`` p and q, or the middle of the
    bracket [s_a, s_b] where that line is flat or its zero lies outside the bracket."""
    (s_p, g_p), (s_q, g_q) = p, q
    s = s_q - g_q * (s_q - s_p) / (g_q - g_p) if g_q != g_p else 0.5 * (s_a + s_b)
    return s if min(s_a, s_b) < s < max(s_a, s_b) else 0.5 * (s_a + s_b)


def newton_converged(size: float, previous: float, tol: float) -> bool:
    """Whether a Newton iterate is within ``tol`` [scaled]: its last correction ``size`` is,
    or the error left after that correction is, estimated from the contraction of the last
    two corrections as ``size**2 / previous`` (at most the error of linear convergence at
    that rate; quadratic convergence leaves far less). The estimate saves the last
    iteration, whose correction only confirms (e.g. scaled corrections 1e-4 then 1e-8: the
    error after the second is ~1e-12 or below)."""
    return size < tol or (np.isfinite(previous) and size < 0.5 * previous and size * size < tol * previous)


STALL_FACTOR = 100.0
""":func:`solve_at_speed` accepts a Newton iteration that stopped shrinking below this many
times ``settings.newton_tol`` [-]: the round-off floor of a small, ill-conditioned cycle
near its Hopf point (measured: scaled steps hovering at 1e-9-2e-9 for a 9e-6 m axle4dof
cycle 0.026 km/h from its Hopf point, after falling quadratically to 1e-9)."""


def solve_at_speed(model: Model, p: np.ndarray, guess: PeriodicOrbit, speed: float,
                   settings: ContinuationSettings = ContinuationSettings()) -> BranchPoint | None:
    """The periodic orbit at a fixed speed [m/s] by Newton from ``guess``; a BranchPoint or None.

    The border rows are the phase condition (relative to the guess) and ``V = speed``.
    The tangent of the returned point is not meaningful (zero).
    """
    coll = Collocation(model, p, guess.mesh, guess.m)
    X = coll.pack(guess)
    X[-1] = speed
    border = np.zeros((2, coll.size))
    border[0] = coll.phase_row(guess)
    border[1, -1] = 1.0
    scale = np.concatenate([np.tile(np.abs(guess.nodes).max(axis=0) + np.ptp(guess.nodes, axis=0) + 1e-300,
                                    coll.N * coll.m), [guess.period, abs(speed) + 1.0]])
    previous = np.inf
    for it in range(1, settings.max_newton + 1):
        out = coll.solve(X, border, np.array([border[0] @ X, X[-1] - speed]))
        if out is None:
            return None
        dX, _, CL, CR = out
        X = X + dX
        size = np.max(np.abs(dX / scale))
        # converged, or at the round-off floor: below STALL_FACTOR tol and no longer halving
        # (a small cycle near a Hopf point, ill-conditioned, whose steps hover about the tolerance)
        if newton_converged(size, previous, settings.newton_tol) or (
                size < STALL_FACTOR * settings.newton_tol and size > 0.5 * previous):
            mu = np.linalg.eigvals(monodromy(CL, CR))
            return BranchPoint(coll.unpack(X), mu, np.zeros(coll.size), it)
        previous = size
    return None


def solve_at_speed_on_kinks(model: Model, p: np.ndarray, point: BranchPoint,
                            settings: ContinuationSettings = ContinuationSettings()) -> BranchPoint | None:
    """``point`` (a cycle solved at fixed speed, e.g. on another cycle's mesh) re-solved on a
    mesh adapted to it with mesh points at its kinks (:func:`switching_times`), as the
    continuation's cycles are, until the kinks stay on the mesh (at most 4 times): a kink
    inside a mesh interval costs the collocation its order (measured: a tread1dof cycle at
    130 km/h solved on a neighbour's mesh had its amplitude 1.4e-4 too large; on its own
    kink-aligned mesh it agrees with a 4x finer mesh to 6e-6). ``point`` itself when it has
    no kink off its mesh (or ``settings.align_kinks`` is off); None if Newton fails."""
    for _ in range(4):
        orbit = point.orbit
        times = switching_times(model, p, orbit) if settings.align_kinks else np.empty(0)
        if not _kinks_off_mesh(times, orbit.mesh):
            return point
        mesh = _with_kinks(Collocation(model, p, orbit.mesh, orbit.m).adapted_mesh(orbit), times)
        again = solve_at_speed(model, p, orbit.with_mesh(mesh), orbit.speed, settings)
        if again is None:
            return None
        point = again
    return point


def orbit_between(a: PeriodicOrbit, c: PeriodicOrbit, speed: float) -> PeriodicOrbit:
    """The orbit at ``speed`` [m/s] interpolated linearly in the speed between two orbits of a
    branch (on ``a``'s mesh): the guess of Newton at that speed."""
    s = (speed - a.speed) / (c.speed - a.speed)
    return replace(a, nodes=(1 - s) * a.nodes + s * c.with_mesh(a.mesh).nodes,
                   period=(1 - s) * a.period + s * c.period, speed=speed)


def orbit_from_hopf(model: Model, p: np.ndarray, orbit: PeriodicOrbit, hopf_speed: float,
                    speed: float) -> PeriodicOrbit:
    """A cycle of the branch born at a Hopf point at ``hopf_speed`` [m/s] moved to ``speed``
    [m/s] by the square-root amplitude law: its deviation from the steady state scaled by
    ``sqrt(|speed - hopf_speed| / |orbit.speed - hopf_speed|)`` about the steady state at
    ``speed`` (a Newton guess between the Hopf point and the branch's first point)."""
    ratio = np.sqrt(abs(speed - hopf_speed) / abs(orbit.speed - hopf_speed))
    nodes = model.equilibrium(speed, p) + ratio * (orbit.nodes - model.equilibrium(orbit.speed, p))
    return replace(orbit, nodes=nodes, speed=speed)


MAX_STEPS_TO_SPEED = 40
"""Largest number of arclength steps of :func:`cycle_along_branch`."""


def cycle_along_branch(model: Model, p: np.ndarray, start: HopfStart | BranchPoint, speed: float,
                       settings: ContinuationSettings = ContinuationSettings(), scales: np.ndarray | None = None,
                       reverse: bool = False, amplitude_ref: float = 1e-4,
                       first_step: float | None = None) -> BranchPoint | None:
    """The cycle at ``speed`` [m/s] on the branch through ``start``, reached along the branch.

    ``start`` is a Hopf point (the branch born there, with the start and norm of
    :func:`~.from_hopf.continue_from_hopf`) or a branch point with its tangent, e.g. a fold (then
    ``scales`` are the state scales of its branch; ``reverse``: along minus the tangent).
    Pseudo-arclength steps towards ``speed`` until one passes it, then Newton at that
    speed (:func:`solve_at_speed`) from the two points that bracket it, on a mesh adapted
    to the interpolated orbit. ``first_step``: arclength of the first step (scaled; default
    ``settings.ds_initial``), then as the branches' steps. None if a corrector fails at the
    smallest step, the branch turns away from ``speed`` (a fold) before reaching it, or
    after :data:`MAX_STEPS_TO_SPEED` steps.
    """
    if isinstance(start, BranchPoint):
        if scales is None:
            raise ValueError("cycle_along_branch from a branch point needs the state scales of its branch")
        stepper = _Stepper.near(model, p, start.orbit, start.orbit.speed, scales, settings)
        X0 = stepper.coll.pack(start.orbit)
        t0 = (-1.0 if reverse else 1.0) * stepper.unit(start.tangent)
        phase_ref = start.orbit
    else:
        stepper, X0, t0, phase_ref = _hopf_start(model, p, start, settings, amplitude_ref)
    side = np.sign(speed - X0[-1])
    ds = settings.ds_initial if first_step is None else first_step
    c = stepper.coll
    for _ in range(MAX_STEPS_TO_SPEED):
        out = stepper.correct(X0, t0, ds, phase_ref)
        if out is None or stepper.norm(out[0] - X0 - ds * t0) > settings.max_correction * ds:
            ds *= 0.5
            if ds < settings.ds_min:
                return None
            continue
        X, t, iterations, _ = out
        if (speed - X[-1]) * side <= 0.0:  # passed
            guess = orbit_between(c.unpack(X0), c.unpack(X), speed)
            return solve_at_speed(model, p, guess.with_mesh(stepper.adapted_mesh(guess, c.N)), speed, settings)
        if t[-1] * side <= 0.0:
            return None  # the branch turns away before the speed
        X0, t0, phase_ref = X, t, c.unpack(X)
        ds = next_step(ds, iterations, settings.ds_max, grow=1.5, shrink_after=5)
    return None
