"""Design: parameter changes that move the SEV band out of an operating speed range.

The paper's section 6 strategies (Figs. 10-12) as a computation. For each parameter
(or a combination), the smallest change within the given bounds such that no speed of
the operating range lies in the SEV band (where vibration persists after a large
disturbance): either the first bifurcation speed rises above the range, or the second
falls below it, or the band vanishes.

Method: the exact sensitivities of the first/second bifurcation speeds give a linear
estimate of the change; a secant iteration on full bifurcation diagrams (continuation)
then finds the change that puts the band edge at the range edge plus a margin, and a
final diagram verifies the result. Combined changes move along the direction of the
normalized sensitivities (``dp_i / p_i`` proportional to ``S_i``: the least change in
the relative sense) with one scalar step.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..params import Params
from .bifurcation import BifurcationDiagram, bifurcation_diagram
from .sensitivity import PARAMETER_LABELS, local_sensitivity, nominal_value, perturbed

__all__ = ["DesignOption", "DesignResult", "clear_operating_range"]


@dataclass
class DesignOption:
    """One way to clear the operating range: parameter values and the resulting band."""

    keys: tuple[str, ...]
    nominal: tuple[float, ...]
    values: tuple[float, ...]
    direction: str  # "up" (band above the range), "down" (below) or "none"
    achieved: bool
    sev_band_kmh: list
    diagram: BifurcationDiagram | None = field(default=None, repr=False)
    note: str = ""

    @property
    def relative_change(self) -> float:
        """Largest |change / nominal| over the keys (absolute change where nominal is 0)."""
        return max(abs(v - n) / (abs(n) if n else 1.0) for v, n in zip(self.values, self.nominal))

    def summary(self) -> dict:
        return {
            "params": list(self.keys),
            "labels": [PARAMETER_LABELS.get(k, k) for k in self.keys],
            "nominal": list(self.nominal),
            "values": list(self.values),
            "relative_change": self.relative_change,
            "direction": self.direction,
            "achieved": self.achieved,
            "sev_band_kmh": [list(b) for b in self.sev_band_kmh],
            "note": self.note,
        }


@dataclass
class DesignResult:
    """Options to move the SEV band out of the operating range, best first."""

    params: Params
    operating_range_kmh: tuple[float, float]
    original: BifurcationDiagram
    options: list[DesignOption]

    def summary(self) -> dict:
        return {
            "model": self.params.model,
            "operating_range_kmh": list(self.operating_range_kmh),
            "original_sev_band_kmh": [list(b) for b in self.original.sev_band_kmh],
            "options": [o.summary() for o in self.options],
        }

    def plot(self, ax=None, option: int = 0, state: str = "x"):
        """Original vs optimized bifurcation diagram (the paper's Figs. 10-12). Returns artists."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(8, 4.5))
        artists = []
        lo, hi = self.operating_range_kmh
        artists.append(ax.axvspan(lo, hi, color="tab:green", alpha=0.12, label="operating range"))
        i = self.original.state_names.index(state)
        artists += _amplitude_lines(ax, self.original, i, "tab:gray", "original")
        chosen = [o for o in self.options if o.achieved and o.diagram is not None]
        if chosen:
            best = chosen[min(option, len(chosen) - 1)]
            text = ", ".join(
                f"{PARAMETER_LABELS.get(k, k)} {n:g}->{v:.4g}" for k, n, v in zip(best.keys, best.nominal, best.values)
            )
            artists += _amplitude_lines(ax, best.diagram, i, "tab:blue", f"optimized: {text}")
        ax.set_xlabel("speed [km/h]")
        ax.set_ylabel("amplitude of x [mm]" if state == "x" else f"amplitude of {state}")
        ax.legend(fontsize=8, loc="upper left")
        return artists


def _amplitude_lines(ax, diagram, i, color, label):
    artists = []
    scale = 1e3 if diagram.state_names[i] == "x" else 1.0
    first = True
    for b in range(len(diagram.branches)):
        pts = [c for c in diagram.cycles if c.branch == b]
        v = np.array([c.speed * 3.6 for c in pts])
        a = np.array([c.amplitude[i] for c in pts]) * scale
        st = np.array([c.stable for c in pts])
        artists += ax.plot(v, np.where(st, a, np.nan), "-", color=color, lw=1.8, label=label if first else None)
        artists += ax.plot(v, np.where(~st, a, np.nan), "--", color=color, lw=1.2)
        first = False
    if first:  # no cycles at all
        artists += ax.plot([], [], "-", color=color, label=f"{label} (no SEV)")
    return artists


def _overlaps(band, lo, hi) -> bool:
    return any(a < hi and b > lo for a, b in band)


def clear_operating_range(
    params: Params,
    operating_range_kmh: tuple[float, float],
    keys=("operating.toe_deg", "friction.mu_static", "tread.lateral_damping_ns_per_m"),
    combine: tuple[str, ...] = (),
    max_relative_change: float = 0.5,
    margin_kmh: float = 2.0,
    speed_range_kmh: tuple[float, float] = (20.0, 300.0),
    diagram: BifurcationDiagram | None = None,
    max_iterations: int = 8,
) -> DesignResult:
    """Smallest change of each key (and of the ``combine`` keys together) that clears the range."""
    lo, hi = (float(v) for v in operating_range_kmh)
    if not lo < hi:
        raise ValueError(f"operating range {lo} {hi}: need low < high [km/h]")
    original = diagram or bifurcation_diagram(params, speed_range_kmh)
    if not _overlaps(original.sev_band_kmh, lo, hi):
        return DesignResult(params, (lo, hi), original, [])
    sens = local_sensitivity(params, keys=tuple(dict.fromkeys((*keys, *combine))), diagram=original)
    grad = {
        (r["quantity"], r["param"]): r["derivative"]
        for r in sens.rows
        if r["quantity"] in ("first_bifurcation", "second_bifurcation")
    }
    options = []
    groups = [(k,) for k in keys] + ([tuple(combine)] if combine else [])
    for group in groups:
        options.append(
            _best_option(params, group, grad, original, lo, hi, max_relative_change, margin_kmh,
                         speed_range_kmh, max_iterations)
        )
    options.sort(key=lambda o: (not o.achieved, o.relative_change))
    return DesignResult(params, (lo, hi), original, options)


def _best_option(params, group, grad, original, lo, hi, max_rel, margin, speed_range, max_iterations):
    nominal = tuple(nominal_value(params, k) for k in group)
    # direction in parameter space: dp_i = nominal_i * S_i (absolute where nominal is 0)
    candidates = []
    for direction, quantity, target in (("up", "first_bifurcation", hi + margin), ("down", "second_bifurcation", lo - margin)):
        d = np.array([grad.get((quantity, k)) or 0.0 for k in group])
        scale = np.array([abs(n) if n else 1.0 for n in nominal])
        step_dir = d * scale**2  # gradient in relative coordinates, mapped back
        slope = float(d @ step_dir)  # dV/ds along the direction
        if slope == 0.0:
            continue
        edge = _edge(original.sev_band_kmh, quantity)
        s0 = (target - edge) / slope
        candidates.append((direction, quantity, target, step_dir, s0))
    best = None
    for direction, quantity, target, step_dir, s0 in sorted(candidates, key=lambda c: abs(c[4]) * np.abs(c[3]).max()):
        g0 = _edge(original.sev_band_kmh, quantity) - target
        option = _secant(params, group, nominal, direction, quantity, target, step_dir, s0, g0, max_rel,
                         speed_range, max_iterations, lo, hi)
        if best is None or (option.achieved, -option.relative_change) > (best.achieved, -best.relative_change):
            best = option
    if best is None:
        return DesignOption(group, nominal, nominal, "none", False, original.sev_band_kmh,
                            note="the bifurcation speeds do not depend on these parameters")
    return best


def _edge(band, quantity) -> float:
    return band[0][0] if quantity == "first_bifurcation" else band[-1][1]


def _values(nominal, step_dir, s):
    return tuple(n + s * d for n, d in zip(nominal, step_dir))


def _evaluate(params, group, values, speed_range):
    p = params
    for k, v in zip(group, values):
        p = perturbed(p, k, v)
    return bifurcation_diagram(p, speed_range)


def _secant(params, group, nominal, direction, quantity, target, step_dir, s0, g0, max_rel, speed_range, iters,
            lo, hi):
    """Secant iteration on the scalar step s (s = 0: nominal, band-edge gap g0) for the band
    edge to reach the target speed, then bisection between the largest step that fails and
    the smallest that clears the range; every evaluation is a full bifurcation diagram."""
    scale = np.array([abs(n) if n else 1.0 for n in nominal])
    s_max = max_rel / max(np.max(np.abs(step_dir) / scale), 1e-300)
    s_prev, g_prev = 0.0, g0
    s = float(np.clip(s0, -s_max, s_max))
    last, best, best_s, s_fail = None, None, 0.0, 0.0
    note = ""

    def run(step):
        diagram = _evaluate(params, group, _values(nominal, step_dir, step), speed_range)
        band = diagram.sev_band_kmh
        return DesignOption(group, nominal, _values(nominal, step_dir, step), direction,
                            not _overlaps(band, lo, hi), band, diagram)

    for _ in range(iters):
        try:
            last = run(s)
        except ValueError as exc:  # a value outside the parameter rules: step back
            note = str(exc)
            s = 0.5 * (s + s_prev)
            continue
        if last.achieved:
            if best is None or abs(s) < abs(best_s):
                best, best_s = last, s
        else:
            s_fail = s if abs(s) > abs(s_fail) else s_fail
        band = last.sev_band_kmh
        g = _edge(band, quantity) - target if band else 0.0  # no band at all: on target
        if last.achieved and abs(g) < 0.5:
            break
        s_new = s * 1.5 if g == g_prev else s - g * (s - s_prev) / (g - g_prev)
        s_prev, g_prev = s, g
        s = float(np.clip(s_new, -s_max, s_max))
        if s == s_prev:
            break
    # the band may vanish abruptly (g jumps to 0): bisect for the least change that clears
    if best is not None:
        for _ in range(iters):
            if abs(best_s - s_fail) <= 0.01 * abs(best_s):
                break
            mid = 0.5 * (best_s + s_fail)
            try:
                trial = run(mid)
            except ValueError:
                break
            if trial.achieved:
                best, best_s = trial, mid
            else:
                s_fail = mid
        last = best
    if last is None:
        return DesignOption(group, nominal, nominal, direction, False, [], note=note)
    if not last.achieved:
        last.note = note or f"not reached within a {max_rel:.0%} change"
    return last
