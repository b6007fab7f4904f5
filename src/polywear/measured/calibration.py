"""Calibration of parameters to observations, with an identifiability report.

Observations (onset speeds, Hopf frequencies, SEV band edges, friction-curve points, each
with its standard deviation and optionally its own test conditions) are fitted by weighted
least squares (:func:`scipy.optimize.least_squares`, trust-region reflective, bounds from
the parameter validation) with the exact sensitivities as the Jacobian: the implicit
function theorem on the Hopf and fold defining systems
(:mod:`polywear.dynamics.sensitivity`), the analytic derivative of the steady friction
curve. The fit is followed by an identifiability analysis of the weighted Jacobian in
relative units (``d r_i / d ln p_j``): singular values and vectors (which combinations
of the parameters the data determine, which they do not), correlations, linearized 95 %
intervals, and profile-likelihood 95 % intervals (``chi^2`` raised by 3.84 with the
other parameters refitted). A parameter that moves along an undetermined combination is
not reported as a number.
"""

from __future__ import annotations

import math
import tomllib
import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..friction.fits import MAX_FRICTION_COEFFICIENT
from ..friction.loops import MAX_SLIDING_SPEED_M_PER_S
from ..models import model_for
from ..results import Result
from ..keys import KEYS, study_keys
from ..params import ParameterError, Params, get_value, with_updates
from ..progress import Progress, StepCounter
from ..settings import check_count, check_positive
from ..units import MAX_SPEED_KMH, STABILITY_SPEED_RANGE_KMH, frequency_order, kmh_to_ms, ms_to_kmh

__all__ = [
    "QUANTITIES",
    "CalibrationError",
    "Observation",
    "CalibrationResult",
    "CalibrationSettings",
    "read_observations",
    "predict",
    "calibrate",
]

QUANTITIES = {
    "first_hopf_kmh": "speed of the lowest Hopf point of steady rolling (linear onset) [km/h]",
    "second_hopf_kmh": "speed of the second Hopf point (end of the linear band) [km/h]",
    "hopf_frequency_hz": "frequency at the lowest Hopf point [Hz]",
    "second_hopf_frequency_hz": "frequency at the second Hopf point [Hz]",
    "first_bifurcation_speed_kmh": "lower end of the SEV band (Hopf point or fold; continuation) [km/h]",
    "second_bifurcation_speed_kmh": "upper end of the SEV band (Hopf point or fold; continuation) [km/h]",
    "amplitude_x_mm": "lateral tread amplitude (half peak-to-peak of x) of the largest stable cycle at at_speed_kmh "
                    "[mm] (continuation)",
    "cycle_frequency_hz": "frequency of the largest stable cycle at at_speed_kmh [Hz] (continuation)",
    "frequency_order": "SEV frequency over the wheel's rotation frequency, f 2 pi R_e / V, at at_speed_kmh [-] "
                     "(continuation)",
    "friction_mu": "steady friction coefficient mu_ss at at_sliding_speed_m_per_s [-]",
}
"""Observable quantities calibrate can fit, and their units."""
RENAMED_QUANTITIES = {"first_bifurcation_kmh": "first_bifurcation_speed_kmh",
                      "second_bifurcation_kmh": "second_bifurcation_speed_kmh",
                      "amplitude_mm": "amplitude_x_mm", "polygon_order": "frequency_order"}
"""Old -> new quantity names that observation files may still use until the next release."""

_HOPF = {"first_hopf_kmh": (0, "speed"), "second_hopf_kmh": (1, "speed"),
         "hopf_frequency_hz": (0, "frequency"), "second_hopf_frequency_hz": (1, "frequency")}
_BAND = {"first_bifurcation_speed_kmh": "first_bifurcation", "second_bifurcation_speed_kmh": "second_bifurcation"}
_CYCLE = ("amplitude_x_mm", "cycle_frequency_hz", "frequency_order")
CHI2_95 = 3.841458820694124
"""chi^2 quantile (1 degree of freedom) of a 95 % profile-likelihood interval."""
Z_95 = 1.959963984540054
"""Normal quantile of a 95 % linearized interval."""


class CalibrationError(InputError, ParameterError):
    """The observations or the request cannot be fitted (one line)."""


@dataclass(frozen=True)
class CalibrationSettings:
    """Numerical settings of :func:`calibrate` and :func:`predict`."""

    n_speeds: int = 200
    """Grid speeds bracketing the Hopf points (then located to 1e-10 m/s), at least 3."""
    undetermined_above: float = 1.0
    """A combination of relative parameter changes counts as undetermined when its
    linearized 95 % half-width exceeds this (1.0: +-100 %) or its singular value is at
    rounding level [-]."""

    def __post_init__(self) -> None:
        check_count(self, "n_speeds", minimum=3)
        check_positive(self, "undetermined_above")


@dataclass(frozen=True)
class Observation:
    """One observed quantity with its standard deviation and test conditions.

    ``set`` holds the ``{"table.key": value}`` conditions of that test that differ from the
    parameter set (e.g. another toe angle).
    """

    quantity: str
    value: float
    sigma: float
    at_speed_kmh: float | None = None
    at_sliding_speed_m_per_s: float | None = None
    set: tuple[tuple[str, Any], ...] = ()
    label: str = ""

    def describe(self) -> str:
        where = ", ".join(f"{k}={v}" for k, v in self.set)
        at = f" at {self.at_sliding_speed_m_per_s} m/s" if self.at_sliding_speed_m_per_s is not None else ""
        return self.label or f"{self.quantity}{at}" + (f" ({where})" if where else "")


_FIELDS = {"quantity", "value", "sigma", "at_speed_kmh", "at_sliding_speed_m_per_s", "set", "label"}


def _number(entry: dict, name: str, where: str, required: bool = True) -> float | None:
    value = entry.get(name)
    if value is None:
        if required:
            raise CalibrationError(f"{where}: {name} missing")
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise CalibrationError(f"{where}: {name} = {value!r}: must be a finite number")
    return float(value)


def read_observations(path: str | Path, params: Params | None = None) -> list[Observation]:
    """Observations from a TOML file of ``[[observation]]`` tables (see docs/calibrate.md).

    Every entry is checked (known quantity, sigma > 0, the conditions valid for
    ``params``); problems are one-line :class:`CalibrationError`.
    """
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise CalibrationError(f"{path}: cannot read observation file ({exc.strerror})") from None
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise CalibrationError(f"{path}: not a valid TOML observation file ({exc})") from None
    entries = data.get("observation")
    if not isinstance(entries, list) or not entries:
        raise CalibrationError(f"{path}: no [[observation]] tables")
    unknown_top = sorted(set(data) - {"observation"})
    if unknown_top:
        raise CalibrationError(f"{path}: unknown table {unknown_top[0]!r} (only [[observation]])")
    out = []
    for i, entry in enumerate(entries, start=1):
        where = f"{path}: observation {i}"
        extra = sorted(set(entry) - _FIELDS)
        if extra:
            raise CalibrationError(f"{where}: unknown field {extra[0]!r} (known: {', '.join(sorted(_FIELDS))})")
        quantity = entry.get("quantity")
        if quantity in RENAMED_QUANTITIES:
            warnings.warn(f"{where}: quantity {quantity!r} is now {RENAMED_QUANTITIES[quantity]!r}; the old name "
                          "goes in the next release", FutureWarning, stacklevel=2)
            quantity = RENAMED_QUANTITIES[quantity]
        if quantity not in QUANTITIES:
            raise CalibrationError(f"{where}: quantity = {quantity!r} is not one calibrate fits "
                                   f"(supported: {', '.join(QUANTITIES)})")
        sigma = _number(entry, "sigma", where)
        if not sigma > 0.0:
            raise CalibrationError(f"{where}: sigma = {sigma!r}: must be positive")
        at_v = _number(entry, "at_sliding_speed_m_per_s", where, required=quantity == "friction_mu")
        at_speed = _number(entry, "at_speed_kmh", where, required=quantity in _CYCLE)
        if at_speed is not None and not 0.0 < at_speed <= MAX_SPEED_KMH:
            raise CalibrationError(f"{where}: at_speed_kmh = {at_speed!r}: must be in (0, {MAX_SPEED_KMH:g}] km/h")
        value = _number(entry, "value", where)
        if quantity.endswith("_kmh") and not 0.0 < value <= MAX_SPEED_KMH:
            raise CalibrationError(f"{where}: {quantity} value = {value!r}: a speed must be in (0, {MAX_SPEED_KMH:g}] km/h")
        if quantity == "friction_mu" and not 0.0 < value <= MAX_FRICTION_COEFFICIENT:
            raise CalibrationError(f"{where}: friction_mu value = {value!r}: must be in (0, {MAX_FRICTION_COEFFICIENT:g}]")
        if at_v is not None and not 0.0 < at_v <= MAX_SLIDING_SPEED_M_PER_S:
            raise CalibrationError(f"{where}: at_sliding_speed_m_per_s = {at_v!r}: must be in "
                                   f"(0, {MAX_SLIDING_SPEED_M_PER_S:g}] m/s")
        conditions = entry.get("set", {})
        if not isinstance(conditions, dict):
            raise CalibrationError(f"{where}: set must be a table of \"table.key\" = value")
        if params is not None and conditions:
            try:
                with_updates(params, conditions)
            except ParameterError as exc:
                raise CalibrationError(f"{where}: set: {exc}") from None
        out.append(Observation(
            quantity=quantity,
            value=value,
            sigma=sigma,
            at_speed_kmh=at_speed,
            at_sliding_speed_m_per_s=at_v,
            set=tuple(sorted(conditions.items())),
            label=str(entry.get("label", "")),
        ))
    return out


# -- the model's predictions and their exact derivatives ------------------------------
def _friction_point(params: Params, v: float) -> tuple[float, dict[str, float]]:
    """mu_ss(v) = G(v) + sigma2 v at v > 0 and its partial derivatives by friction key."""
    f = params.friction
    a = v / f.stribeck_velocity_m_per_s
    e = math.exp(-(a**f.stribeck_exponent))
    drop = f.mu_static - f.mu_coulomb
    value = f.mu_coulomb + drop * e + f.sigma2_s_per_m * v
    partials = {
        "friction.mu_static": e,
        "friction.mu_coulomb": 1.0 - e,
        "friction.stribeck_velocity_m_per_s": drop * e * f.stribeck_exponent * a**f.stribeck_exponent
        / f.stribeck_velocity_m_per_s,
        "friction.stribeck_exponent": -drop * e * a**f.stribeck_exponent * math.log(a),
        "friction.sigma2_s_per_m": v,
    }
    return value, partials


def _hopf_rows(params: Params, obs: list[Observation], keys: list[str], speed_range_kmh, n_speeds):
    from ..dynamics.sensitivity import hopf_speed_derivative, parameter_direction
    from ..dynamics.stability import StabilitySettings, critical_eigenvalue_derivative, stability

    model = model_for(params)
    p = model.pack(params)
    hopfs = stability(params, speed_range_kmh, StabilitySettings(n_speeds=n_speeds)).hopf_points
    directions = [parameter_direction(model, params, key) for key in keys]
    values, rows = [], []
    for o in obs:
        index, kind = _HOPF[o.quantity]
        if index >= len(hopfs):
            values.append(math.nan)
            rows.append(np.full(len(keys), math.nan))
            continue
        h = hopfs[index]
        row = np.zeros(len(keys))
        if kind == "speed":
            values.append(h.speed_kmh)
            for j, d in enumerate(directions):
                row[j] = ms_to_kmh(hopf_speed_derivative(model, p, h, d))
        else:
            values.append(h.frequency_hz)
            dlam_dv = critical_eigenvalue_derivative(model, h.u, h.speed_ms, p, h.q, h.w, dV=1.0)
            for j, d in enumerate(directions):
                if not np.any(d):
                    continue
                dlam = critical_eigenvalue_derivative(model, h.u, h.speed_ms, p, h.q, h.w, dp=d)
                dv = -dlam.real / dlam_dv.real  # the Hopf point moves along the speed
                row[j] = (dlam.imag + dlam_dv.imag * dv) / (2.0 * math.pi)
        rows.append(row)
    return values, rows


def _band_rows(params: Params, obs: list[Observation], keys: list[str], diagram):
    from ..dynamics.sensitivity import sensitivity

    sens = sensitivity(params, keys, diagram=diagram).rows
    values, rows = [], []
    for o in obs:
        name = _BAND[o.quantity]
        mine = [r for r in sens if r["quantity"] == name]
        if not mine:
            values.append(math.nan)
            rows.append(np.full(len(keys), math.nan))
            continue
        values.append(mine[0]["speed_kmh"])
        by_key = {r["param"]: r["derivative"] for r in mine}
        rows.append(np.array([by_key[k] for k in keys], dtype=float))
    return values, rows


def _cycle_derivatives(model, p, orbit, directions) -> list[tuple[float, float]]:
    """(d amplitude_x [m], d period [s]) of a cycle at fixed speed along each direction.

    The collocation system ``G(X, p) = 0`` with the phase condition and ``V`` fixed is
    differentiated: ``A dX = -G_p`` (``A`` the bordered Newton matrix), ``G_p`` from the
    complex-step derivative of the right-hand side at the Gauss points. The amplitude's
    derivative is the central difference of the amplitude along the linear change of the
    nodes (the extrema move smoothly), no re-solve.
    """
    from scipy.sparse.linalg import splu

    from ..solvers.collocation import Collocation
    from ..dynamics.derivatives import rhs_directional

    coll = Collocation(model, p, orbit.mesh, orbit.m)
    X = coll.pack(orbit)
    border = np.zeros((2, coll.size))
    border[0] = coll.phase_row(orbit)
    border[1, -1] = 1.0
    lu = splu(coll.sparse_matrix(X, border))
    states = coll.gauss_states(orbit)
    x = model.index("x")
    out = []
    for d in directions:
        if not np.any(d):
            out.append((0.0, 0.0))
            continue
        gp = np.concatenate([-orbit.period * rhs_directional(model, u, orbit.speed, p, dp=d) for u in states])
        rhs = np.zeros(coll.size)
        rhs[: gp.size] = -gp
        dX = lu.solve(rhs)
        dnodes = dX[:-2].reshape(orbit.nodes.shape)
        eps = 1e-6 * np.max(np.abs(orbit.nodes[:, x])) / max(np.max(np.abs(dnodes[:, x])), 1e-300)
        amp = [replace(orbit, nodes=orbit.nodes + s * eps * dnodes).amplitude()[x] for s in (1.0, -1.0)]
        out.append(((amp[0] - amp[1]) / (2.0 * eps), float(dX[-2])))
    return out


def _cycle_rows(params: Params, obs: list[Observation], keys: list[str], diagram):
    from ..dynamics.sensitivity import parameter_direction

    model = model_for(params)
    p = model.pack(params)
    directions = [parameter_direction(model, params, key) for key in keys]
    x = model.index("x")
    values, rows = [], []
    for o in obs:
        stable = [c for c in diagram.cycles_at(o.at_speed_kmh) if c.stable and c.orbit is not None]
        if not stable:
            values.append(math.nan)
            rows.append(np.full(len(keys), math.nan))
            continue
        orbit = stable[-1].orbit  # the largest stable cycle
        derivs = _cycle_derivatives(model, p, orbit, directions)
        f = 1.0 / orbit.period
        df = np.array([-dt / orbit.period**2 for _, dt in derivs])
        if o.quantity == "amplitude_x_mm":
            values.append(1e3 * orbit.amplitude()[x])
            rows.append(np.array([1e3 * da for da, _ in derivs]))
        elif o.quantity == "cycle_frequency_hz":
            values.append(f)
            rows.append(df)
        else:  # frequency order n = f 2 pi R_e / V; R_e enters here directly
            radius, v = params.operating.rolling_radius_m, kmh_to_ms(o.at_speed_kmh)
            n = frequency_order(f, v, radius)
            row = frequency_order(df, v, radius)
            row += np.array([n / radius if k == "operating.rolling_radius_m" else 0.0 for k in keys])
            values.append(n)
            rows.append(row)
    return values, rows


def predict(
    params: Params,
    observations: list[Observation],
    keys: list[str] | tuple[str, ...] = (),
    speed_range_kmh: tuple[float, float] = STABILITY_SPEED_RANGE_KMH,
    settings: CalibrationSettings = CalibrationSettings(),
) -> tuple[np.ndarray, np.ndarray]:
    """Model values of the observed quantities and their derivatives (``settings.n_speeds``
    brackets the Hopf points).

    Returns
    -------
    values : ndarray (n_obs,)
        In the units of each quantity; NaN where the quantity does not exist (e.g. no
        second Hopf point in the speed range).
    jacobian : ndarray (n_obs, n_keys)
        d value / d key [quantity units per key unit], exact.
    """
    keys = list(keys)
    values = np.full(len(observations), math.nan)
    jac = np.full((len(observations), len(keys)), math.nan)
    groups: dict[tuple, list[int]] = {}
    for i, o in enumerate(observations):
        groups.setdefault(o.set, []).append(i)
    for conditions, index in groups.items():
        cond = with_updates(params, dict(conditions)) if conditions else params
        diagram = None
        for kind, rows_of in (("hopf", _HOPF), ("band", _BAND), ("cycle", _CYCLE)):
            mine = [i for i in index if observations[i].quantity in rows_of]
            if not mine:
                continue
            obs = [observations[i] for i in mine]
            if kind == "hopf":
                vals, rows = _hopf_rows(cond, obs, keys, speed_range_kmh, settings.n_speeds)
            else:
                if diagram is None:
                    from ..dynamics.bifurcation import bifurcation

                    diagram = bifurcation(cond, speed_range_kmh)
                vals, rows = (_band_rows if kind == "band" else _cycle_rows)(cond, obs, keys, diagram)
            values[mine] = vals
            jac[mine] = rows
        for i in index:
            o = observations[i]
            if o.quantity == "friction_mu":
                values[i], partials = _friction_point(cond, o.at_sliding_speed_m_per_s)
                jac[i] = [partials.get(k, 0.0) for k in keys]
    return values, jac


# -- bounds from the parameter validation ---------------------------------------------
def _bounds(key: str) -> tuple[float, float]:
    """(low, high) of a float key from its validation rules (open bounds as closed)."""
    return KEYS[key].lower, KEYS[key].upper


OVERFLOW = ("the residuals over their sigma overflow: a value or a sigma of the observations is far out of "
            "scale")
"""The error when (value - model) / sigma of an observation is not a finite number."""
AT_BOUND = 1e-6
"""A fitted value within this of a validation bound (relative to the starting value, in
the fit's scaled coordinates) sits on the bound: the data do not fit inside the key's range [-]."""


def _at_bound(x: float, low: float, high: float) -> float | None:
    """The bound (scaled like ``x``, the value over its starting value) ``x`` sits on, or None."""
    return next((b for b in (low, high) if math.isfinite(b) and abs(x - b) <= AT_BOUND * max(1.0, abs(b))), None)


# -- the result -------------------------------------------------------------------------
@dataclass
class CalibrationResult(Result):
    """Fitted parameters, residuals and the identifiability report.

    ``parameters``: one dict per varied key (value None where not identifiable);
    ``residuals``: one dict per observation; ``identifiability``: singular values,
    determined and undetermined combinations, correlations, chi^2.
    """

    params: Params
    fitted: Params
    parameters: list[dict]
    residuals: list[dict]
    identifiability: dict
    settings: dict = field(default_factory=dict)

    def summary(self) -> dict:
        return {"parameters": self.parameters, "residuals": self.residuals,
                "identifiability": self.identifiability}

    def to_dataframe(self):
        """pandas DataFrame: one row per observation with its prediction and normalized residual."""
        import pandas as pd

        return pd.DataFrame(self.residuals)

    def _dataset(self):
        """The residual table along ``row``."""
        return self._table_dataset()

    def plot(self, ax=None):
        """Normalized residuals (predicted - observed) / sigma per observation."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(7, 3.5))
        z = [r["normalized"] for r in self.residuals]
        bars = ax.barh(range(len(z)), z, color="tab:blue")
        ax.set_yticks(range(len(z)), [r["observation"] for r in self.residuals], fontsize=8)
        ax.invert_yaxis()
        for x in (-2.0, 2.0):
            ax.axvline(x, color="0.6", ls="--", lw=0.8)
        ax.axvline(0.0, color="k", lw=0.8)
        ax.set_xlabel("(predicted - observed) / sigma [-]")
        return list(bars)


def _combination(vector: np.ndarray, keys: list[str]) -> str:
    """'+0.50 ln(a) - 0.50 ln(b)' for the significant components of a singular vector."""
    parts = [f"{'+' if c >= 0 else '-'}{abs(c):.2f} ln({k})"
             for c, k in zip(vector, keys) if abs(c) >= 0.05]
    return " ".join(parts)


def calibrate(
    params: Params,
    observations: list[Observation],
    keys: list[str] | tuple[str, ...],
    speed_range_kmh: tuple[float, float] = STABILITY_SPEED_RANGE_KMH,
    settings: CalibrationSettings = CalibrationSettings(),
    profile: bool = True,
    progress: Progress | None = None,
) -> CalibrationResult:
    """Fit ``keys`` to ``observations`` and report what the data determine.

    Parameters
    ----------
    params : Params
        Starting point and every other parameter.
    observations : list of Observation
    keys : sequence of str
        Float configuration keys to vary (``table.key``).
    speed_range_kmh : (float, float)
        Speeds searched for Hopf points and bands [km/h].
    settings : CalibrationSettings
        Speed grid of the Hopf points and the threshold of an undetermined combination.
    profile : bool
        Also compute profile-likelihood intervals (a refit per evaluation).
    progress : callable, optional
        Progress callback (:mod:`polywear.progress`): model evaluations, total unknown.
    """
    from scipy.optimize import least_squares

    n_speeds, undetermined_above = settings.n_speeds, settings.undetermined_above
    keys = list(keys)
    allowed = {k for k in study_keys() if KEYS[k].kind == "stored"}
    for key in keys:
        if key not in allowed:
            raise CalibrationError(f"--vary {key}: not a float parameter key (e.g. tread.lateral_damping_ns_per_m)")
    if len(set(keys)) != len(keys):
        raise CalibrationError("--vary: a key is given twice")
    if not keys:
        raise CalibrationError("--vary: give at least one parameter key to fit")
    for o in observations:
        clash = [k for k, _ in o.set if k in keys]
        if clash:
            raise CalibrationError(f"observation {o.describe()}: its set fixes {clash[0]}, which is varied")
    n, m = len(observations), len(keys)
    if n < m:
        raise CalibrationError(
            f"{n} observation{'s' if n != 1 else ''} cannot determine {m} parameters: "
            f"give at least {m} observations, or vary fewer keys"
        )
    scale = np.array([abs(float(get_value(params, k))) or 1.0 for k in keys])
    bounds = np.array([_bounds(k) for k in keys]).T / scale
    observed = np.array([o.value for o in observations])
    sigma = np.array([o.sigma for o in observations])
    x0 = np.array([float(get_value(params, k)) for k in keys]) / scale
    cache: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}
    step = StepCounter(progress)

    def evaluate(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        tag = np.asarray(x, dtype=float).tobytes()
        if tag not in cache:
            try:
                trial = with_updates(params, dict(zip(keys, map(float, x * scale))))
                values, jac = predict(trial, observations, keys, speed_range_kmh, settings)
            except ParameterError:  # a cross-rule (e.g. mu_c <= mu_s) broken: not a valid point
                values, jac = np.full(n, math.nan), np.full((n, m), math.nan)
            if len(cache) > 64:
                cache.clear()
            cache[tag] = ((values - observed) / sigma, jac * scale / sigma[:, None])
            step()
        return cache[tag]

    r0, J0 = evaluate(x0)
    with np.errstate(over="ignore"):
        overflow = np.any(np.isinf(r0)) or np.any(np.isinf(J0)) or not np.isfinite(np.nansum(np.square(J0 * r0[:, None])))
    if overflow:
        raise CalibrationError(OVERFLOW)
    if not np.all(np.isfinite(r0)):
        missing = [observations[i].describe() for i in np.flatnonzero(~np.isfinite(r0))]
        raise CalibrationError(f"at the starting parameters the model has no {missing[0]} in "
                               f"{speed_range_kmh[0]:g}-{speed_range_kmh[1]:g} km/h: start closer, or widen --speed-range")
    lo = np.nextafter(bounds[0], np.inf)
    fit = least_squares(lambda x: evaluate(x)[0], x0, jac=lambda x: evaluate(x)[1], bounds=(lo, bounds[1]),
                        method="trf", x_scale=1.0, xtol=1e-10, ftol=1e-10, gtol=1e-10, max_nfev=100)
    x_hat = fit.x
    r, J = evaluate(x_hat)
    chi2 = float(r @ r)
    if not math.isfinite(chi2):
        raise CalibrationError(OVERFLOW)
    # identifiability in relative units: columns d r / d ln p = J x (x is p / scale)
    Jrel = J * x_hat[None, :]
    U, s, Vt = np.linalg.svd(Jrel, full_matrices=False)
    s_max = s[0] if s.size else 0.0
    undetermined_mask = (s <= 1e-9 * max(s_max, 1e-300)) | (Z_95 / np.maximum(s, 1e-300) > undetermined_above)
    if len(s) < m:
        undetermined_mask = np.concatenate([undetermined_mask, np.ones(m - len(s), bool)])
        s = np.concatenate([s, np.zeros(m - len(s))])
        Vt = np.linalg.svd(Jrel, full_matrices=True)[2]
    Vt = Vt * np.where(Vt[np.arange(m), np.argmax(np.abs(Vt), axis=1)] < 0.0, -1.0, 1.0)[:, None]  # largest > 0
    combos = []
    for k in range(m):
        combos.append({
            "singular_value": float(s[k]),
            "vector": {key: float(v) for key, v in zip(keys, Vt[k])},
            "combination": _combination(Vt[k], keys),
            "half_width_95_relative": (Z_95 / s[k]) if s[k] > 0 else None,
        })
    null_vectors = Vt[undetermined_mask]
    identifiable = [not np.any(np.abs(null_vectors[:, j]) > 0.05) for j in range(m)] if len(null_vectors) else [True] * m
    # linearized covariance of ln p on the determined subspace
    det = ~undetermined_mask
    cov_rel = (Vt[det].T / s[det] ** 2) @ Vt[det] if np.any(det) else np.zeros((m, m))
    sd_rel = np.sqrt(np.diag(cov_rel))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov_rel / np.outer(sd_rel, sd_rel)
    values = x_hat * scale
    parameters = []
    for j, key in enumerate(keys):
        entry = {"key": key, "initial": float(x0[j] * scale[j]), "identifiable": bool(identifiable[j]),
                 "value": None, "ci_low": None, "ci_high": None, "linear_ci": None, "profile_ci": None}
        if identifiable[j]:
            half = Z_95 * sd_rel[j]
            entry.update(value=float(values[j]), sd=float(sd_rel[j] * values[j]),
                         linear_ci=[float(values[j] * math.exp(-half)), float(values[j] * math.exp(half))])
            entry["ci_low"], entry["ci_high"] = entry["linear_ci"]
        else:
            along = [c["combination"] for c, u in sorted(zip(combos, undetermined_mask), key=lambda cu: cu[0]["singular_value"])
                     if u and abs(c["vector"][key]) > 0.05]  # the least determined first
            entry["reason"] = (f"not identifiable from these observations: {key} moves along the undetermined "
                               f"combination {along[0]} (fix it, or add an observation that depends on it)")
        parameters.append(entry)
    if profile and any(identifiable):
        cov_x = cov_rel * np.outer(x_hat, x_hat)  # covariance of x = p / scale
        for j, entry in enumerate(parameters):
            if entry["identifiable"]:
                entry["profile_ci"] = _profile_interval(j, x_hat, chi2, evaluate, (lo, bounds[1]), cov_x, scale)
                if entry["profile_ci"] is not None:
                    entry["ci_low"], entry["ci_high"] = entry["profile_ci"]
    fitted = with_updates(params, {k: float(v) for k, v, ok in zip(keys, values, identifiable) if ok})
    predicted = r * sigma + observed
    residuals = [{"observation": o.describe(), "quantity": o.quantity, "observed": o.value, "sigma": o.sigma,
                  "predicted": float(pv), "normalized": float(z)}
                 for o, pv, z in zip(observations, predicted, r)]
    report = {
        "chi2": chi2,
        "dof": n - m,
        "singular_values": [c["singular_value"] for c in combos],
        "determined": [c for c, u in zip(combos, undetermined_mask) if not u],
        "undetermined": [c for c, u in zip(combos, undetermined_mask) if u],
        "correlations": {"keys": keys, "matrix": np.where(np.isfinite(corr), corr, 0.0).tolist()},
        "converged": bool(fit.success),
        "evaluations": int(fit.nfev),
        "criterion": f"undetermined: singular value at rounding level or 95 % half-width > "
                     f"{undetermined_above:g} in ln(p) (a factor e = 2.7)",
    }
    refused = [p["key"] for p in parameters if not p["identifiable"]]
    if refused:
        report["refused"] = refused
    report["warnings"] = []
    for j, entry in enumerate(parameters):
        bound = _at_bound(x_hat[j], bounds[0][j], bounds[1][j]) if entry["value"] is not None else None
        entry["at_bound"] = bound is not None
        if bound is not None:
            report["warnings"].append(
                f"{entry['key']} = {entry['value']:.6g} is at its validation bound {bound * scale[j]:g}: the data do "
                f"not fit within the key's range (chi2 = {chi2:.4g}); the value is no estimate")
    return CalibrationResult(params=params, fitted=fitted, parameters=parameters, residuals=residuals,
                             identifiability=report,
                             settings={"keys": keys, "speed_range_kmh": list(speed_range_kmh), "n_speeds": n_speeds,
                                       "profile": profile,
                                       "n_observations": n})


def _profile_interval(j, x_hat, chi2_min, evaluate, bounds, cov_x, scale) -> list[float | None]:
    """95 % profile-likelihood interval of parameter j [key units]; None: no end before the bound.

    ``q(t) = sqrt(chi2_profile(t) - chi2_min)`` is linear in t where the problem is; each
    end ``q = 1.96`` is found by the secant method from the linearized end, every
    profile point a refit of the other parameters started on their linear prediction
    ``y_hat + cov_yt / cov_tt (t - t_hat)``.
    """
    from scipy.optimize import least_squares

    others = [i for i in range(len(x_hat)) if i != j]
    sd = math.sqrt(cov_x[j, j])
    slope = cov_x[others, j] / cov_x[j, j]

    def q_of(t: float) -> float:
        x = x_hat.copy()
        x[j] = t
        if others:
            y0 = np.clip(x_hat[others] + slope * (t - x_hat[j]), np.nextafter(bounds[0][others], np.inf),
                         np.nextafter(bounds[1][others], -np.inf))

            def full(y):
                z = x.copy()
                z[others] = y
                return z

            fit = least_squares(lambda y: evaluate(full(y))[0], y0, jac=lambda y: evaluate(full(y))[1][:, others],
                                bounds=(bounds[0][others], bounds[1][others]), method="trf", max_nfev=30)
            x = full(fit.x)
        r = evaluate(x)[0]
        if not np.all(np.isfinite(r)):
            return math.nan
        return math.sqrt(max(float(r @ r) - chi2_min, 0.0))

    target = math.sqrt(CHI2_95)
    ends: list[float | None] = []
    for side in (-1.0, 1.0):
        lo, hi = bounds[0][j], bounds[1][j]
        t_prev, q_prev = x_hat[j], 0.0
        t = x_hat[j] + side * target * sd
        end = None
        for _ in range(12):
            t = min(max(t, np.nextafter(lo, np.inf)), np.nextafter(hi, -np.inf))
            q = q_of(t)
            if math.isnan(q):  # not a valid parameter set there: back towards the last good point
                t = 0.5 * (t + t_prev)
                continue
            if abs(q - target) < 1e-3 * target:
                end = t
                break
            if q < target and (t <= np.nextafter(lo, np.inf) or t >= np.nextafter(hi, -np.inf)):
                break  # the bound comes first: open on this side
            step = (target - q) * (t - t_prev) / (q - q_prev) if q != q_prev else side * sd
            t_prev, q_prev, t = t, q, t + step
        ends.append(None if end is None else float(end * scale[j]))
    return ends
