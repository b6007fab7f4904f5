"""What stops polygonal wear: the least parameter change that keeps every polygon order
from growing over the drive cycle, or pushes the visible-polygon distance beyond a target.

Criterion (linear wear map, exact and fast; :mod:`polywear.wear.criterion` judges one car,
by the map or by the evolution). On a drive cycle the one profile is worn at
every speed in turn, so harmonic n changes per km at the share-weighted complex rate
``lambda_n = sum_i share_i ln(1 + dW_n/W_n)(V_i) * revolutions per km``. "Every order
stable" asks ``max_n Re lambda_n <= 0``. A target distance D asks that the seeded
roughness grown as ``W_n exp(lambda_n D)`` (the linear evolution, which the nonlinear
one follows to 0.05 % while rolling is stable) stays below the visible peak-to-valley
depth. The map applies only where steady rolling is stable: an option must also leave
every cycle speed outside the linear band (where the tread vibrates).

Search (:func:`polywear.dynamics.least_change.least_factor`). Per parameter and per
direction (more and less of it), multiplicative steps ``p0 * f`` on a geometric grid up
to ``max_factor``; the first step that meets the criterion is refined by bisection in
``ln f`` to 1 %. Parameter handling (keys,
``adhesion_scale``, categories) is that of :mod:`polywear.dynamics.design`.

Judged by the evolution (``Judge.EVOLUTION``, the default with a target distance when
the tread vibrates at a cycle speed, where the map does not apply). Every probe of the
search runs the nonlinear evolution (:func:`~polywear.wear.evolution.wear_evolution`) over the
target distance on the cycle; it meets the criterion when no polygon becomes visible
within it, vibrating or not. A probe's evolution stops as soon as its polygon is visible
(``until_visible``: a failing probe costs only the distance to it) and at a step budget
of :data:`PROBE_MAX_STEPS` and a work budget of :data:`PROBE_MAX_REVOLUTIONS` (a probe that
creeps in short steps, e.g. at the edge of locking, or needs the longest windows in every
step is *undecided*: not an option, listed in ``undecided``). The search
(:func:`_search_by_evolution`) goes by distance from the nominal car, level by level of a
geometric grid of :data:`EVOLUTION_GRID` steps to ``max_factor``: at each level every open
direction (more and less of each key) is probed, side by side (threads, or the
executor); after the first level, a direction whose largest change fails is closed (the
search assumes the criterion holds beyond the least change). A direction that meets the
criterion at a level is refined in ``ln f`` to :data:`EVOLUTION_REFINE`, two probes per key
and round, side by side: a trisection where only one direction of the key is open, one probe
at a third of each bracket where both are (the direction that meets sooner closes the
other); ``refine_rounds`` bounds the rounds; an undecided probe is no end of the bracket, and after
``max_undecided`` (:data:`MAX_UNDECIDED`) undecided probes the bracket stays as it is (its lower end, the
largest change whose polygon is visible, is kept in the option as ``below``). With
``least_only`` (the report) the search stops at the first level where a direction meets
it (the other directions fail there, so their least change is larger), and keys that an engineer does not set (adhesion) are searched only
where no alignment, bushing or tread key meets it. A probe where rolling is stable at
every cycle speed and the linear map alone makes the polygon ``CLEARLY_VISIBLE`` times
the visible depth fails without an evolution. Each option keeps the evolution at its
least change. A bracket is refined no further where the other direction of its key already
meets the criterion at a change no larger than the bracket's lower end (that direction's
least change is the key's). The refinement's probes are near the criterion by construction
and are judged with the full settings at once, also where a screen is given. ``max_levels``
stops the walk after that many grid levels and ``refine`` False skips the refinement (the
level's change is then the option, an upper bound of the least change); the report for
axle4dof searches one level and refines it by one round.

Screened (``WearDesignSettings.screen``, e.g. :data:`SCREEN`): every probe is judged first
by a cheaper evolution, and again with the full settings where the screened verdict is
undecided or within :data:`SCREEN_MARGIN` of the criterion; the least change of every key
and its bracket's other end (unrefined: every direction that meets it) are judged with the
full settings after the walk, and where one
of them changes its verdict the search walks again over the probes already made (so the
options' evolutions are those of the full settings).

Verification. Each option found by the map can be checked by the nonlinear evolution over
the target distance (:func:`verify_option`): the depth it reaches and whether the polygon
becomes visible, with the original parameters beside it.
"""

from __future__ import annotations

import itertools
import math
import os
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace

import numpy as np

from ..parallel import Executor
from ..progress import Progress

from ..models import model_for
from ..results import Result
from ..params import Params
from ..settings import check_count, check_positive
from ..dynamics.design import DEFAULT_KEYS, ENGINEERING, parameter_category, parameter_label
from ..dynamics.least_change import least_factor
from ..dynamics.sensitivity import nominal_value, parameter_direction, perturbed
from .criterion import (Judge, cycle_growth, cycle_rates, evolved_from, evolved_over,
                        linear_depth_mm, meets_criterion, outcome_text)
from .evolution import EvolutionResult, EvolutionSettings, wear_evolution

__all__ = ["Judge", "WearDesignOption", "WearDesignResult", "WearDesignSettings", "cycle_rates", "cycle_growth",
           "linear_depth_mm", "wear_design", "verify_option"]

_REFINE = 0.01
"""Relative accuracy of the least change [-]."""
EVOLUTION_GRID = 8
"""Grid steps per direction where the evolution judges (each probe is one evolution) [-]."""
EVOLUTION_REFINE = 0.02
"""Relative accuracy of the least change judged by the evolution [-] (its error-controlled
distance steps move the visible distance by about 1 %)."""
PROBE_MAX_STEPS = 40
"""Step budget of one probe's evolution [distance steps] beyond the fewest its distance
takes (:func:`~polywear.wear.evolution.step_budget`): the default car takes 17-30 steps
over 100 000 km; a probe that needs more is undecided [-]. Toe 0.53-0.547 deg on the
default cycle creeps in steps of about 10 km (toe 0.545 deg: 4 300 km in 500 steps, 66 s
CPU); a car just past its Hopf point (small vibration) can take about 90 steps and decide."""
PROBE_MAX_REVOLUTIONS = 10_000
"""Work budget of one probe's evolution [simulated revolutions, summed over its windows]
(``EvolutionSettings.max_revolutions``): decided probes of the default cars take 900-4 500
(tread1dof and axle4dof, 100 000 km on the default cycle); tread1dof at toe 0.54 deg,
vibrating at order 7.9993 at 120 km/h, needs windows of 1 024 revolutions in every step and
reached 98 km in 56 000 revolutions (73 s CPU) before its step budget stopped it: an
undecided probe now costs at most about a fifth of that [-]."""
MAX_UNDECIDED = 2
"""A bracket of the evolution search is refined no further after this many of its probes
were undecided, by default [-] (inside a creeping stretch most probes creep, each to the
budget: 4 of the 5 probes within toe 0.52-0.56 deg on the default cycle)."""
SCREEN = EvolutionSettings(tolerance=0.1, revolutions=6)
"""Cheaper evolution settings that screen the probes where ``WearDesignSettings.screen`` asks
for it (the report, axle4dof): a looser distance-step tolerance and the fewest revolutions
per window (docs/wear.md, "Cars that vibrate")."""
SCREEN_MARGIN = 0.25
"""A screened probe is judged again with the full settings where its verdict is this close
to the criterion: its polygon visible beyond ``1 - SCREEN_MARGIN`` of the target distance,
or its depth at the target above ``1 - SCREEN_MARGIN`` of the visible depth [-]."""


@dataclass(frozen=True)
class WearDesignSettings:
    """Numerical settings of :func:`wear_design` (``polywear wear design --max-factor, --judge``)."""

    max_factor: float = 4.0
    """Largest change searched: ``p0 * f`` or ``p0 / f`` [-] (> 1, finite)."""
    grid: int = 24
    """Grid steps per direction where the map judges [-] (integer >= 1; the evolution
    takes :data:`EVOLUTION_GRID`)."""
    judge: Judge = Judge.AUTO
    """What judges an option (:class:`Judge`; its text is accepted too)."""
    evolution: EvolutionSettings = EvolutionSettings()
    """Settings of the evolutions where the evolution judges."""
    least_only: bool = False
    """Where the evolution judges: only the least change (the report): stop at the first grid
    level where a direction meets the criterion, and search adhesion only where no key an
    engineer sets meets it. False: the least change of every key."""
    threads: int | None = None
    """Threads that run the probes of one level side by side where the evolution judges and
    no executor is given [-] (default: the CPU count; each probe's evolution runs its cycle
    speeds' windows in threads of its own too, except with 1: all in one thread; the result
    does not depend on it)."""
    max_undecided: int = MAX_UNDECIDED
    """Where the evolution judges: a bracket is refined no further after this many of its
    probes were undecided [-] (integer >= 1; the report takes 1)."""
    max_levels: int | None = None
    """Where the evolution judges: grid levels searched at most [-] (integer >= 1; None: all
    :data:`EVOLUTION_GRID`); a direction that meets the criterion at none of them gets a note
    that the search stopped there."""
    refine: bool = True
    """Where the evolution judges: refine the bracket of a direction that meets the criterion
    to :data:`EVOLUTION_REFINE` (module notes; ``refine_rounds`` bounds it). False: the least
    change is the grid level where it first meets it."""
    refine_rounds: int | None = None
    """Where the evolution judges and ``refine``: rounds of the refinement at most (each round
    two probes per key, side by side) [-] (integer >= 1; None: until every bracket is
    :data:`EVOLUTION_REFINE` wide). One round leaves a bracket a third or two thirds of a
    grid step wide (the report for axle4dof)."""
    screen: EvolutionSettings | None = None
    """Where the evolution judges: cheaper settings (e.g. :data:`SCREEN`) that judge every
    probe first; a probe whose screened verdict is undecided or near the criterion
    (:data:`SCREEN_MARGIN`) is judged again with ``evolution``, and so are the least change
    of every key and its bracket's other end (the search walks again where one of them
    changes its verdict). None: every probe with ``evolution``."""

    def __post_init__(self) -> None:
        check_positive(self, "max_factor")
        if not self.max_factor > 1.0:
            raise ValueError(f"WearDesignSettings: max_factor = {self.max_factor!r}: must be above 1")
        check_count(self, "grid")
        for name in ("least_only", "refine"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"WearDesignSettings: {name} = {getattr(self, name)!r}: must be True or False")
        for name in ("max_levels", "refine_rounds"):
            if getattr(self, name) is not None:
                check_count(self, name)
        if self.refine_rounds is not None and not self.refine:
            raise ValueError(f"WearDesignSettings: refine_rounds = {self.refine_rounds!r} with refine = False: "
                             "no rounds without the refinement")
        if self.threads is not None:
            check_count(self, "threads")
        check_count(self, "max_undecided")
        if self.judge not in tuple(Judge):
            raise ValueError(f"WearDesignSettings: judge = {self.judge!r}: must be one of "
                             f"{', '.join(j.value for j in Judge)}")
        object.__setattr__(self, "judge", Judge(self.judge))  # the member, where its text was given
        for name in ("evolution", "screen"):
            if not isinstance(getattr(self, name), EvolutionSettings) and (name, getattr(self, name)) != ("screen", None):
                raise ValueError(f"WearDesignSettings: {name} = {getattr(self, name)!r}: must be an EvolutionSettings")


@dataclass
class WearDesignOption:
    key: str
    label: str
    category: str
    nominal: float
    value: float
    relative_change: float
    growth_per_1000km: float
    """max_n of the share-weighted growth with the change [e-folds per 1000 km] (inf: the
    tread vibrates at a cycle speed)"""
    order: int
    """fastest-growing order of the map, or the dominant order of the evolution where it judged"""
    verification: dict | None = None
    evolution: dict | None = None
    """where the evolution judged: ``{"distance_km", "depth_mm", "visible_km", "dominant_order"}``
    at the least change"""
    below: dict | None = None
    """where the evolution judged: the largest change below the least one whose probe shows a
    visible polygon within the target (the search's bracket): ``{"value", "relative_change",
    "visible_km"}``; None: the nominal car (its evolution is the result's)"""
    other_direction: dict | None = None
    """where the evolution judged without refining (``WearDesignSettings.refine`` False): the
    other direction of the same key where it meets the criterion too, not refined either:
    ``{"value", "relative_change", "evolution"}`` (its evolution with the full settings)"""

    def summary(self) -> dict:
        return dict(self.__dict__) | {"growth_per_1000km": _finite(self.growth_per_1000km)}


@dataclass
class WearDesignResult(Result):
    params: Params
    cycle: tuple
    target_km: float | None
    nominal_depth_at_target_mm: float | None
    """linear estimate of the nominal depth at the target distance [mm]"""
    nominal_growth_per_1000km: float
    nominal_order: int
    nominal_rolling_stable: bool
    options: list[WearDesignOption]
    not_found: list[str] = field(default_factory=list)
    judge: Judge = Judge.MAP
    """The judge used: ``Judge.MAP`` or ``Judge.EVOLUTION`` (``AUTO`` resolved)"""
    nominal_evolution: dict | None = None
    """where the evolution judged: the nominal car's (as :attr:`WearDesignOption.evolution`)"""
    undecided: list[dict] = field(default_factory=list)
    """where the evolution judged: the probes whose evolution stopped at its step or work budget
    (:data:`PROBE_MAX_STEPS`), counted as not meeting the criterion: ``{"key", "value",
    "relative_change", "at_km"}``"""
    evolutions: int = 0
    """where the evolution judged: the evolutions run by the search (the nominal car's not counted)"""
    settings: WearDesignSettings = WearDesignSettings()
    """The settings of the search (``judge`` as given: ``AUTO`` stays ``AUTO``)"""

    def summary(self) -> dict:
        return {
            "model": self.params.model,
            "cycle": [{"speed_kmh": v, "share": s} for v, s in self.cycle],
            "target_km": self.target_km,
            "judge": self.judge,
            "criterion": "every order stable over the cycle" if self.target_km is None else
            f"visible polygon beyond {self.target_km:g} km (" +
            ("nonlinear evolution" if self.judge == Judge.EVOLUTION else "linear evolution") + ")",
            "nominal_evolution": self.nominal_evolution,
            "nominal_depth_at_target_mm": _finite(self.nominal_depth_at_target_mm)
            if self.nominal_depth_at_target_mm is not None else None,
            "nominal": {"growth_per_1000km": _finite(self.nominal_growth_per_1000km), "order": self.nominal_order,
                        "rolling_stable_at_every_cycle_speed": self.nominal_rolling_stable},
            "options": [o.summary() for o in self.options],
            "not_found": self.not_found,
            "undecided": self.undecided,
            "evolutions": self.evolutions,
            "least_only": self.settings.least_only,
            "refined": self.settings.refine,
            "refine_rounds": self.settings.refine_rounds if self.settings.refine else 0,
            "distances_scale_as": "1/k_e",
        }

    def to_dataframe(self):
        """pandas DataFrame: one row per option (its summary)."""
        import pandas as pd

        return pd.DataFrame([o.summary() for o in self.options], columns=list(WearDesignOption.__dataclass_fields__))

    def _dataset(self):
        """The options table along ``row``."""
        return self._table_dataset()

    def plot(self, ax=None):
        """Share-weighted growth [e-folds per 1000 km] of each option against the nominal one. Returns artists."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(7, 3.5))
        labels = [f"{o.label} {o.relative_change * 100:+.0f} %" for o in self.options]
        growth = [o.growth_per_1000km if math.isfinite(o.growth_per_1000km) else np.nan for o in self.options]
        bars = ax.barh(range(len(labels)), growth, color="tab:blue")
        artists = [bars, ax.axvline(self.nominal_growth_per_1000km, color="tab:red", ls="--", label="nominal"),
                   ax.axvline(0.0, color="k", lw=0.8)]
        ax.set_yticks(range(len(labels)), labels, fontsize=8)
        ax.invert_yaxis()
        ax.set_xlabel("largest growth over the cycle [e-folds per 1000 km]")
        ax.legend(fontsize=8)
        return artists


def _finite(x: float):
    return x if math.isfinite(x) else None


@dataclass(frozen=True)
class _KeySearch:
    """The least change of one key judged by the map (a picklable task of :func:`wear_design`):
    its :class:`WearDesignOption`, or the note why there is none."""

    params: Params
    cycle: tuple
    target_km: float | None
    max_factor: float
    grid: int

    def __call__(self, key: str) -> WearDesignOption | str:
        nominal = nominal_value(self.params, key)

        def meets(factor: float):
            hit = meets_criterion(self.params, key, nominal, factor, self.cycle, self.target_km)
            return hit if hit is not None and hit[0] else None

        best = least_factor(meets, self.max_factor, self.grid, _REFINE)
        if best is None:
            return f"{key}: no change within x{self.max_factor:g} meets the criterion"
        factor, (_, g, order, _) = best
        return _option(key, nominal, factor, g, order)


def _option(key: str, nominal: float, factor: float, growth: float, order: int, evolved: dict | None = None,
            below: dict | None = None, other_direction: dict | None = None) -> WearDesignOption:
    return WearDesignOption(
        key=key, label=parameter_label(key), category=parameter_category(key), nominal=nominal,
        value=nominal * factor, relative_change=factor - 1.0, growth_per_1000km=growth, order=order,
        evolution=evolved, below=below, other_direction=other_direction)


@dataclass(frozen=True)
class _Probe:
    """One probe of the evolution search (a picklable task): :func:`~.criterion.meets_criterion` judged by the
    evolution with ``(key, nominal value, factor, full)``, its windows in ``workers`` threads
    (:func:`~polywear.wear.evolution.wear_evolution`; None: one per cycle speed, which fills
    the cores a round's last probes leave idle; the result is the same); with ``screen`` and
    not ``full``, judged by the screen first and again with ``settings`` where the screen is
    not clear (:func:`_screen_clear`). Returns (its answer, evolutions run,
    whether judged with ``settings``)."""

    params: Params
    cycle: tuple
    target_km: float
    settings: EvolutionSettings
    screen: EvolutionSettings | None = None
    workers: int | None = 1

    def __call__(self, job: tuple[str, float, float, bool]):
        key, nominal, factor, full = job
        runs = 0
        if self.screen is not None and not full:
            out = meets_criterion(self.params, key, nominal, factor, self.cycle, self.target_km, Judge.EVOLUTION,
                         self.screen, workers=self.workers)
            runs += out is not None and out[3] is not None
            if _screen_clear(out, self.target_km, self.params.wear.visible_depth_mm):
                return out, runs, out is None or out[3] is None  # no evolution: the same with any settings
        out = meets_criterion(self.params, key, nominal, factor, self.cycle, self.target_km, Judge.EVOLUTION,
                     self.settings, workers=self.workers)
        return out, runs + (out is not None and out[3] is not None), True


def _screen_clear(out, target_km: float, visible_mm: float) -> bool:
    """Whether a screened probe's verdict stands (module notes): decided without an evolution,
    or its polygon visible before ``(1 - SCREEN_MARGIN)`` of the target, or none visible and
    the depth at the target below ``(1 - SCREEN_MARGIN)`` of the visible depth."""
    if out is None or out[3] is None:
        return True
    evolved = out[3]
    if evolved.get("undecided"):
        return False
    if evolved["visible_km"] is not None:
        return evolved["visible_km"] < (1.0 - SCREEN_MARGIN) * target_km
    return evolved["depth_mm"] < (1.0 - SCREEN_MARGIN) * visible_mm


def _search_by_evolution(params: Params, keys: Sequence[str], cycle, target_km: float,
                         settings: WearDesignSettings, executor: Executor | None,
                         progress: Progress | None) -> tuple[dict, list[dict], int]:
    """The least change of ``keys`` judged by the evolution (module notes): ({key: its
    :class:`WearDesignOption` or the note why there is none}, the undecided probes, the
    evolutions run)."""
    def budgeted(evolution: EvolutionSettings) -> EvolutionSettings:
        return replace(evolution, until_visible=True, max_steps=min(evolution.max_steps, PROBE_MAX_STEPS),
                       max_revolutions=min(evolution.max_revolutions or PROBE_MAX_REVOLUTIONS, PROBE_MAX_REVOLUTIONS))

    probe = _Probe(params, cycle, target_km, budgeted(settings.evolution),
                   None if settings.screen is None else budgeted(settings.screen),
                   workers=1 if executor is not None or settings.threads == 1 else None)
    nominal = {key: nominal_value(params, key) for key in keys}
    cache: dict[tuple[str, float], tuple | None] = {}
    full: set[tuple[str, float]] = set()  # the probes judged with settings.evolution
    runs = [0]
    threads = settings.threads or os.cpu_count() or 1

    def run(points: list[tuple[str, float]], confirm: bool = False) -> list:
        """The probes at (key, |ln f| with its sign), side by side; cached (``confirm``: judged
        with the full settings where they were screened)."""
        todo = list(dict.fromkeys(p for p in points if p not in cache or (confirm and p not in full)))
        jobs = [(key, nominal[key], math.exp(x), confirm) for key, x in todo]
        if executor is not None:
            outs = executor.map(probe, jobs)
        elif threads > 1 and len(jobs) > 1:
            with ThreadPoolExecutor(min(threads, len(jobs))) as pool:
                outs = list(pool.map(probe, jobs))
        else:
            outs = [probe(job) for job in jobs]
        for (key, x), (out, ran, judged_full) in zip(todo, outs):
            cache[key, x] = out
            runs[0] += ran
            if judged_full:
                full.add((key, x))
            if progress is not None and out is not None and out[3] is not None:
                progress(len(cache), None, f"{key} = {nominal[key] * math.exp(x):.4g}: {outcome_text(out[3])}"
                         + ("" if judged_full else " (screened)"))
        return [cache[p] for p in points]

    def ok(out) -> bool:
        return out is not None and out[0]

    def failed(out) -> bool:  # decided: not met and not undecided
        return not ok(out) and not (out is not None and out[3] is not None and out[3].get("undecided"))

    def least(found: dict, key: str):
        """(|ln f| that meets, sign, |ln f| that fails) of the key's least change, or None."""
        return min(((hi, s, lo) for (k, s), (lo, hi) in found.items() if k == key), default=None)

    top = math.log(settings.max_factor)
    levels = np.linspace(0.0, top, EVOLUTION_GRID + 1)[1:][:settings.max_levels]
    engineering = [k for k in keys if parameter_category(k) in ENGINEERING]
    tiers = [engineering, [k for k in keys if k not in engineering]] if settings.least_only else [list(keys)]

    def walk() -> tuple[dict, dict]:
        """The search over the cached probes (running those not yet cached): ({direction:
        (|ln f| that fails, that meets)}, {direction: the note why it has no bracket})."""
        found: dict[tuple[str, int], tuple[float, float]] = {}
        notes: dict[tuple[str, int], str] = {}
        for tier in tiers:
            if settings.least_only and found:
                notes.update({(key, s): "not searched (a change of a key an engineer sets meets the criterion)"
                              for key in tier for s in (1, -1)})
                continue
            open_ = [(key, s) for key in tier for s in (1, -1)]
            failed_at = dict.fromkeys(open_, 0.0)  # |ln f| of the largest change that failed
            for i, level in enumerate(levels):
                if not open_:
                    break
                outs = run([(key, s * level) for key, s in open_])
                met = [d for d, out in zip(open_, outs) if ok(out)]
                for d, out in zip(open_, outs):
                    if failed(out):
                        failed_at[d] = level
                for d in met:
                    found[d] = (failed_at[d], level)
                open_ = [d for d in open_ if d not in met]
                if met and settings.least_only:
                    notes.update({d: f"{_signed(d[1] * level)} does not meet the criterion, a change of another "
                                     "key no larger does (not searched further)" for d in open_})
                    break
                if i == 0 and len(levels) > 1 and levels[-1] == top and open_:  # the largest change closes
                    outs = run([(key, s * top) for key, s in open_])  # a direction that fails there
                    for d, out in zip(list(open_), outs):
                        if not ok(out):
                            open_.remove(d)
                            notes[d] = (f"no change within x{settings.max_factor:g} meets the criterion"
                                        if failed(out) else
                                        f"the largest change (x{settings.max_factor:g}) is undecided (not searched)")
            else:  # every level searched: the open directions stopped at settings.max_levels
                for key, s in open_:
                    notes[key, s] = (f"{_signed(s * levels[-1])} "
                                     + ("does not meet the criterion" if failed(cache[key, s * levels[-1]])
                                        else "is undecided")
                                     + f"; the search stopped there ({len(levels)} grid level"
                                     + ("s" if len(levels) > 1 else "") + ", WearDesignSettings.max_levels)")
        if not settings.refine:
            return found, notes
        # the brackets refined side by side, two probes per key and round: trisection of a
        # bracket whose key has no other open, one probe at a third of each where both
        # directions of a key are open (the one that meets sooner closes the other); an
        # undecided probe is no end of a bracket, a bracket is refined no further after
        # settings.max_undecided of its probes were undecided, nor where the other direction of
        # its key already meets the criterion at a change no larger than the bracket's lower end
        undecided_in = dict.fromkeys(found, 0)
        for _ in itertools.islice(itertools.count(), settings.refine_rounds):  # None: unbounded
            open_ = [d for d, (lo, hi) in found.items() if hi - lo > EVOLUTION_REFINE
                     and undecided_in[d] < settings.max_undecided and found.get((d[0], -d[1]), (0.0, math.inf))[1] > lo]
            rounds = {}
            for key, s in open_:
                lo, hi = found[key, s]
                rounds[key, s] = [lo + (hi - lo) * j / 3.0 for j in ((1,) if (key, -s) in open_ else (1, 2))]
            if not rounds:
                break
            # near the criterion by construction: judged with the full settings at once (a screen
            # would judge most of them twice)
            outs = iter(run([(key, s * x) for (key, s), xs in rounds.items() for x in xs], confirm=True))
            for d, xs in rounds.items():
                lo, hi = found[d]
                got = [next(outs) for _ in xs]
                undecided_in[d] += sum(not ok(out) and not failed(out) for out in got)
                j = next((i for i, out in enumerate(got) if ok(out)), len(xs))
                found[d] = (max([x for x, out in zip(xs[:j], got[:j]) if failed(out)], default=lo),
                            xs[j] if j < len(xs) else hi)
        return found, notes

    while True:  # with a screen: the least change of every key and its other end judged with the full settings
        found, notes = walk()
        ends = [(key, s * x) for key in keys if (best := least(found, key)) is not None
                for x, s in ((best[0], best[1]), (best[2], best[1])) if x > 0.0 and (key, s * x) not in full]
        if not settings.refine:  # unrefined, every direction that meets is an option's or its other direction
            ends += [(key, s * hi) for (key, s), (_, hi) in found.items() if (key, s * hi) not in full]
        if not ends:
            break
        run(ends, confirm=True)
    by_key: dict[str, WearDesignOption | str] = {}
    for key in keys:
        best = least(found, key)
        if best is None:
            up, down = notes[key, 1], notes[key, -1]
            by_key[key] = f"{key}: {up}" if up == down else f"{key}: more: {up}; less: {down}"
            continue
        hi, s, lo = best
        _, g, order, evolved = cache[key, s * hi]
        below = cache[key, s * lo] if lo > 0.0 else None
        other = found.get((key, -s)) if not settings.refine else None
        by_key[key] = _option(key, nominal[key], math.exp(s * hi), g, order, evolved, None if below is None else {
            "value": nominal[key] * math.exp(s * lo), "relative_change": math.expm1(s * lo),
            "visible_km": below[3]["visible_km"] if below is not None and below[3] is not None else None},
            None if other is None else {"value": nominal[key] * math.exp(-s * other[1]),
                                        "relative_change": math.expm1(-s * other[1]),
                                        "evolution": cache[key, -s * other[1]][3]})
    undecided = [{"key": key, "value": nominal[key] * math.exp(x), "relative_change": math.expm1(x),
                  "at_km": out[3]["distance_km"]}
                 for (key, x), out in cache.items() if out is not None and out[3] is not None and out[3].get("undecided")]
    return by_key, undecided, runs[0]


def _signed(x: float) -> str:
    """The change ``f = exp(x)`` in percent of the nominal value, with its sign."""
    return f"{math.expm1(x) * 100:+.0f} %"


def wear_design(params: Params, keys: Sequence[str] | None = None, target_km: float | None = None,
                cycle: Sequence[tuple[float, float]] | None = None,
                settings: WearDesignSettings = WearDesignSettings(),
                executor: Executor | None = None, progress: Progress | None = None,
                nominal: EvolutionResult | None = None) -> WearDesignResult:
    """Least relative change of each key (both directions) that meets the wear criterion.

    ``keys`` default :data:`polywear.dynamics.design.DEFAULT_KEYS` (those that enter the
    model); ``target_km``: visible-polygon distance to exceed [km] (None: every order
    stable); ``cycle``: ((speed [km/h], share), ...), default ``wear.cycle``; ``settings``
    (:class:`WearDesignSettings`): largest change, grid, judge, the evolutions' settings;
    ``executor`` (:class:`~polywear.parallel.Executor`, default in this process): where the
    map judges, where the keys are searched, one task per key; where the evolution judges,
    where the probes of one grid level or refinement round run, one task per probe (default:
    ``settings.threads`` threads); ``progress`` (:mod:`polywear.progress`) after every
    evolution (seconds each): ``(probes so far, None, "key = value: outcome")``;
    ``nominal``: the nominal car's evolution over ``target_km`` on ``cycle`` where it was
    already run (the report's), else it is run here where the evolution judges.
    """
    if not isinstance(settings, WearDesignSettings):
        raise TypeError(f"wear_design: settings = {settings!r}: a WearDesignSettings")
    judge = settings.judge
    if judge == Judge.EVOLUTION and target_km is None:
        raise ValueError("judge = 'evolution' needs a target distance")
    cycle = tuple(cycle) if cycle is not None else params.wear.cycle_shares()
    g0, order0, stable0 = cycle_growth(params, cycle)
    if judge == Judge.AUTO:
        judge = Judge.EVOLUTION if target_km is not None and not stable0 else Judge.MAP
    not_found = []
    model = model_for(params)
    depth0 = None if target_km is None else linear_depth_mm(params, target_km, cycle)
    nominal_evolution = None
    if judge == Judge.EVOLUTION:
        nominal_evolution = (evolved_over(params, target_km, cycle, settings.evolution) if nominal is None
                             else evolved_from(nominal, target_km, cycle))
        nominal_ok = nominal_evolution["visible_km"] is None
        if progress is not None:
            progress(0, None, f"nominal: {outcome_text(nominal_evolution)}")
    else:
        nominal_ok = stable0 and (g0 <= 0.0 if target_km is None else depth0 < params.wear.visible_depth_mm)
    if nominal_ok:
        not_found.append("no change needed: the nominal parameters already meet the criterion")
        keys = ()
    entries = []  # per key in order: the note why it is not searched, or the key to search
    for key in DEFAULT_KEYS if keys is None else keys:
        wear_key = key.startswith("tire.")  # the load coupling and the patch: every model
        if not wear_key and not np.any(parameter_direction(model, params, key)):
            if keys:
                entries.append(f"{key}: does not enter the {params.model} model")
        elif nominal_value(params, key) == 0.0:
            entries.append(f"{key}: nominal value 0 (no relative change)")
        else:
            entries.append((key,))
    searched = [e[0] for e in entries if isinstance(e, tuple)]
    undecided, evolutions = [], 0
    if judge == Judge.EVOLUTION:
        by_key, undecided, evolutions = _search_by_evolution(params, searched, cycle, target_km, settings, executor,
                                                             progress)
        found = iter([by_key[key] for key in searched])
    else:
        found = iter((executor or Executor("serial")).map(
            _KeySearch(params, cycle, target_km, settings.max_factor, settings.grid), searched))
    entries = [next(found) if isinstance(e, tuple) else e for e in entries]
    options = [o for o in entries if isinstance(o, WearDesignOption)]
    not_found += [o for o in entries if isinstance(o, str)]
    if target_km is None and not options and not nominal_ok:
        not_found.append("every order stable is out of reach while the tire damping c_z > 0: the high orders "
                         "grow slowly through it in this model (docs/wear.md); give a target distance instead")
    # what an engineer sets (alignment, bushings, tread) first, then road/compound; least change first
    options.sort(key=lambda o: (o.category not in ENGINEERING, abs(math.log1p(o.relative_change))))
    return WearDesignResult(params=params, cycle=cycle, target_km=target_km, nominal_depth_at_target_mm=depth0,
                            nominal_growth_per_1000km=g0, nominal_order=order0, nominal_rolling_stable=stable0,
                            options=options, not_found=not_found, judge=judge, nominal_evolution=nominal_evolution,
                            settings=settings, undecided=undecided, evolutions=evolutions)


def verify_option(params: Params, option: WearDesignOption, distance_km: float, cycle=None,
                  settings: EvolutionSettings = EvolutionSettings(step_km=5000.0)) -> dict:
    """Evolve the profile with the option (and without) over ``distance_km`` [km] with
    ``settings`` (:class:`~.wear_evolution.EvolutionSettings`, here 5000 km steps); stores and
    returns ``{"depth_mm", "visible_km", "nominal_depth_mm", "nominal_visible_km", "verified"}``."""
    cycle = tuple(cycle) if cycle is not None else params.wear.cycle_shares()
    changed = perturbed(params, option.key, option.value)
    with_option = wear_evolution(changed, distance_km, cycle, settings)
    nominal = wear_evolution(params, distance_km, cycle, settings)
    out = {
        "distance_km": distance_km,
        "depth_mm": float(with_option.depth_mm[-1]),
        "visible_km": with_option.visible_km,
        "nominal_depth_mm": float(nominal.depth_mm[-1]),
        "nominal_visible_km": nominal.visible_km,
        "verified": with_option.visible_km is None,
    }
    option.verification = out
    return out
