"""One run of a global study: the SEV band's outputs for one parameter set.

:class:`StudyEvaluator` turns a sampled parameter set into the study's outputs (the Hopf
speeds alone, or the SEV band's edges, width and largest amplitude) and a
:class:`SampleOutcome` that says how they were obtained or why they are missing; the
band comes from the fast path (:mod:`.fast_band`), from the edges-only continuation
(:func:`edges_band`, four-Hopf cars), or from the whole diagram. The study itself
(sampling, SALib indices, convergence) is :mod:`.global_sensitivity`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from enum import StrEnum
from typing import NamedTuple

import numpy as np

from ..params import ParameterError, Params
from ..units import DEFAULT_OPERATING_RANGE_KMH, DEFAULT_SPEED_RANGE_KMH, ms_to_kmh
from ..dynamics.intervals import subtract
from ..dynamics.stability import fast_linear_band
from .sampling import SAMPLE_FAILURES, sample_params

__all__ = ["HOPF_OUTPUTS", "BIFURCATION_OUTPUTS", "StudyEvaluator", "SampleStatus", "SampleOutcome",
           "WithoutBranchFrom", "EdgesBand", "edges_band", "max_stable_amplitude"]


HOPF_OUTPUTS = ("hopf_1_kmh", "hopf_2_kmh", "linear_band_width_kmh")
BIFURCATION_OUTPUTS = ("first_bifurcation_speed_kmh", "second_bifurcation_speed_kmh", "sev_band_width_kmh", "max_amplitude_mm")
RENAMED_OUTPUTS = {"first_bifurcation_speed_kmh": "first_bifurcation_kmh",
                   "second_bifurcation_speed_kmh": "second_bifurcation_kmh"}
"""New -> old output names, kept beside the new ones in the summary's ``indices`` and
``convergence`` until the next release."""



class SampleStatus(StrEnum):
    """How the evaluation of one sample ended (the value is the text recorded for it)."""

    OK = "ok"
    NO_BAND = "no band in the speed range"
    """Speeds NaN, width 0."""
    AT_EDGE = "band reaches the edge of the speed range"
    """That bound and the width NaN."""
    INVALID = "invalid parameters"
    """The sampled values are not a valid parameter set (all outputs NaN)."""
    FAILED = "failed"
    """A numerical failure: equilibrium, continuation, ... (all outputs NaN)."""
    UNDECIDED = "band edge at a period doubling or torus bifurcation"
    """A bound of the SEV band is a PD or NS point where steady rolling is stable: the
    doubled or quasi-periodic motion may reach beyond it, which only the doubled branch or
    a simulation decides (:func:`~polywear.studies.edges.pd_ns_edges_kmh`); that bound and
    the width NaN."""


@dataclass(frozen=True)
class SampleOutcome:
    """The status of one sample, the reason in words where there is one, and whether the
    fast band path (not the continuation) gave its outputs."""

    status: SampleStatus
    detail: str | None = None
    fast: bool = False
    edges_only: bool = False
    """The branches were followed only as far as the band's edges need (:mod:`.edges`):
    ``max_amplitude_mm`` is NaN (the cycles inside the linear band were not all computed)."""
    gap_after_pd_ns: bool = False
    """The band has a gap after a PD/NS point with rolling stable (undecided, not counted in the width)."""
    top_fold: bool = False
    """Edges only, with the band's top from the fold above the last Hopf point followed in the
    parameters (:meth:`~polywear.studies.fast_band.FastBand.top_fold`) instead of that Hopf
    point's branch."""
    gap_fold: bool = False
    """Edges only, with the band in the gap between the two intervals of the linear band from
    the third Hopf point's first fold followed in the parameters
    (:meth:`~polywear.studies.fast_band.FastBand.gap_fold`) instead of that point's branch."""

    def __str__(self) -> str:
        """``"status: detail"`` (the status alone without a detail), as recorded per sample."""
        return self.status.value if self.detail is None else f"{self.status.value}: {self.detail}"


def _band_outputs(intervals, speed_range_kmh) -> tuple[tuple[float, float, float], SampleOutcome]:
    """(lowest bound, highest bound, total width) of a union of speed intervals, and the outcome."""
    if not intervals:
        return (np.nan, np.nan, 0.0), SampleOutcome(SampleStatus.NO_BAND)
    lo, hi = speed_range_kmh
    first, last = intervals[0][0], intervals[-1][1]
    width = float(sum(b - a for a, b in intervals))
    status = SampleStatus.OK
    tol = 1e-9 * hi  # range ends pass through m/s and back
    if first <= lo + tol:
        first, width, status = np.nan, np.nan, SampleStatus.AT_EDGE
    if last >= hi - tol:
        last, width, status = np.nan, np.nan, SampleStatus.AT_EDGE
    return (first, last, width), SampleOutcome(status)


def max_stable_amplitude(diagram, speed_range_kmh, state: str = "x") -> float:
    """Largest amplitude of ``state`` on a stable cycle within a speed range (0 if none).

    Between consecutive stable cycle points of a branch the amplitude is interpolated
    linearly, so the range ends are included exactly.
    """
    i = diagram.state_names.index(state)
    lo, hi = speed_range_kmh
    best = 0.0
    for b in range(len(diagram.branches)):
        pts = [c for c in diagram.cycles if c.branch == b]
        for a, c in zip(pts, pts[1:] + [None]):
            va = a.speed_kmh
            if a.stable and lo <= va <= hi:
                best = max(best, float(a.amplitude[i]))
            if c is None or not (a.stable and c.stable):
                continue
            vc = c.speed_kmh
            for edge in (lo, hi):
                if min(va, vc) < edge < max(va, vc):
                    s = (edge - va) / (vc - va)
                    best = max(best, float((1 - s) * a.amplitude[i] + s * c.amplitude[i]))
    return best


def _fast_outputs(band, speed_range_kmh, operating_range_kmh):
    """The bifurcation outputs of a fast-path band: the largest stable amplitude in the
    operating range is taken at its ends and at the folds inside it (where the stable branch
    ends; along a stable run the amplitude grows monotonically towards its fold)."""
    outputs, outcome = _band_outputs(band.sev_band_kmh, speed_range_kmh)
    lo, hi = operating_range_kmh
    folds = [a for v, a in zip(band.folds_kmh, band.fold_amplitude_x_m) if lo <= v <= hi]
    return (*outputs, max([*band.amplitude_x_m, *folds], default=0.0) * 1e3), replace(outcome, fast=True)


@dataclass(frozen=True)
class WithoutBranchFrom:
    """Stop criterion of the branches (``bifurcation(stop=...)``): ``inner``'s, and the branch
    from the Hopf point nearest to ``hopf_kmh`` [km/h] stopped at its first point (the edge
    it would decide is known otherwise: :meth:`~polywear.studies.fast_band.FastBand.top_fold`)."""

    hopf_kmh: float
    inner: object
    """The stop criterion of the other branches (e.g. :class:`~polywear.studies.edges.BranchStop`)."""

    def __call__(self, stab):
        inner = self.inner(stab)
        speeds = [h.speed_kmh for h in stab.hopf_points]
        nearest = lambda v: min(range(len(speeds)), key=lambda k: abs(speeds[k] - v))
        skipped = nearest(self.hopf_kmh) if speeds else None

        def stop(branch) -> bool:
            return nearest(ms_to_kmh(branch.points[0].orbit.speed)) == skipped or inner(branch)

        return stop


class EdgesBand(NamedTuple):
    """The outcome of :func:`edges_band`."""

    sev_band_kmh: list
    """The SEV band [km/h]."""
    gaps_after_pd_ns_kmh: list
    """Its gaps after PD/NS points [km/h] (``sev_band``'s undecided gaps, the pieces from the
    folds included)."""
    diagram: object
    """The edges-only diagram the band came from."""
    top: object
    """The :class:`~polywear.studies.fast_band.TopFold` used, or None."""
    gap: object
    """The :class:`~polywear.studies.fast_band.GapFold` used, or None."""


def edges_band(params: Params, speed_range_kmh: tuple[float, float] = DEFAULT_SPEED_RANGE_KMH,
               fast: object = None, gap_fold: bool = False) -> EdgesBand:
    """The SEV band [km/h] of ``params`` by the edges-only continuation (:class:`EdgesBand`):
    with ``fast`` (a :class:`~polywear.studies.fast_band.FastBand`) the band's top is the
    fold above a hard last Hopf point followed in the parameters where that succeeds (then
    that Hopf point's branch is not continued, and the last hard region runs from it to the
    fold); with ``gap_fold`` too, the band in the gap between the two intervals of the
    linear band is [max(F, second Hopf point), third Hopf point] from the first fold F of
    the third Hopf point's branch followed in the parameters where that succeeds (then that
    branch is not continued). Those pieces join the diagram's stable-cycle intervals in
    :func:`~polywear.dynamics.diagram.sev_band`. Where neither fold is used (both None):
    :func:`~polywear.studies.edges.edges_diagram`'s band."""
    from ..dynamics.bifurcation import bifurcation
    from ..dynamics.diagram import sev_band
    from .edges import BranchStop, edges_diagram
    from .fast_band import GapFold, TopFold

    top = None if fast is None else fast.top_fold(params)
    top = top if isinstance(top, TopFold) else None
    gap = fast.gap_fold(params) if fast is not None and gap_fold else None
    gap = gap if isinstance(gap, GapFold) else None
    if top is None and gap is None:
        diagram = edges_diagram(params, speed_range_kmh)
        return EdgesBand(diagram.sev_band_kmh, diagram.gaps_after_pd_ns_kmh, diagram, None, None)
    stop = BranchStop()
    for known in (top, gap):
        if known is not None:
            stop = WithoutBranchFrom(known.hopf_kmh, stop)
    diagram = bifurcation(params, speed_range_kmh, stop=stop)
    hopf = lambda v: min((h.speed_kmh for h in diagram.hopf_points), key=lambda w: abs(w - v))
    pieces = [] if top is None else [(hopf(top.hopf_kmh), top.fold_kmh)]
    if gap is not None:
        pieces.append((max(gap.fold_kmh, hopf(gap.second_hopf_kmh)), hopf(gap.hopf_kmh)))
    oscillatory = subtract(diagram.linear_band_kmh, diagram.divergence_kmh)
    sev, gaps = sev_band(oscillatory, [*diagram.stable_cycle_intervals_kmh(), *pieces], diagram.pd_ns_speeds_kmh)
    return EdgesBand(sev, gaps, diagram, top, gap)


@dataclass(frozen=True)
class StudyEvaluator:
    """The study's outputs for one sample: picklable, deterministic (a task of any backend)."""

    params: Params
    keys: tuple[str, ...]
    outputs: str = "hopf"
    speed_range_kmh: tuple[float, float] = DEFAULT_SPEED_RANGE_KMH
    operating_range_kmh: tuple[float, float] = DEFAULT_OPERATING_RANGE_KMH
    fast: object = None
    """A :class:`~polywear.studies.fast_band.FastBand` (amplitudes at the operating-range
    ends) tried first for ``outputs = "bifurcation"``; the continuation where it does not apply."""
    edges_only: bool = False
    """Where the fast path does not apply, continue the branches only as far as the SEV
    band's edges need (:func:`~polywear.studies.edges.edges_diagram`; ``max_amplitude_mm`` NaN)."""
    top_fold: bool = False
    """With ``edges_only``: where the last Hopf point is hard and a reference has the fold
    above it, that fold followed in the parameters (:meth:`~polywear.studies.fast_band.FastBand.top_fold`)
    is the band's top, and the branch from that Hopf point is not continued."""
    gap_fold: bool = False
    """With ``edges_only`` and ``top_fold``: for four Hopf points of criticalities hard, soft,
    hard, hard, the band in the gap between the two intervals of the linear band from the
    first fold of the third Hopf point's branch followed in the parameters
    (:meth:`~polywear.studies.fast_band.FastBand.gap_fold`); that branch is not continued."""

    @property
    def names(self) -> tuple[str, ...]:
        return HOPF_OUTPUTS if self.outputs == "hopf" else BIFURCATION_OUTPUTS

    def __call__(self, values) -> tuple[tuple[float, ...], SampleOutcome]:
        """(output values, outcome) for the parameter values of one sample."""
        nan = (np.nan,) * len(self.names)
        try:
            params = sample_params(self.params, self.keys, values)
        except ParameterError as exc:
            return nan, SampleOutcome(SampleStatus.INVALID, str(exc))
        try:
            if self.outputs == "hopf":
                return _band_outputs(fast_linear_band(params, self.speed_range_kmh), self.speed_range_kmh)
            return self._bifurcation(params)
        except SAMPLE_FAILURES as exc:  # a numerical failure is recorded with its reason
            return nan, SampleOutcome(SampleStatus.FAILED, f"{type(exc).__name__}: {exc}")

    def _bifurcation(self, params):
        from ..dynamics.bifurcation import bifurcation
        from .edges import pd_ns_edges_kmh
        from .fast_band import Band

        if self.fast is not None:
            band = self.fast.try_fast(params)
            if isinstance(band, Band):
                return _fast_outputs(band, self.speed_range_kmh, self.operating_range_kmh)

        if self.edges_only:
            sev, gaps, diagram, top, gap = edges_band(params, self.speed_range_kmh,
                                                      self.fast if self.top_fold else None, self.gap_fold)
        else:
            diagram, top, gap = bifurcation(params, self.speed_range_kmh), None, None
            sev, gaps = diagram.sev_band_kmh, diagram.gaps_after_pd_ns_kmh
        for info in diagram.branch_info:
            if info["failed"]:
                return (np.nan,) * 4, SampleOutcome(
                    SampleStatus.FAILED, f"continuation from {info['from_hopf_kmh']:.2f} km/h: {info['end_reason']}",
                    edges_only=self.edges_only, top_fold=top is not None, gap_fold=gap is not None)
        band, outcome = _band_outputs(sev, diagram.speed_range_kmh)  # the range as widened
        undecided = [v for v in pd_ns_edges_kmh(diagram) if sev and v in (sev[0][0], sev[-1][1])]
        if undecided:
            first, last, _ = band
            band = tuple(np.nan if v in undecided else v for v in (first, last)) + (np.nan,)
            outcome = SampleOutcome(SampleStatus.UNDECIDED, "at " + ", ".join(f"{v:.3f}" for v in undecided)
                                    + " km/h")
        amplitude = np.nan if self.edges_only else max_stable_amplitude(diagram, self.operating_range_kmh) * 1e3
        return (*band, amplitude), replace(outcome, edges_only=self.edges_only, top_fold=top is not None,
                                           gap_fold=gap is not None,
                                           gap_after_pd_ns=bool(gaps))
