"""The SEV band without the whole bifurcation diagram: the fast path of studies and fleets.

A study or a fleet needs, per parameter set, only the bifurcation speeds and the bands
(linear, SEV, hard) and perhaps the cycle amplitude at a few speeds, not every cycle of
every branch. The full path (:func:`~polywear.dynamics.bifurcation.bifurcation`)
continues whole branches; the fast path solves the defining systems directly:

1. **Hopf points**: equilibrium eigenvalues on a coarse grid (``n_grid`` speeds), each
   sign change refined by Brent's method on the tracked eigenvalue, with the first
   Lyapunov coefficient (:func:`~polywear.dynamics.stability.stability`).
2. **Folds of cycles**: each fold of a *reference* (a solved nearby parameter set) is
   followed in the parameters along the straight line ``p(theta) = p_ref + theta (p -
   p_ref)`` from ``theta = 0`` to 1. Predictor: the exact fold-speed gradient of the
   reference (left null vector of the collocation system,
   :func:`~polywear.dynamics.sensitivity.fold_speed_derivative`), then secants; the
   Newton guess is the last fold moved along its tangent in the parameters (the whole
   orbit to first order, :func:`~polywear.solvers.continuation.fold_parameter_tangent`).
   Corrector (:func:`~polywear.solvers.continuation.solve_fold`): Newton on the fold's
   minimally augmented system (the collocation equations, the phase condition and the
   vanishing speed component of the bordered Jacobian's null vector), so the fold is
   found without stepping along the new branch. Where that Newton fails (its basin is
   smaller: e.g. a fold of tiny amplitude next to its Hopf point) the step falls back to
   :func:`~polywear.solvers.continuation.locate_fold`: Newton onto the new branch, then
   pseudo-arclength steps to a bracket of the fold and secants inside it. The first try
   is one step; a step whose fold misses the prediction by more than the predicted
   change is halved, a good one doubled.
3. **Bands by label**: every end of the reference's SEV band, hard regions and
   stable-cycle intervals is labelled by the special point it sits at (Hopf point k, fold
   j, an end of the speed range); the sample's bands are the same intervals with its own
   speeds at the labels.
4. **Amplitudes** at chosen speeds: Newton at fixed speed
   (:func:`~polywear.solvers.continuation.solve_at_speed`) from the reference's stable
   cycle at that speed (near a Hopf end rescaled by the square-root amplitude law). When
   the reference has none there (the sample's stable interval reaches past the
   reference's), or Newton fails or lands on an unstable cycle: along the sample's own
   branch (:func:`~polywear.solvers.continuation.cycle_along_branch`) from the end of its
   stable interval nearest to the speed, from the Hopf point or from the fold (the
   stable side of it).

The fast path applies only while the topology is the reference's. It falls back to the
full continuation, and says why (``Band.path``, ``Band.reason``), when: the number of
Hopf points or any criticality differs (a band closes or opens, a Bautin point is
crossed), a real eigenvalue crosses, a narrow band lies between grid speeds (a
growth-rate extremum of the wrong sign there, refined by a bounded search), a fold cannot be followed or its
amplitude shrinks below ``min_fold_amplitude`` of the reference's (towards a Bautin
point), a fold leaves the speed range, the order of the special speeds changes, or a
cycle at a chosen speed is not found or is unstable. A reference whose bands have an
end that is not a Hopf point, fold or range end (a period doubling or torus bifurcation
changes stability), or that has such bifurcations at all, is not used: every sample
then takes the full path.

What the fast path cannot see: a new pair of folds born on a branch (a cusp) without any
change in the Hopf points, or a period doubling appearing on the stable branch. The
agreement tests (``tests/test_fast_band.py``) compare both paths on random samples and
count every difference as a failure.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..models import model_for
from ..parallel import Executor
from ..params import Params
from ..progress import Progress
from ..units import DEFAULT_SPEED_RANGE_KMH, kmh_to_ms, ms_to_kmh
from ..solvers.continuation import (BranchPoint, ContinuationSettings, cycle_along_branch, fold_at, fold_curvature,
                                    on_adapted_mesh, recentred, solve_at_speed, solve_at_speed_on_kinks,
                                    solve_fold)
from ..dynamics.points import PointKind
from .sampling import SAMPLE_FAILURES, sample_params
from . import band_folds
from .band import (LABEL_TOL_KMH, Band, BandPath, Fallback, FallbackReason, _difference, _distance, _Fallback,
                   band_from_diagram)
from .band_folds import GAP_FOLD_CRITICALITY, GapFold, TopFold, _gap_fold_index, _top_fold_index

__all__ = ["Band", "BandPath", "BandReference", "FallbackReason", "FastBand", "GAP_FOLD_CRITICALITY", "GapFold", "TopFold",
           "band_from_diagram", "band_reference",
           "Pilot", "pilot_indices", "pilot_references", "pilot_size", "pilot_stage"]


def _fixed_range() -> dict:
    """Keyword that keeps the full diagram on the given speed range (where it can widen it):
    both paths must answer on the same range; choose the range wide enough instead."""
    import inspect

    from ..dynamics.bifurcation import bifurcation

    return {"extend": False} if "extend" in inspect.signature(bifurcation).parameters else {}


_FIXED_RANGE = _fixed_range()


# -- the reference: a solved parameter set with its special points labelled -----------------------
@dataclass(frozen=True)
class BandReference:
    """A solved parameter set the fast path starts from (picklable)."""

    params: Params
    p: np.ndarray
    band: Band
    folds: tuple[BranchPoint, ...]
    scales: tuple[np.ndarray, ...]
    """State scales of the continuation norm, per fold (those of its branch)."""
    fold_gradients: tuple[np.ndarray, ...] = ()
    """dV_fold/dp [m/s per unit of each kernel parameter], per fold (exact, left null vector)."""
    fold_curvatures: tuple[float, ...] = ()
    """d(dV/ds)/ds along the branch at each fold (first step of :func:`locate_fold`, the fallback corrector)."""
    sev_labels: tuple = ()
    hard_labels: tuple = ()
    stable_labels: tuple = ()
    cycles: tuple = ()
    """The stable cycle (PeriodicOrbit) of largest amplitude at each chosen speed, or None."""
    unusable: str = ""
    """Why the reference cannot serve the fast path ("" if it can)."""
    speed_range_kmh: tuple[float, float] = DEFAULT_SPEED_RANGE_KMH
    """The range of the reference's diagram [km/h]."""
    top_fold: int | None = None
    """Index of the fold that ends the SEV band above the last Hopf point, a hard one (the
    last hard region runs from that point to the fold), or None: what :meth:`FastBand.top_fold`
    follows; set on unusable references too (a period doubling below it changes nothing
    there), not where a branch failed or a real eigenvalue crosses."""
    gap_fold: int | None = None
    """Index into :attr:`folds` of the first fold ``F`` of the branch from the third of four
    Hopf points (criticalities :data:`GAP_FOLD_CRITICALITY`) where the band's piece in the
    gap between the two intervals of the linear band is [max(F, second Hopf point), third
    Hopf point], or None: what :meth:`FastBand.gap_fold` follows (usable or not)."""

    def band_speed(self, label) -> float:
        """Speed [km/h] of a label: ("H", k) Hopf point, ("F", j) fold, ("lo"|"hi", 0) range end."""
        kind, k = label
        if kind == "H":
            return self.band.hopf_kmh[k]
        if kind == "F":
            return self.band.folds_kmh[k]
        return self.speed_range_kmh[0 if kind == "lo" else 1]


def _label(value: float, hopf: tuple, folds: tuple, speed_range) -> tuple | None:
    for name, speeds in (("H", hopf), ("F", folds)):
        for k, v in enumerate(speeds):
            if abs(value - v) <= LABEL_TOL_KMH:
                return (name, k)
    for name, v in zip(("lo", "hi"), speed_range):
        if abs(value - v) <= LABEL_TOL_KMH:
            return (name, 0)
    return None


def _labelled(intervals, hopf, folds, speed_range) -> tuple | None:
    out = []
    for a, b in intervals:
        la, lb = _label(a, hopf, folds, speed_range), _label(b, hopf, folds, speed_range)
        if la is None or lb is None:
            return None
        out.append((la, lb))
    return tuple(out)


def band_reference(diagram, amplitude_speeds_kmh=()) -> BandReference:
    """The :class:`BandReference` of a full diagram (its folds, labels and cycles)."""
    model = model_for(diagram.params)
    band = band_from_diagram(diagram, amplitude_speeds_kmh)
    folds, scales = [], []
    for branch in diagram.branches:
        for label, point, _ in branch.special:
            if label == "LP":
                folds.append(point)
                scales.append(branch.scales)
    from ..dynamics.sensitivity import fold_speed_derivative

    p = model.pack(diagram.params)
    unit = np.eye(len(p))
    gradients = tuple(np.array([fold_speed_derivative(model, p, f, e) for e in unit]) for f in folds)
    ix = diagram.state_names.index("x")
    cycles = []
    for v in band.amplitude_speeds_kmh:
        stable = [c for c in diagram.cycles_at(v) if c.stable]
        cycles.append(max(stable, key=lambda c: c.amplitude[ix]).orbit if stable else None)
    unusable = ""
    if any(s.kind in (PointKind.PD, PointKind.NS) for s in diagram.special):
        unusable = "period doubling or torus bifurcation in the reference"
    if diagram.stability.real_crossings_kmh:
        unusable = "real eigenvalue crossing in the reference"
    if any(info["failed"] for info in diagram.branch_info):
        unusable = "a cycle branch of the reference failed"
    labels = {}
    for name, intervals in (("sev", band.sev_band_kmh), ("hard", band.hard_regions_kmh),
                            ("stable", diagram.stable_cycle_intervals_kmh())):
        labels[name] = _labelled(intervals, band.hopf_kmh, band.folds_kmh, diagram.speed_range_kmh)
        if labels[name] is None and not unusable:
            unusable = f"an end of the reference's {name} intervals is not a Hopf point, fold or range end"
    if not unusable and any(kind in ("lo", "hi") for pairs in labels.values() for pair in pairs for kind, _ in pair):
        # a branch leaves the range: its fold lies beyond it, or none was found there; a
        # sample whose fold lies inside the range would get the range end as band edge
        unusable = "an interval of the reference ends at an end of the speed range (a fold may lie beyond it)"
    return BandReference(
        params=diagram.params,
        p=p,
        band=band,
        folds=tuple(folds),
        scales=tuple(scales),
        fold_gradients=gradients,
        fold_curvatures=tuple(fold_curvature(model, p, f, sc, diagram.settings) for f, sc in zip(folds, scales)),
        sev_labels=labels["sev"] or (),
        hard_labels=labels["hard"] or (),
        stable_labels=labels["stable"] or (),
        cycles=tuple(cycles),
        unusable=unusable,
        speed_range_kmh=tuple(diagram.speed_range_kmh),
        top_fold=_top_fold_index(diagram, band),
        gap_fold=_gap_fold_index(diagram, band, folds),
    )


# -- several references: a deterministic pilot stage -------------------------------------------------
@dataclass(frozen=True)
class _PilotReference:
    """Picklable task: the :class:`BandReference` of one parameter set, or why it failed."""

    speed_range_kmh: tuple[float, float]
    amplitude_speeds_kmh: tuple[float, ...]
    settings: ContinuationSettings

    def __call__(self, params: Params) -> BandReference | str:
        from ..dynamics.bifurcation import bifurcation

        try:
            diagram = bifurcation(params, self.speed_range_kmh, self.settings, **_FIXED_RANGE)
            return band_reference(diagram, self.amplitude_speeds_kmh)
        except SAMPLE_FAILURES as exc:  # a pilot that fails is no reference; the caller counts it
            return f"{type(exc).__name__}: {exc}"


def pilot_indices(n_samples: int, n_pilot: int) -> np.ndarray:
    """``n_pilot`` evenly spaced indices into ``n_samples`` samples (all of them if fewer):
    the pilot stage of a study or fleet, fixed by the sample list alone."""
    if n_pilot >= n_samples:
        return np.arange(n_samples)
    return np.unique(np.round(np.linspace(0, n_samples - 1, n_pilot)).astype(int))


PILOT_MAX = 32
"""Largest pilot stage [samples] of :func:`pilot_size`."""
PILOT_EVERY = 32
"""One pilot sample per this many samples [-] (pilot samples cost ~2.5 full continuations each)."""


def pilot_size(n_samples: int) -> int:
    """Pilot samples for a study or fleet of ``n_samples`` [-]: one per :data:`PILOT_EVERY`,
    at most :data:`PILOT_MAX`."""
    return min(PILOT_MAX, n_samples // PILOT_EVERY)


def pilot_references(params_list, speed_range_kmh=DEFAULT_SPEED_RANGE_KMH, amplitude_speeds_kmh=(),
                     settings: ContinuationSettings | None = None, executor: Executor = Executor(),
                     progress: Progress | None = None) -> tuple[tuple, list[str]]:
    """References of several parameter sets by the full continuation, for :class:`FastBand`.

    A sample then starts from the nearest reference with its own Hopf signature, so the
    topologies the pilot met (e.g. a hard first Hopf point, a second band) take the fast
    path too. The pilot is computed before any sample and depends only on the parameter
    sets given, so results stay independent of backend, batch size and worker count.
    ``executor`` (:class:`polywear.parallel.Executor`) runs the continuations; ``progress``:
    parameter sets done of all.

    Returns (the references, usable or not, and the messages of the pilots that failed).
    """
    results = _solved(params_list, speed_range_kmh, amplitude_speeds_kmh, settings, executor, progress)
    return tuple(r for r in results if isinstance(r, BandReference)), [r for r in results if isinstance(r, str)]


def _solved(params_list, speed_range_kmh, amplitude_speeds_kmh=(), settings: ContinuationSettings | None = None,
            executor: Executor = Executor(), progress: Progress | None = None) -> list:
    """Per parameter set, in order: its :class:`BandReference` or why it failed."""
    task = _PilotReference(tuple(speed_range_kmh), tuple(float(v) for v in amplitude_speeds_kmh),
                           settings or ContinuationSettings())
    return executor.map(task, list(params_list), progress)


@dataclass(frozen=True)
class Pilot:
    """The outcome of :func:`pilot_stage`."""

    references: tuple[BandReference, ...]
    """The nominal set's (first, when solved) and the pilot samples', usable or not."""
    samples: dict[int, BandReference]
    """Sample index -> its reference, for the pilot samples solved (their full diagrams)."""
    nominal: BandReference | None
    """The nominal set's reference (None: it failed, the first of ``failed`` says why)."""
    failed: tuple[str, ...] = ()
    """Why the pilots that failed did (the nominal set's first, if it failed)."""


def pilot_stage(base: Params, keys, X, nominal: Params | BandReference, speed_range_kmh=DEFAULT_SPEED_RANGE_KMH,
                amplitude_speeds_kmh=(), executor: Executor = Executor(), progress: Progress | None = None) -> Pilot:
    """The pilot stage of a study or fleet: the nominal set and the :func:`pilot_size`
    samples at :func:`pilot_indices` of the design ``X`` (rows of values of ``keys``, set
    on ``base``) by the full continuation (:func:`pilot_references`). ``nominal`` is a
    parameter set, or its reference when already solved. A sample that is no valid
    parameter set is left out (the study or fleet records it with its own evaluation).
    ``executor`` and ``progress`` as in :func:`pilot_references`."""
    from ..params import ParameterError

    todo: dict[int, Params] = {}
    for i in pilot_indices(len(X), pilot_size(len(X))):
        try:
            todo[int(i)] = sample_params(base, keys, X[i])
        except ParameterError:
            continue
    given = isinstance(nominal, BandReference)
    results = _solved(([] if given else [nominal]) + list(todo.values()), speed_range_kmh, amplitude_speeds_kmh,
                      executor=executor, progress=progress)
    first = nominal if given else results.pop(0)
    samples = {i: r for i, r in zip(todo, results) if isinstance(r, BandReference)}
    return Pilot(references=tuple(r for r in (first, *results) if isinstance(r, BandReference)), samples=samples,
                 nominal=first if isinstance(first, BandReference) else None,
                 failed=tuple(r for r in (first, *results) if isinstance(r, str)))


# -- the fast path ------------------------------------------------------------------------------------
def _rescaled(model, p_ref, p, guess, V, labels, ref_interval, interval, v_kmh):
    """The reference's cycle at speed V [m/s] as a guess for ``p`` near a Hopf end of its
    stable interval: deviation from the steady state scaled by ``sqrt(|v - v_H| / |v - v_H,ref|)``
    (the amplitude law near a Hopf point), around the sample's steady state. None without a Hopf end."""
    ends = [i for i in (0, 1) if labels[i][0] == "H"]
    if not ends:
        return None
    i = min(ends, key=lambda j: abs(v_kmh - interval[j]))
    ratio = np.sqrt(abs(v_kmh - interval[i]) / max(abs(v_kmh - ref_interval[i]), 1e-12))
    u_ref, u_new = model.equilibrium(V, p_ref), model.equilibrium(V, p)
    return replace(guess, nodes=u_new + ratio * (guess.nodes - u_ref))


def _crosses_between(params, a_kmh: float, b_kmh: float, peak: bool) -> bool:
    """Whether the largest growth rate's extremum between two grid speeds changes sign
    (a negative local maximum that is positive, or a positive minimum that is negative):
    a narrow band the grid missed. Bounded scalar search, as ``fast_linear_band`` does."""
    from scipy.optimize import minimize_scalar

    from ..dynamics.stability import equilibrium_eigenvalues

    model = model_for(params)
    p = model.pack(params)

    def rate(V):
        return float(equilibrium_eigenvalues(model, p, [V])[1].real.max())

    sign = -1.0 if peak else 1.0
    best = minimize_scalar(lambda V: sign * rate(V), bounds=(kmh_to_ms(a_kmh), kmh_to_ms(b_kmh)), method="bounded",
                           options={"xatol": 1e-6})
    return (rate(best.x) > 0.0) == peak


@dataclass(frozen=True)
class FastBand:
    """Picklable solver: ``FastBand(references, ...)(params) -> Band`` (fast path or fallback).

    Parameters
    ----------
    references : solved parameter sets (:func:`band_reference`, :func:`pilot_references`);
        the warm start is the nearest (relative distance of the kernel parameter vectors)
        usable one whose Hopf points have the sample's number and criticalities (known
        from the cheap first step, before any fold is followed).
    speed_range_kmh : where Hopf points and cycles are searched [km/h].
    amplitude_speeds_kmh : speeds [km/h] for ``Band.amplitude_x_m``; must be those the
        references were made with.
    n_grid : speeds of the eigenvalue grid of the Hopf search [-].
    max_halvings : fold steps are halved at most this often before falling back [-].
    min_fold_amplitude : fall back when a fold's amplitude drops below this fraction of
        the reference's (a Bautin point is near) [-].
    adapt_mesh : adapt the mesh to the sample's fold orbit and re-locate the fold (off: the
        fold speeds agree with the continuation's to ~1e-12 without it, on both models).
    fold_newton : Newton iterations of one fold solve before its step is halved [-]
        (from folds 10 % away in the parameters they took 5-10).
    fold_tangent : start each fold solve from the last fold moved along its tangent in the
        parameters (:func:`~polywear.solvers.continuation.fold_parameter_tangent`: the orbit
        to first order) rather than only recentred on the new steady state.
    """

    references: tuple[BandReference, ...]
    speed_range_kmh: tuple[float, float] = DEFAULT_SPEED_RANGE_KMH
    amplitude_speeds_kmh: tuple[float, ...] = ()
    n_grid: int = 48
    max_halvings: int = 6
    min_fold_amplitude: float = 0.1
    adapt_mesh: bool = False
    fold_newton: int = 12
    fold_tangent: bool = True
    settings: ContinuationSettings = field(default_factory=ContinuationSettings)

    def __call__(self, params: Params) -> Band:
        """The band of ``params``: fast path, or the full continuation when it does not apply."""
        band = self.try_fast(params)
        return band if isinstance(band, Band) else self.full(params, band)

    def try_fast(self, params: Params) -> Band | Fallback:
        """The fast path's band, or why it does not apply (then nothing else is computed)."""
        model = model_for(params)
        p = model.pack(params)
        try:
            stab, ref = self._hopf(params, p)
            return self._fast(model, params, p, ref, stab)
        except _Fallback as exc:
            return exc.fallback

    def top_fold(self, params: Params) -> TopFold | Fallback:
        """:func:`.band_folds.top_fold` with this solver's references and settings."""
        return band_folds.top_fold(self, params)

    def gap_fold(self, params: Params) -> GapFold | Fallback:
        """:func:`.band_folds.gap_fold` with this solver's references and settings."""
        return band_folds.gap_fold(self, params)

    def usage_verdict(self, params: Params, speeds_kmh) -> tuple | None:
        """From the Hopf points alone: (SEV band holds a usage speed, a hard region holds one,
        first bifurcation speed [km/h] or NaN), or None when a fold's position decides it.

        A fold's speed is not computed; it is bounded by its neighbours in the reference's
        order of Hopf and fold speeds (the fast path requires that order). A usage speed is
        decided when it lies inside an interval whatever the fold speeds, or outside every
        interval whatever they are."""
        model = model_for(params)
        try:
            stab, ref = self._hopf(params, model.pack(params))
        except _Fallback:
            return None
        hopf = [h.speed_kmh for h in stab.hopf_points]
        order = [label for _, label in sorted([(v, ("H", i)) for i, v in enumerate(ref.band.hopf_kmh)]
                                              + [(v, ("F", j)) for j, v in enumerate(ref.band.folds_kmh)])]
        lo, hi = self.speed_range_kmh

        def bounds(label):
            kind, k = label
            if kind != "F":
                v = hopf[k] if kind == "H" else (lo if kind == "lo" else hi)
                return v, v
            i = order.index(label)
            below = [hopf[m] for kind_, m in order[:i] if kind_ == "H"]
            above = [hopf[m] for kind_, m in order[i + 1:] if kind_ == "H"]
            return max(below, default=lo), min(above, default=hi)

        def holds(labels):
            unknown = False
            for v in speeds_kmh:
                for a, b in labels:
                    (_, a_hi), (b_lo, _) = bounds(a), bounds(b)
                    (a_lo, _), (_, b_hi) = bounds(a), bounds(b)
                    if a_hi <= v <= b_lo:
                        return True
                    unknown |= a_lo <= v <= b_hi
            return None if unknown else False

        sev, hard = holds(ref.sev_labels), holds(ref.hard_labels)
        if sev is None or hard is None:
            return None
        first = bounds(ref.sev_labels[0][0]) if ref.sev_labels else (np.nan, np.nan)
        return sev, hard, first[0] if first[0] == first[1] else np.nan

    def full(self, params: Params, fallback: Fallback | None = None) -> Band:
        """The full continuation's band (the fallback, with its reason)."""
        return band_from_diagram(self.diagram(params), self.amplitude_speeds_kmh, fallback)

    def diagram(self, params: Params):
        """The full bifurcation diagram of ``params`` on the solver's speed range (not widened)."""
        from ..dynamics.bifurcation import bifurcation

        return bifurcation(params, self.speed_range_kmh, self.settings, **_FIXED_RANGE)

    def _nearest(self, p, criticality: tuple) -> BandReference:
        """The nearest usable reference with these Hopf criticalities (relative distance)."""
        same = [r for r in self.references if r.p.shape == p.shape]
        if not same:
            raise _Fallback(FallbackReason.NO_REFERENCE, "no reference for this model")
        same = [r for r in same if r.band.hopf_criticality == criticality]
        if not same:
            names = tuple(str(c) for c in criticality)  # ('soft', 'hard'), plain strings or enum members
            raise _Fallback(FallbackReason.HOPF_SIGNATURE, f"no reference with the Hopf points {names}")
        usable = [r for r in same if not r.unusable]
        if not usable:
            raise _Fallback(FallbackReason.REFERENCE_UNUSABLE, same[0].unusable)
        return min(usable, key=lambda r: _distance(p, r.p))

    # -- the steps --------------------------------------------------------------------------------
    def _hopf(self, params, p):
        """The stability analysis of ``params`` and the reference of its Hopf signature."""
        from ..dynamics.stability import StabilitySettings, stability

        try:
            stab = stability(params, self.speed_range_kmh, StabilitySettings(n_speeds=self.n_grid))
        except RuntimeError as exc:
            raise _Fallback(FallbackReason.STABILITY_FAILED, f"stability: {exc}") from exc
        if stab.real_crossings_kmh:
            raise _Fallback(FallbackReason.REAL_CROSSING, "real eigenvalue crossing")
        ref = self._nearest(p, tuple(h.criticality for h in stab.hopf_points))
        r = stab.eigenvalues.real.max(axis=1)
        inner = r[1:-1]
        peak = (inner >= r[:-2]) & (inner >= r[2:]) & (inner <= 0.0)
        trough = (inner <= r[:-2]) & (inner <= r[2:]) & (inner > 0.0)
        for i in np.flatnonzero(peak | trough) + 1:
            if _crosses_between(params, stab.speeds_kmh[i - 1], stab.speeds_kmh[i + 1], bool(peak[i - 1])):
                raise _Fallback(FallbackReason.NARROW_BAND,
                                f"a narrow band near {stab.speeds_kmh[i]:.1f} km/h, between grid speeds")
        return stab, ref

    def follow_fold(self, model, p, ref, j) -> BranchPoint:
        """Fold j of the reference followed from ``ref.p`` to ``p``.

        Each step (:func:`~polywear.solvers.continuation.fold_at`) solves the fold's defining
        system directly (:func:`~polywear.solvers.continuation.solve_fold`; where its Newton
        fails, :func:`~polywear.solvers.continuation.locate_fold`) from the last fold, its speed
        predicted by the exact gradient of the reference's fold speed for the first step,
        then by the secant through the last two folds; a step whose fold misses the
        prediction by more than the predicted change (plus 1e-3 of the speed: the error of
        a first-order prediction is of second order) is halved, a good one doubled.
        """
        direction = _difference(p, ref.p)
        fold, scales = ref.folds[j], ref.scales[j]
        slope = float(ref.fold_gradients[j] @ direction)  # dV/dtheta [m/s]
        theta, h, halvings = 0.0, 1.0, 0
        while theta < 1.0:
            nxt = min(1.0, theta + h)
            V_pred = fold.orbit.speed + (nxt - theta) * slope
            new = fold_at(model, fold, ref.p + theta * direction, ref.p + nxt * direction, V_pred, scales,
                          self.settings, ref.fold_curvatures[j], self.fold_newton, self.fold_tangent)
            change = abs(V_pred - fold.orbit.speed)
            if new is None or abs(new.orbit.speed - V_pred) > change + 1e-3 * fold.orbit.speed:
                halvings += 1
                if halvings > self.max_halvings:
                    raise _Fallback(FallbackReason.FOLD_NOT_FOLLOWED, f"fold {j + 1} not followed to this sample (step halved {self.max_halvings} times)")
                h *= 0.5
                continue
            slope = (new.orbit.speed - fold.orbit.speed) / (nxt - theta)
            fold, theta, h = new, nxt, 2.0 * h
        if self.adapt_mesh:
            fold = solve_fold(model, p, on_adapted_mesh(model, p, fold), fold.orbit.speed, scales, self.settings,
                              self.fold_newton)
            if fold is None:
                raise _Fallback(FallbackReason.FOLD_NOT_FOLLOWED, f"fold {j + 1} lost after mesh adaptation")
        return fold

    def _along_branch(self, model, p, ref, stab, fold_points, labels, interval, V) -> BranchPoint | None:
        """A stable cycle at speed V [m/s] on the sample's branch from the end of its stable
        ``interval`` [km/h] (with the reference's ``labels``) nearest to V: from a Hopf end the
        branch born there, from a fold end either side of it (the stable one). None if not found."""
        ends = [(abs(ms_to_kmh(V) - v), label) for v, label in zip(interval, labels) if label[0] in ("H", "F")]
        if not ends:
            return None
        kind, j = min(ends)[1]
        if kind == "H":
            from ..dynamics.bifurcation import branch_start

            return cycle_along_branch(model, p, branch_start(stab.hopf_points[j]), V, self.settings)
        # first step from V - V_F = curvature s^2 / 2 (the reference's curvature), within the branches' steps
        fold = fold_points[j]
        s = np.sqrt(2.0 * abs((V - fold.orbit.speed) / ref.fold_curvatures[j]))
        first = float(np.clip(s, self.settings.ds_initial, self.settings.ds_max)) if np.isfinite(s) else None
        for reverse in (False, True):
            point = cycle_along_branch(model, p, fold, V, self.settings, ref.scales[j], reverse, first_step=first)
            if point is not None and point.stable:
                return point
        return None

    def _fast(self, model, params, p, ref, stab) -> Band:
        if ref.band.amplitude_speeds_kmh != tuple(float(v) for v in self.amplitude_speeds_kmh):
            raise ValueError(f"amplitude speeds {self.amplitude_speeds_kmh} differ from the reference's "
                             f"{ref.band.amplitude_speeds_kmh}")
        lo, hi = self.speed_range_kmh
        hopf = tuple(h.speed_kmh for h in stab.hopf_points)
        ix = model.index("x")
        folds, fold_amp, fold_points = [], [], []
        for j, ref_amp in enumerate(ref.band.fold_amplitude_x_m):
            point = self.follow_fold(model, p, ref, j)
            amplitude = float(point.orbit.amplitude()[ix])
            if amplitude < self.min_fold_amplitude * ref_amp:
                raise _Fallback(FallbackReason.FOLD_AMPLITUDE, f"fold {j + 1}: amplitude {amplitude:.3g} m, below "
                                f"{self.min_fold_amplitude} of the reference's (Bautin point near?)")
            V = ms_to_kmh(point.orbit.speed)
            if not lo < V < hi:
                raise _Fallback(FallbackReason.FOLD_OUT_OF_RANGE, f"fold {j + 1} at {V:.2f} km/h, outside the speed range")
            folds.append(V)
            fold_amp.append(amplitude)
            fold_points.append(point)
        order = lambda hs, fs: [k for _, k in sorted([(v, ("H", i)) for i, v in enumerate(hs)]
                                                     + [(v, ("F", i)) for i, v in enumerate(fs)])]
        if order(hopf, folds) != order(ref.band.hopf_kmh, ref.band.folds_kmh):
            raise _Fallback(FallbackReason.ORDER_CHANGED, "the order of Hopf and fold speeds differs from the reference's")
        speed_of = {("H", k): v for k, v in enumerate(hopf)} | {("F", k): v for k, v in enumerate(folds)}
        speed_of |= {("lo", 0): lo, ("hi", 0): hi}

        def mapped(labels):
            return tuple((speed_of[a], speed_of[b]) for a, b in labels)

        stable = mapped(ref.stable_labels)
        amplitudes = []
        ref_stable = tuple((ref.band_speed(a), ref.band_speed(b)) for a, b in ref.stable_labels)
        for v, guess in zip(self.amplitude_speeds_kmh, ref.cycles):
            k = next((i for i, (a, b) in enumerate(stable) if a <= v <= b), None)
            if k is None:
                amplitudes.append(0.0)
                continue
            V = kmh_to_ms(v)
            point = None
            if guess is not None:
                # the guess rescaled by the square-root law of the nearest Hopf end (ratio ~ 1 far
                # from it; near it Newton from the reference's tiny cycle fails), else as it is
                scaled = _rescaled(model, ref.p, p, guess, V, ref.stable_labels[k], ref_stable[k], stable[k], v)
                point = None if scaled is None else solve_at_speed(model, p, scaled, V, self.settings)
                if point is None:
                    point = solve_at_speed(model, p, recentred(model, guess, ref.p, p, V), V, self.settings)
            if point is None or not point.stable:
                # no reference cycle there (its interval ends on the other side of v), Newton
                # failed or landed on an unstable cycle: along the sample's own branch
                point = self._along_branch(model, p, ref, stab, fold_points, ref.stable_labels[k], stable[k], V)
            if point is not None and point.stable:  # on its own mesh, kinks on mesh points, as the continuation's
                point = solve_at_speed_on_kinks(model, p, point, self.settings)
            if point is None or not point.stable:
                raise _Fallback(FallbackReason.AMPLITUDE_CYCLE, f"stable cycle at {v:g} km/h found neither from the "
                                "reference's nor along the branch from the nearest end of its stable interval")
            amplitudes.append(float(point.orbit.amplitude()[ix]))
        return Band(
            hopf_kmh=hopf,
            hopf_criticality=tuple(h.criticality for h in stab.hopf_points),
            folds_kmh=tuple(folds),
            fold_amplitude_x_m=tuple(fold_amp),
            linear_band_kmh=tuple(tuple(b) for b in stab.linear_band_kmh),
            sev_band_kmh=mapped(ref.sev_labels),
            hard_regions_kmh=mapped(ref.hard_labels),
            amplitude_speeds_kmh=tuple(self.amplitude_speeds_kmh),
            amplitude_x_m=tuple(amplitudes),
            path=BandPath.FAST,
        )
