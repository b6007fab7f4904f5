"""The branch's data: settings, why a branch ended, its points, and the stability predicates.

A :class:`Branch` of :class:`BranchPoint` s is what :func:`~.from_hopf.continue_from_hopf`
returns; :class:`HopfStart` is the Hopf point it starts from, as plain data (speed [m/s],
frequency [rad/s], steady state, critical eigenvector). The predicates on Floquet
multipliers (:func:`trivial_error`, :func:`stability_decided`, :func:`certainly_unstable`)
decide what a point's multipliers may be used for.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from ...settings import check_count, check_order, check_positive
from ..collocation import PeriodicOrbit

__all__ = ["ContinuationSettings", "BranchEnd", "BranchPoint", "Branch", "HopfStart", "MAX_TRIVIAL_ERROR",
           "same_special_point", "stability_decided", "certainly_unstable", "trivial_error"]


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
    crossing_tol: float = 1e-8
    """A located period doubling (PD) has a multiplier within this of -1, a torus bifurcation
    (NS) a complex pair within this of modulus 1. The multipliers themselves are accurate to
    ~1e-7 (the trivial multiplier's error at 48 PD/NS points of 9 axle4dof samples: median
    8e-8), but the location converges on the discrete problem's crossing, so the same point
    reached from either end of a branch agrees to this over |dmu/dV| (0.016 to 10 per km/h
    there): at most ~6e-7 km/h. With 1e-6 that was up to 6e-5 km/h (an NS point 5.1e-6 and
    2.9e-5 km/h apart from the two ends, car 1181 of ``bench_fleet.py edges --seed 7``); 1e-8
    costs ~0.5 more correctors per point (car 157: 60 instead of 54 for 12 points)."""
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
    event_step: float = 1e-4
    """A step in which two bifurcations (fold, PD, NS) are located is retried with half the
    step until the step is this short, so that every stretch of the branch between two of
    them has a point of its own: the stability of the branch is told from its points, and a
    stable window from a fold to a period doubling 0.012 km/h wide, both inside one step,
    was found on 40 mesh intervals and missed on 20 and 80 (whose steps happened to
    straddle it), which moved that car's first bifurcation speed by 0.56 km/h."""
    max_correction: float = 5.0
    """A step of a branch whose corrector ends more than this many step lengths from its
    predictor (scaled norm) has left the branch, e.g. past a Hopf point onto other cycles
    far away: it counts as failed, and is retried shorter (on the default diagrams the
    correctors end within 0.7 step lengths)."""
    max_turn: float | None = 0.2
    """Largest angle [rad] between the tangents at the ends of one step (scaled norm), or None
    (no limit: step lengths follow the Newton iterations alone). A step that turns by more
    is retried shorter, and the next step is sized to turn by ``turn_target`` of it. Without
    it, steps of full length across sharp bends of a branch stepped over narrow stable
    windows next to folds (14 of 100 random axle4dof cars with four Hopf points at +-10 %,
    e.g. a window at 63.23-63.37 km/h below a first Hopf point at 68.2 km/h) or landed on
    another branch passing close by. 0.2 rad costs ~1.3-1.4x the steps' CPU time of no
    limit; 0.1 rad gave the same bands on those 14 cars."""
    turn_target: float = 0.85
    """Share of ``max_turn`` the next step aims to turn by [-]: after an accepted step of
    length ds that turned by ``turn``, the next is at most ``turn_target * max_turn / k``
    long, k = turn / ds, times k / k_prev of the step before where that grows (the bend
    sharpens towards the tip of a fold). 0.85 instead of a fixed half of ``max_turn``: the
    tread1dof diagram in 137 instead of 142 cycles (145 instead of 158 corrector solves),
    the axle4dof one in 74 instead of 87 (88 instead of 101), same bands and special points on the cars of
    ``tests/test_continuation_robust.py``."""
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
                       "min_amplitude", "hopf_approach_step", "event_step", "max_correction",
                       "turn_floor", "turn_target")
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
    STOPPED = "stopped"
    """The caller's stop criterion held (``continue_from_hopf(stop=...)``): not a failure."""

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
    BranchEnd.STOPPED: "stopped where the rest of the branch was not needed",
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


@dataclass(frozen=True)
class HopfStart:
    """A Hopf point of the steady states as the start of its branch of cycles.

    ``equilibrium`` is the steady state there (one value per state of the model) and
    ``eigenvector`` the critical right eigenvector ``q`` of its Jacobian ``J``
    (``J q = i omega q``, any normalisation: the start scales its x component to 1).
    """

    speed_ms: float
    """Speed of the Hopf point [m/s]."""
    omega: float
    """Angular frequency of the critical pair [rad/s]."""
    equilibrium: np.ndarray
    eigenvector: np.ndarray


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
