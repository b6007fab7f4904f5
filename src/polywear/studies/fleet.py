"""Fleet risk: the share of built cars whose SEV band reaches the speeds customers drive.

The fleet spec (:mod:`.fleet_spec`, a TOML file) gives the distributions of the
parameters that vary from car to car and their correlations, the usage profile (share
of the distance by speed), the sample size and the seed.

Per car the band comes from :class:`~polywear.studies.fast_band.FastBand` (fast path
from the nearest reference with the car's Hopf signature, full continuation as
fallback). The references come from a pilot stage
(:func:`~polywear.studies.fast_band.pilot_stage`, as in studies): the nominal car and
evenly spaced cars of the sample (one per 32, at most 32) by the full continuation; those
cars keep their full diagrams as their results (path ``"pilot"``). A car is *at risk* when its SEV
band (hard regions included) contains a speed of the usage profile with a positive
share; it has *hard excitation* when such a speed lies in a hard region (stable rolling
there, but a disturbance starts SEV). A car whose band (full path) has a gap holding a
usage speed, in a diagram with period doublings or torus bifurcations, is counted apart
(``gap_after_pd_ns_share``): the band counts period-1 cycles only, and the motion past
those bifurcations can persist in such a gap (a simulation decides; the risk does not
count it). The risk probability gets an exact binomial
(Clopper-Pearson) interval over the cars that were evaluated.

Wear risk. With ``wear_km`` (D) every car's worn profile is evolved over D km on the
usage cycle (the usage speeds with their shares, :func:`~polywear.wear.evolution.wear_evolution`,
vibrating or not): the wear risk is the share of cars whose polygon becomes visible
(``wear.visible_depth_mm``) within D, with the same exact interval; the most dangerous
order is the order most of the visible polygons have; its drivers are computed as the
band risk's. Every car's evolution has a budget of distance steps (``wear_max_steps``
beyond the fewest that D takes at the longest step) and of simulated revolutions
(``wear_max_revolutions``): a car that would need more (a vibration within a few
thousandths of an integer order that does not lock: its windows are long and the steps
stay near 10 km) is stopped there, counted and
listed with its parameters (``wear_over_budget``), and kept out of the wear risk; its band
counts in the band risk as any other car's.

Reproducibility: all samples are drawn in the calling process from
``numpy.random.SeedSequence(seed)`` before any evaluation, the pilot stage depends on
the samples alone, and every other car is evaluated independently of the others (warm
start from the fixed references), so the result does not depend on the backend, the
number of workers or on resuming from a checkpoint (a resumed run solves the same pilot
again): it is bit-identical.

Drivers of the risk: first-order (main-effect) indices of the risk indicator from the
same samples, by the given-data binning estimator ``Var(E[Y | X_i]) / Var(Y)`` with
``X_i`` cut into equal-probability bins. With correlated parameters a main effect
includes what the correlated partners carry (e.g. toe and camber).
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..params import ParameterError, Params, to_toml
from ..parallel import Executor
from ..progress import Progress, report, shifted
from ..results import Result, with_deprecated_keys
from .fleet_spec import (WEAR_MAX_REVOLUTIONS, WEAR_MAX_STEPS, FleetParameter, FleetSpec, FleetUsage, load_fleet_spec,
                         sample_fleet)
from .sampling import SAMPLE_FAILURES, sample_params

if TYPE_CHECKING:
    from .fast_band import BandReference

__all__ = ["CarOutcome", "FleetParameter", "FleetUsage", "FleetSpec", "load_fleet_spec", "sample_fleet", "FleetEvaluator",
           "FleetResult", "fleet"]

OUTPUTS = ("first_bifurcation_speed_kmh", "second_bifurcation_speed_kmh", "at_risk", "hard_at_usage", "fast_path",
           "wear_visible_km", "usage_in_gap_after_pd_ns", "gap_sev_by_simulation", "wear_order")
RENAMED_KEYS = {"first_bifurcation_speed_kmh": "first_bifurcation_kmh",
                "second_bifurcation_speed_kmh": "second_bifurcation_kmh"}
"""New -> old keys of :meth:`FleetResult.summary` (the old ones go in the next release)."""
N_BINS = 20
"""Equal-probability bins of the main-effect estimator."""
PATHS = ("hopf", "fast", "full", "pilot")
"""How a car's risk was decided: the Hopf points alone (``FastBand.usage_verdict``), the
fast band path, the full continuation (a fallback, with its
:class:`~polywear.studies.fast_band.FallbackReason`), or the full continuation of the
pilot stage (the car is a reference)."""
CAR_FIELDS = ("failure", "detail", "path", "fallback", "fallback_detail", "wear")
"""The fields of :class:`CarOutcome`, stored per car in the checkpoint."""


@dataclass(frozen=True)
class CarOutcome:
    """How one car ended. Failed: ``failure`` (the exception type, or ``"wear evolution"``) and
    ``detail`` (its message); evaluated: ``path`` (one of :data:`PATHS`) and, on the full
    path, ``fallback`` (a :class:`~polywear.studies.fast_band.FallbackReason` value) and
    ``fallback_detail``; ``wear``: why an evaluated car has no wear result (its evolution
    stopped at the step budget), else empty. The texts of the files (:attr:`status`,
    :attr:`path_text`) are composed from these fields, never parsed back."""

    failure: str = ""
    detail: str = ""
    path: str = ""
    fallback: str = ""
    fallback_detail: str = ""
    wear: str = ""

    @property
    def ok(self) -> bool:
        return not self.failure

    @property
    def status(self) -> str:
        """``"ok"`` or ``"failed: <type>: <message>"``."""
        return "ok" if self.ok else f"failed: {self.failure}: {self.detail}"

    @property
    def path_text(self) -> str:
        """``"hopf"``, ``"fast"``, ``"full: <reason>: <message>"``, or ``""`` for a failed car."""
        return f"full: {self.fallback}: {self.fallback_detail}" if self.path == "full" else self.path


LISTED_FAILURES = 20
"""Failed cars listed one by one (index and reason) in the summary; all are counted."""


@dataclass(frozen=True)
class FleetEvaluator:
    """One car: (outputs, :class:`CarOutcome`). Outputs as :data:`OUTPUTS` (speeds [km/h],
    visible-polygon distance [km] (inf: not within ``wear_km``), 0/1 flags, polygon order)."""

    params: Params
    keys: tuple[str, ...]
    solver: object  # FastBand
    usage_speeds_kmh: tuple[float, ...]
    wear_km: float | None = None
    """Evolve the wear over this distance [km] on ``usage_cycle`` (None: no wear)."""
    wear_max_steps: int = WEAR_MAX_STEPS
    """Step budget of the evolution beyond ``ceil(wear_km / longest step)`` (:attr:`FleetSpec.wear_max_steps`)."""
    wear_max_revolutions: int = WEAR_MAX_REVOLUTIONS
    """Work budget of the evolution [simulated revolutions] (:attr:`FleetSpec.wear_max_revolutions`)."""
    usage_cycle: tuple[tuple[float, float], ...] = ()
    """(speed [km/h], share) of the usage, shares summing to 1."""
    band_every: int = 1
    simulate_gaps: bool = False
    """Decide usage speeds in gaps after PD/NS by simulation (:attr:`FleetSpec.simulate_gaps`)."""
    pilot: dict = field(default_factory=dict)
    """Car index -> its :class:`~polywear.studies.fast_band.Band` from the pilot stage (its full diagram)."""

    def __call__(self, item) -> tuple[tuple[float, ...], CarOutcome]:
        """``item = (car index, parameter values)``."""
        index, values = item
        solved = self.pilot.get(index)  # a pilot car's band is known: its whole full diagram
        try:
            params = sample_params(self.params, self.keys, values)
            whole = solved is not None or index % self.band_every == 0
            verdict = None if whole else self.solver.usage_verdict(params, self.usage_speeds_kmh)
            band, diagram = (solved, None) if solved is not None or verdict is not None else self._band(params)
        except SAMPLE_FAILURES as exc:  # invalid parameters or a numerical failure: recorded, never dropped
            return (np.nan,) * len(OUTPUTS), CarOutcome(failure=type(exc).__name__, detail=str(exc))
        worn = self._wear(params) if self.wear_km is not None else (np.nan, np.nan, "")
        if isinstance(worn, CarOutcome):
            return (np.nan,) * len(OUTPUTS), worn
        visible, order, over = worn
        if verdict is not None:  # Hopf points alone decided: no second speed for this car
            at_risk, hard, first = verdict
            return ((first, np.nan, float(at_risk), float(hard), 1.0, visible, 0.0, np.nan, order),
                    CarOutcome(path="hopf", wear=over))
        inside = lambda intervals: any(a <= v <= b for v in self.usage_speeds_kmh for a, b in intervals)
        if solved is not None or band.path == "fast":
            outcome = CarOutcome(path="fast" if solved is None else "pilot", wear=over)
        else:  # the fast path was tried first, so the reason is set
            outcome = CarOutcome(path="full", fallback=band.reason.value, fallback_detail=band.detail, wear=over)
        in_gap = [v for v in self.usage_speeds_kmh if any(a < v < b for a, b in band.gaps_after_pd_ns_kmh)]
        gap_sev = np.nan
        if in_gap and self.simulate_gaps:
            gap_sev = self._gap_sev(params, in_gap, diagram)
            if isinstance(gap_sev, CarOutcome):
                return (np.nan,) * len(OUTPUTS), gap_sev
        return (band.first_bifurcation_speed_kmh, band.second_bifurcation_speed_kmh, float(inside(band.sev_band_kmh)),
                float(inside(band.hard_regions_kmh)), float(band.path == "fast"), visible, float(bool(in_gap)),
                gap_sev, order), outcome

    def _band(self, params):
        """(band, full diagram or None): the fast path, else the full continuation, whose
        diagram is kept for the simulations of :meth:`_gap_sev`."""
        from .fast_band import Band, band_from_diagram

        band = self.solver.try_fast(params)
        if isinstance(band, Band):
            return band, None
        diagram = self.solver.diagram(params)
        return band_from_diagram(diagram, self.solver.amplitude_speeds_kmh, band), diagram

    def _gap_sev(self, params, speeds_kmh, diagram=None) -> float | CarOutcome:
        """1.0 if a simulation (:func:`~polywear.dynamics.attractor.reached_attractors`, from the
        car's ``diagram``, computed again for a pilot car) ends in SEV at one of these speeds
        [km/h], else 0.0; or the failure."""
        from ..dynamics.attractor import reached_attractors

        try:
            diagram = diagram if diagram is not None else self.solver.diagram(params)
            return float(any(a.oscillating for v in speeds_kmh for a in reached_attractors(diagram, v)))
        except SAMPLE_FAILURES as exc:
            return CarOutcome(failure="gap simulation", detail=f"{type(exc).__name__}: {exc}")

    def _wear(self, params) -> tuple[float, float, str] | CarOutcome:
        """(distance [km] at which the polygon becomes visible, inf if not within ``wear_km``;
        its order: the dominant order where it first is visible, else at the end; "") by the
        nonlinear evolution on the usage cycle, stopped once the polygon is visible; (nan, nan,
        why) where it stopped at the step budget (:func:`wear_step_budget`); or the failure."""
        from ..wear.evolution import EvolutionSettings, StepBudgetError, wear_evolution

        settings = EvolutionSettings(max_steps=self.wear_max_steps, max_revolutions=self.wear_max_revolutions,
                                     until_visible=True)
        try:
            worn = wear_evolution(params, self.wear_km, self.usage_cycle, settings=settings, workers=1)  # cars in parallel
        except StepBudgetError as exc:
            return (np.nan, np.nan,
                    f"over the budget of {exc.budget:,} {exc.unit} at {exc.done_km:,.0f} of {self.wear_km:,.0f} km")
        except SAMPLE_FAILURES as exc:
            return CarOutcome(failure="wear evolution", detail=f"{type(exc).__name__}: {exc}")
        visible = worn.visible_km
        at = np.flatnonzero(worn.depth_mm >= params.wear.visible_depth_mm)
        order = worn.dominant_order[at[0] if at.size else -1]
        return (math.inf if visible is None else visible), float(order), ""


def wear_step_budget(wear_km: float, max_steps: int = WEAR_MAX_STEPS) -> int:
    """Most distance steps (rejected ones included) of one car's evolution over ``wear_km`` [km]:
    ``max_steps`` beyond the fewest the distance takes at the evolution's longest step."""
    from ..wear.evolution import EvolutionSettings, step_budget

    return step_budget(wear_km, EvolutionSettings(max_steps=max_steps))


def _spec_hash(params: Params, spec: FleetSpec) -> str:
    text = to_toml(params) + spec.model_dump_json()
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def main_effects(X: np.ndarray, y: np.ndarray, n_bins: int = N_BINS) -> np.ndarray:
    """Var(E[y | x_i]) / Var(y) per column of X, with x_i cut into equal-probability bins."""
    var = np.var(y)
    out = np.zeros(X.shape[1])
    if var == 0.0:
        return out
    for i in range(X.shape[1]):
        ranks = np.argsort(np.argsort(X[:, i], kind="stable"), kind="stable")
        bins = ranks * n_bins // len(y)
        means = np.array([y[bins == b].mean() for b in range(n_bins) if np.any(bins == b)])
        counts = np.array([np.sum(bins == b) for b in range(n_bins) if np.any(bins == b)])
        out[i] = np.sum(counts * (means - y.mean()) ** 2) / len(y) / var
    return out


MIN_CLASS_CARS = 20
"""Fewest cars of each outcome (at risk, not at risk) for :func:`classifier_importances`."""


CLASSIFIER_CARS = 20000
"""Largest number of cars the classifier of :func:`classifier_importances` uses (a stratified
subsample beyond it: a fit and 35 shuffled predictions take ~2.5 s at this size)."""


def classifier_importances(X: np.ndarray, y: np.ndarray, seed: int, repeats: int = 5) -> dict | None:
    """Permutation importances of a gradient-boosted classifier of the 0/1 outcome ``y`` from
    the parameters ``X``: the drop of its ROC AUC on held-out cars (30 %, stratified) when
    one column is shuffled, mean over ``repeats`` shuffles. Unlike main effects it credits a
    parameter for what it does together with others (risk only where toe AND mu_s are high).
    At most :data:`CLASSIFIER_CARS` cars (stratified subsample). None with fewer than
    :data:`MIN_CLASS_CARS` cars of either outcome. Deterministic for a given ``seed`` (split,
    boosting and shuffles; the same with 1 and 2 threads, checked bit for bit)."""
    from sklearn.ensemble import HistGradientBoostingClassifier
    from sklearn.inspection import permutation_importance
    from sklearn.metrics import roc_auc_score
    from sklearn.model_selection import train_test_split

    y = np.asarray(y, dtype=int)
    if min(np.sum(y == 1), np.sum(y == 0)) < MIN_CLASS_CARS:
        return None
    if len(y) > CLASSIFIER_CARS:
        X, _, y, _ = train_test_split(X, y, train_size=CLASSIFIER_CARS, stratify=y, random_state=seed)
    X_fit, X_test, y_fit, y_test = train_test_split(X, y, test_size=0.3, stratify=y, random_state=seed)
    model = HistGradientBoostingClassifier(early_stopping=False, random_state=seed).fit(X_fit, y_fit)
    auc = float(roc_auc_score(y_test, model.predict_proba(X_test)[:, 1]))
    drop = permutation_importance(model, X_test, y_test, scoring="roc_auc", n_repeats=repeats, random_state=seed)
    return {"importance": drop.importances_mean, "std": drop.importances_std, "auc": auc,
            "n_fit": len(y_fit), "n_test": len(y_test)}


@dataclass
class FleetResult(Result):
    """Samples, per-car outputs and statuses, and the fleet statistics."""

    params: Params
    spec: FleetSpec
    samples: np.ndarray
    values: np.ndarray  # (samples, len(OUTPUTS))
    outcomes: list[CarOutcome]
    """Per car: how it ended (failure, or path and fallback reason)."""
    confidence: float = 0.95
    settings: dict = field(default_factory=dict)

    @property
    def status(self) -> list[str]:
        """Per car: ``"ok"`` or ``"failed: <type>: <message>"`` (the text of the files)."""
        return [c.status for c in self.outcomes]

    @property
    def paths(self) -> list[str]:
        """Per car: ``"hopf"``, ``"fast"``, ``"full: <reason>: <message>"``, ``"pilot"`` or ``""`` (failed);
        see :data:`PATHS`."""
        return [c.path_text for c in self.outcomes]

    @property
    def keys(self) -> list[str]:
        return [q.key for q in self.spec.parameter]

    @property
    def ok(self) -> np.ndarray:
        return np.array([c.ok for c in self.outcomes], dtype=bool)

    def risk_ci(self, mask=None) -> tuple[int, int, float, float]:
        """(cars at risk, cars evaluated, Clopper-Pearson lower, upper) among ``mask``."""
        sel = self.ok if mask is None else self.ok & mask
        n = int(sel.sum())
        k, (lo, hi) = self._share(self.values[sel, 2], n)
        return k, n, lo, hi

    def risk_against_tolerance(self, key: str, n: int = 8) -> list[dict]:
        """Risk among the cars whose ``key`` lies within +-tol of its centre, for growing tol.

        Conditioning on the samples within tolerance is the fleet built to that tolerance
        (the distribution truncated there), with the same samples."""
        j = self.keys.index(key)
        dev = np.abs(self.samples[:, j] - self.spec.parameter[j].center)
        rows = []
        for tol in np.quantile(dev, np.linspace(1.0 / n, 1.0, n)):
            k, m, lo, hi = self.risk_ci(dev <= tol)
            rows.append({"tolerance": float(tol), "cars": m, "risk": k / m if m else np.nan, "ci": [lo, hi]})
        return rows

    def summary(self) -> dict:
        ok = self.ok
        k, n, lo, hi = self.risk_ci()
        v = self.values[ok]

        def quantiles(col):
            x, at_end = self._inside_range(v[:, col])
            out = {f"p{q}": float(np.percentile(x, q)) for q in (5, 50, 95)} if x.size else {}
            return out | {"n": int(x.size), "n_at_range_end": at_end}

        hard, hard_ci = self._share(v[:, 3], n)
        gap, gap_ci = self._share(v[:, 6], n)
        gap_sev, gap_sev_ci = self._share(v[:, 7], n)
        drivers = main_effects(self.samples[ok], v[:, 2]) if n > 2 * N_BINS else np.full(len(self.keys), np.nan)
        classifier = self._classifier
        failures: dict[str, int] = {}
        for c in self.outcomes:
            if not c.ok:
                failures[c.failure] = failures.get(c.failure, 0) + 1
        failed_cars = [{"car": i, "reason": c.status} for i, c in enumerate(self.outcomes) if not c.ok]
        return with_deprecated_keys({
            "model": self.params.model,
            "n_samples": len(self.outcomes),
            "n_evaluated": n,
            "failed_samples": len(self.outcomes) - n,
            "failures": failures,
            "failed_cars": failed_cars[:LISTED_FAILURES],
            "risk_probability": k / n if n else None,
            "risk_ci": [lo, hi],
            "confidence": self.confidence,
            "hard_excitation_share": hard / n if n else None,
            "hard_excitation_ci": list(hard_ci),
            "gap_after_pd_ns_share": gap / n if n else None,
            "gap_after_pd_ns_ci": list(gap_ci),
            "gap_sev_share": gap_sev / n if n and self.spec.simulate_gaps else None,
            "gap_sev_ci": list(gap_sev_ci) if self.spec.simulate_gaps else None,
            "first_bifurcation_speed_kmh": quantiles(0),
            "second_bifurcation_speed_kmh": quantiles(1),
            "fast_path_share": float(np.mean(v[:, 4])) if n else None,
            **self._path_summary(),
            "drivers_main_effect": {key: (None if not np.isfinite(d) else float(d)) for key, d in
                                    zip(self.keys, drivers)},
            "drivers_importance": None if classifier is None else {
                key: float(d) for key, d in zip(self.keys, classifier["importance"])},
            "drivers_classifier": None if classifier is None else {
                "model": "gradient-boosted trees (scikit-learn HistGradientBoostingClassifier)",
                "held_out_auc": classifier["auc"], "n_fit": classifier["n_fit"], "n_test": classifier["n_test"],
                "importance_std": {key: float(d) for key, d in zip(self.keys, classifier["std"])}},
            "usage": [u.model_dump() for u in self.spec.usage],
            **self._wear_summary(v, n),
            "settings": self.settings,
        }, RENAMED_KEYS)

    @cached_property
    def _classifier(self) -> dict | None:
        """:func:`classifier_importances` of the risk over the evaluated cars (fitted once)."""
        ok = self.ok
        return classifier_importances(self.samples[ok], self.values[ok, 2], self.spec.seed) if ok.any() else None

    def _share(self, flags, n) -> tuple[int, tuple[float, float]]:
        """(cars flagged, exact binomial interval of their share at ``confidence``) among ``n`` evaluated."""
        k = int(np.nansum(flags)) if n else 0
        if not n:
            return k, (np.nan, np.nan)
        from scipy.stats import binomtest

        c = binomtest(k, n).proportion_ci(self.confidence, method="exact")
        return k, (float(c.low), float(c.high))

    def _path_summary(self) -> dict:
        """Cars per path (:data:`PATHS`) and the fallbacks to the full path by reason tag."""
        paths = {name: 0 for name in PATHS}
        reasons: dict[str, int] = {}
        for c in self.outcomes:
            if c.path:
                paths[c.path] += 1
                if c.path == "full":
                    reasons[c.fallback] = reasons.get(c.fallback, 0) + 1
        return {"paths": paths, "fallback_reasons": dict(sorted(reasons.items(), key=lambda kv: -kv[1]))}

    def _inside_range(self, speeds) -> tuple[np.ndarray, int]:
        """Finite speeds strictly inside the speed range, and how many sit at a range end
        (the band reaches it: the true bifurcation speed lies beyond, censored)."""
        lo, hi = self.spec.speed_range_kmh
        x = speeds[np.isfinite(speeds)]
        at_end = np.isclose(x, lo, rtol=1e-12) | np.isclose(x, hi, rtol=1e-12)
        return x[~at_end], int(at_end.sum())

    def _wear_summary(self, v, n) -> dict:
        """The wear risk within ``spec.wear_km`` (its exact interval) over the cars whose
        evolution ended within its step budget, the cars over the budget (counted, listed
        with their parameters), the most dangerous order, the visible distances and the
        drivers, as the band risk's (None without it)."""
        D = self.spec.wear_km
        if D is None or n == 0:
            return {"wear_risk_probability": None, "wear_risk_ci": None}
        evaluated = self.ok
        over = [i for i, c in enumerate(self.outcomes) if c.ok and c.wear]
        evaluated[over] = False
        budget = {"wear_max_steps": wear_step_budget(D, self.spec.wear_max_steps),
                  "wear_max_revolutions": self.spec.wear_max_revolutions, "wear_over_budget": len(over),
                  "wear_over_budget_cars": [
                      {"car": i, "reason": self.outcomes[i].wear,
                       "parameters": {key: float(x) for key, x in zip(self.keys, self.samples[i])}}
                      for i in over[:LISTED_FAILURES]]}
        v, X, n = self.values[evaluated], self.samples[evaluated], int(evaluated.sum())
        if n == 0:
            return {"wear_km": D, "wear_risk_probability": None, "wear_risk_ci": None, **budget}
        visible = v[:, 5] < D
        k, ci = self._share(visible, n)
        orders, counts = np.unique(v[visible, 8].astype(int), return_counts=True)
        drivers = main_effects(X, visible.astype(float)) if n > 2 * N_BINS else np.full(len(self.keys), np.nan)
        classifier = classifier_importances(X, visible, self.spec.seed)
        seen = v[visible, 5]
        return {
            "wear_km": D, "wear_cycle": [{"speed_kmh": s, "share": w} for s, w in self.spec.usage_cycle()],
            "wear_risk_probability": k / n, "wear_risk_ci": list(ci), "wear_n_evaluated": n, **budget,
            "wear_most_dangerous_order": int(orders[np.argmax(counts)]) if k else None,
            "wear_orders": {str(o): int(c) for o, c in zip(orders, counts)},
            "wear_visible_km": {f"p{q}": float(np.percentile(seen, q)) for q in (5, 50, 95)} if k else {},
            "wear_drivers_main_effect": {key: (None if not np.isfinite(d) else float(d)) for key, d in
                                         zip(self.keys, drivers)},
            "wear_drivers_importance": None if classifier is None else {
                key: float(d) for key, d in zip(self.keys, classifier["importance"])},
            "wear_drivers_classifier": None if classifier is None else {
                "held_out_auc": classifier["auc"], "n_fit": classifier["n_fit"], "n_test": classifier["n_test"]},
            "wear_distances_scale_as": "1/k_e",
        }

    def _dataset(self):
        """Every car: sampled parameters, outputs, status, path and wear note (``fleet_spec_json`` attr)."""
        import xarray as xr

        return xr.Dataset(
            {"sample": (("car", "param"), self.samples), "value": (("car", "output"), self.values),
             "status": ("car", np.array(self.status, dtype=str)), "path": ("car", np.array(self.paths, dtype=str)),
             "wear_note": ("car", np.array([c.wear for c in self.outcomes], dtype=str))},
            coords={"param": self.keys, "output": list(OUTPUTS)},
            attrs={"fleet_spec_json": self.spec.model_dump_json()},
        )

    def to_dataframe(self):
        """One row per car: the sampled parameters, the outputs, status, path and wear note
        (why a car has no wear result: over the step budget; else empty)."""
        import pandas as pd

        df = pd.DataFrame(self.samples, columns=self.keys)
        for j, name in enumerate(OUTPUTS):
            df[name] = self.values[:, j]
        df["status"] = self.status
        df["path"] = self.paths
        df["wear_note"] = [c.wear for c in self.outcomes]
        return df

    def plot(self, ax=None):
        """Histograms of the first and second bifurcation speeds and the usage speeds. Returns artists."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(7, 3.5))
        v = self.values[self.ok]
        artists = []
        for col, label in ((0, "first bifurcation speed"), (1, "second bifurcation speed")):
            x, at_end = self._inside_range(v[:, col])
            if at_end:
                label += f" ({at_end} cars at the range end, not shown)"
            if x.size:
                artists.append(ax.hist(x, bins=40, alpha=0.6, label=label)[2])
        for u in self.spec.usage:
            if u.share > 0:
                artists.append(ax.axvline(u.speed_kmh, color="k", ls="--", lw=1))
        k, n, lo, hi = self.risk_ci()
        ax.set_title(f"{self.params.model}: risk {k}/{n} = {k / max(n, 1):.3f} [{lo:.3f}, {hi:.3f}]", fontsize=10)
        ax.set_xlabel("speed [km/h]")
        ax.set_ylabel("cars")
        ax.legend(fontsize=8)
        return artists

    def plot_drivers(self, ax=None):
        """Bars per parameter: main effect on the risk and the classifier's importance (where
        there is one). Returns artists."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(5, 3.5))
        s = self.summary()
        names = [k.split(".")[-1] for k in self.keys]
        y = np.arange(len(names))
        main = [np.nan if v is None else v for v in s["drivers_main_effect"].values()]
        artists = [ax.barh(y - 0.2, main, height=0.4, label="main effect")]
        if s["drivers_importance"] is not None:
            auc = s["drivers_classifier"]["held_out_auc"]
            artists.append(ax.barh(y + 0.2, list(s["drivers_importance"].values()), height=0.4,
                                   label=f"importance (AUC drop; classifier AUC {auc:.2f})"))
        ax.set_yticks(y, names, fontsize=8)
        ax.invert_yaxis()
        ax.set_xlabel("share of the risk's variance / AUC drop")
        ax.set_title("what drives the risk", fontsize=10)
        ax.legend(fontsize=7)
        return artists

    def figure(self, tolerance_key: str | None = None):
        """Speed histograms, the risk against the tolerance of ``tolerance_key`` (toe if
        varied), and the drivers of the risk (:meth:`plot_drivers`)."""
        import matplotlib.pyplot as plt

        key = tolerance_key or next((k for k in self.keys if "toe" in k), self.keys[0])
        fig, (a, b, c) = plt.subplots(1, 3, figsize=(16, 3.8), width_ratios=(1.2, 1.0, 0.9))
        self.plot(a)
        self.plot_drivers(c)
        rows = self.risk_against_tolerance(key)
        tol = [r["tolerance"] for r in rows]
        b.errorbar(tol, [r["risk"] for r in rows],
                   yerr=np.abs(np.array([[r["risk"] - r["ci"][0], r["ci"][1] - r["risk"]] for r in rows]).T),
                   marker="o", capsize=3)
        b.set_xlabel(f"tolerance of {key} (+- around its centre)")
        b.set_ylabel("risk probability")
        b.set_title("risk of a fleet built to that tolerance", fontsize=10)
        fig.tight_layout()
        return fig


CHECKPOINT_FILE = "fleet_checkpoint.npz"
"""The checkpoint's file in the checkpoint folder."""


def _checkpoint_path(out_dir: Path) -> Path:
    return Path(out_dir) / CHECKPOINT_FILE


def _pilot_progress(progress: Progress | None, done: int, samples: int) -> Progress | None:
    """The pilot stage's progress as messages at ``done`` of ``samples`` cars (no car is finished by it)."""
    if progress is None:
        return None
    forward = progress

    def pilot(k: float, n: float | None, message: str = "") -> None:
        forward(done, samples, f"pilot: {k:.0f} of {n} references by full continuation")

    return pilot


def fleet(params: Params, spec: FleetSpec, *, backend: str | None = None, workers: int | None = None,
          scheduler: str | None = None, batch_size: int | None = None, executor: Executor | None = None,
          checkpoint_dir: str | Path | None = None, resume: bool = False, progress: Progress | None = None,
          reference: BandReference | None = None, pilot: bool = True, wear_km: float | None = None) -> FleetResult:
    """Evaluate the fleet; ``wear_km`` [km] sets ``spec.wear_km`` (the wear risk within that
    distance: every car's wear evolved on the usage cycle). With ``checkpoint_dir`` save every ``spec.checkpoint_every`` cars
    (``resume`` continues from the checkpoint, which must belong to the same params and spec).
    The cars run on ``executor`` (:class:`~polywear.parallel.Executor`), or on the one made of
    ``backend`` (default ``"processes"``), ``workers``, ``scheduler`` and ``batch_size`` (give
    either). Every round of ``checkpoint_every`` cars is one ``executor.map`` call (a new
    pool on the ``processes`` backend); without ``checkpoint_dir`` all cars are one round.
    First the pilot stage (:func:`~polywear.studies.fast_band.pilot_stage`, on the same
    executor in its default batches; a resumed run solves it again): the nominal car, unless its ``reference`` is
    given, and with ``pilot`` evenly spaced cars (off: the nominal reference alone).
    ``progress`` (:mod:`polywear.progress`): cars done of ``spec.samples``; during the
    pilot stage the references done in the message."""
    from .fast_band import FastBand, pilot_stage

    executor = Executor.from_options(backend, workers, scheduler, batch_size, executor)
    if wear_km is not None:
        spec = FleetSpec.model_validate(spec.model_dump() | {"wear_km": wear_km})
    keys = tuple(q.key for q in spec.parameter)
    X = sample_fleet(spec)
    digest = _spec_hash(params, spec)
    ckpt = _checkpoint_path(checkpoint_dir) if checkpoint_dir else None
    data = None
    if resume and ckpt is not None and ckpt.exists():
        data = np.load(ckpt, allow_pickle=False)
        if str(data["digest"]) != digest:
            raise ParameterError(f"{ckpt}: checkpoint of another parameter set or spec; remove it or drop --resume")
        if not set(CAR_FIELDS) <= set(data.files):
            raise ParameterError(f"{ckpt}: checkpoint of an older polywear (no per-car outcomes or wear budget); "
                                 "remove it or drop --resume")
        if "pilot" not in data.files:
            raise ParameterError(f"{ckpt}: checkpoint of an older polywear (no pilot stage); remove it or drop --resume")
        if data["values"].shape[1] != len(OUTPUTS):
            raise ParameterError(f"{ckpt}: checkpoint of an older polywear (other outputs per car); "
                                 "remove it or drop --resume")
    done = int(data["done"]) if data is not None else 0
    nominal = reference if reference is not None else sample_params(params, keys, [q.center for q in spec.parameter])
    stage = pilot_stage(params, keys, X if pilot else X[:0], nominal, spec.speed_range_kmh,
                        executor=replace(executor, batch_size=None),
                        progress=_pilot_progress(progress, done, spec.samples))
    if stage.nominal is None:  # no fleet without its nominal car
        raise RuntimeError(f"nominal car: {stage.failed[0]}")
    pilot_cars = np.array(sorted(stage.samples), dtype=int)
    if data is not None and not np.array_equal(data["pilot"], pilot_cars):
        raise ParameterError(f"{ckpt}: checkpoint with other pilot cars; remove it or drop --resume")
    solver = FastBand(stage.references, speed_range_kmh=tuple(spec.speed_range_kmh))
    usage = tuple(u.speed_kmh for u in spec.usage if u.share > 0)
    evaluator = FleetEvaluator(params, keys, solver, usage, wear_km=spec.wear_km, wear_max_steps=spec.wear_max_steps,
                               wear_max_revolutions=spec.wear_max_revolutions,
                               usage_cycle=spec.usage_cycle(),
                               band_every=spec.band_every, simulate_gaps=spec.simulate_gaps,
                               pilot={i: r.band for i, r in stage.samples.items()})
    values = np.full((spec.samples, len(OUTPUTS)), np.nan)
    outcomes: list[CarOutcome] = []
    if data is not None:
        values[:done] = data["values"][:done]
        outcomes = [CarOutcome(*(str(v) for v in row)) for row in zip(*(data[name][:done] for name in CAR_FIELDS))]
        report(progress)(done, spec.samples)
    every = spec.checkpoint_every if ckpt is not None else spec.samples  # no checkpoint: one round
    for start in range(len(outcomes), spec.samples, every):
        chunk = X[start:start + every]
        results = executor.map(evaluator, list(enumerate(chunk, start)), shifted(progress, start, spec.samples))
        values[start:start + len(chunk)] = [r[0] for r in results]
        outcomes += [r[1] for r in results]
        if ckpt is not None:
            from ..io import atomic_path

            with atomic_path(ckpt) as tmp:
                with open(tmp, "wb") as fh:
                    columns = {name: np.array([getattr(c, name) for c in outcomes], dtype=str) for name in CAR_FIELDS}
                    np.savez(fh, digest=digest, done=len(outcomes), values=values, pilot=pilot_cars, **columns)
    return FleetResult(params=params, spec=spec, samples=X, values=values, outcomes=outcomes,
                       settings={"backend": executor.backend, "seed": spec.seed, "samples": spec.samples,
                                 "reference_unusable": stage.nominal.unusable or None,
                                 "pilot_cars": len(pilot_cars), "pilot_failed": len(stage.failed)})
