"""The branch of cycles born at a Hopf point, continued in the speed (:func:`continue_from_hopf`).

Each step is the stepper's (:mod:`.stepper`); along the way the branch's folds
(:mod:`.folds`) and PD/NS points (:mod:`.events`) are located, and a step whose
multipliers are not resolved is re-solved on finer meshes (:func:`_refine_step`). The
branch ends with a typed reason (:class:`~.branch.BranchEnd`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from ..arclength import next_step
from ..collocation import PeriodicOrbit
from .branch import (MAX_TRIVIAL_ERROR, Branch, BranchEnd, BranchPoint, ContinuationSettings, HopfStart,
                     certainly_unstable, same_special_point, stability_decided, trivial_error)
from .events import _locate_crossing, _multiplier_events
from .folds import _locate_fold
from .stepper import KINK_SAMPLES, _align_to_kinks, _hopf_start, _Out, _Step, _Stepper

if TYPE_CHECKING:
    from ...models.base import Model

__all__ = ["continue_from_hopf"]


def _first_harmonic(orbit: PeriodicOrbit, scales: np.ndarray,
                    samples: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Scaled first Fourier coefficient of the orbit about its mean (``samples``:
    ``orbit.dense(KINK_SAMPLES)`` if known)."""
    tau, u = orbit.dense(KINK_SAMPLES) if samples is None else samples
    u = u[:-1] / scales
    tau = tau[:-1]
    weights = np.gradient(np.append(tau, 1.0))[:-1]
    return (u - u.mean(axis=0)).T @ (weights * np.exp(-2j * np.pi * tau))


def _scaled_amplitude(orbit: PeriodicOrbit, scales: np.ndarray) -> float:
    return float(np.max(np.ptp(orbit.nodes, axis=0) / scales)) * 0.5


def continue_from_hopf(
    model: Model,
    p: np.ndarray,
    hopf: HopfStart,
    speed_bounds: tuple[float, float],
    settings: ContinuationSettings = ContinuationSettings(),
    amplitude_ref: float = 1e-4,
    on_step: Callable[[Branch], None] | None = None,
    stop: Callable[[Branch], bool] | None = None,
) -> Branch:
    """Continue the cycles born at the Hopf point ``hopf`` within ``speed_bounds`` [m/s].

    ``amplitude_ref`` [m] sets the scale of the tread displacement ``x`` (other states
    scale with the critical eigenvector); ``on_step(branch)`` is called after every step.
    The branch ends (``Branch.end``, a :class:`BranchEnd`, with ``end_speed`` and
    ``end_detail``) when it leaves the speed range, returns to an equilibrium (a Hopf
    point: detected when the first harmonic of the orbit changes sign, i.e. the
    amplitude passed through zero), exceeds the amplitude or period limit, or fails
    after the rescues (finer meshes) listed in ``recoveries``, or when ``stop(branch)``,
    asked after every step, is true (``BranchEnd.STOPPED``: the caller needs no more of it).
    """
    stepper, X0, t0, phase_ref = _hopf_start(model, p, hopf, settings, amplitude_ref)
    scales, period_scale = stepper.scales, stepper.period_scale
    branch = Branch(scales=scales)
    ds = settings.ds_initial
    prev: BranchPoint | None = None
    prev_harmonic = None
    steps_since_adapt = 0
    curvature = None  # turn per unit step [rad] of the last accepted step that turned

    def finish(end: BranchEnd, detail: str = "") -> None:
        branch.end, branch.end_detail = end, detail
        branch.end_speed = branch.points[-1].orbit.speed if branch.points else hopf.speed_ms

    def last_kmh() -> float:
        return 3.6 * (branch.points[-1].orbit.speed if branch.points else hopf.speed_ms)

    for _ in range(settings.max_steps):
        resolved = True
        out = stepper.correct(X0, t0, ds, phase_ref, predicted=True)
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
        known = stepper.known(X)
        harmonic = _first_harmonic(orbit, scales, known[2] if known else None)
        if prev_harmonic is not None and np.real(np.vdot(prev_harmonic, harmonic)) < 0:
            if ds > settings.hopf_approach_step:  # approach in shorter steps: a fold may lie just before it
                ds *= 0.5
                continue
            finish(BranchEnd.HOPF_REACHED)
            break
        point = BranchPoint(orbit, multipliers, t, iterations, resolved=resolved)
        events = []
        if prev is not None and np.sign(point.tangent_speed) != np.sign(prev.tangent_speed):
            fold = _locate_fold((stepper, X0, t0, phase_ref), ds, prev, point)
            if fold is not None:
                events.append(("LP", fold))
        if prev is not None and prev.resolved and resolved:  # counts of unresolved cycles are unknown
            for label in _multiplier_events(prev, point):
                located = _locate_crossing((stepper, X0, t0, phase_ref), ds, prev, point, label)
                # a crossing is only as good as the multipliers there: on strongly unstable
                # cycles the monodromy product loses the trivial multiplier (and a sign
                # change of a huge real multiplier mimics a crossing of -1)
                if located is not None and trivial_error(located.multipliers) <= MAX_TRIVIAL_ERROR:
                    events.append((label, located))
        if len(events) > 1 and ds > settings.event_step:
            # two bifurcations in one step: the stretch between them (e.g. a stable window
            # from a fold to a period doubling, both ends of the step unstable) would have
            # no point of its own to tell its stability by
            ds *= 0.5
            continue
        for label, located in events:
            _add_special(branch, label, located)
        branch.points.append(point)
        if on_step is not None:
            on_step(branch)
        if stop is not None and stop(branch):
            finish(BranchEnd.STOPPED, f"at {3.6 * orbit.speed:.3f} km/h")
            break
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
        if settings.max_turn is not None and turn > 0.0:
            # sized to turn by turn_target * max_turn at the turn per unit step [rad] ahead,
            # extrapolated from the last two steps where it grows (towards the tip of a fold)
            bend = turn / ds
            ahead = bend * max(1.0, bend / curvature) if curvature else bend
            ds_next = min(ds_next, max(settings.turn_target * settings.max_turn / ahead, settings.turn_floor))
            curvature = bend
        ds = ds_next
        steps_since_adapt += 1
        if settings.adapt_every and steps_since_adapt >= settings.adapt_every:
            steps_since_adapt = 0
            # scales never shrink and follow each state's excursion from the Hopf equilibrium
            scales = np.maximum(scales, np.abs(orbit.nodes - hopf.equilibrium).max(axis=0))
            branch.scales = scales
            # a mesh refined by a rescue is halved again once the last points are resolved 100x better
            recent = branch.points[-settings.adapt_every:]
            coarser = c.N > settings.n_intervals and all(
                pt.resolved and pt.trivial_multiplier_error < 1e-2 * settings.multiplier_tol for pt in recent)
            n_new = max(settings.n_intervals, c.N // 2) if coarser else c.N
            stepper, X0, t0, phase_ref = stepper.remesh(stepper.adapted_mesh(orbit, n_new, X), X0, t0, scales)
    else:
        finish(BranchEnd.MAX_STEPS, f"{settings.max_steps} steps, the last at {last_kmh():.3f} km/h")
    return branch


def _add_special(branch: Branch, label: str, point: BranchPoint) -> None:
    """Record a special point between the last stored point and the next, once: not if the
    branch already has one of this kind at the same place (a branch retracing itself)."""
    if not any(lab == label and same_special_point(pt.orbit, point.orbit) for lab, pt, _ in branch.special):
        branch.special.append((label, point, len(branch.points)))


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
