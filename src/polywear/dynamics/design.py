"""Design: parameter changes that move the SEV band out of an operating speed range.

The paper's section 6 strategies (Figs. 10-12) as a computation. For each parameter
(or a combination), the least change such that no speed of the operating range (widened
by a margin) lies in the SEV band: the first bifurcation speed rises above the range,
the second falls below it, or the band vanishes.

Method. Both directions of every parameter are searched (more and less of it), and the
least change that clears is kept. The search runs in log coordinates ``x = ln(p / p0)``
(absolute ``x = p`` where ``p0 = 0``), in which a power law ``V ∝ p^S`` of a band edge is
a straight line: toe, for example, moves the speeds of the tread model exactly as
``1 / sin(toe)``, which a linear estimate in ``p`` gets badly wrong when toe is reduced.
The exact normalized sensitivities ``S`` give the first estimate; a safeguarded secant
iteration on full bifurcation diagrams (continuation) then brackets the least change
that clears, to 1 % of the step (5 % beyond the bound) or to 0.5 km/h of the band
edge. Every reported option is a computed diagram. Combined changes move along
``dx ∝ S`` of the edge to move (the least change in the relative sense).

Options are ranked: the parameters an engineer sets (alignment, axle bushings, tread)
first, then road/compound options (friction), then the rest; within a group the ones
that clear within the allowed change first, then the least change. A change larger than
the bound is still searched (up to ``DesignSettings.search_factor``) and flagged
``within_bound = False``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from enum import StrEnum

import numpy as np

from ..models import model_for
from ..results import Result
from ..keys import ADHESION_SCALE, key_info
from ..params import Params
from ..progress import Progress, StepCounter
from ..settings import check_positive
from ..units import DEFAULT_SPEED_RANGE_KMH, ms_to_kmh
from .bifurcation import SPEED_CEILING_KMH, SPEED_FLOOR_KMH, bifurcation
from .diagram import BifurcationDiagram
from .stability import stability
from .sensitivity import (
    PARAMETER_LABELS,
    sensitivity,
    nominal_value,
    parameter_direction,
    perturbed,
)

__all__ = [
    "DEFAULT_KEYS",
    "DesignOption",
    "DesignOutcome",
    "DesignResult",
    "DesignSettings",
    "design",
    "default_operating_range",
    "parameter_category",
    "signed_percent",
]

ALIGNMENT_KEYS = ("operating.toe_deg", "operating.camber_deg")
BUSHING_KEYS = (
    "axle.toe_stiffness_nm_per_rad",
    "axle.toe_damping_nms_per_rad",
    "axle.camber_stiffness_nm_per_rad",
    "axle.camber_damping_nms_per_rad",
)
TREAD_KEYS = ("tread.lateral_stiffness_n_per_m", "tread.lateral_damping_ns_per_m")
ROAD_KEYS = (ADHESION_SCALE, "friction.mu_static")
DEFAULT_KEYS = ALIGNMENT_KEYS + BUSHING_KEYS + TREAD_KEYS + ROAD_KEYS
"""Searched by default: what an engineer sets, then adhesion as a road/compound option.
Keys that do not enter the model (camber, axle keys in tread1dof) are skipped."""

ENGINEERING = ("alignment", "axle bushing", "tread")
"""Categories of the parameters an engineer controls (ranked first)."""
_CATEGORY_RANK = {"alignment": 0, "axle bushing": 0, "tread": 0, "road/compound": 1, "other": 2}


def default_operating_range(speed_kmh: float) -> tuple[float, float]:
    """The speeds kept free of SEV when none are given: operating speed −30/+20 km/h."""
    return max(speed_kmh - 30.0, 1.0), speed_kmh + 20.0


def parameter_category(key: str) -> str:
    """'alignment', 'axle bushing', 'tread', 'road/compound' (friction) or 'other'."""
    if key in ALIGNMENT_KEYS:
        return "alignment"
    if key.startswith("axle.") and ("stiffness" in key or "damping" in key):
        return "axle bushing"
    if key in TREAD_KEYS:
        return "tread"
    if key == ADHESION_SCALE or key.startswith("friction."):
        return "road/compound"
    return "other"


def parameter_unit(key: str) -> str:
    """Unit of a configuration key ('deg', 'N/m', ...); '' if dimensionless (``adhesion_scale`` too)."""
    unit = key_info(key).unit
    return "" if unit == "-" else unit


def parameter_label(key: str) -> str:
    return PARAMETER_LABELS.get(key, key)


def _with_unit(key: str, value: float) -> str:
    """'0.22°', '80 N s/m', '×1.15' (a derived key: a factor), '0.6048'."""
    unit = parameter_unit(key)
    if key_info(key).kind == "derived":
        return f"×{value:.4g}"
    if unit == "deg":
        return f"{value:.4g}°"
    return f"{value:.4g} {unit}" if unit else f"{value:.4g}"


def signed_percent(r: float) -> str:
    """A relative change ``r`` [-] in percent with its sign, a true minus: '−55.4 %'."""
    return f"{'+' if r >= 0 else '−'}{abs(r) * 100:.1f} %"


class DesignOutcome(StrEnum):
    """Where an option that clears the operating range puts the SEV band (the value is its text)."""

    NOT_CLEARED = ""
    """The option does not clear the range (its ``note`` says why)."""
    VANISHES = "the band vanishes"
    ABOVE = "the band moves above the range"
    BELOW = "the band moves below the range"
    BOTH_SIDES = "bands remain on both sides of the range"


@dataclass
class DesignOption:
    """One way to clear the operating range: parameter values and the resulting band.

    ``achieved``: the range (widened by the margin) is free of SEV at ``values``;
    ``within_bound``: the largest relative change is within the allowed one.
    """

    keys: tuple[str, ...]
    nominal: tuple[float, ...]
    values: tuple[float, ...]
    achieved: bool
    sev_band_kmh: list
    within_bound: bool = True
    outcome: DesignOutcome = DesignOutcome.NOT_CLEARED
    diagram: BifurcationDiagram | None = field(default=None, repr=False)
    note: str = ""

    @property
    def relative_changes(self) -> tuple[float, ...]:
        """Signed ``value / nominal - 1`` per key (more of a negative camber is positive); the
        absolute change where the nominal is 0."""
        return tuple(v / n - 1.0 if n else v for v, n in zip(self.values, self.nominal))

    @property
    def relative_change(self) -> float:
        """Largest |relative change| over the keys."""
        return max(abs(r) for r in self.relative_changes)

    @property
    def category(self) -> str:
        """The least controllable category of the keys (a change needing the road counts as road)."""
        return max((parameter_category(k) for k in self.keys), key=_CATEGORY_RANK.__getitem__)

    def value_changes(self) -> list[str]:
        """Per key: '0.5° → 0.2228°'."""
        return [f"{_with_unit(k, n)} → {_with_unit(k, v)}"
                for k, n, v in zip(self.keys, self.nominal, self.values)]

    def change_text(self) -> str:
        """'toe angle 0.5° → 0.2228° (−55.4 %)', joined with ' + ' for combinations."""
        return " + ".join(f"{parameter_label(k)} {c} ({signed_percent(r)})"
                          for k, c, r in zip(self.keys, self.value_changes(), self.relative_changes))

    def text(self, max_relative_change: float | None = None) -> str:
        """One line: the signed change with units, the bound flag and what it does to the band."""
        if self.diagram is not None:
            band = self.diagram.band_text(self.sev_band_kmh) if self.sev_band_kmh else ""
        else:
            band = ", ".join(f"{a:.1f}-{b:.1f} km/h" for a, b in self.sev_band_kmh)
        after = f"SEV band {band}" if band else "no SEV band"
        if self.achieved:
            flag = "" if self.within_bound else (
                f", beyond the ±{max_relative_change * 100:g} % bound" if max_relative_change is not None else ", beyond the bound")
            return f"{self.change_text()}{flag}: clears the range, {self.outcome}" + (f" ({after})" if band else "")
        if self.values == self.nominal:  # nothing computed
            return f"{' + '.join(parameter_label(k) for k in self.keys)}: {self.note}"
        return f"{self.change_text()}: does not clear the range ({self.note}; {after})"

    def summary(self) -> dict:
        return {
            "params": list(self.keys),
            "labels": [parameter_label(k) for k in self.keys],
            "units": [parameter_unit(k) for k in self.keys],
            "category": self.category,
            "nominal": list(self.nominal),
            "values": list(self.values),
            "relative_changes": list(self.relative_changes),
            "relative_change": self.relative_change,
            "achieved": bool(self.achieved),
            "within_bound": bool(self.within_bound),
            "outcome": self.outcome,
            "sev_band_kmh": (self.diagram.open_bounds(self.sev_band_kmh) if self.diagram is not None
                             else [list(b) for b in self.sev_band_kmh]),
            "value_changes": self.value_changes(),
            "change": self.change_text(),
            "note": self.note,
        }


@dataclass
class DesignResult(Result):
    """Options to move the SEV band out of the operating range, ranked (see the module doc).

    ``reason`` says why there are no options (the range is already free of SEV).
    """

    params: Params
    operating_range_kmh: tuple[float, float]
    original: BifurcationDiagram
    options: list[DesignOption]
    max_relative_change: float = 0.5
    margin_kmh: float = 2.0
    reason: str = ""
    skipped: list[str] = field(default_factory=list)

    @property
    def best(self) -> DesignOption | None:
        """The first-ranked option that clears the range (None if none does)."""
        return next((o for o in self.options if o.achieved and o.diagram is not None), None)

    def summary(self) -> dict:
        return {
            "model": self.params.model,
            "operating_range_kmh": list(self.operating_range_kmh),
            "margin_kmh": self.margin_kmh,
            "max_relative_change": self.max_relative_change,
            "original_sev_band_kmh": self.original.open_bounds(self.original.sev_band_kmh),
            "reason": self.reason,
            "not_in_model": list(self.skipped),
            "options": [{**o.summary(), "text": o.text(self.max_relative_change)} for o in self.options],
            "lines": self.lines(),
        }

    def to_dataframe(self):
        """pandas DataFrame, one row per option and key (signed relative change, units, outcome)."""
        import pandas as pd

        rows = []
        for rank, o in enumerate(self.options, 1):
            for k, unit, n, v, r in zip(o.keys, (parameter_unit(k) for k in o.keys), o.nominal, o.values,
                                        o.relative_changes):
                rows.append({"rank": rank, "option": " + ".join(o.keys), "category": o.category, "param": k,
                             "unit": unit, "nominal": n, "value": v, "relative_change": r, "achieved": o.achieved,
                             "within_bound": o.within_bound, "outcome": o.outcome,
                             "sev_band_kmh": (o.diagram.band_text(o.sev_band_kmh) if o.diagram is not None and o.sev_band_kmh
                                              else "; ".join(f"{a:.3f}-{b:.3f}" for a, b in o.sev_band_kmh)),
                             "note": o.note})
        return pd.DataFrame(rows)

    table = to_dataframe  # the older name

    def _dataset(self):
        """The options table along ``row``."""
        return self._table_dataset()

    def lines(self) -> list[str]:
        """The result as text: the band now, then the options by group, ranked."""
        lo, hi = self.operating_range_kmh
        band = self.original.band_text()
        out = [f"SEV band now: {band}; operating range {lo:g}-{hi:g} km/h (kept clear by {self.margin_kmh:g} km/h)"]
        if self.reason:
            return out + [self.reason]
        groups = (
            ("Options you control (alignment, axle bushings, tread), least change first:", ENGINEERING),
            ("Road/compound options (tread-road friction: a compound or surface, not a vehicle setting):",
             ("road/compound",)),
            ("Other parameters:", ("other",)),
        )
        for heading, categories in groups:
            chosen = [o for o in self.options if o.category in categories]
            if chosen:
                out.append(heading)
                out += [f"  {o.text(self.max_relative_change)}" for o in chosen]
        if self.options and not any(o.achieved and o.within_bound for o in self.options):
            out.append(f"No option clears the range within a ±{self.max_relative_change * 100:g} % change; "
                       "the least changes that do are flagged 'beyond the bound'.")
        if self.skipped:
            out.append(f"Not in model {self.params.model}: {', '.join(self.skipped)}")
        return out

    def plot(self, ax=None, option: int = 0, state: str = "x"):
        """Original vs optimized bifurcation diagram (the paper's Figs. 10-12). Returns artists.

        ``option`` indexes the options that clear the range, in rank order.
        """
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(8, 4.5))
        artists = []
        lo, hi = self.operating_range_kmh
        artists.append(ax.axvspan(lo, hi, facecolor="none", edgecolor=(0.17, 0.63, 0.17, 0.45), hatch="//", lw=0.0,
                                  label=f"operating range {lo:g}-{hi:g} km/h"))
        speed = self.params.operating.speed_kmh
        artists.append(ax.axvline(speed, color="tab:green", lw=1.2, ls="-.", label=f"operating speed {speed:g} km/h"))
        i = self.original.state_names.index(state)
        artists += _amplitude_lines(ax, self.original, i, "tab:gray", "original")
        chosen = [o for o in self.options if o.achieved and o.diagram is not None]
        if chosen:
            best = chosen[min(option, len(chosen) - 1)]
            artists += _amplitude_lines(ax, best.diagram, i, "tab:blue", f"changed: {best.change_text()}")
        ax.set_title(f"{self.params.model}: keeping {lo:g}-{hi:g} km/h free of SEV"
                     + ("" if chosen else " (no option clears it)"), fontsize=10)
        ax.set_xlabel("speed [km/h]")
        ax.set_ylabel("amplitude of x [mm]" if state == "x" else f"amplitude of {state}")
        ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
        return artists


def _amplitude_lines(ax, diagram, i, color, label):
    artists = []
    scale = 1e3 if diagram.state_names[i] == "x" else 1.0
    first = True
    for b in range(len(diagram.branches)):
        pts = [c for c in diagram.cycles if c.branch == b]
        v = ms_to_kmh(np.array([c.speed_ms for c in pts]))
        a = np.array([c.amplitude[i] for c in pts]) * scale
        st = np.array([c.stable for c in pts])
        for mask, style, lw in ((st, "-", 1.8), (~st, "--", 1.2)):
            seg = mask | np.r_[mask[1:], False] | np.r_[False, mask[:-1]]  # joined at a stability change
            artists += ax.plot(v, np.where(seg, a, np.nan), style, color=color, lw=lw,
                               label=label if first and style == "-" else None)
        first = False
    if first:  # no cycles at all
        artists += ax.plot([], [], "-", color=color, label=f"{label} (no SEV)")
    return artists


# -- the search ---------------------------------------------------------------------------
def _gap(band, low: float, high: float) -> float | None:
    """How far (in ln speed) the band still has to move to leave ``[low, high]``.

    Positive while a band overlaps, the smaller of the two ways out (first edge up to
    ``high``, last edge down to ``low``); negative once clear, minus the distance to the
    nearest edge; None when there is no band at all.
    """
    over = [(a, b) for a, b in band if a < high and b > low]
    if over:
        a, b = min(a for a, _ in over), max(b for _, b in over)
        return min(math.log(high / a), math.log(b / low))
    if not band:
        return None
    above = [math.log(a / high) for a, _ in band if a >= high]
    below = [math.log(low / b) for _, b in band if b <= low]
    return -min(above + below)


def _outcome(band, low: float, high: float) -> DesignOutcome:
    if not band:
        return DesignOutcome.VANISHES
    if all(a >= high for a, _ in band):
        return DesignOutcome.ABOVE
    if all(b <= low for _, b in band):
        return DesignOutcome.BELOW
    return DesignOutcome.BOTH_SIDES


def _band_over_all_speeds(params: Params, option: DesignOption, low: float, high: float) -> None:
    """Before an option is said to make the band vanish: steady rolling at every speed from
    ``SPEED_FLOOR_KMH`` to ``SPEED_CEILING_KMH``. Where it has a Hopf point or is unstable
    outside the analysed range, the diagram over those speeds replaces the option's band,
    diagram and outcome (the band moved, it did not vanish)."""
    p = params
    for k, v in zip(option.keys, option.values):
        p = perturbed(p, k, v)
    whole = stability(p, (SPEED_FLOOR_KMH, SPEED_CEILING_KMH))
    speeds = [h.speed_kmh for h in whole.hopf_points] + [v for band in whole.linear_band_kmh for v in band]
    if not speeds:
        return
    diagram = bifurcation(p, (max(min(speeds) / 1.1, SPEED_FLOOR_KMH), min(max(speeds) * 1.1, SPEED_CEILING_KMH)))
    if not diagram.sev_band_kmh:
        return
    option.diagram, option.sev_band_kmh = diagram, diagram.sev_band_kmh
    option.outcome = _outcome(diagram.sev_band_kmh, low, high)


@dataclass
class _Search:
    """Everything one option search needs (one key or one combination)."""

    params: Params
    keys: tuple[str, ...]
    nominal: np.ndarray
    low: float  # the operating range widened by the margin [km/h]
    high: float
    max_relative_change: float
    search_factor: float  # values between p0 / factor and p0 * factor
    speed_range: tuple[float, float]
    step: StepCounter  # bifurcation diagrams computed
    max_evaluations: int = 8

    def values(self, x: np.ndarray) -> tuple[float, ...]:
        return tuple(float(n * math.exp(xi)) if n else float(xi) for n, xi in zip(self.nominal, x))

    def relative_change(self, x: np.ndarray) -> float:
        return max(abs(v / n - 1.0) if n else abs(v) for v, n in zip(self.values(x), self.nominal))

    def t_limit(self, d: np.ndarray, relative: float | None = None) -> float:
        """Largest step t along d within the search factor and, if given, every |relative change| <= relative."""
        t = math.inf
        for n, di in zip(self.nominal, d):
            if di == 0.0:
                continue
            if not n:  # absolute coordinate: the factor minus one, in the key's units
                t = min(t, (self.search_factor - 1.0 if relative is None else relative) / abs(di))
                continue
            t = min(t, math.log(self.search_factor) / abs(di))
            if relative is not None:
                x = math.log1p(relative) if di > 0 else -math.log1p(-min(relative, 1.0 - 1e-12))
                t = min(t, x / abs(di))
        return t

    def run(self, x: np.ndarray) -> tuple[DesignOption, float | None]:
        values = self.values(x)
        p = self.params
        for k, v in zip(self.keys, values):
            p = perturbed(p, k, v)  # ParameterError (a ValueError) outside the parameter rules
        option = DesignOption(self.keys, tuple(float(v) for v in self.nominal), values, False, [])
        self.step.begin(option.change_text())
        diagram = bifurcation(p, self.speed_range)
        self.step()
        band = diagram.sev_band_kmh
        g = _gap(band, self.low, self.high)
        lost = [info["at_speed_kmh"] for info in diagram.branch_info if info["failed"]]
        option.achieved = (g is None or g <= 0.0) and not lost
        if lost:  # cycles beyond a lost branch are unknown: a clear range cannot be confirmed
            option.note = (f"continuation failed (a cycle branch lost at {', '.join(f'{v:.1f}' for v in lost)} km/h), "
                           "so a clear range cannot be confirmed")
        option.sev_band_kmh = band
        option.diagram = diagram
        option.outcome = _outcome(band, self.low, self.high) if option.achieved else DesignOutcome.NOT_CLEARED
        option.within_bound = option.relative_change <= self.max_relative_change * (1 + 1e-9)
        return option, g

    def along(self, d: np.ndarray, g0: float, t_start: float, t_max: float):
        """Least step t > 0 along ``d`` that clears: (option that clears or None, last failure or None)."""
        fail_t, fail_g = 0.0, g0
        fails = [(0.0, g0)]
        ok_t, ok_g, best, last, note = math.inf, None, None, None, ""
        t = min(t_start, t_max)
        edge_tol = 0.5 / self.high  # 0.5 km/h at the range edge, in ln speed
        t_bound = self.t_limit(d, self.max_relative_change)
        for _ in range(self.max_evaluations):
            try:
                option, g = self.run(t * d)
            except ValueError as exc:  # outside the parameter rules: that is the limit
                note, t_max = str(exc), t
                t = 0.5 * (fail_t + t) if best is None else 0.5 * (fail_t + ok_t)
                continue
            if option.achieved:
                ok_t, ok_g, best = t, g, option
            else:
                fail_t, fail_g, last = t, g, option
                fails.append((t, g))
            # 1 % of the step; 5 % once the least change is known to lie beyond the bound (flagged anyway)
            tol = 0.05 if fail_t >= t_bound else 0.01
            if best is not None and (ok_t - fail_t <= tol * ok_t or (ok_g is not None and -ok_g <= edge_tol)):
                break
            if best is None:  # not bracketed yet: extrapolate the gap (secant), at most 4x
                if t >= t_max:
                    break
                (t1, g1), (t2, g2) = fails[-2], fails[-1]
                t_new = t2 - g2 * (t2 - t1) / (g2 - g1) if g2 < g1 else 4.0 * t2
                t = min(t_max, max(1.1 * t2, min(t_new, 4.0 * t2)))
            else:  # bracketed: secant (false position) kept inside, else bisection
                width = ok_t - fail_t
                t_new = fail_t + fail_g * width / (fail_g - ok_g) if ok_g is not None else fail_t + 0.5 * width
                t = min(max(t_new, fail_t + 0.1 * width), ok_t - 0.1 * width)
        if last is not None and note:
            last.note = f"stopped at the parameter rules: {note}"
        return best, last


def _best_option(search: _Search, grad_first, grad_second, original_band) -> DesignOption:
    """The least clearing change of one key or combination, searching every useful direction."""
    g0 = _gap(original_band, search.low, search.high)
    a, b = original_band[0][0], original_band[-1][1]
    if len(search.keys) == 1:
        directions = [np.array([1.0]), np.array([-1.0])]
    else:  # the steepest directions for each edge, in relative terms
        directions = [v / np.abs(v).max() for v in (grad_first, -grad_second) if np.any(v)]
    have_grad = np.any(grad_first) or np.any(grad_second)
    nominal = tuple(float(v) for v in search.nominal)
    plans, far = [], []
    for d in directions:
        rates = ((math.log(search.high / a), float(grad_first @ d)), (math.log(b / search.low), float(-grad_second @ d)))
        estimates = [gap / rate for gap, rate in rates if rate > 0.0]
        if estimates:
            t_est = min(estimates)
        elif have_grad:
            continue  # both edges move the wrong way (the band widens)
        else:
            t_est = search.t_limit(d, 0.1)  # no sensitivities (an edge at a PD/NS point): start at 10 %
        if t_est > 2.0 * search.t_limit(d):
            far.append(math.exp(t_est * np.abs(d).max()))
            continue
        plans.append((search.relative_change(t_est * d), d, t_est))
    if not plans:
        if far:
            note = (f"not searched: the sensitivities put the change needed at a factor of about {min(far):.3g}, "
                    f"far beyond the search factor {search.search_factor:g}")
        else:
            note = "both directions widen the band (by the sensitivities)"
        return DesignOption(search.keys, nominal, nominal, False, original_band, note=note)
    best, failures = None, []
    for _, d, t_est in sorted(plans, key=lambda p: p[0]):
        t_max = search.t_limit(d, None if best is None else best.relative_change)
        if best is not None and t_max <= 0.0:
            continue
        found, last = search.along(d, g0, t_est, t_max)
        if found is not None and (best is None or found.relative_change < best.relative_change):
            best = found
        if last is not None:
            failures.append(last)
    if best is not None:
        return best
    if not failures:
        return DesignOption(search.keys, nominal, nominal, False, original_band, note="no diagram could be computed")
    closest = min(failures, key=lambda o: _gap(o.sev_band_kmh, search.low, search.high) or 0.0)
    factor = search.search_factor
    closest.note = closest.note or f"not reached between 1/{factor:g} and {factor:g} times the nominal value"
    return closest


@dataclass(frozen=True)
class DesignSettings:
    """Numerical settings of :func:`design` (``polywear design --margin,
    --search-factor``)."""

    margin_kmh: float = 2.0
    """A change must also clear this much on each side of the operating range [km/h] (>= 0)."""
    search_factor: float = 3.0
    """Values are searched between ``nominal / search_factor`` and ``nominal * search_factor``
    [-] (> 1; at least ``1 + max_relative_change``); a direction whose first estimate lies
    beyond twice that (in ln p) is not computed."""

    def __post_init__(self) -> None:
        m = self.margin_kmh
        if not (isinstance(m, (int, float)) and not isinstance(m, bool) and math.isfinite(m) and m >= 0.0):
            raise ValueError(f"DesignSettings: margin_kmh = {m!r}: must be >= 0 and finite [km/h]")
        check_positive(self, "search_factor")
        if not self.search_factor > 1.0:
            raise ValueError(f"DesignSettings: search_factor = {self.search_factor!r}: must be above 1")


def design(
    params: Params,
    operating_range_kmh: tuple[float, float],
    keys: Sequence[str] = DEFAULT_KEYS,
    combine: tuple[str, ...] = (),
    max_relative_change: float = 0.5,
    speed_range_kmh: tuple[float, float] = DEFAULT_SPEED_RANGE_KMH,
    diagram: BifurcationDiagram | None = None,
    settings: DesignSettings = DesignSettings(),
    progress: Progress | None = None,
) -> DesignResult:
    """Least change of each key (and of the ``combine`` keys together) that clears the range.

    Parameters
    ----------
    operating_range_kmh
        Speeds [km/h] to keep free of SEV; a change must also clear ``settings.margin_kmh``
        on each side.
    keys, combine
        Configuration keys (or ``adhesion_scale``) changed alone, and changed together.
        Keys that do not enter the model are skipped (listed in ``result.skipped``).
    max_relative_change
        The allowed change (relative to the nominal value); larger ones are flagged.
    settings
        The margin [km/h] and the search factor [-] (:class:`DesignSettings`).
    diagram
        The nominal diagram, if already computed.
    progress
        Progress callback (:mod:`polywear.progress`): bifurcation diagrams computed, total
        unknown; the message names the change before each diagram.
    """
    lo, hi = (float(v) for v in operating_range_kmh)
    if not lo < hi:
        raise ValueError(f"operating range {lo} {hi}: need low < high [km/h]")
    if not max_relative_change > 0.0:
        raise ValueError(f"max_relative_change = {max_relative_change!r}: must be positive")
    margin_kmh = settings.margin_kmh
    step = StepCounter(progress)
    # every diagram covers the operating range and its margin: a band starting just above
    # the speed range but inside the operating range must not be missed
    speed_range_kmh = (min(speed_range_kmh[0], max(lo - margin_kmh, 0.5 * lo)), max(speed_range_kmh[1], hi + margin_kmh))
    if diagram is None:
        step.begin("nominal bifurcation diagram")
        diagram = bifurcation(params, speed_range_kmh)
        step()
    original = diagram
    model = model_for(params)
    keys, combine = tuple(dict.fromkeys(keys)), tuple(dict.fromkeys(combine))
    skipped = [k for k in dict.fromkeys((*keys, *combine)) if not parameter_direction(model, params, k).any()]
    keys = tuple(k for k in keys if k not in skipped)
    combine = tuple(k for k in combine if k not in skipped)

    def result(options, reason=""):
        return DesignResult(params, (lo, hi), original, options, max_relative_change, margin_kmh, reason, skipped)

    band = original.sev_band_kmh
    low, high = max(lo - margin_kmh, 0.5 * lo), hi + margin_kmh
    if not band:
        s_lo, s_hi = original.speed_range_kmh
        return result([], f"No SEV band in {s_lo:g}-{s_hi:g} km/h: steady rolling is stable and no stable cycle "
                          "exists, so there is nothing to move.")
    if _gap(band, low, high) <= 0.0:
        return result([], f"The SEV band lies outside the operating range (with the {margin_kmh:g} km/h margin): "
                          "nothing to move.")
    sens = sensitivity(params, keys=tuple(dict.fromkeys((*keys, *combine))), diagram=original)
    # d ln V / dx per key, x = ln(p / p0) (x = p where p0 = 0), for the first and last band edge
    grad: dict[tuple[str, str], float] = {}
    for r in sens.rows:
        if r["quantity"] in ("first_bifurcation", "second_bifurcation") and r["derivative"] is not None:
            grad[(r["quantity"], r["param"])] = r["derivative"] * (r["nominal"] or 1.0) / r["speed_kmh"]

    options = []
    for group in [(k,) for k in keys] + ([combine] if len(combine) > 1 else []):
        search = _Search(params, group, np.array([nominal_value(params, k) for k in group]), low, high,
                         max_relative_change, max(settings.search_factor, 1.0 + max_relative_change),
                         tuple(speed_range_kmh),
                         step)
        g1 = np.array([grad.get(("first_bifurcation", k), 0.0) for k in group])
        g2 = np.array([grad.get(("second_bifurcation", k), 0.0) for k in group])
        options.append(_best_option(search, g1, g2, band))
    for option in options:
        if option.outcome is DesignOutcome.VANISHES:
            step.begin(f"{option.change_text()}: every speed")
            _band_over_all_speeds(params, option, low, high)
            step()
    options.sort(key=lambda o: (_CATEGORY_RANK[o.category], not o.achieved, not o.within_bound,
                                o.values == o.nominal, o.relative_change))  # computed before not searched
    return result(options)
