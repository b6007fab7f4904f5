"""The bifurcation diagram of tread amplitude against speed (the paper's Fig. 6, by continuation).

Pipeline: equilibria and their stability along speed (:mod:`.stability`), Hopf points
with criticality, cycle branches continued from every Hopf point not already reached
by an earlier branch (:mod:`polywear.solvers.continuation`), special points (folds
LP, period doubling PD, torus NS). The result, its speed bands (docs/model.md section 5)
and its plots are :class:`~polywear.dynamics.diagram.BifurcationDiagram`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from ..models import model_for
from ..params import Params
from ..progress import Progress, StepCounter
from ..solvers.continuation import (Branch, BranchEnd, ContinuationSettings, HopfStart, continue_from_hopf,
                                   same_special_point)
from ..units import DEFAULT_SPEED_RANGE_KMH, MAX_SPEED_KMH, kmh_to_ms, ms_to_kmh
from .diagram import BifurcationDiagram, CyclePoint, cycle_point
from .points import PointKind, SpecialPoint
from .stability import HopfPoint, StabilityResult, StabilitySettings, stability

__all__ = ["bifurcation", "branch_start", "SPEED_FLOOR_KMH", "SPEED_CEILING_KMH"]

FINEST_TURN = 0.1
"""A diagram whose branch was lost, or two of whose branches end at one Hopf point, is
continued again, once, with half the largest turn of a step (``ContinuationSettings.max_turn``)
and twice the steps, unless the turn would fall below this [rad]."""
SPEED_FLOOR_KMH = 1.0
"""Lowest speed [km/h] the analysed range is extended to when the SEV band runs into its lower end."""
SPEED_CEILING_KMH = MAX_SPEED_KMH
"""Highest speed [km/h] the analysed range is extended to (the highest operating speed accepted)."""
OPERATING_MARGIN = 1.1
"""The analysed range holds the operating speed V with a margin: from V / 1.1 to 1.1 V at least."""


def branch_start(hopf: HopfPoint) -> HopfStart:
    """The Hopf point as the start of its branch of cycles, the plain data the solvers take
    (:func:`~polywear.solvers.continuation.continue_from_hopf`, ``cycle_along_branch``)."""
    return HopfStart(hopf.speed_ms, hopf.omega, hopf.u, hopf.q)


def _special_point(branch_index: int, kind: PointKind, point) -> SpecialPoint:
    """A special point located on a cycle branch: its speed, frequency and amplitudes."""
    cycle = cycle_point(branch_index, point)
    return SpecialPoint(kind, cycle.speed_kmh, 1.0 / cycle.period, cycle.amplitude, branch_index, orbit=point.orbit)


def bifurcation(
    params: Params,
    speed_range_kmh: tuple[float, float] = DEFAULT_SPEED_RANGE_KMH,
    settings: ContinuationSettings = ContinuationSettings(),
    stability_settings: StabilitySettings = StabilitySettings(),
    progress: Progress | None = None,
    extend: bool = True,
    stop: Callable[[StabilityResult], Callable[[Branch], bool]] | None = None,
) -> BifurcationDiagram:
    """Continuation of equilibria and of the cycles from every Hopf point in the speed range.

    ``progress(steps done, None, "branch b: speed")`` is called after every continuation
    step (:mod:`polywear.progress`).
    With ``extend`` the range is not allowed to decide the answer: it is widened to hold
    the operating speed (``OPERATING_MARGIN``), and while the SEV band or a cycle branch
    runs into one of its ends, widened on that side (down to ``SPEED_FLOOR_KMH`` in one
    step, up by doubling to ``SPEED_CEILING_KMH``) and the diagram computed again, with
    the stability grid as fine as on the requested range. An end still cut at the limit
    is reported by ``open_edges``.

    This is ``polywear bifurcation`` and ``pw.bifurcation``.

    Parameters
    ----------
    params : Params
        The parameter set.
    speed_range_kmh : (float, float)
        Speeds analysed [km/h], ``0 < low < high`` (widened as above with ``extend``).
    settings : ContinuationSettings
        Collocation mesh and step control of the cycle continuation.
    stability_settings : StabilitySettings
        The stability analysis that brackets the Hopf points: its grid ``n_speeds`` on the
        requested range (a widened range keeps that grid spacing, with at most four times
        the points) and ``xtol_ms`` [m/s].
    progress : callable, optional
        Progress callback (:mod:`polywear.progress`), called after every continuation step.
    extend : bool
        Widen the range until the answer no longer depends on it.
    stop : callable, optional
        ``stop(stability_result)`` gives the stop criterion of every branch (``Branch ->
        bool``, :func:`~polywear.solvers.continuation.continue_from_hopf`), e.g. the SEV
        band edges alone (:mod:`polywear.studies.edges`); None: whole branches.

    Returns
    -------
    BifurcationDiagram
        Hopf points, stable and unstable cycle branches, folds and other special
        points, linear and SEV bands [km/h], hard regions, trigger amplitudes;
        ``summary()`` is what ``polywear bifurcation --json`` prints.
    """
    if extend:
        return _extended_diagram(params, speed_range_kmh, settings, stability_settings, progress, stop)
    lo, hi = (float(v) for v in speed_range_kmh)
    stab = stability(params, (lo, hi), settings=stability_settings)
    model = model_for(params)
    p = model.pack(params)
    bounds = (kmh_to_ms(lo), kmh_to_ms(hi))
    runs: list[tuple[int, Branch, int | None]] = []  # (start, branch, end): indices of Hopf points
    reached: set[int] = set()
    step = StepCounter(progress)
    for k, hopf in enumerate(stab.hopf_points):
        if k in reached:
            continue
        callback = None if progress is None else (
            lambda br, b=len(runs): step(f"branch {b}: {ms_to_kmh(br.points[-1].orbit.speed):.1f} km/h"))
        branch = continue_from_hopf(model, p, branch_start(hopf), bounds, settings, on_step=callback,
                                    stop=None if stop is None else stop(stab))
        end_hopf = None
        if branch.end is BranchEnd.HOPF_REACHED and branch.points:
            end_hopf = _nearest_hopf(stab.hopf_points, branch.points[-1], exclude=k)
            if end_hopf is not None:
                reached.add(end_hopf)
        runs.append((k, branch, end_hopf))
    # a branch lost from a Hopf point that a later branch ends at is that branch, known from its other end
    notes: list[str] = []
    lost: set[int] = set()
    for start, branch, _ in runs:
        other = next((a for a, _, e in runs if e == start), None)
        if branch.failed and other is not None:
            lost.add(start)
            notes.append(f"the branch from {stab.hopf_points[start].speed_kmh:.3f} km/h was lost after "
                         f"{ms_to_kmh(branch.end_speed):.3f} km/h ({branch.end_reason}); it is the branch from "
                         f"{stab.hopf_points[other].speed_kmh:.3f} km/h, followed to it from its other end")
    diagram = _assembled(params, stab, [r for r in runs if r[0] not in lost], settings, (lo, hi))
    diagram.continuation_notes = notes
    trouble = _branch_trouble(diagram.branch_info)
    if not trouble or settings.max_turn is None or settings.max_turn / 2 < FINEST_TURN:
        return diagram
    # e.g. a step across a sharp bend that landed on another branch passing close by: all
    # branches again in steps that turn half as much, kept if that lost fewer
    finer = replace(settings, max_turn=settings.max_turn / 2, max_steps=2 * settings.max_steps)
    again = bifurcation(params, (lo, hi), finer, stability_settings, step.relay if progress else None,
                        extend=False, stop=stop)
    left = _branch_trouble(again.branch_info)
    kept = again if len(left) < len(trouble) else diagram
    kept.continuation_notes = [
        f"{'; '.join(trouble)}: all cycle branches continued again with steps that turn by at most "
        f"{finer.max_turn:g} rad (up to {finer.max_steps} steps), "
        + ("which resolved it" if not left else f"after which {'; '.join(left)}"
           + ("" if kept is again else " (the first continuation is kept)")),
        *kept.continuation_notes]
    return kept


def _assembled(params: Params, stab: StabilityResult, runs: list[tuple[int, Branch, int | None]],
               settings: ContinuationSettings, speed_range_kmh: tuple[float, float]) -> BifurcationDiagram:
    """The diagram of the branches ``runs`` (start, branch, end: indices of Hopf points)."""
    info: list[dict] = []
    cycles: list[CyclePoint] = []
    special: list[SpecialPoint] = []
    for b, (k, branch, end_hopf) in enumerate(runs):
        hopf = stab.hopf_points[k]
        info.append(
            {
                "branch": b,
                "from_hopf_kmh": hopf.speed_kmh,
                "to_hopf_kmh": stab.hopf_points[end_hopf].speed_kmh if end_hopf is not None else None,
                "ended": branch.end.value,
                "failed": branch.failed,
                "at_speed_kmh": ms_to_kmh(branch.end_speed),
                "end_reason": branch.end_reason,
                "recoveries": list(branch.recoveries),
                "n_points": len(branch.points),
                "max_trivial_multiplier_error": max(
                    (pt.trivial_multiplier_error for pt in branch.points if pt.resolved), default=0.0),
                "n_unresolved_points": sum(not pt.resolved for pt in branch.points),
            }
        )
        points = [cycle_point(b, pt) for pt in branch.points]
        if points:  # the branch's ends at Hopf points are cycles of zero amplitude
            points.insert(0, _hopf_end(b, hopf, points[0]))
            if end_hopf is not None:
                points.append(_hopf_end(b, stab.hopf_points[end_hopf], points[-1]))
        cycles += points
        for label, pt, _ in branch.special:  # once: branches can meet the same special point
            kind = PointKind(label)
            if not any(s.kind is kind and same_special_point(pt.orbit, s.orbit) for s in special):
                special.append(_special_point(b, kind, pt))
    return BifurcationDiagram(
        params=params,
        stability=stab,
        cycles=cycles,
        branches=[branch for _, branch, _ in runs],
        branch_info=info,
        special=special,
        settings=settings,
        speed_range_kmh=speed_range_kmh,
    )


def _branch_trouble(info: list[dict]) -> list[str]:
    """What is wrong with a diagram's branches (``branch_info``), in words: branches lost,
    and Hopf points that two branches start or end at."""
    out = [f"the branch from {i['from_hopf_kmh']:.3f} km/h was lost after {i['at_speed_kmh']:.3f} km/h"
           for i in info if i["failed"]]
    ends = [i["from_hopf_kmh"] for i in info] + [i["to_hopf_kmh"] for i in info if i["to_hopf_kmh"] is not None]
    out += [f"two branches end at the Hopf point at {v:.3f} km/h" for v in sorted(set(ends)) if ends.count(v) > 1]
    return out


def _extended_diagram(params, speed_range_kmh, settings, stability_settings, progress, stop=None) -> BifurcationDiagram:
    """The diagram on the requested range widened until the range no longer cuts the answer."""
    step = StepCounter(progress)  # counts on across the widened ranges
    requested = tuple(float(v) for v in speed_range_kmh)
    lo, hi = requested
    op = params.operating.speed_kmh
    notes = []
    lo = min(lo, max(op / OPERATING_MARGIN, SPEED_FLOOR_KMH))
    hi = max(hi, min(round(op * OPERATING_MARGIN, 6), SPEED_CEILING_KMH))
    if (lo, hi) != requested:
        notes.append(f"range widened to {lo:g}-{hi:g} km/h to hold the operating speed {op:g} km/h")
    n_speeds = stability_settings.n_speeds
    spacing = (requested[1] - requested[0]) / max(n_speeds - 1, 1)
    diagram = None
    while True:
        n = min(max(n_speeds, int(np.ceil((hi - lo) / spacing)) + 1), 4 * n_speeds)
        try:
            wider = bifurcation(params, (lo, hi), settings, replace(stability_settings, n_speeds=n),
                                step.relay if progress else None, extend=False, stop=stop)
        except (RuntimeError, ValueError, ArithmeticError) as exc:
            if diagram is None:
                raise
            # e.g. no equilibrium at the new low speeds: keep the last diagram, its cut end stays open
            notes[-1] = f"range not widened to {lo:g}-{hi:g} km/h: {exc}"
            break
        diagram = wider
        cut = _cut_ends(diagram)
        below = lo > SPEED_FLOOR_KMH and "lower" not in cut and _unstable_below(params, lo, spacing, stability_settings)
        if below:
            cut.add("lower")
        new_lo = SPEED_FLOOR_KMH if "lower" in cut and lo > SPEED_FLOOR_KMH else lo
        new_hi = min(round(2.0 * hi, 6), SPEED_CEILING_KMH) if "upper" in cut and hi < SPEED_CEILING_KMH else hi
        if (new_lo, new_hi) == (lo, hi):
            break
        ends = " and ".join(f"{lo:g}" if e == "lower" else f"{hi:g}" for e in sorted(cut) if
                            (e == "lower" and new_lo != lo and not below) or (e == "upper" and new_hi != hi))
        why = [f"the SEV band or a cycle branch ran into {ends} km/h"] if ends else []
        why += [f"steady rolling has a Hopf point or is unstable below {lo:g} km/h"] if below else []
        notes.append(f"range widened to {new_lo:g}-{new_hi:g} km/h: {'; '.join(why)}")
        lo, hi = new_lo, new_hi
    diagram.requested_range_kmh = requested
    diagram.range_notes = notes
    return diagram


def _unstable_below(params: Params, lo: float, spacing: float, stability_settings: StabilitySettings) -> bool:
    """True when steady rolling has a Hopf point or is unstable between ``SPEED_FLOOR_KMH``
    and ``lo`` [km/h] (grid ``spacing`` [km/h]): a band below the analysed range."""
    n = min(max(3, int(np.ceil((lo - SPEED_FLOOR_KMH) / spacing)) + 1), 4 * stability_settings.n_speeds)
    try:
        below = stability(params, (SPEED_FLOOR_KMH, lo), replace(stability_settings, n_speeds=n))
    except (RuntimeError, ValueError, ArithmeticError):
        return False  # e.g. no equilibrium at walking pace: the range is not widened down
    return bool(below.hopf_points or below.linear_band_kmh)


def _cut_ends(diagram: BifurcationDiagram) -> set[str]:
    """Ends of the range that cut the answer: the SEV band runs into them, or a cycle branch left the range there."""
    ends = set(diagram.open_edges)
    lo, hi = diagram.speed_range_kmh
    for branch in diagram.branches:
        if branch.points:
            v = ms_to_kmh(branch.points[-1].orbit.speed)
            if v > hi:
                ends.add("upper")
            elif v < lo:
                ends.add("lower")
    return ends


def _hopf_end(branch_index: int, hopf: HopfPoint, neighbour: CyclePoint) -> CyclePoint:
    """The zero-amplitude end of a branch at a Hopf point (stability of its neighbour)."""
    return CyclePoint(
        branch=branch_index,
        speed_ms=hopf.speed_ms,
        period=2.0 * np.pi / hopf.omega,
        amplitude=np.zeros_like(neighbour.amplitude),
        mean=np.asarray(hopf.u, dtype=float),
        stable=neighbour.stable,
        n_unstable=neighbour.n_unstable,
        max_multiplier=1.0,
        trivial_multiplier_error=0.0,
        label=PointKind.HOPF.value,
    )


def _nearest_hopf(hopfs: list[HopfPoint], last_point, exclude: int) -> int | None:
    """Index of the Hopf point a branch ended at (nearest speed, matching frequency)."""
    V = last_point.orbit.speed
    f = 1.0 / last_point.orbit.period
    best, best_d = None, np.inf
    for k, h in enumerate(hopfs):
        if k == exclude and len(hopfs) > 1:
            continue
        d = abs(h.speed_ms - V) / h.speed_ms + abs(h.frequency_hz - f) / h.frequency_hz
        if d < best_d:
            best, best_d = k, d
    return best if best_d < 0.2 else None
