"""The fleet spec: which parameters vary from car to car and how, the usage cycle, and
the run's settings (a TOML file, :class:`FleetSpec`); :func:`sample_fleet` draws the cars.

Distributions: normal, uniform, truncated normal, lognormal, discrete mixtures (road
types, load cases). Correlations go through a Gaussian copula: correlated standard
normals ``z = L e`` with ``L L^T = R``, then each marginal by its inverse CDF of
``Phi(z)``; ``R`` is the correlation of the normal scores.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from ..keys import get_value, with_updates
from ..params import CYCLE_SHARE_TOLERANCE, MAX_WEAR_KM, ParameterError, Params, parse_override
from ..units import FLEET_SPEED_RANGE_KMH

__all__ = ["FleetParameter", "FleetUsage", "FleetCorrelation", "FleetSpec", "load_fleet_spec", "sample_fleet",
           "WEAR_MAX_STEPS", "WEAR_MAX_REVOLUTIONS"]

WEAR_MAX_STEPS = 200
"""Default budget of one car's wear evolution [distance steps], beyond the fewest steps the
distance takes at the longest step (``ceil(D / 8 000 km)``). On the 110/130 km/h cycle
over 60 000 km most cars take 19-67 steps (0.1-0.2 s CPU each), a car locked at order 9
whose growth holds the steps at 35-760 km 132; a car whose vibration stays a few
thousandths off an integer order without locking takes steps of ~10 km (thousands of
steps, about an hour of CPU; stopped at the budget after ~1.5 min)."""
WEAR_MAX_REVOLUTIONS = 100_000
"""Work budget of one car's wear evolution [simulated revolutions, summed over its windows],
about 2 min of CPU for tread1dof: fleet car 11 of the 40-car sample (a vibration 0.0035 off
order 8, windows of ~860 revolutions) takes 16 000 over 60 000 km; car 187 of the 1 000-car
benchmark (within a thousandth of order 7 at 130 km/h, windows of up to 1 024 revolutions)
decides after 52 174 (visible at 30 718 km, 74 s CPU; before docs/wear.md point 13 it
reached 28 km in 310 s) [-]."""


class _Spec(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class FleetParameter(_Spec):
    """Distribution of one parameter over the fleet (units of the key)."""

    key: str
    distribution: Literal["normal", "uniform", "truncnormal", "lognormal", "discrete"]
    mean: float | None = None
    std: float | None = Field(None, gt=0.0)
    low: float | None = None
    high: float | None = None
    values: tuple[float, ...] = ()
    weights: tuple[float, ...] = ()

    @model_validator(mode="after")
    def _complete(self):
        where = f"fleet.parameter {self.key}"
        need = {"normal": ("mean", "std"), "lognormal": ("mean", "std"), "uniform": ("low", "high"),
                "truncnormal": ("mean", "std", "low", "high"), "discrete": ()}[self.distribution]
        for name in need:
            if getattr(self, name) is None:
                raise ParameterError(f"{where}: {self.distribution} needs {name}")
        if self.low is not None and self.high is not None and not self.low < self.high:
            raise ParameterError(f"{where}: low = {self.low} must be below high = {self.high}")
        if self.distribution == "lognormal" and self.mean <= 0.0:
            raise ParameterError(f"{where}: lognormal needs mean > 0")
        if self.distribution == "discrete":
            if not self.values or len(self.weights) != len(self.values):
                raise ParameterError(f"{where}: discrete needs values and as many weights")
            if min(self.weights) < 0.0 or not sum(self.weights) > 0.0:
                raise ParameterError(f"{where}: weights must be >= 0 with a positive sum")
        return self

    @property
    def center(self) -> float:
        """Value of the nominal car (the warm start): mean, or the weighted mean of discrete values."""
        if self.distribution == "discrete":
            return float(np.average(self.values, weights=self.weights))
        if self.distribution == "uniform":
            return 0.5 * (self.low + self.high)
        return float(self.mean)

    def ppf(self, u: np.ndarray) -> np.ndarray:
        """Inverse CDF at probabilities ``u`` in (0, 1)."""
        from scipy import stats

        if self.distribution == "normal":
            return stats.norm.ppf(u, self.mean, self.std)
        if self.distribution == "uniform":
            return self.low + u * (self.high - self.low)
        if self.distribution == "truncnormal":
            a, b = (self.low - self.mean) / self.std, (self.high - self.mean) / self.std
            return stats.truncnorm.ppf(u, a, b, loc=self.mean, scale=self.std)
        if self.distribution == "lognormal":  # mean and std of the value itself
            s2 = math.log1p((self.std / self.mean) ** 2)
            return stats.lognorm.ppf(u, math.sqrt(s2), scale=self.mean * math.exp(-0.5 * s2))
        cdf = np.cumsum(self.weights) / np.sum(self.weights)
        return np.asarray(self.values)[np.minimum(np.searchsorted(cdf, u, side="right"), len(cdf) - 1)]


class FleetUsage(_Spec):
    """Share of the distance driven at a speed."""

    speed_kmh: float = Field(gt=0.0, le=1000.0)
    share: float = Field(gt=0.0, le=1.0)


class FleetCorrelation(_Spec):
    """Correlation matrix of the normal scores of some parameters (Gaussian copula)."""

    keys: tuple[str, ...]
    matrix: tuple[tuple[float, ...], ...]


class FleetSpec(_Spec):
    """The ``[fleet]`` table of a fleet spec file."""

    samples: int = Field(10000, ge=1, le=10_000_000)
    seed: int = Field(0, ge=0)
    checkpoint_every: int = Field(2000, ge=1)
    parameter: tuple[FleetParameter, ...]
    usage: tuple[FleetUsage, ...]
    correlation: FleetCorrelation | None = None
    speed_range_kmh: tuple[float, float] = FLEET_SPEED_RANGE_KMH
    band_every: int = Field(1, ge=1)
    """Every k-th car gets its whole band (both bifurcation speeds); the others only what
    their risk needs: the Hopf points, and the folds only where a fold's position decides
    whether a usage speed lies in the band. Risk and hard share stay exact for every car."""
    wear_km: float | None = Field(None, gt=0.0, le=MAX_WEAR_KM)
    """With it, every car's wear is evolved over this distance [km] on the usage cycle:
    the wear risk is the share of cars whose polygon becomes visible within it."""
    wear_max_steps: int = Field(WEAR_MAX_STEPS, ge=1, le=100_000)
    """Budget of one car's wear evolution [distance steps] beyond ``ceil(wear_km / 8 000 km)``:
    a car that would need more is counted in ``wear_over_budget``, listed with its
    parameters, and kept out of the wear risk (:data:`WEAR_MAX_STEPS`)."""
    wear_max_revolutions: int = Field(WEAR_MAX_REVOLUTIONS, ge=1, le=100_000_000)
    """Work budget of one car's wear evolution [simulated revolutions, summed over its
    windows]: a car whose windows need more is counted in ``wear_over_budget`` like one over
    its step budget (:data:`WEAR_MAX_REVOLUTIONS`)."""
    simulate_gaps: bool = False
    """Decide a car with a usage speed in a gap of its band after a period doubling or torus
    bifurcation by simulation, as the verdict does (runs from the stable cycle of its diagram
    nearest in speed and from steady rolling disturbed, a few seconds per car): the
    share where the tread ends in SEV is ``gap_sev_share``."""

    @model_validator(mode="after")
    def _consistent(self):
        keys = [q.key for q in self.parameter]
        if not keys:
            raise ParameterError("fleet.parameter: give at least one [[fleet.parameter]]")
        if len(set(keys)) != len(keys):
            raise ParameterError("fleet.parameter: a key is given twice")
        if not self.usage:
            raise ParameterError("fleet.usage: give [[fleet.usage]] speeds with their shares")
        total = math.fsum(u.share for u in self.usage)
        if abs(total - 1.0) > CYCLE_SHARE_TOLERANCE:
            raise ParameterError(f"fleet.usage: shares sum to {total:.6g}: must sum to 1 (within {CYCLE_SHARE_TOLERANCE})")
        speeds = [u.speed_kmh for u in self.usage]
        if len(set(speeds)) != len(speeds):
            raise ParameterError("fleet.usage: a speed_kmh is given more than once")
        lo, hi = self.speed_range_kmh
        if not 0.0 < lo < hi:
            raise ParameterError(f"fleet.speed_range_kmh = [{lo}, {hi}]: need 0 < low < high")
        for u in self.usage:
            if not lo <= u.speed_kmh <= hi:
                raise ParameterError(f"fleet.usage: speed_kmh = {u.speed_kmh} outside speed_range_kmh [{lo}, {hi}]")
        if self.correlation is not None:
            c = self.correlation
            unknown = [k for k in c.keys if k not in keys]
            if unknown:
                raise ParameterError(f"fleet.correlation: key {unknown[0]} has no [[fleet.parameter]]")
            R = np.asarray(c.matrix, dtype=float)
            if R.shape != (len(c.keys), len(c.keys)):
                raise ParameterError(f"fleet.correlation: matrix must be {len(c.keys)} x {len(c.keys)}")
            if not np.allclose(R, R.T) or not np.allclose(np.diag(R), 1.0) or np.any(np.abs(R) > 1.0):
                raise ParameterError("fleet.correlation: matrix must be symmetric with unit diagonal and |r| <= 1")
            if np.linalg.eigvalsh(R).min() <= 0.0:
                raise ParameterError("fleet.correlation: matrix is not positive definite")
        return self

    def usage_cycle(self) -> tuple[tuple[float, float], ...]:
        """(speed [km/h], share) of the usage speeds with a positive share, shares normalised to 1."""
        used = [u for u in self.usage if u.share > 0.0]
        total = math.fsum(u.share for u in used)
        return tuple((u.speed_kmh, u.share / total) for u in used)

    def correlation_matrix(self) -> np.ndarray:
        """Full correlation matrix of the normal scores, in parameter order."""
        keys = [q.key for q in self.parameter]
        R = np.eye(len(keys))
        if self.correlation is not None:
            idx = [keys.index(k) for k in self.correlation.keys]
            R[np.ix_(idx, idx)] = np.asarray(self.correlation.matrix, dtype=float)
        return R


SPEC_SETTINGS = ("samples", "seed", "checkpoint_every", "band_every", "wear_km", "wear_max_steps", "wear_max_revolutions",
                 "simulate_gaps", "speed_range_kmh")
"""Keys of the ``[fleet]`` table that ``--set fleet.KEY=VALUE`` may change."""


def _spec_overrides(overrides: tuple[str, ...] | list[str]) -> dict:
    """``{"samples": 1000}`` from ``["fleet.samples=1000"]`` (one ParameterError line for a bad one)."""
    out = {}
    for item in overrides:
        key, value = parse_override(item)
        table, _, name = key.partition(".")
        if table != "fleet" or name not in SPEC_SETTINGS:
            raise ParameterError(f"{key}: not a fleet setting (fleet.{', fleet.'.join(SPEC_SETTINGS)})")
        out[name] = value
    return out


def _check_values(spec: FleetSpec, params: Params) -> None:
    """Refuse a parameter whose nominal car, or any of whose discrete values, the model
    cannot take (a car that would fail for certain, found up front)."""
    for q in spec.parameter:
        values = q.values if q.distribution == "discrete" else (q.center,)
        for value in values:
            try:
                with_updates(params, {q.key: float(value)})
            except ParameterError as exc:
                what = "discrete value" if q.distribution == "discrete" else f"{q.distribution} centre"
                raise ParameterError(f"fleet.parameter {q.key}: {what} {value:g} is not valid for the model ({exc})") from None


def load_fleet_spec(path: str | Path, params: Params, overrides: tuple[str, ...] | list[str] = ()) -> FleetSpec:
    """Read and validate the ``[fleet]`` table, with ``fleet.KEY=VALUE`` overrides of its
    settings (:data:`SPEC_SETTINGS`); every problem is one ParameterError line."""
    import tomllib

    try:
        data = tomllib.loads(Path(path).read_text())
    except FileNotFoundError:
        raise ParameterError(f"fleet spec {path}: no such file") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ParameterError(f"fleet spec {path}: not valid TOML: {exc}") from None
    if "fleet" not in data:
        raise ParameterError(f"fleet spec {path}: no [fleet] table")
    try:
        spec = FleetSpec.model_validate({**data["fleet"], **_spec_overrides(overrides)})
    except ValidationError as exc:
        err = exc.errors()[0]
        where = "fleet." + ".".join(str(x) for x in err["loc"])
        msg = err["msg"].removeprefix("Value error, ")
        raise ParameterError(msg if msg.startswith("fleet") else f"{where}: {msg}") from None
    for q in spec.parameter:
        try:
            get_value(params, q.key)
        except ParameterError:
            raise ParameterError(f"fleet.parameter: unknown key {q.key}") from None
    _check_values(spec, params)
    return spec


def sample_fleet(spec: FleetSpec) -> np.ndarray:
    """(samples, parameters) values from the copula, drawn from ``SeedSequence(spec.seed)``."""
    from scipy.stats import norm

    rng = np.random.default_rng(np.random.SeedSequence(spec.seed))
    L = np.linalg.cholesky(spec.correlation_matrix())
    z = rng.standard_normal((spec.samples, len(spec.parameter))) @ L.T
    u = np.clip(norm.cdf(z), 1e-15, 1.0 - 1e-15)
    return np.column_stack([q.ppf(u[:, j]) for j, q in enumerate(spec.parameter)])
