"""What stops polygonal wear: the least parameter change that keeps every polygon order
from growing over the drive cycle, or pushes the visible-polygon distance beyond a target.

Criterion (linear wear map, exact and fast). On a drive cycle the one profile is worn at
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
within it, vibrating or not. The same search on a coarser grid (:data:`EVOLUTION_GRID`
steps, bisection to :data:`EVOLUTION_REFINE`); a direction whose largest change
(``max_factor``) does not meet it is not searched further (the search assumes the criterion
holds beyond the least change). A probe where rolling is stable at every cycle speed and
the linear map alone makes the polygon :data:`CLEARLY_VISIBLE` times the visible depth
fails without an evolution. Each option keeps the evolution at its least change.

Verification. Each option found by the map can be checked by the nonlinear evolution over
the target distance (:func:`verify_option`): the depth it reaches and whether the polygon
becomes visible, with the original parameters beside it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from enum import StrEnum

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
from .evolution import EvolutionSettings, wear_evolution
from .map import wear_map

__all__ = ["Judge", "WearDesignOption", "WearDesignResult", "WearDesignSettings", "cycle_rates", "cycle_growth",
           "linear_depth_mm", "wear_design", "verify_option"]

_REFINE = 0.01
"""Relative accuracy of the least change [-]."""
EVOLUTION_GRID = 8
"""Grid steps per direction where the evolution judges (each probe is one evolution) [-]."""
EVOLUTION_REFINE = 0.02
"""Relative accuracy of the least change judged by the evolution [-] (its error-controlled
distance steps move the visible distance by about 1 %)."""
CLEARLY_VISIBLE = 2.0
"""A probe with stable rolling at every cycle speed whose linear-map depth at the target
exceeds this many visible depths fails without an evolution (the nonlinear evolution
follows the linear one while the profile is small) [-]."""


class Judge(StrEnum):
    """What judges a wear design option (the value is its text in JSON and on the command line)."""

    AUTO = "auto"
    """The evolution with a target distance where the nominal tread vibrates at a cycle
    speed, else the map (a result records the one it used)."""
    MAP = "map"
    """The linear wear map (exact while rolling is stable at every cycle speed)."""
    EVOLUTION = "evolution"
    """The nonlinear evolution over the target distance (every probe an evolution: minutes)."""


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

    def __post_init__(self) -> None:
        check_positive(self, "max_factor")
        if not self.max_factor > 1.0:
            raise ValueError(f"WearDesignSettings: max_factor = {self.max_factor!r}: must be above 1")
        check_count(self, "grid")
        if self.judge not in tuple(Judge):
            raise ValueError(f"WearDesignSettings: judge = {self.judge!r}: must be one of "
                             f"{', '.join(j.value for j in Judge)}")
        object.__setattr__(self, "judge", Judge(self.judge))  # the member, where its text was given
        if not isinstance(self.evolution, EvolutionSettings):
            raise ValueError(f"WearDesignSettings: evolution = {self.evolution!r}: must be an EvolutionSettings")


def cycle_rates(params: Params, cycle=None) -> np.ndarray | None:
    """Complex rate per km of every order over the cycle, ``sum_i share_i ln(1 + dW/W)_i``
    times revolutions per km (real part: growth, imaginary: turn); None if steady rolling
    is unstable at a cycle speed."""
    cycle = tuple(cycle) if cycle is not None else params.wear.cycle_shares()
    m = wear_map(params, [v for v, _ in cycle])
    if not m.rolling_stable.all():
        return None
    shares = np.array([s for _, s in cycle])
    return (shares @ np.log1p(m.relative_change)) * m.revolutions_per_km


def cycle_growth(params: Params, cycle=None) -> tuple[float, int, bool]:
    """(max_n g_n [e-folds per 1000 km], its order, every cycle speed rolling-stable)."""
    rates = cycle_rates(params, cycle)
    if rates is None:
        return math.inf, 0, False
    k = int(np.argmax(rates.real))
    return float(rates.real[k] * 1000.0), k + 1, True


def linear_depth_mm(params: Params, distance_km: float, cycle=None) -> float:
    """Peak-to-valley depth [mm] after ``distance_km`` of the seeded roughness grown by the
    linear map (exact while the profile is small and rolling stable; inf if it is not)."""
    from .evolution import initial_roughness, peak_to_valley

    rates = cycle_rates(params, cycle)
    if rates is None:
        return math.inf
    W = initial_roughness(params) * np.exp(rates * distance_km)
    return peak_to_valley(W, params.wear.profile_points) * 1e3


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


def _outcome(evolved: dict) -> str:
    """An evolution of :func:`_evolved` in words."""
    return ("no visible polygon" if evolved["visible_km"] is None
            else f"visible after {evolved['visible_km']:,.0f} km")


def _evolved(params: Params, target_km: float, cycle, settings: EvolutionSettings) -> dict:
    """The evolution over ``target_km`` [km] on ``cycle``: depth at its end [mm], visible
    distance [km] (None: not within it) and dominant order at its end."""
    worn = wear_evolution(params, target_km, cycle, settings)
    return {"distance_km": target_km, "depth_mm": float(worn.depth_mm[-1]), "visible_km": worn.visible_km,
            "dominant_order": int(worn.dominant_order[-1])}


def _meets(params: Params, key: str, nominal: float, factor: float, cycle, target_km: float | None,
           judge: Judge = Judge.MAP, settings: EvolutionSettings = EvolutionSettings()):
    """(criterion met, growth [e-folds per 1000 km], order, the evolution or None) with
    ``key`` at ``nominal * factor``; None where it cannot be evaluated."""
    try:
        changed = perturbed(params, key, nominal * factor)
    except ValueError:
        return None
    visible = params.wear.visible_depth_mm
    evolved = None
    try:
        g, order, stable = cycle_growth(changed, cycle)
        if target_km is None:
            ok = stable and g <= 0.0
        elif judge == "map":
            ok = stable and linear_depth_mm(changed, target_km, cycle) < visible
        elif stable and linear_depth_mm(changed, target_km, cycle) > CLEARLY_VISIBLE * visible:
            ok = False
        else:
            evolved = _evolved(changed, target_km, cycle, settings)
            ok = evolved["visible_km"] is None
            order = evolved["dominant_order"]
    except (ValueError, RuntimeError, ArithmeticError, np.linalg.LinAlgError):
        return None
    return ok, g, order, evolved


@dataclass(frozen=True)
class _KeySearch:
    """The least change of one key (a picklable task of :func:`wear_design`): its
    :class:`WearDesignOption`, or the note why there is none."""

    params: Params
    cycle: tuple
    target_km: float | None
    judge: Judge
    max_factor: float
    grid: int
    settings: EvolutionSettings
    progress: Progress | None = None
    """Called after every probe judged by an evolution (a serial search only)."""

    def __call__(self, key: str) -> WearDesignOption | str:
        nominal = nominal_value(self.params, key)
        cache: dict[float, tuple | None] = {}

        def probe(factor: float):
            if factor not in cache:
                cache[factor] = _meets(self.params, key, nominal, factor, self.cycle, self.target_km, self.judge,
                                       self.settings)
                evolved = cache[factor][3] if cache[factor] is not None else None
                if self.progress is not None and evolved is not None:
                    self.progress(len(cache), None, f"{key} = {nominal * factor:.4g}: {_outcome(evolved)}")
            return cache[factor]

        evolution = self.judge == "evolution"
        grid = EVOLUTION_GRID if evolution else self.grid
        refine = EVOLUTION_REFINE if evolution else _REFINE
        closed = set()  # directions (True: more) whose largest change fails: not searched
        if evolution:
            last = np.linspace(0.0, math.log(self.max_factor), grid + 1)[-1]  # the grid's last step, as least_factor's
            for up, extreme in ((True, float(np.exp(last))), (False, float(np.exp(-last)))):
                hit = probe(extreme)
                if hit is not None and not hit[0]:
                    closed.add(up)

        def meets(factor: float):
            if (factor > 1.0) in closed:
                return None
            hit = probe(factor)
            return hit if hit is not None and hit[0] else None

        best = least_factor(meets, self.max_factor, grid, refine)
        if best is None:
            return f"{key}: no change within x{self.max_factor:g} meets the criterion"
        factor, (_, g, order, evolved) = best
        return WearDesignOption(
            key=key, label=parameter_label(key), category=parameter_category(key), nominal=nominal,
            value=nominal * factor, relative_change=factor - 1.0, growth_per_1000km=g, order=order,
            evolution=evolved)


def wear_design(params: Params, keys: Sequence[str] | None = None, target_km: float | None = None,
                cycle: Sequence[tuple[float, float]] | None = None,
                settings: WearDesignSettings = WearDesignSettings(),
                executor: Executor | None = None, progress: Progress | None = None) -> WearDesignResult:
    """Least relative change of each key (both directions) that meets the wear criterion.

    ``keys`` default :data:`polywear.dynamics.design.DEFAULT_KEYS` (those that enter the
    model); ``target_km``: visible-polygon distance to exceed [km] (None: every order
    stable); ``cycle``: ((speed [km/h], share), ...), default ``wear.cycle``; ``settings``
    (:class:`WearDesignSettings`): largest change, grid, judge, the evolutions' settings;
    ``executor`` (:class:`~polywear.parallel.Executor`, default in this process): where the
    keys are searched, one task per key; ``progress`` (:mod:`polywear.progress`, without an
    executor only) after every evolution (seconds to minutes each): ``(probes of the key,
    None, "key = value: outcome")``.
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
        nominal_evolution = _evolved(params, target_km, cycle, settings.evolution)
        nominal_ok = nominal_evolution["visible_km"] is None
        if progress is not None:
            progress(0, None, f"nominal: {_outcome(nominal_evolution)}")
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
    search = _KeySearch(params, cycle, target_km, judge, settings.max_factor, settings.grid, settings.evolution,
                        progress if executor is None else None)
    found = iter((executor or Executor("serial")).map(search, [e[0] for e in entries if isinstance(e, tuple)]))
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
                            settings=settings)


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
