"""The SEV band's edges without the whole diagram: branches followed only as far as an edge needs.

For the cars the fast band path (:mod:`.fast_band`) cannot label (four Hopf points with
period-doubling cascades), a study needs the band's edges, not the cascades. The SEV
band (:func:`~polywear.dynamics.diagram.sev_band`) is the union of the oscillatory
linear band ``O`` (steady rolling unstable through a Hopf pair, known from the
eigenvalues alone) and the speeds of stable cycles. Inside ``O`` nothing a branch does
moves an edge: every edge is a Hopf point, or a fold or PD/NS point of a branch *outside*
``O``. So each branch is continued, step for step as the full continuation does
(:func:`~polywear.dynamics.bifurcation.bifurcation` with a stop criterion), until its
last point lies deeper than :data:`EDGE_DEPTH_KMH` inside the interval of ``O`` its Hopf
point bounds (a cascade branch: until it lies that deep again after a fold, see below);
a Hopf point that branch would have reached starts its own branch, which
covers the other end the same way. Up to the stop every point, fold and PD/NS point is the full
continuation's, bit for bit.

What the depth is for: a branch can leave ``O`` again after entering it (an *excursion*:
past the Hopf point at the end of an interval of ``O``, into the gap next to it; in 33 of
60 random four-Hopf cars at +-10 %). Stopping on entry misses the folds there: in
``tests/test_edges.py::EXCURSION_AXLE`` the branch from the Hopf point at 80.49 km/h dips
0.3 km/h into ``O`` before it turns and folds at 80.92 km/h, an edge. The depth is the
rule. Why its own interval: a branch from the lower Hopf point of the second interval can
cross the gap below it, turn 2.5 km/h inside the first interval and come back across the
gap stable, a hard region filling the gap (2 of the first 18 cars of the agreement run,
when the branches stopped in any interval). The agreement run of
``benchmarks/bench_fleet.py edges`` is the rule's check on cars (docs/fleet.md, "Cars the
fast path cannot label").

Why a cascade branch goes on (one with a PD or NS point before its first deep point): it
snakes, and its first fold inside ``O`` can bring it back to the end of the interval it came
from. In ``tests/test_edges.py::WINDOW_AXLE`` the branch from the Hopf point at 63.74 km/h
runs 4.3 km/h deep, folds at 67.99 km/h and comes back to a window of stable cycles at
63.689-63.690 km/h, below that Hopf point; stopped at its first deep point it missed the
window (2 of 200 cars, the other a window of 0.078 km/h). So a cascade branch is followed
through a fold and stopped at the first deep point after it on its way away from the end
nearer to it. Checked on the full branches of the 200 cars of the agreement run: the stretches
this rule skips stay 1.55 km/h or more inside ``O``; those the first rule skipped left it in 7
cars (in 2 of them changing the band).

Cost: the stretches a study needs are the branches' ends outside ``O`` (the hard
regions, windows next to folds) and the excursions; the cascades inside ``O`` are skipped.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..dynamics.bifurcation import bifurcation
from ..dynamics.diagram import BifurcationDiagram
from ..dynamics.points import PointKind
from ..params import Params
from ..solvers.continuation import ContinuationSettings
from ..units import DEFAULT_SPEED_RANGE_KMH, ms_to_kmh

__all__ = ["EDGE_DEPTH_KMH", "BranchStop", "edges_diagram", "oscillatory_intervals", "pd_ns_edges_kmh",
           "window_edges_kmh"]

EDGE_DEPTH_KMH = 2.0
"""A branch is stopped once its last point lies this far [km/h] inside an interval of the
oscillatory linear band (from both ends of it)."""


def oscillatory_intervals(stab) -> list[tuple[float, float]]:
    """Intervals [km/h] of the linear band of ``stab`` (a StabilityResult) with no real
    eigenvalue crossing in them: steady rolling unstable through Hopf pairs alone."""
    return [(a, b) for a, b in stab.linear_band_kmh
            if not any(a <= v <= b for v in stab.real_crossings_kmh)]


@dataclass(frozen=True)
class BranchStop:
    """Stop criterion of the branches (``bifurcation(stop=BranchStop(...))``): called with the
    stability result, it gives ``Branch -> bool``. *Deep* means ``depth_kmh`` [km/h] inside
    the oscillatory interval the branch's Hopf point bounds or lies in (the one nearest to
    its first point). A branch is stopped at its first deep point, unless it has a PD or NS
    point before it (a cascade branch): that one is followed on through a fold and stopped
    at the first deep point after one, moving away from the end of the interval nearer to it.
    A branch that crosses a gap into another interval is followed on: it may come back
    across the gap, stable (a hard region filling it)."""

    depth_kmh: float = EDGE_DEPTH_KMH

    def __call__(self, stab):
        intervals = oscillatory_intervals(stab)

        def stop(branch) -> bool:
            if not intervals:
                return False
            points = branch.points
            start = ms_to_kmh(points[0].orbit.speed)
            a, b = min(intervals, key=lambda iv: max(iv[0] - start, start - iv[1], 0.0))
            speeds = [ms_to_kmh(pt.orbit.speed) for pt in points]
            deep = [a + self.depth_kmh < v < b - self.depth_kmh for v in speeds]
            if not deep[-1]:
                return False
            entry = deep.index(True)
            if entry == len(points) - 1:  # the first deep point: a cascade branch goes on
                return not any(label in ("PD", "NS") and k <= entry for label, _, k in branch.special)
            turned = any(points[k].tangent_speed * points[k - 1].tangent_speed < 0
                         for k in range(entry + 1, len(points)))
            v = speeds[-1]
            return turned and (points[-1].tangent_speed > 0) == (v - a < b - v)

        return stop


def edges_diagram(params: Params, speed_range_kmh=DEFAULT_SPEED_RANGE_KMH,
                  settings: ContinuationSettings = ContinuationSettings(),
                  depth_kmh: float = EDGE_DEPTH_KMH, extend: bool = True) -> BifurcationDiagram:
    """The diagram of ``params`` with every branch stopped ``depth_kmh`` [km/h] inside the
    oscillatory linear band: its SEV band, hard regions, folds outside that band and gaps
    after PD/NS points are the full diagram's (``bifurcation`` with the same arguments);
    its cycles inside the band are not all there (no amplitudes from it)."""
    return bifurcation(params, speed_range_kmh, settings, extend=extend, stop=BranchStop(depth_kmh))


def _pd_ns_kmh(diagram) -> list[float]:
    """Speeds [km/h] of the PD and NS points of every branch of ``diagram``."""
    return [ms_to_kmh(pt.orbit.speed) for branch in diagram.branches for label, pt, _ in branch.special
            if PointKind(label) in (PointKind.PD, PointKind.NS)]


def _near(v: float, speeds) -> bool:
    return any(abs(v - w) <= 1e-9 * max(1.0, abs(v)) for w in speeds)


def window_edges_kmh(diagram: BifurcationDiagram) -> list[float]:
    """Bounds of the SEV band [km/h] at a fold of a *window*: an interval of the band from
    that fold to a PD or NS point (stable cycles only between them, rolling stable). Where
    the PD is subcritical, its doubled cycles lie over the window and may turn stable
    beyond the fold, so the motion could outlast the fold: a simulation past the fold
    tells (``benchmarks/bench_fleet.py edges --simulate``)."""
    sev, points = diagram.sev_band_kmh, _pd_ns_kmh(diagram)
    folds = [f.speed_kmh for f in diagram.folds]
    if not sev:
        return []
    (a, b), (c, d) = sev[0], sev[-1]
    out = [a] if _near(a, folds) and _near(b, points) else []
    return out + ([d] if _near(d, folds) and _near(c, points) and d != a else [])


def pd_ns_edges_kmh(diagram: BifurcationDiagram) -> list[float]:
    """Ends [km/h] of the SEV band (its first and second bifurcation speeds) that are PD or NS
    points of a branch: there steady rolling is stable and the stable cycles end in a period
    doubling or torus bifurcation, so the doubled or quasi-periodic motion may reach beyond;
    only the doubled branch or a simulation decides such an edge."""
    sev = diagram.sev_band_kmh
    if not sev:
        return []
    points = _pd_ns_kmh(diagram)
    return [e for e in (sev[0][0], sev[-1][1]) if _near(e, points)]
