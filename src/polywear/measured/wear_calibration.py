"""The wear rate from measured worn tires: fit k_e (and the initial roughness), check, predict.

Why one evolution serves every k_e. The wear law writes ``k_e`` times the friction work
into the profile, and the vibration sees only the profile: the evolution at rate ``k`` to
distance ``d`` is the evolution at a reference rate ``k_ref`` to distance ``d k / k_ref``
(up to the distance step; tested). So the harmonics a tire with rate ``k`` shows at
``d`` are read off one reference evolution at ``d k / k_ref``. The initial roughness
``r0`` does not scale out (the locked, nonlinear part of the growth depends on the level),
so where it is fitted the evolution runs once per level of a grid and the log amplitudes
are interpolated in ``log r0``: exact while the growth is linear, but past the pull into
locking ``ln|W_n|`` bends in ``log r0`` (slope 1, up to 1.4 at the lock's onset, then
0.2-0.4), and a grid a factor 3 apart is off there by up to 0.16, two to three standard
deviations of a reading. So the grid is filled to steps of a factor ``REFINE`` around the
fit and over the whole range the profile intervals explore (off by at most 0.03 there).

What the data determine. One mileage gives, per order, one amplitude ``A = r0 c e^{g k d}``
while the growth is exponential: k_e and r0 enter only as a combination, which is
reported instead of a number. Two mileages (or one, with a measured or assumed new-tire
roughness) separate them. The fit is weighted least squares on the log amplitudes of the
dominant orders (each reading's standard error from the harmonic fit, plus a model floor
``MODEL_SCATTER`` for the tire-to-tire randomness of the initial roughness); intervals
are profile likelihood (chi^2 + 3.84, the other parameter refitted), widened by the
reduced chi^2 where it exceeds 1.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import Any, Iterable

import numpy as np

from ..params import Params, with_updates
from ..progress import Progress
from ..results import Result
from ..wear.evolution import EvolutionResult, EvolutionSettings, wear_evolution
from .profile import MeasuredProfiles, ProfileError

__all__ = ["WearCalibration", "calibrate_wear", "predict_visible_km"]

RATE_KEY = "wear.energetic_rate_mm3_per_j"
ROUGHNESS_KEY = "wear.initial_roughness_um"
ROUGHNESS_GRID = (0.1, 0.3, 1.0, 3.0, 10.0)
"""Initial roughness levels, as multiples of the parameter set's, where r0 is fitted."""
MODEL_SCATTER = 0.05
"""Floor of a log amplitude's standard deviation [-]: 5 %, for what the harmonic fit's
error does not hold (tested with the evolution's own profiles, where the model is exact)."""
MAX_ORDERS = 3
"""Orders fitted: the largest ones above the noise floor at the latest mileage, ..."""
MIN_SHARE = 0.3
"""... with at least this share of the dominant order's amplitude: a weaker order is ruled
by the tire's own random initial roughness in that order, which no model knows."""
MAX_REFINEMENTS = 10
"""Rounds of fitting: the reference run longer where k_e (or, once, its interval) reaches its reach,
the roughness grid filled to steps of at most a factor ``REFINE`` around the fitted level
(``REFINE`` either side), then over the whole range the profile intervals explore."""
REFINE = 1.25
RANGE = 4.0
"""The reference evolution covers k_e up to this multiple of the reference rate; it is
run longer where the fit reaches that edge."""


@dataclass(frozen=True)
class _Reading:
    distance_km: float
    order: int
    log_amplitude: float
    sigma: float
    tire: str


def _readings(measured: MeasuredProfiles) -> tuple[list[_Reading], list[int]]:
    """Log amplitudes of the dominant orders at every known mileage (above the floor)."""
    latest = measured.latest()
    K = max(p.harmonics_mm.size for p in latest)
    total = np.zeros(K)
    for p in latest:
        total[: p.harmonics_mm.size] += np.where(p.significant, p.amplitude_mm, 0.0)
    orders = [int(n) + 1 for n in np.argsort(total)[::-1][:MAX_ORDERS] if total[n] >= MIN_SHARE * total.max() > 0]
    out = []
    for p in measured.profiles:
        if p.distance_km is None:
            continue
        for n in orders:
            if n <= p.harmonics_mm.size and p.significant[n - 1]:
                a, s = float(p.amplitude_mm[n - 1]), float(p.std_error_mm[n - 1])
                out.append(_Reading(p.distance_km, n, math.log(a), math.hypot(s / a, MODEL_SCATTER), p.label))
    return out, orders


def _log_amplitude(run: EvolutionResult, distance_km: np.ndarray, order: int) -> np.ndarray:
    """ln|W_n| [ln mm] of ``run`` at ``distance_km`` (linear in distance between steps)."""
    amp = np.log(np.maximum(np.abs(run.harmonics[:, order - 1]) * 1e3, 1e-12))
    return np.interp(distance_km, run.distance_km, amp)


def _filled(levels: list[float], lo: float, hi: float) -> list[float]:
    """Roughness levels [-] to add so that no gap between neighbouring ``levels`` that
    reaches into ``[lo, hi]`` (ln level) is wider than a factor ``REFINE`` (equal steps in ln)."""
    x = np.log(sorted(levels))
    step = math.log(REFINE)
    new = []
    for a, b in itertools.pairwise(x):
        if b > lo and a < hi and b - a > step * 1.001:
            parts = math.ceil((b - a) / step)
            new += [math.exp(a + (b - a) * i / parts) for i in range(1, parts)]
    return new


def _walk(chi2_at, start: float, lo: float, hi: float, target: float) -> tuple[float | None, float | None]:
    """Ends of the interval around ``start`` where ``chi2_at <= target``: outwards in steps from
    0.02 growing 1.6x, the last one clamped to the bound (``lo``, ``hi``), then 30 bisections;
    None at an end whose bound is still within the target."""
    ends = []
    for direction, bound in ((-1, lo), (1, hi)):
        step, x = 0.02, start
        while True:
            x_new = x + direction * step
            clamped = direction * (x_new - bound) >= 0
            if clamped:
                x_new = bound
            if chi2_at(x_new) > target:
                a, b = x, x_new
                for _ in range(30):
                    m = 0.5 * (a + b)
                    a, b = (m, b) if chi2_at(m) <= target else (a, m)
                ends.append(0.5 * (a + b))
                break
            if clamped:
                ends.append(None)
                break
            x, step = x_new, step * 1.6
    return ends[0], ends[1]


def _intervals(residuals, theta: np.ndarray, lo: list[float], hi: list[float], target: float,
               visited: list[float]) -> list[tuple[float | None, float | None]]:
    """Profile-likelihood interval of each parameter (theta's units: ln k-scale, ln r0-level):
    where chi^2, the other parameter refitted, stays within ``target``; None at an end that
    reaches the searched range. ``visited`` gets the ln r0-level of every profile point within
    the target (the range the grid of levels must resolve)."""
    from scipy.optimize import least_squares

    out = []
    for j in range(len(theta)):
        def chi2_at(value: float, j: int = j) -> float:
            if len(theta) == 1:
                return float(np.sum(residuals(np.array([value])) ** 2))
            other = 1 - j

            def r_other(z: np.ndarray) -> np.ndarray:
                t = np.empty(2)
                t[j], t[other] = value, z[0]
                return residuals(t)

            f = least_squares(r_other, [theta[other]], bounds=([lo[other]], [hi[other]]))
            chi2 = float(2.0 * f.cost)
            if chi2 <= target:
                visited.append(value if j == 1 else float(f.x[0]))
            return chi2

        out.append(_walk(chi2_at, theta[j], lo[j], hi[j], target))
    return out


@dataclass
class WearCalibration(Result):
    """The fitted wear rate k_e (and initial roughness), with what the data can tell."""

    params: Params
    """the parameter set with the fitted k_e (and r0)"""
    measured: MeasuredProfiles
    cycle: tuple[tuple[float, float], ...]
    identifiable: bool
    energetic_rate_mm3_per_j: float | None
    rate_interval: tuple[float, float] | None
    initial_roughness_um: float
    roughness_fitted: bool
    roughness_interval: tuple[float, float] | None
    combination: str | None
    """where not identifiable: the combination of k_e and r0 the data determine"""
    orders: list[int]
    chi2: float
    dof: int
    comparison: dict
    """measured vs predicted dominant order and visible distance"""
    disagreements: list[str]
    reference: EvolutionResult
    """the evolution the predictions are read from (at the reference rate)"""
    settings: dict = field(default_factory=dict)

    def summary(self) -> dict:
        rate = None if self.energetic_rate_mm3_per_j is None else {
            "value": self.energetic_rate_mm3_per_j, "interval": list(self.rate_interval) if self.rate_interval else None}
        return {
            "dominant_order": self.measured.dominant_order,
            "peak_to_valley_mm": self.measured.summary()["peak_to_valley_mm"],
            "energetic_rate_mm3_per_j": rate,
            "identifiable": self.identifiable,
            "combination": self.combination,
            "initial_roughness_um": {"value": self.initial_roughness_um, "fitted": self.roughness_fitted,
                                     "interval": list(self.roughness_interval) if self.roughness_interval else None},
            "fitted_orders": self.orders,
            "chi2": self.chi2, "dof": self.dof,
            "comparison": self.comparison,
            "disagreements": self.disagreements,
            "cycle": [{"speed_kmh": v, "share": s} for v, s in self.cycle],
        }

    def _dataset(self):
        return self.measured._dataset()

    def plot(self, ax: Any = None):
        """Measured amplitudes of the fitted orders against distance, and the calibrated
        prediction (log scale)."""
        import matplotlib.pyplot as plt

        if ax is None:
            ax = plt.figure(figsize=(6.5, 4)).add_subplot()
        artists = []
        readings, _ = _readings(self.measured)
        scale = self.distance_scale()
        top = max([r.distance_km for r in readings] + [1.0]) * 1.3
        d = np.linspace(0.0, top, 200)
        for i, n in enumerate(self.orders):
            color = f"C{i}"
            pts = [r for r in readings if r.order == n]
            artists.append(ax.errorbar([r.distance_km for r in pts], [math.exp(r.log_amplitude) for r in pts],
                                       yerr=[math.exp(r.log_amplitude) * r.sigma for r in pts], fmt="o", color=color,
                                       label=f"order {n} measured"))
            below = [(p.distance_km, p.floor_mm[n - 1]) for p in self.measured.profiles
                     if p.distance_km is not None and n <= p.harmonics_mm.size and not p.significant[n - 1]]
            if below:
                artists.append(ax.scatter(*zip(*below), marker="v", color=color, facecolors="none",
                                          label=f"order {n} below the noise floor"))
            if scale is not None:
                artists += ax.plot(d, np.exp(_log_amplitude(self.reference, d * scale, n)), color=color,
                                   label=f"order {n} calibrated")
        ax.set_yscale("log")
        ax.set_xlabel("distance [km]")
        ax.set_ylabel("amplitude [mm]")
        ax.legend(fontsize=8)
        return artists

    def distance_scale(self) -> float | None:
        """k / k_ref: the reference evolution's distance per measured km [-] (None where k_e
        is not determined)."""
        if self.energetic_rate_mm3_per_j is None:
            return None
        return self.energetic_rate_mm3_per_j / self.reference.params.wear.energetic_rate_mm3_per_j


def _measured_visible_km(measured: MeasuredProfiles, limit_mm: float) -> float | None:
    """Where the measured peak-to-valley first reaches ``limit_mm`` (log-linear between
    mileages, over the tires and ribs; the earliest); None if it does not."""
    best = None
    for profiles in measured.tires.values():
        known = [(p.distance_km, p.peak_to_valley_mm) for p in profiles if p.distance_km is not None]
        for (d0, a0), (d1, a1) in zip([(0.0, 0.0)] + known, known):
            if a1 >= limit_mm:
                if a0 <= 0.0:
                    at = d1 if d0 == d1 else d0 + (d1 - d0) * limit_mm / a1
                else:
                    at = d0 + (d1 - d0) * math.log(limit_mm / a0) / math.log(a1 / a0) if a1 > a0 else d1
                best = at if best is None else min(best, at)
                break
    return best


def _growing_orders(params: Params, cycle, reference: EvolutionResult) -> set[int]:
    """Orders the model lets grow on the cycle: the wear map's growing orders where rolling
    is stable, and the orders next to the vibration's where the tread vibrates."""
    from ..wear.map import wear_map

    speeds = [v for v, _ in cycle]
    wmap = wear_map(params, speeds)
    growth = np.nan_to_num(wmap.growth_per_1000km, nan=-np.inf)
    out = {int(n) for n in wmap.orders[np.any(growth > 0.0, axis=0)]}
    nu = reference.vibration_order[np.isfinite(reference.vibration_order)]
    for value in np.unique(np.round(nu)):
        out |= {int(value) - 1, int(value), int(value) + 1}
    return out


def calibrate_wear(measured: MeasuredProfiles, params: Params, cycle: Iterable[tuple[float, float]] | None = None,
                   roughness_known: bool = False, settings: EvolutionSettings = EvolutionSettings(),
                   progress: Progress | None = None) -> WearCalibration:
    """Fit k_e (``wear.energetic_rate_mm3_per_j``) so that the evolution on ``cycle``
    reproduces the measured growth of the dominant orders.

    ``roughness_known``: take ``wear.initial_roughness_um`` as known (measured on new
    tires, or assumed); otherwise it is fitted where two or more mileages allow it, and
    with one mileage the result is the combination of both that the data determine.
    """
    from scipy.optimize import least_squares

    cycle = tuple(cycle) if cycle is not None else params.wear.cycle_shares()
    readings, orders = _readings(measured)
    if not readings:
        raise ProfileError("no order stands above the noise floor at a known mileage (distance_km): nothing to "
                           "calibrate")
    if any(n > params.wear.max_order for n in orders):
        raise ProfileError(f"measured order {max(orders)} is above wear.max_order = {params.wear.max_order}")
    mileages = sorted({r.distance_km for r in readings})
    fit_roughness = not roughness_known and len(mileages) >= 2
    k_ref = params.wear.energetic_rate_mm3_per_j
    r_ref = params.wear.initial_roughness_um
    span = RANGE
    d = np.array([r.distance_km for r in readings])
    y = np.array([r.log_amplitude for r in readings])
    sig = np.array([r.sigma for r in readings])
    n_of = np.array([r.order for r in readings])
    cache: dict[tuple[float, float], EvolutionResult] = {}

    def run_at(level: float, distance: float) -> EvolutionResult:
        """The evolution with the initial roughness ``level`` times the parameter set's."""
        key = (level, distance)
        if key not in cache:
            if progress is not None:
                progress(len(cache), None, f"evolution {len(cache) + 1} (roughness x{level:.3g}, {distance:.0f} km)")
            cache[key] = wear_evolution(with_updates(params, {ROUGHNESS_KEY: r_ref * level}), distance, cycle, settings)
        return cache[key]

    levels = list(ROUGHNESS_GRID) if fit_roughness else [1.0]
    previous = None
    widened = False
    single_mileage = len(mileages) < 2 and not roughness_known
    for _ in range(MAX_REFINEMENTS):
        distance = max(mileages) * span
        runs = [run_at(level, distance) for level in levels]
        x_levels = np.log(np.asarray(levels))
        logs = [np.log(np.maximum(np.abs(run.harmonics) * 1e3, 1e-12)) for run in runs]  # ln|W_n| [ln mm]

        def model(theta: np.ndarray) -> np.ndarray:
            scaled = d * math.exp(theta[0])
            at = np.array([[np.interp(dj, run.distance_km, log[:, n - 1]) for dj, n in zip(scaled, n_of)]
                           for run, log in zip(runs, logs)])
            if len(runs) == 1:
                return at[0]
            return np.array([np.interp(theta[1], x_levels, at[:, j]) for j in range(len(d))])

        def residuals(theta: np.ndarray) -> np.ndarray:
            return (model(theta) - y) / sig

        lo = [math.log(1e-3), x_levels.min()] if fit_roughness else [math.log(1e-3)]
        hi = [math.log(span), x_levels.max()] if fit_roughness else [math.log(span)]
        starts = [np.array([s, 0.0][: len(lo)]) for s in np.linspace(math.log(0.01), math.log(span * 0.9), 7)]
        if previous is not None:
            starts.append(np.clip(previous, lo, hi))
        fits = [least_squares(residuals, x0, bounds=(lo, hi), x_scale=1.0, diff_step=1e-4) for x0 in starts]
        best = min(fits, key=lambda f: f.cost)
        previous = theta = best.x
        chi2 = float(2.0 * best.cost)
        target = chi2 + 3.84 * max(1.0, chi2 / max(len(y) - len(theta), 1))
        singular = np.linalg.svd(best.jac, compute_uv=False) if best.jac.size else np.array([0.0])
        identifiable = not single_mileage and singular.min() > 1e-6 * max(singular.max(), 1e-300)
        ends = []
        if theta[0] >= hi[0] - 0.05:  # k at the top of the reference's reach: run it longer
            span *= RANGE
            continue
        # the grid no coarser than REFINE around the fitted roughness, then over the whole range the
        # intervals explore: past the pull into locking ln|W_n| bends in ln r0 (module notes)
        new = _filled(levels, theta[1] - math.log(REFINE), theta[1] + math.log(REFINE)) if fit_roughness else []
        if new:
            levels = sorted(levels + new)
            continue
        visited = [theta[1]] if fit_roughness else []  # ln r0 of the fit and of the profiles within the target
        if identifiable:
            ends = _intervals(residuals, theta, lo, hi, target, visited)
            if ends[0][1] is None and not widened:  # the rate's interval reaches the reference's reach:
                span *= RANGE  # run it longer, once (open beyond that: not determined)
                widened = True
                continue
        new = _filled(levels, min(visited) - math.log(REFINE), max(visited) + math.log(REFINE)) if visited else []
        if not new:
            break
        levels = sorted(levels + new)
    if identifiable and not ends:  # the rounds ran out before the intervals: those of the last fit
        ends = _intervals(residuals, theta, lo, hi, target, [])

    run_index = int(np.argmin(np.abs(x_levels - (theta[1] if fit_roughness else 0.0))))
    reference = runs[run_index]
    combination = None
    rate = rate_ci = rough_ci = None
    roughness = r_ref * (math.exp(theta[1]) if fit_roughness else 1.0)
    if identifiable:
        rate = k_ref * math.exp(theta[0])
        rate_ci = None if None in ends[0] else (k_ref * math.exp(ends[0][0]), k_ref * math.exp(ends[0][1]))
        if fit_roughness:
            rough_ci = None if None in ends[1] else (r_ref * math.exp(ends[1][0]), r_ref * math.exp(ends[1][1]))
        identifiable = rate_ci is not None
    if not identifiable:
        combination = _combination(readings, reference, k_ref, r_ref, theta[0], orders)
    fitted = with_updates(params, {RATE_KEY: rate if rate is not None else k_ref, ROUGHNESS_KEY: roughness})
    scale = None if rate is None else rate / k_ref
    predicted_visible = None if scale is None or reference.visible_km is None else reference.visible_km / scale
    measured_visible = _measured_visible_km(measured, params.wear.visible_depth_mm)
    latest_km = max(mileages)
    predicted_order = None
    if scale is not None:
        at = np.searchsorted(reference.distance_km, latest_km * scale).clip(0, len(reference.distance_km) - 1)
        predicted_order = int(reference.dominant_order[at])
    comparison = {
        "measured_dominant_order": measured.dominant_order,
        "predicted_dominant_order": predicted_order,
        "at_km": latest_km,
        "measured_visible_km": measured_visible,
        "predicted_visible_km": predicted_visible,
        "predicted_visible_interval_km": None if rate_ci is None or reference.visible_km is None else
        [reference.visible_km * k_ref / rate_ci[1], reference.visible_km * k_ref / rate_ci[0]],
    }
    growing = _growing_orders(params, cycle, reference)
    disagreements = [f"measured order {n} cannot grow on this cycle by the model (the wear map decays it at every "
                     "speed where rolling is stable, and no vibration writes it): the model misses what wears it"
                     for n in orders if n not in growing]
    if predicted_order is not None and measured.dominant_order is not None and predicted_order != measured.dominant_order:
        disagreements.append(f"dominant order: measured {measured.dominant_order}, predicted {predicted_order} at "
                             f"{latest_km:g} km")
    return WearCalibration(fitted, measured, cycle, identifiable, rate, rate_ci, roughness, fit_roughness and identifiable,
                           rough_ci, combination, orders, chi2, len(y) - len(theta), comparison, disagreements,
                           reference, settings={"step_km": settings.step_km, "revolutions": settings.revolutions,
                                                "roughness_known": roughness_known})


def _combination(readings: list[_Reading], reference: EvolutionResult, k_ref: float, r_ref: float, log_scale: float,
                 orders: list[int]) -> str:
    """What one mileage determines: along the growth, ln A = ln r0 + G k d, so
    ``k_e / ln(A / r0)`` is fixed. G from the reference evolution's growth of the order."""
    n = orders[0]
    pts = [r for r in readings if r.order == n]
    r = max(pts, key=lambda q: q.distance_km)
    amp0 = float(np.abs(reference.harmonics[0, n - 1]) * 1e3)
    at = r.distance_km * math.exp(log_scale)
    growth = (_log_amplitude(reference, np.array([at]), n)[0] - math.log(max(amp0, 1e-12))) / max(at, 1e-9)
    if growth <= 0:
        return (f"order {n} does not grow in the model on this cycle: its amplitude {math.exp(r.log_amplitude):.3g} mm "
                f"at {r.distance_km:g} km cannot fix k_e")
    per_k = growth / k_ref  # e-folds per km per (mm^3/J)
    value = 1.0 / (per_k * r.distance_km)
    return (f"one mileage fixes only k_e / ln(A{n} / r{n}) = {value:.3g} mm^3/J, with A{n} = "
            f"{math.exp(r.log_amplitude):.3g} mm the measured amplitude of order {n} at {r.distance_km:g} km and r{n} "
            f"its unknown amplitude on the new tire (for the assumed r0 = {r_ref:g} um RMS over all orders, "
            f"r{n} = {amp0 * 1e3:.3g} um: pass --roughness-known to use it, or measure a second mileage)")


def predict_visible_km(calibration: WearCalibration, params: Params | None = None,
                       cycle: Iterable[tuple[float, float]] | None = None, distance_km: float = 200_000.0,
                       settings: EvolutionSettings = EvolutionSettings()) -> dict:
    """Visible distance [km] on ``cycle`` (default: the calibration's) for ``params``
    (default: the calibrated car; give a changed car for a design change) with the
    calibrated k_e and its interval: one evolution, then the 1/k_e scaling."""
    if calibration.energetic_rate_mm3_per_j is None:
        raise ProfileError("the data do not determine k_e (see the combination); nothing to predict with")
    car = calibration.params if params is None else with_updates(params, {
        RATE_KEY: calibration.energetic_rate_mm3_per_j, ROUGHNESS_KEY: calibration.initial_roughness_um})
    cycle = calibration.cycle if cycle is None else tuple(cycle)
    run = wear_evolution(car, distance_km, cycle, settings)
    visible = run.visible_km
    k = calibration.energetic_rate_mm3_per_j
    interval = None
    if visible is not None and calibration.rate_interval is not None:
        interval = [visible * k / calibration.rate_interval[1], visible * k / calibration.rate_interval[0]]
    return {"visible_km": visible, "visible_interval_km": interval, "within_km": distance_km,
            "dominant_order": int(run.dominant_order[-1]), "cycle": [{"speed_kmh": v, "share": s} for v, s in cycle]}
