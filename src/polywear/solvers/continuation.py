"""Pseudo-arclength continuation of periodic orbits in the speed V.

Each step predicts along the unit tangent, corrects with Newton on the collocation
equations plus the integral phase condition and the arclength condition, and takes
the next tangent from the same bordered matrix. Step length adapts to the number of
Newton iterations. All norms are weighted by scales (state amplitudes, period,
speed) so that the arclength mixes quantities of order one.

Along the branch: Floquet multipliers at every point (monodromy by condensation,
with the trivial multiplier as accuracy check), folds of cycles located by secant
iteration on the speed component of the tangent, period doubling and torus
(Neimark-Sacker) bifurcations detected by multipliers crossing the unit circle
at -1 or as a complex pair, and located on the crossing by root finding on a
test function of the multipliers.

Every branch ends with a typed reason (:class:`BranchEnd`). Before a branch is given
up the numerics are rescued as a specialist would: a step whose monodromy fails the
trivial-multiplier check, or whose Newton iteration fails at the smallest step, is
re-solved on a finer, kink-aligned, adapted mesh. What cannot be rescued ends the
branch as failed, with the speed and the reason.

:func:`locate_fold` finds the fold of cycles at a parameter vector near a fold known at
nearby parameters (the stability maps' fold curves, the fleet's fast band path). The
predictor/corrector step, tangent orientation and step-length control are
:mod:`polywear.solvers.arclength`, shared with the Hopf curves of
:mod:`polywear.solvers.curve_continuation`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from enum import Enum
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
from ..settings import check_count, check_order, check_positive
from .arclength import correct, next_step, oriented
from .collocation import Collocation, PeriodicOrbit, monodromy

if TYPE_CHECKING:
    from ..dynamics.stability import HopfPoint
    from ..models.base import Model

__all__ = [
    "BranchEnd",
    "ContinuationSettings",
    "BranchPoint",
    "Branch",
    "continue_from_hopf",
    "solve_at_speed",
    "orbit_from_hopf",
    "orbit_between",
    "cycle_along_branch",
    "switching_times",
    "fold_curvature",
    "locate_fold",
    "solve_fold",
    "on_adapted_mesh",
    "certainly_unstable",
    "same_special_point",
    "stability_decided",
    "trivial_error",
]


@dataclass(frozen=True)
class ContinuationSettings:
    """Numerical settings of the cycle continuation (dimensionless unless stated)."""

    n_intervals: int = 40
    degree: int = 4
    ds_initial: float = 0.02
    ds_min: float = 1e-7
    ds_max: float = 0.5
    max_steps: int = 400
    newton_tol: float = 1e-10
    max_newton: int = 8
    adapt_every: int = 3
    fold_tol: float = 1e-9
    crossing_tol: float = 1e-6
    """A located period doubling (PD) has a multiplier within this of -1, a torus bifurcation
    (NS) a complex pair within this of modulus 1. Above the accuracy of the multipliers on
    most cycles (the trivial multiplier's error at 48 PD/NS points of 9 axle4dof samples:
    median 8e-8); the speed error is this over |dmu/dV| (0.016 to 10 per km/h there):
    median 8e-7, at most 6e-5 km/h."""
    min_amplitude: float = 1e-3
    """The branch ends (at a Hopf point) once the scaled amplitude falls below this."""
    max_amplitude: float = 1e3
    """The branch stops once the scaled amplitude exceeds this."""
    align_kinks: bool = True
    """Put mesh points where the orbit crosses a kink of the vector field (v_r = 0, contact
    loss) and re-solve, so that no collocation interval straddles a jump of the Jacobian."""
    multiplier_tol: float = 1e-5
    """Accepted |mu - 1| of the trivial Floquet multiplier (a larger one only where every
    other multiplier is far from the unit circle, see :func:`stability_decided`). Otherwise
    the step is re-solved on an adapted mesh with twice the intervals (up to
    ``max_intervals``); if that does not help the branch ends as failed
    (``BranchEnd.MULTIPLIER_CHECK_LOST``)."""
    max_intervals: int = 320
    """Finest mesh the rescue of a step may use (mesh intervals)."""
    hopf_approach_step: float = 1e-4
    """A step that passes through zero amplitude (onto another Hopf point) is retried with
    half the step until the step is this short, so that a fold just before the Hopf point
    is not stepped over; then the branch ends there (``BranchEnd.HOPF_REACHED``)."""
    max_correction: float = 5.0
    """A step of a branch whose corrector ends more than this many step lengths from its
    predictor (scaled norm) has left the branch, e.g. past a Hopf point onto other cycles
    far away: it counts as failed, and is retried shorter (on the default diagrams the
    correctors end within 0.7 step lengths)."""
    max_turn: float | None = 0.2
    """Largest angle [rad] between the tangents at the ends of one step (scaled norm), or None
    (no limit: step lengths follow the Newton iterations alone). A step that turns by more
    is retried shorter, and the next step is sized to turn by about half of it. Without
    it, steps of full length across sharp bends of a branch stepped over narrow stable
    windows next to folds (14 of 100 random axle4dof cars with four Hopf points at +-10 %,
    e.g. a window at 63.23-63.37 km/h below a first Hopf point at 68.2 km/h) or landed on
    another branch passing close by. 0.2 rad costs ~1.3-1.4x the steps' CPU time of no
    limit; 0.1 rad gave the same bands on those 14 cars."""
    turn_floor: float = 1e-3
    """Steps this short are never rejected or shortened for their turn: at a corner of a
    branch (grazing of a kink of the vector field) the tangent jumps however short the step."""
    max_period_factor: float = 10.0
    """The branch ends (``BranchEnd.PERIOD_LIMIT``) when the period exceeds this multiple
    of the period at its Hopf point: the cycles approach an orbit of infinite period
    (e.g. homoclinic to the steady state), where the monodromy product loses all accuracy."""

    def __post_init__(self) -> None:
        check_count(self, "n_intervals", "degree", "max_steps", "max_newton")
        check_count(self, "adapt_every", minimum=0)  # 0: never adapt the mesh
        check_positive(self, "ds_initial", "ds_min", "ds_max", "newton_tol", "fold_tol", "crossing_tol",
                       "min_amplitude", "hopf_approach_step", "max_correction",
                       "turn_floor")
        if self.max_turn is not None and not 0.0 < self.max_turn <= np.pi:
            raise ValueError(f"ContinuationSettings: max_turn = {self.max_turn!r}: must be None or lie in (0, pi] [rad]")
        check_positive(self, "max_amplitude", "multiplier_tol", "max_period_factor", finite=False)
        check_order(self, "ds_min", "ds_initial", "ds_max")
        check_order(self, "min_amplitude", "max_amplitude")


class BranchEnd(str, Enum):
    """Why a branch of cycles ended. A ``failed`` end is a numerical failure: the branch
    beyond its last point is unknown, and nothing may be concluded from where it stops."""

    RANGE_END = "range_end"
    HOPF_REACHED = "hopf_reached"
    AMPLITUDE_LIMIT = "amplitude_limit"
    PERIOD_LIMIT = "period_limit"
    STEP_UNDERFLOW = "step_underflow"
    MULTIPLIER_CHECK_LOST = "multiplier_check_lost"
    MAX_STEPS = "max_steps"

    @property
    def failed(self) -> bool:
        return self in (BranchEnd.STEP_UNDERFLOW, BranchEnd.MULTIPLIER_CHECK_LOST, BranchEnd.MAX_STEPS)

    @property
    def description(self) -> str:
        return _END_TEXT[self]


_END_TEXT = {
    BranchEnd.RANGE_END: "left the speed range",
    BranchEnd.HOPF_REACHED: "returned to an equilibrium (Hopf point)",
    BranchEnd.AMPLITUDE_LIMIT: "amplitude limit reached",
    BranchEnd.PERIOD_LIMIT: "period limit reached (the cycles approach an orbit of infinite period)",
    BranchEnd.STEP_UNDERFLOW: "step size underflow (Newton did not converge)",
    BranchEnd.MULTIPLIER_CHECK_LOST: "Floquet multipliers not resolved (trivial multiplier check lost)",
    BranchEnd.MAX_STEPS: "maximum number of steps",
}


@dataclass
class BranchPoint:
    """One converged orbit of a branch, with its Floquet multipliers."""

    orbit: PeriodicOrbit
    multipliers: np.ndarray
    tangent: np.ndarray = field(repr=False)
    """Unit tangent of the branch (same layout as the collocation unknowns)."""
    newton_iterations: int
    label: str = ""
    resolved: bool = True
    """False for a cycle so strongly unstable that the monodromy product cannot resolve its
    trivial multiplier on the finest mesh: it is certainly unstable (see
    :func:`certainly_unstable`), but the count of unstable multipliers is not known."""

    @property
    def tangent_speed(self) -> float:
        """dV/ds, the speed component of the unit tangent (zero at a fold)."""
        return float(self.tangent[-1])

    @property
    def trivial_multiplier_error(self) -> float:
        """Accuracy check of the monodromy: |mu - 1| of the trivial multiplier (see :func:`trivial_error`)."""
        return trivial_error(self.multipliers)

    @property
    def n_unstable(self) -> int:
        """Number of multipliers outside the unit circle, the trivial one excluded."""
        mu = self.multipliers
        trivial = int(np.argmin(np.abs(mu - 1.0)))
        others = np.delete(mu, trivial)
        return int(np.sum(np.abs(others) > 1.0))

    @property
    def stable(self) -> bool:
        return self.n_unstable == 0


@dataclass
class Branch:
    """A branch of periodic orbits continued from a Hopf point."""

    points: list[BranchPoint] = field(default_factory=list)
    special: list[tuple[str, BranchPoint, int]] = field(default_factory=list)
    """(label, point, index): the special point lies between points[index - 1] and points[index]."""
    end: BranchEnd | None = None
    end_detail: str = ""
    """Where and why the branch ended, in words (speed, step, mesh, multiplier error)."""
    end_speed: float | None = None
    """Speed [m/s] of the last converged point (for a failed branch: where it was lost)."""
    recoveries: list[str] = field(default_factory=list)
    """Numerical rescues on the way (mesh refinements), in words."""
    scales: np.ndarray | None = None

    @property
    def failed(self) -> bool:
        """True when the branch ended by a numerical failure (see :class:`BranchEnd`)."""
        return self.end is not None and self.end.failed

    @property
    def end_reason(self) -> str:
        """The end in words: the reason, then the detail."""
        if self.end is None:
            return ""
        return self.end.description + (f": {self.end_detail}" if self.end_detail else "")


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

    def correct(self, X0: np.ndarray, t0: np.ndarray, ds: float, phase_ref: PeriodicOrbit) -> _Out | None:
        """Newton from the predictor X0 + ds t0.

        Returns ``(X, tangent, iterations, multipliers)`` or None when Newton fails.
        """
        c = self.coll
        border = np.vstack([c.phase_row(phase_ref), self.weights * t0])

        def newton_step(X: np.ndarray) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray, np.ndarray]] | None:
            out = c.solve(X, border, np.array([border[0] @ X, border[1] @ (X - X0) - ds]))
            return None if out is None else (out[0], out[1:])

        done = correct(newton_step, X0, t0, ds, self.settings.max_newton,
                       lambda dX: bool(np.max(np.abs(dX * self.inv_scale)) < self.settings.newton_tol))
        if done is None:
            return None
        X, (t, CL, CR), iterations = done
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
        phase_ref = previous.with_mesh(mesh)
        return new, new.coll.pack(phase_ref), new.unit(new.coll.pack(tangent.with_mesh(mesh))), phase_ref

    def adapted_mesh(self, orbit: PeriodicOrbit, n_intervals: int) -> np.ndarray:
        """``n_intervals`` intervals equidistributed for ``orbit`` (AUTO's rule), kinks on mesh
        points (with ``settings.align_kinks``)."""
        mesh = self.coll.adapted_mesh(orbit, n_intervals)
        return _with_kinks(mesh, switching_times(self.model, self.p, orbit)) if self.settings.align_kinks else mesh


_Out = tuple[np.ndarray, np.ndarray, int, np.ndarray]
"""A converged corrector: point X, unit tangent, Newton iterations, Floquet multipliers."""
_Step = tuple[_Stepper, np.ndarray, np.ndarray, PeriodicOrbit]
"""Where a step starts from: stepper, point X0, tangent t0, phase reference."""


def _first_harmonic(orbit: PeriodicOrbit, scales: np.ndarray) -> np.ndarray:
    """Scaled first Fourier coefficient of the orbit about its mean."""
    tau, u = orbit.dense(8)
    u = u[:-1] / scales
    tau = tau[:-1]
    weights = np.gradient(np.append(tau, 1.0))[:-1]
    return (u - u.mean(axis=0)).T @ (weights * np.exp(-2j * np.pi * tau))


def _scaled_amplitude(orbit: PeriodicOrbit, scales: np.ndarray) -> float:
    return float(np.max(np.ptp(orbit.nodes, axis=0) / scales)) * 0.5


def _hopf_start(model: Model, p: np.ndarray, hopf: HopfPoint, settings: ContinuationSettings,
                amplitude_ref: float) -> _Step:
    """The start of the branch born at ``hopf``: the steady state as a trivial orbit on a uniform
    mesh, the tangent along the critical eigenvector (x component ``amplitude_ref`` [m]) and the
    norm's scales (x: ``amplitude_ref``, other states: the eigenvector's, plus 0.1 of the steady state)."""
    q = hopf.q / hopf.q[model.index("x")]  # x component 1
    scales = np.maximum(np.abs(q), 1e-6 * np.abs(q).max()) * amplitude_ref + 0.1 * np.abs(hopf.u)
    period_scale = 2.0 * np.pi / hopf.omega
    speed_scale = 0.1 * hopf.speed_ms
    N = settings.n_intervals
    mesh = np.linspace(0.0, 1.0, N + 1)
    stepper = _Stepper(model, p, mesh, settings, scales, speed_scale, period_scale)
    c = stepper.coll
    tau = (mesh[:-1, None] + np.diff(mesh)[:, None] * c.sch.nodes[None, :-1]).ravel()
    psi = np.real(q[None, :] * np.exp(2j * np.pi * tau)[:, None]) * amplitude_ref
    trivial = PeriodicOrbit(mesh, np.tile(hopf.u, (N * c.m, 1)), period_scale, hopf.speed_ms, c.m)
    t0 = stepper.unit(np.concatenate([psi.ravel(), [0.0, 0.0]]))
    return stepper, c.pack(trivial), t0, PeriodicOrbit(mesh, psi, period_scale, hopf.speed_ms, c.m)


def continue_from_hopf(
    model: Model,
    p: np.ndarray,
    hopf: HopfPoint,
    speed_bounds: tuple[float, float],
    settings: ContinuationSettings = ContinuationSettings(),
    amplitude_ref: float = 1e-4,
    on_step: Callable[[Branch], None] | None = None,
) -> Branch:
    """Continue the cycles born at ``hopf`` (a stability.HopfPoint) within ``speed_bounds`` [m/s].

    ``amplitude_ref`` [m] sets the scale of the tread displacement ``x`` (other states
    scale with the critical eigenvector); ``on_step(branch)`` is called after every step.
    The branch ends (``Branch.end``, a :class:`BranchEnd`, with ``end_speed`` and
    ``end_detail``) when it leaves the speed range, returns to an equilibrium (a Hopf
    point: detected when the first harmonic of the orbit changes sign, i.e. the
    amplitude passed through zero), exceeds the amplitude or period limit, or fails
    after the rescues (finer meshes) listed in ``recoveries``.
    """
    stepper, X0, t0, phase_ref = _hopf_start(model, p, hopf, settings, amplitude_ref)
    scales, period_scale = stepper.scales, stepper.period_scale
    branch = Branch(scales=scales)
    ds = settings.ds_initial
    prev: BranchPoint | None = None
    prev_harmonic = None
    steps_since_adapt = 0

    def finish(end: BranchEnd, detail: str = "") -> None:
        branch.end, branch.end_detail = end, detail
        branch.end_speed = branch.points[-1].orbit.speed if branch.points else hopf.speed_ms

    def last_kmh() -> float:
        return 3.6 * (branch.points[-1].orbit.speed if branch.points else hopf.speed_ms)

    for _ in range(settings.max_steps):
        resolved = True
        out = stepper.correct(X0, t0, ds, phase_ref)
        if out is not None and stepper.norm(out[0] - X0 - ds * t0) > settings.max_correction * ds:
            out = None  # Newton left the branch (e.g. past a Hopf point): the step is retried shorter
        turn = 0.0 if out is None or settings.max_turn is None else stepper.angle(out[1], t0)
        if settings.max_turn is not None and turn > settings.max_turn and ds > settings.turn_floor:
            out = None  # a sharp bend: the step may have crossed onto another branch
        if out is not None and settings.align_kinks:
            stepper, X0, t0, phase_ref, out = _align_to_kinks((stepper, X0, t0, phase_ref), ds, out)
        if out is not None and not stability_decided(out[3], settings.multiplier_tol):
            stepper, X0, t0, phase_ref, out = _refine_step((stepper, X0, t0, phase_ref), ds, out, branch.recoveries)
            if out is not None and certainly_unstable(out[3], settings.multiplier_tol):
                resolved = False  # keep going: unstable for sure, only the count is unknown
            elif out is not None and not stability_decided(out[3], settings.multiplier_tol):
                mu = out[3]
                finish(BranchEnd.MULTIPLIER_CHECK_LOST,
                       f"beyond {last_kmh():.3f} km/h |mu - 1| of the trivial multiplier is "
                       f"{trivial_error(mu):.1e} with {stepper.coll.N} mesh intervals (largest multiplier "
                       f"{np.abs(mu).max():.1e}); stability there is unknown; "
                       + _period_detail(stepper, stepper.coll.unpack(out[0])))
                break
        c = stepper.coll
        if out is None:
            ds *= 0.5
            if ds < settings.ds_min:
                if 2 * c.N <= settings.max_intervals:
                    # rescue: the previous point on a finer adapted, kink-aligned mesh, steps anew
                    stepper, X0, t0, phase_ref = stepper.remesh(stepper.adapted_mesh(c.unpack(X0), 2 * c.N), X0, t0)
                    branch.recoveries.append(
                        f"Newton failed beyond {last_kmh():.3f} km/h: mesh refined to {stepper.coll.N} intervals")
                    ds = settings.ds_initial
                    continue
                finish(BranchEnd.STEP_UNDERFLOW,
                       f"beyond {last_kmh():.3f} km/h, with steps down to {settings.ds_min:g} and "
                       f"{c.N} mesh intervals")
                break
            continue
        X, t, iterations, multipliers = out
        orbit = c.unpack(X)
        harmonic = _first_harmonic(orbit, scales)
        if prev_harmonic is not None and np.real(np.vdot(prev_harmonic, harmonic)) < 0:
            if ds > settings.hopf_approach_step:  # approach in shorter steps: a fold may lie just before it
                ds *= 0.5
                continue
            finish(BranchEnd.HOPF_REACHED)
            break
        point = BranchPoint(orbit, multipliers, t, iterations, resolved=resolved)
        if prev is not None and np.sign(point.tangent_speed) != np.sign(prev.tangent_speed):
            fold = _locate_fold((stepper, X0, t0, phase_ref), ds, prev, point)
            if fold is not None:
                _add_special(branch, "LP", fold)
        if prev is not None and prev.resolved and resolved:  # counts of unresolved cycles are unknown
            for label in _multiplier_events(prev, point):
                located = _locate_crossing((stepper, X0, t0, phase_ref), ds, prev, point, label)
                # a crossing is only as good as the multipliers there: on strongly unstable
                # cycles the monodromy product loses the trivial multiplier (and a sign
                # change of a huge real multiplier mimics a crossing of -1)
                if located is not None and trivial_error(located.multipliers) <= MAX_TRIVIAL_ERROR:
                    _add_special(branch, label, located)
        branch.points.append(point)
        if on_step is not None:
            on_step(branch)
        amplitude = _scaled_amplitude(orbit, scales)
        if not (speed_bounds[0] <= orbit.speed <= speed_bounds[1]):
            finish(BranchEnd.RANGE_END)
            break
        if amplitude < settings.min_amplitude and len(branch.points) > 3:
            finish(BranchEnd.HOPF_REACHED)
            break
        if amplitude > settings.max_amplitude:
            finish(BranchEnd.AMPLITUDE_LIMIT, f"at {3.6 * orbit.speed:.3f} km/h")
            break
        if orbit.period > settings.max_period_factor * period_scale:
            finish(BranchEnd.PERIOD_LIMIT, _period_detail(stepper, orbit))
            break
        prev, prev_harmonic = point, harmonic
        X0, t0, phase_ref = X, t, orbit
        ds_next = next_step(ds, iterations, settings.ds_max, grow=1.5, shrink_after=5)
        if settings.max_turn is not None and turn > 0.0:  # sized to turn by about max_turn / 2
            ds_next = min(ds_next, max(0.5 * settings.max_turn * ds / turn, settings.turn_floor))
        ds = ds_next
        steps_since_adapt += 1
        if settings.adapt_every and steps_since_adapt >= settings.adapt_every:
            steps_since_adapt = 0
            # scales never shrink and follow each state's excursion from the Hopf equilibrium
            scales = np.maximum(scales, np.abs(orbit.nodes - hopf.u).max(axis=0))
            branch.scales = scales
            # a mesh refined by a rescue is halved again once the last points are resolved 100x better
            recent = branch.points[-settings.adapt_every:]
            coarser = c.N > settings.n_intervals and all(
                pt.resolved and pt.trivial_multiplier_error < 1e-2 * settings.multiplier_tol for pt in recent)
            n_new = max(settings.n_intervals, c.N // 2) if coarser else c.N
            stepper, X0, t0, phase_ref = stepper.remesh(stepper.adapted_mesh(orbit, n_new), X0, t0, scales)
    else:
        finish(BranchEnd.MAX_STEPS, f"{settings.max_steps} steps, the last at {last_kmh():.3f} km/h")
    return branch


def same_special_point(a: PeriodicOrbit, b: PeriodicOrbit, rtol: float = 1e-5) -> bool:
    """True if two orbits are the same special point within ``rtol``: speed, period and
    every state's peak-to-peak (relative to the largest of the two) agree. Peak-to-peak of
    the orbit (:meth:`PeriodicOrbit.extrema`, 64 samples per mesh interval), not of its mesh
    nodes: two branches reach one point on different meshes, and the nodes miss the peaks
    by up to 1e-3 of the range (measured: a period doubling met by two tread1dof branches,
    1.4e-4; axle4dof PD points on a mesh with every interval halved, 2e-5 to 2e-3; with 16
    samples per interval still up to 1e-5, with 64 below 1e-7)."""
    if not (abs(a.speed - b.speed) <= rtol * abs(a.speed) and abs(a.period - b.period) <= rtol * a.period):
        return False
    (lo_a, hi_a), (lo_b, hi_b) = a.extrema(64), b.extrema(64)
    span_a, span_b = hi_a - lo_a, hi_b - lo_b
    return bool(np.all(np.abs(span_a - span_b) <= rtol * np.maximum(span_a, span_b).max()))


def _add_special(branch: Branch, label: str, point: BranchPoint) -> None:
    """Record a special point between the last stored point and the next, once: not if the
    branch already has one of this kind at the same place (a branch retracing itself)."""
    if not any(lab == label and same_special_point(pt.orbit, point.orbit) for lab, pt, _ in branch.special):
        branch.special.append((label, point, len(branch.points)))


MAX_TRIVIAL_ERROR = 1e-2
"""Largest error of the trivial Floquet multiplier with which multipliers are used at all
[-]: to decide the stability of a strongly unstable cycle (:func:`stability_decided`) and
to report a located PD or NS point. Measured beyond it: a "PD" at a fold of the heavy-load
axle (trivial error 0.03, its dominant real multiplier -5.7e4 at one point and +1.3e5 at the
next, which an invertible monodromy matrix cannot do); the genuine PD points of nine
four-Hopf axle4dof diagrams had errors of 6e-8 to 2e-5 (the largest next to a fold)."""


def stability_decided(multipliers: np.ndarray, tol: float) -> bool:
    """True if the multipliers are accurate enough to count those outside the unit circle.

    Either the trivial multiplier is within ``tol`` of 1, or (a strongly unstable cycle,
    whose monodromy product cannot resolve 1 to ``tol``) its error is below
    :data:`MAX_TRIVIAL_ERROR` and every
    other multiplier is more than 10 times that error away from the unit circle.
    """
    error = trivial_error(multipliers)
    if error <= tol:
        return True
    others = np.delete(multipliers, int(np.argmin(np.abs(multipliers - 1.0))))
    return error <= MAX_TRIVIAL_ERROR and bool(np.all(np.abs(np.abs(others) - 1.0) > 10.0 * error))


def certainly_unstable(multipliers: np.ndarray, tol: float) -> bool:
    """True if the largest multiplier exceeds 1 by more than 100 times the error of the
    trivial one (or ``tol``). The dominant multiplier of the monodromy product is accurate
    relative to its size even when 1 cannot be resolved next to it (rounding of a matrix
    of norm 1e17 is about 10), so such a cycle is unstable whatever the error."""
    return float(np.abs(multipliers).max()) - 1.0 > 100.0 * max(trivial_error(multipliers), tol)


def trivial_error(multipliers: np.ndarray, cluster: float = 1e-2) -> float:
    """|mu - 1| of the trivial Floquet multiplier, the accuracy check of the monodromy matrix.

    Normally the distance of the multiplier nearest 1. At a fold of cycles a second
    multiplier reaches 1 and the two form a Jordan block: an error d of the matrix
    splits them to about 1 +- sqrt(d), while their mean stays within O(d) of 1. So when
    the two multipliers nearest 1 lie within ``cluster`` of it, at comparable distances,
    the error of their mean is used.
    """
    d = np.abs(multipliers - 1.0)
    if d.size < 2:
        return float(d.min())
    i, j = np.argsort(d)[:2]
    if d[j] < cluster and d[j] <= 10.0 * d[i]:
        return float(min(d[i], abs(0.5 * (multipliers[i] + multipliers[j]) - 1.0)))
    return float(d[i])


def _refine_step(start: _Step, ds: float, out: _Out, notes: list[str]) -> tuple[
        _Stepper, np.ndarray, np.ndarray, PeriodicOrbit, _Out]:
    """Re-solve a converged step whose trivial multiplier is off, until it is resolved: first
    on a mesh adapted afresh to the new orbit (the periodic adaptation lags behind, and
    aligning kinks moves mesh points), then on meshes with twice the intervals up to
    ``settings.max_intervals``. Stops when doubling does not halve the error (then it is
    not the mesh: a strongly unstable cycle), or Newton fails on the finer mesh. Returns
    the attempt with the smallest error, as ``(stepper, X0, t0, phase_ref, out)``."""
    settings = start[0].settings
    best: tuple[_Stepper, np.ndarray, np.ndarray, PeriodicOrbit, _Out] = (*start, out)
    factor = 1
    while (not stability_decided(best[4][3], settings.multiplier_tol)
           and factor * best[0].coll.N <= settings.max_intervals):
        stepper, X0, t0, phase_ref, good = best
        error = trivial_error(good[3])
        mesh = stepper.adapted_mesh(stepper.coll.unpack(good[0]), factor * stepper.coll.N)
        stepper, X0, t0, phase_ref = stepper.remesh(mesh, X0, t0)
        new = stepper.correct(X0, t0, ds, phase_ref)
        if new is not None and settings.align_kinks:
            stepper, X0, t0, phase_ref, new = _align_to_kinks((stepper, X0, t0, phase_ref), ds, new)
        new_error = np.inf if new is None else trivial_error(new[3])
        notes.append(f"trivial multiplier error {error:.1e} near {3.6 * X0[-1]:.3f} km/h: mesh adapted anew with "
                     f"{stepper.coll.N} intervals, error {new_error:.1e}")
        if new is not None and new_error < error:
            best = (stepper, X0, t0, phase_ref, new)
        if factor == 2 and not new_error < 0.5 * error:
            break
        factor = 2
    return best


def _period_detail(stepper: _Stepper, orbit: PeriodicOrbit) -> str:
    """The orbit's period against the Hopf period (``stepper.period_scale``), and how close it
    comes to the steady state (in units of its own range, max over states): near 0 for an
    orbit close to a homoclinic one."""
    hopf_period = stepper.period_scale
    _, u = orbit.dense(16)
    span = np.ptp(u, axis=0)
    moving = span > 0.0
    u_eq = stepper.model.equilibrium(orbit.speed, stepper.p)
    closest = float(np.min(np.max(np.abs(u - u_eq)[:, moving] / span[moving], axis=1)))
    return (f"period {orbit.period:.4g} s = {orbit.period / hopf_period:.1f} x the Hopf period at "
            f"{3.6 * orbit.speed:.3f} km/h; the orbit comes within {closest:.1%} of its range to the steady "
            f"state (a homoclinic orbit when this goes to 0)")


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


def cycle_along_branch(model: Model, p: np.ndarray, start: HopfPoint | BranchPoint, speed: float,
                       settings: ContinuationSettings = ContinuationSettings(), scales: np.ndarray | None = None,
                       reverse: bool = False, amplitude_ref: float = 1e-4,
                       first_step: float | None = None) -> BranchPoint | None:
    """The cycle at ``speed`` [m/s] on the branch through ``start``, reached along the branch.

    ``start`` is a Hopf point (the branch born there, with the start and norm of
    :func:`continue_from_hopf`) or a branch point with its tangent, e.g. a fold (then
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


# -- kinks of the vector field (sliding velocity through zero, contact loss) -----------
KINK_SIGNALS = (("sliding_velocity", 0.0), ("contact_lost", 0.5))
"""Auxiliary outputs whose crossing of the given level is a kink of the vector field."""


def switching_times(model: Model, p: np.ndarray, orbit: PeriodicOrbit, per_interval: int = 8,
                    tol: float = 1e-13) -> np.ndarray:
    """Normalized times where the orbit crosses a kink of the vector field (bisection-refined).

    The vector field is continuous there (|v_r| and the clamp max(N, 0) are Lipschitz),
    so no jump (saltation) of the monodromy matrix occurs, but the Jacobian jumps: the
    collocation mesh is aligned with these times so that no interval straddles one.
    """
    signals = [(model.aux_names.index(name), level) for name, level in KINK_SIGNALS if name in model.aux_names]
    if not signals:
        return np.empty(0)
    tau, u = orbit.dense(per_interval)
    aux = model.diagnostics(u, orbit.speed, p)
    times = []
    for col, level in signals:
        g = aux[:, col] - level
        for i in np.flatnonzero(np.sign(g[:-1]) * np.sign(g[1:]) < 0):
            a, b, ga = tau[i], tau[i + 1], g[i]
            while b - a > tol:
                mid = 0.5 * (a + b)
                gm = model.diagnostics(orbit.evaluate(mid)[0], orbit.speed, p)[col] - level
                if np.sign(gm) == np.sign(ga):
                    a, ga = mid, gm
                else:
                    b = mid
            times.append(0.5 * (a + b))
    return np.sort(np.mod(times, 1.0))


def _kinks_off_mesh(times: np.ndarray, mesh: np.ndarray) -> bool:
    """Whether any kink time lies more than 1e-9 from every mesh point."""
    return times.size > 0 and float(np.max(np.min(np.abs(times[:, None] - mesh[None, :]), axis=1))) >= 1e-9


def _with_kinks(mesh: np.ndarray, times: np.ndarray) -> np.ndarray:
    """The mesh with its nearest interior point moved onto each switching time."""
    if times.size == 0:
        return mesh
    mesh = mesh.copy()
    free = np.ones(len(mesh), dtype=bool)
    free[[0, -1]] = False
    for tc in times:
        candidates = np.flatnonzero(free)
        j = candidates[np.argmin(np.abs(mesh[candidates] - tc))]
        mesh[j] = tc
        free[j] = False
    mesh = np.sort(mesh)
    if np.min(np.diff(mesh)) <= 1e-9:
        return np.sort(np.unique(mesh))  # two kinks in one interval: keep what is distinct
    return mesh


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
        times = switching_times(stepper.model, stepper.p, orbit)
        mesh = stepper.coll.mesh
        if not _kinks_off_mesh(times, mesh):
            break
        stepper, X0, t0, phase_ref = stepper.remesh(_with_kinks(mesh, times), X0, t0)
        new = stepper.correct(X0, t0, ds, phase_ref)
    return stepper, X0, t0, phase_ref, new


def _nontrivial(multipliers: np.ndarray) -> np.ndarray:
    """The Floquet multipliers without the trivial one (the one nearest 1)."""
    return np.delete(multipliers, int(np.argmin(np.abs(multipliers - 1.0))))


def _event_counts(point: BranchPoint) -> dict[str, int]:
    """Multipliers outside the unit circle (trivial one excluded): real negative ("PD"), complex
    ("NS"), real positive ("+1")."""
    mu = _nontrivial(point.multipliers)
    outside = np.abs(mu) > 1.0
    real = np.abs(mu.imag) < 1e-8 * np.abs(mu)
    return {"PD": int(np.sum(outside & real & (mu.real < 0))), "NS": int(np.sum(outside & ~real)),
            "+1": int(np.sum(outside & real & (mu.real > 0)))}


def _multiplier_events(a: BranchPoint, b: BranchPoint) -> list[str]:
    """Period doubling (PD) and torus (NS) crossings between two consecutive points."""
    ca, cb = _event_counts(a), _event_counts(b)
    return [label for label in ("PD", "NS") if ca[label] != cb[label]]


def _pd_test(multipliers: np.ndarray) -> float:
    """Test function of period doubling: the product of ``(mu + 1) / (|mu| + 1)`` over the
    non-trivial multipliers. Each factor lies in [-1, 1] and a complex pair gives
    ``|mu + 1|^2 / (|mu| + 1)^2 > 0``, so it is continuous along the branch (also where two
    real multipliers meet and become a complex pair) and changes sign exactly where a real
    multiplier crosses -1; its sign is (-1)^(number of real multipliers below -1)."""
    mu = _nontrivial(multipliers)
    return float(np.real(np.prod((mu + 1.0) / (np.abs(mu) + 1.0))))


def _pd_residual(multipliers: np.ndarray) -> float:
    """Distance of the non-trivial multiplier nearest -1 from -1."""
    return float(np.min(np.abs(_nontrivial(multipliers) + 1.0)))


def _upper(multipliers: np.ndarray) -> np.ndarray:
    """The non-trivial multipliers with imaginary part >= 0 (one of each complex pair)."""
    mu = _nontrivial(multipliers)
    return mu[mu.imag >= 0.0]


def _ns_pair(a: np.ndarray, b: np.ndarray) -> tuple[complex, complex] | None:
    """The complex multiplier pair that crosses the unit circle between two points with
    multipliers ``a`` and ``b``: complex multipliers (upper half plane), one at each point,
    each the other's nearest there, with moduli on opposite sides of 1 (the closest such
    match); None if there is none (e.g. the count of complex multipliers outside the circle
    changed only because two real ones outside met and became a complex pair)."""
    ua, ub = _upper(a), _upper(b)
    matches = []
    for za in ua[np.abs(ua.imag) >= 1e-8 * np.abs(ua)]:
        zb = ub[np.argmin(np.abs(ub - za))]
        back = ua[np.argmin(np.abs(ua - zb))]
        if back == za and abs(zb.imag) >= 1e-8 * abs(zb) and (abs(za) - 1.0) * (abs(zb) - 1.0) < 0.0:
            matches.append((abs(za - zb), za, zb))
    return min(matches, key=lambda m: m[0])[1:] if matches else None


def _collisions_only(a: BranchPoint, b: BranchPoint) -> bool:
    """True if the change of the counts of multipliers outside the unit circle between two
    points is accounted for by real multipliers crossing +1 or -1 singly (where the parity of
    those counts changed), with the rest only pairs of real multipliers outside meeting and
    becoming a complex pair outside, or the reverse (which is no bifurcation)."""
    ca, cb = _event_counts(a), _event_counts(b)
    total = sum(cb.values()) - sum(ca.values())
    single = [(cb[k] - ca[k]) % 2 for k in ("PD", "+1")]
    return any(total == da + db for da in ((-1, 1) if single[0] else (0,))
               for db in ((-1, 1) if single[1] else (0,)))


def _locate_crossing(start: _Step, ds: float, prev: BranchPoint, point: BranchPoint,
                     label: str) -> BranchPoint | None:
    """The PD or NS point between ``prev`` (arclength 0 from the start X0) and ``point`` (arclength ds).

    PD: root in the arclength of :func:`_pd_test`, which changes sign where a real multiplier
    crosses -1. NS: root of ``|mu| - 1`` of the complex pair that crosses (:func:`_ns_pair`),
    followed from iterate to iterate as the multiplier nearest the value interpolated
    between the bracket's ends. Both by :func:`_crossing_in_bracket`, to
    ``settings.crossing_tol`` on the multiplier. Where the count of such multipliers
    outside the circle changed without such a crossing: None if the counts changed only by
    real pairs outside meeting and becoming complex ones or the reverse
    (:func:`_collisions_only`: no bifurcation), else bisection in the arclength on the count
    (:func:`_bisect_crossing`, several crossings in one step).
    """
    if label == "PD":
        if np.sign(_pd_test(prev.multipliers)) != np.sign(_pd_test(point.multipliers)):
            return _crossing_in_bracket(start, ds, prev, point, label, _pd_value)
    else:
        pair = _ns_pair(prev.multipliers, point.multipliers)
        if pair is not None:
            return _crossing_in_bracket(start, ds, prev, point, label, _ns_value, pair)
    return None if _collisions_only(prev, point) else _bisect_crossing(start, ds, prev, point, label)


def _pd_value(multipliers: np.ndarray, guess: complex) -> tuple[float, complex, float]:
    """(test function, followed multiplier, residual) of period doubling (``guess`` unused)."""
    return _pd_test(multipliers), -1.0, _pd_residual(multipliers)


def _ns_value(multipliers: np.ndarray, guess: complex) -> tuple[float, complex, float]:
    """(|mu| - 1, mu, ||mu| - 1|) of the multiplier in the upper half plane nearest ``guess``."""
    upper = _upper(multipliers)
    z = complex(upper[np.argmin(np.abs(upper - guess))])
    return abs(z) - 1.0, z, abs(abs(z) - 1.0)


def _secant_in_bracket(p: tuple[float, float], q: tuple[float, float], s_a: float, s_b: float) -> float:
    """The zero of the line through the points ``(s, g)`` p and q, or the middle of the
    bracket [s_a, s_b] where that line is flat or its zero lies outside the bracket."""
    (s_p, g_p), (s_q, g_q) = p, q
    s = s_q - g_q * (s_q - s_p) / (g_q - g_p) if g_q != g_p else 0.5 * (s_a + s_b)
    return s if min(s_a, s_b) < s < max(s_a, s_b) else 0.5 * (s_a + s_b)


CROSSING_ITERATIONS = 30
"""Largest number of correctors of one PD/NS location (:func:`_crossing_in_bracket`)."""


def _crossing_in_bracket(start: _Step, ds: float, prev: BranchPoint, point: BranchPoint, label: str,
                         value: Callable[[np.ndarray, complex], tuple[float, complex, float]],
                         pair: tuple[complex, complex] = (-1.0, -1.0)) -> BranchPoint:
    """Illinois (regula falsi that halves the value at an end kept twice in a row; bisection
    where a step would leave the bracket) in the arclength s from X0 for the root of a test
    function of the multipliers, between ``prev`` (s = 0) and ``point`` (s = ds).

    ``value(multipliers, guess)`` gives the test function, the multiplier followed (the one
    nearest ``guess``, interpolated linearly in s between the bracket's ends ``pair``) and
    the residual (distance of the multiplier from the crossing). Stops when the residual is
    below ``settings.crossing_tol``, after :data:`CROSSING_ITERATIONS` correctors or when the
    bracket is down to rounding. Returns the point with the smallest residual, labelled:
    on the crossing to the tolerance, not a point past it (its stability is marginal);
    ``point`` if the first corrector fails.
    """
    stepper, X0, t0, phase_ref = start
    tol = stepper.settings.crossing_tol
    (g_0, z_0, _), (g_1, z_1, _) = value(prev.multipliers, pair[0]), value(point.multipliers, pair[1])
    ends: list[tuple[float, float, complex]] = [(0.0, g_0, z_0), (ds, g_1, z_1)]  # (s, test function, multiplier)
    best, best_residual, replaced = point, np.inf, -1
    for _ in range(CROSSING_ITERATIONS):
        (s_a, g_a, z_a), (s_b, g_b, z_b) = ends
        s = _secant_in_bracket((s_a, g_a), (s_b, g_b), s_a, s_b)
        out = stepper.correct(X0, t0, s, phase_ref)
        solved_on = stepper
        if out is not None and stepper.settings.align_kinks:  # as the branch's points: kinks on mesh points
            solved_on, *_, out = _align_to_kinks(start, s, out)
        if out is None:
            break
        X, t, iterations, multipliers = out
        g, z, residual = value(multipliers, z_a + (s - s_a) / (s_b - s_a) * (z_b - z_a))
        if residual < best_residual:
            best, best_residual = BranchPoint(solved_on.coll.unpack(X), multipliers, t, iterations), residual
        if residual < tol:
            break
        side = 0 if np.sign(g) == np.sign(g_a) else 1
        ends[side] = (s, g, z)
        if side == replaced:  # the same end replaced twice in a row: halve the other's value (Illinois)
            s_kept, g_kept, z_kept = ends[1 - side]
            ends[1 - side] = (s_kept, 0.5 * g_kept, z_kept)
        replaced = side
        if abs(ends[1][0] - ends[0][0]) <= 1e-12 * abs(ds):
            break
    return BranchPoint(best.orbit, best.multipliers, best.tangent, best.newton_iterations, label)


def _bisect_crossing(start: _Step, ds: float, prev: BranchPoint, point: BranchPoint, label: str,
                     rtol: float = 1e-3) -> BranchPoint:
    """Bisection in the arclength on the count of ``label`` multipliers outside the unit circle,
    to ``rtol * ds`` (where no single crossing can be followed): the first point past the
    first change of the count, labelled; ``point`` if a corrector fails."""
    stepper, X0, t0, phase_ref = start
    before = _event_counts(prev)[label]
    s_a, s_b, best = 0.0, ds, point
    while abs(s_b - s_a) > rtol * abs(ds):
        s = 0.5 * (s_a + s_b)
        out = stepper.correct(X0, t0, s, phase_ref)
        if out is None:
            break
        X, t, iterations, multipliers = out
        trial = BranchPoint(stepper.coll.unpack(X), multipliers, t, iterations)
        if _event_counts(trial)[label] == before:
            s_a = s
        else:
            s_b, best = s, trial
    return BranchPoint(best.orbit, best.multipliers, best.tangent, best.newton_iterations, label)


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
