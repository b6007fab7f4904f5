"""Fitting LuGre parameters: the static curve to steady mu(v) points, sigma0 and sigma1 to loops."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, ClassVar

import numpy as np
from numpy.typing import ArrayLike

from ..keys import KEYS
from ..params import Friction, with_updates
from ..physics.lugre import steady_friction
from ..progress import Progress, StepCounter
from ..results import Result
from ..settings import check_count, check_positive
from .curve import STEADY_PARAMETERS, _axes, _friction_toml, _steady_args, steady_curve
from .data import FrictionDataError
from .loops import MAX_SLIDING_SPEED_M_PER_S, _periodic_orbit

__all__ = [
    "MAX_FRICTION_COEFFICIENT",
    "LOOP_PARAMETERS",
    "FrictionFit",
    "LoopFit",
    "LoopFitSettings",
    "fit_loops",
    "fit_steady_curve",
    "steady_friction_jacobian",
]


MAX_FRICTION_COEFFICIENT = 3.0
"""Largest |mu| a measured point may have [-]: rubber on the stickiest surface stays below."""


def _check_points(v: np.ndarray, y: np.ndarray) -> None:
    """Refuse points no tire measurement gives: |v| beyond ``MAX_SLIDING_SPEED_M_PER_S``,
    |mu| zero or beyond ``MAX_FRICTION_COEFFICIENT``, mu against the sliding direction at v > 0."""
    for name, bad, rule in (
        ("sliding velocity", np.abs(v) > MAX_SLIDING_SPEED_M_PER_S, f"|v| at most {MAX_SLIDING_SPEED_M_PER_S:g} m/s"),
        ("friction coefficient", (np.abs(y) > MAX_FRICTION_COEFFICIENT) | (y == 0.0),
         f"0 < |mu| <= {MAX_FRICTION_COEFFICIENT:g}"),
        ("friction coefficient", (v > 0.0) & (y < 0.0), "mu > 0 where v > 0 (friction opposes sliding)"),
    ):
        if np.any(bad):
            i = int(np.flatnonzero(bad)[0])
            raise FrictionDataError(f"point {i + 1} (v = {v[i]:g} m/s, mu = {y[i]:g}): {name} out of range, need {rule}")


# -- fitting the static curve --------------------------------------------------------------


def steady_friction_jacobian(velocity, friction: Friction) -> np.ndarray:
    """d mu_ss / d(parameter) for ``STEADY_PARAMETERS`` at each velocity, shape ``(n, 5)``.

    Analytic; for v = 0 (where mu_ss jumps) the row is zero.
    """
    v = np.asarray(velocity, dtype=float)
    sigma2, mu_s, mu_c, v_s, delta = _steady_args(friction)
    s = np.sign(v)
    a = np.abs(v) / v_s
    ad = a**delta
    e = np.exp(-ad)
    log_a = np.log(np.where(a > 0.0, a, 1.0))
    return np.stack([
        s * e,
        s * (1.0 - e),
        s * (mu_s - mu_c) * e * delta * ad / v_s,
        -s * (mu_s - mu_c) * e * ad * log_a,
        v,
    ], axis=-1)


@dataclass(frozen=True, eq=False)
class _ParameterFit(Result):
    """What a least-squares fit of friction parameters reports (one row per data point)."""

    KEYS: ClassVar[tuple[str, ...]] = ()
    """The ``[friction]`` keys this kind of fit can determine."""

    velocity: np.ndarray
    """measured sliding velocity, as given [m/s]"""
    mu: np.ndarray
    """measured friction coefficient, as given [-]"""
    friction: Friction
    """fitted parameters (the other keys from the base set)"""
    fitted: tuple[str, ...]
    standard_errors: dict[str, float]
    """per fitted key, from the Jacobian at the optimum (inf if not identifiable)"""
    covariance: np.ndarray
    confidence: float
    rms: float
    r_squared: float
    converged: bool
    message: str
    nfev: int
    at_bound: tuple[str, ...]
    source: str

    @property
    def n_points(self) -> int:
        return int(self.velocity.size)

    def value(self, name: str) -> float:
        return float(getattr(self.friction, name))

    def interval(self, name: str) -> tuple[float, float]:
        """Two-sided confidence interval of a fitted key (Student t, n - p dof)."""
        from scipy.stats import t as student_t

        half = student_t.ppf(0.5 + self.confidence / 2.0, self.n_points - len(self.fitted)) * self.standard_errors[name]
        return self.value(name) - half, self.value(name) + half

    def to_toml(self) -> str:
        """The fitted ``[friction]`` table, ready to paste into a parameter file."""
        notes = {name: f"fitted, +/- {self.standard_errors[name]:.3g} (1 s.e.)" for name in self.fitted}
        for name in type(self.friction).model_fields:
            notes.setdefault(name, "not fitted")
        return _friction_toml(self.friction, notes)

    def updated_params(self, params):
        """``params`` with this fit's ``[friction]`` values."""
        return with_updates(params, {f"friction.{n}": getattr(self.friction, n) for n in type(self.friction).model_fields})

    def summary(self) -> dict[str, Any]:
        finite = lambda x: float(x) if math.isfinite(x) else None  # noqa: E731
        return {
            "source": self.source,
            "n_points": self.n_points,
            "converged": self.converged,
            "message": self.message,
            "nfev": self.nfev,
            "rms_residual": self.rms,
            "r_squared": self.r_squared,
            "confidence": self.confidence,
            "parameters": {
                name: {
                    "value": self.value(name),
                    "fitted": name in self.fitted,
                    **({"standard_error": finite(self.standard_errors[name]),
                        "interval": [finite(x) for x in self.interval(name)],
                        "at_bound": name in self.at_bound} if name in self.fitted else {}),
                }
                for name in self.KEYS
            },
            "warnings": self.warnings(),
            "toml": self.to_toml(),
        }

    def warnings(self) -> list[str]:
        """One line per fitted key pinned at a bound of the fit: at the bound, the value is no estimate."""
        return [f"{name} = {self.value(name):.6g} is at the bound of the fit: the data do not fit the model inside "
                "its range there (at the bound / does not fit); the value is no estimate" for name in self.at_bound]

    def _attrs(self, title: str) -> dict[str, Any]:
        return {
            "title": title,
            "source": self.source,
            "friction_toml": self.to_toml(),
            "rms_residual": self.rms,
            "r_squared": self.r_squared,
            "converged": int(self.converged),
            "message": self.message,
        }


@dataclass(frozen=True, eq=False)
class FrictionFit(_ParameterFit):
    """Least-squares fit of the static friction curve to measured steady points."""

    KEYS: ClassVar[tuple[str, ...]] = STEADY_PARAMETERS

    magnitudes: bool
    """True if the data gave |mu| at negative velocities (see :func:`fit_steady_curve`)"""

    @property
    def signed_mu(self) -> np.ndarray:
        """Measured mu with the sign of the velocity (the model is odd in v) [-]."""
        return np.where(self.velocity < 0.0, -np.abs(self.mu), self.mu) if self.magnitudes else self.mu

    @property
    def residuals(self) -> np.ndarray:
        """signed measured mu minus the fitted static curve [-]."""
        return self.signed_mu - steady_friction(self.velocity, *_steady_args(self.friction))

    def summary(self) -> dict[str, Any]:
        """What ``polywear friction fit --json`` prints: the fit's parameters, errors, quality."""
        return {**super().summary(), "negative_velocity_data": "magnitudes" if self.magnitudes else "signed"}

    def _dataset(self):
        """xarray Dataset: measured points, residuals and the covariance of the fitted keys."""
        import xarray as xr

        return xr.Dataset(
            {
                "velocity": ("point", self.velocity, {"long_name": "sliding velocity", "units": "m/s"}),
                "mu": ("point", self.mu, {"long_name": "measured friction coefficient", "units": "1"}),
                "residual": ("point", self.residuals, {"long_name": "measured - fitted", "units": "1"}),
                "covariance": (("fitted", "fitted_"), self.covariance),
            },
            coords={"fitted": list(self.fitted), "fitted_": list(self.fitted)},
            attrs=self._attrs("LuGre static curve fit"),
        )

    def plot(self, ax=None):
        """Measured points folded onto v > 0 and the fitted static curve; returns artists."""
        ax = _axes(ax)
        v, mu = np.abs(self.velocity), np.sign(self.velocity) * self.signed_mu
        neg = self.velocity < 0.0
        artists = [ax.plot(v[~neg], mu[~neg], "o", ms=4, mfc="none", color="C0", label="measured, v > 0")[0]]
        if neg.any():
            artists.append(ax.plot(v[neg], mu[neg], "s", ms=4, mfc="none", color="C1",
                                   label="measured, v < 0 (folded)")[0])
        grid = np.linspace(0.0, v.max() * 1.05, 400)[1:]
        artists += steady_curve(self.friction, grid).plot(ax=ax, label=f"fit (rms {self.rms:.2g})")
        ax.legend(fontsize="small")
        return artists


def _initial_guess(v: np.ndarray, mu: np.ndarray, base: Friction) -> dict[str, float]:
    """Starting values from the folded data (v > 0): peak, floor, half-drop speed."""
    order = np.argsort(v)
    v, mu = v[order], mu[order]
    lower = v <= np.median(v)
    mu_s = float(np.clip(mu[lower].max(), 1e-3, 5.0))
    mu_c = float(np.clip(mu.min(), 1e-3 * mu_s, mu_s))
    below = np.nonzero(mu < 0.5 * (mu_s + mu_c))[0]
    v_s = float(v[below[0]]) if below.size else float(np.median(v))
    return {
        "mu_static": mu_s,
        "mu_coulomb": mu_c,
        "stribeck_velocity_m_per_s": max(v_s, 1e-6),
        "stribeck_exponent": base.stribeck_exponent,
        "sigma2_s_per_m": 0.0,
    }


def fit_steady_curve(
    velocity,
    mu,
    base: Friction | None = None,
    *,
    fit: tuple[str, ...] = STEADY_PARAMETERS,
    confidence: float = 0.95,
    source: str = "",
) -> FrictionFit:
    """Fit mu_s, mu_c, v_s, delta, sigma2 of the static curve to measured steady points.

    The model mu_ss(v) = sgn(v) G(v) + sigma2 v is odd in v. Data at v < 0 may be
    signed (mu < 0 there) or magnitudes: if every point at v < 0 has mu >= 0, they are
    taken as magnitudes. Points at v = 0 (where steady friction is not defined) are
    rejected. ``scipy.optimize.least_squares`` (trust-region reflective) minimizes the
    residuals within the rules of :class:`~polywear.params.Friction`: mu_c is
    parametrized as mu_s times a ratio in [0, 1] so that mu_c <= mu_s is a box bound.
    It starts from the data (peak, floor, half-drop speed) with delta = 1, 2 and 4
    (and the base delta) and keeps the best fit.

    Parameters
    ----------
    velocity, mu : array
        Measured sliding velocity [m/s] and friction coefficient [-].
    base : Friction, optional
        Values of the keys that are not fitted (default: the built-in defaults).
    fit : tuple of str
        Which of :data:`STEADY_PARAMETERS` to fit; the others stay at ``base``.
    confidence : float
        Level of the reported intervals.
    """
    from scipy.optimize import least_squares

    base = base or Friction()
    v = np.asarray(velocity, dtype=float).ravel()
    y = np.asarray(mu, dtype=float).ravel()
    fit = tuple(fit)
    unknown = [name for name in fit if name not in STEADY_PARAMETERS]
    if unknown or not fit:
        raise ValueError(f"fit = {list(fit)}: choose from {', '.join(STEADY_PARAMETERS)}")
    fit = tuple(name for name in STEADY_PARAMETERS if name in fit)
    if v.shape != y.shape:
        raise FrictionDataError(f"velocity and mu differ in length ({v.size} vs {y.size})")
    if not (np.all(np.isfinite(v)) and np.all(np.isfinite(y))):
        raise FrictionDataError("data contain NaN or infinite values")
    if np.any(v == 0.0):
        raise FrictionDataError("data contain v = 0, where steady friction is not defined")
    _check_points(v, y)
    if v.size <= len(fit):
        raise FrictionDataError(f"{v.size} points cannot determine {len(fit)} parameters (need more points)")
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence = {confidence!r}: must lie in (0, 1)")

    neg = v < 0.0
    magnitudes = bool(neg.any() and np.all(y[neg] >= 0.0))
    signed = np.where(neg, -np.abs(y), y) if magnitudes else y
    fold_v, fold_mu = np.abs(v), np.sign(v) * signed

    fields = {name: getattr(base, name) for name in STEADY_PARAMETERS}
    col = {name: i for i, name in enumerate(STEADY_PARAMETERS)}
    free = [col[name] for name in fit]
    ratio = "mu_coulomb" in fit  # mu_c = ratio * mu_s, ratio in [0, 1]

    def natural(theta) -> dict[str, float]:
        values = dict(fields, **dict(zip(fit, theta)))
        if ratio:
            values["mu_coulomb"] = values["mu_coulomb"] * values["mu_static"]
        return values

    def curve(values: dict[str, float]) -> Friction:
        return Friction.model_construct(**{**base.model_dump(), **values})

    def residuals(theta):
        return steady_friction(fold_v, *_steady_args(curve(natural(theta)))) - fold_mu

    def jacobian(theta):
        values = natural(theta)
        full = steady_friction_jacobian(fold_v, curve(values))
        if ratio:  # chain rule through mu_c = ratio * mu_s
            r = theta[fit.index("mu_coulomb")]
            full = full.copy()
            full[:, col["mu_static"]] += r * full[:, col["mu_coulomb"]]
            full[:, col["mu_coulomb"]] *= values["mu_static"]
        return full[:, free]

    def key_bounds(name: str) -> tuple[float, float]:  # the key's plausibility bounds (polywear.keys)
        return KEYS[f"friction.{name}"].lower, KEYS[f"friction.{name}"].upper

    bounds = {name: key_bounds(name) for name in STEADY_PARAMETERS}
    if "mu_coulomb" not in fit:
        bounds["mu_static"] = (fields["mu_coulomb"], bounds["mu_static"][1])
    if ratio:
        bounds["mu_coulomb"] = (0.0, 1.0)
    lower = np.array([bounds[n][0] for n in fit])
    upper = np.array([bounds[n][1] for n in fit])

    guess = _initial_guess(fold_v, fold_mu, base)
    if ratio:
        mu_s_guess = guess["mu_static"] if "mu_static" in fit else fields["mu_static"]
        guess["mu_coulomb"] = min(guess["mu_coulomb"] / mu_s_guess, 1.0)
    solutions = []
    for delta in sorted({1.0, 2.0, 4.0, base.stribeck_exponent}):
        start = np.clip([{**guess, "stribeck_exponent": delta}[n] for n in fit], lower, upper)
        solutions.append(least_squares(residuals, start, jac=jacobian, bounds=(lower, upper), method="trf",
                                       x_scale="jac", xtol=1e-14, ftol=1e-14, gtol=1e-14, max_nfev=2000))
        if "stribeck_exponent" not in fit:
            break
    best = min(solutions, key=lambda sol: sol.cost)  # the first of equal costs, as before

    values = natural(best.x)
    at_bound = tuple(name for name, active in zip(fit, best.active_mask) if active != 0)
    try:
        fitted = _validated_friction(base, values)
    except Exception as exc:  # a fitted value broke a rule, e.g. mu_c -> 0 at its bound
        raise FrictionDataError(f"the fit left the valid parameter range ({exc}); fix that parameter") from None

    # covariance in the natural parameters, from the analytic Jacobian at the optimum
    res = residuals(best.x)
    cov = _covariance(steady_friction_jacobian(fold_v, fitted)[:, free], res)
    return FrictionFit(
        velocity=v,
        mu=y,
        magnitudes=magnitudes,
        friction=fitted,
        fitted=fit,
        standard_errors={name: float(math.sqrt(cov[i, i])) for i, name in enumerate(fit)},
        covariance=cov,
        confidence=confidence,
        rms=float(np.sqrt(np.mean(res**2))),
        r_squared=_r_squared(res, fold_mu),
        converged=bool(best.status > 0),
        message=str(best.message).rstrip("."),
        nfev=int(best.nfev),
        at_bound=at_bound,
        source=source,
    )


def _validated_friction(base: Friction, values: dict[str, float]) -> Friction:
    """A validated Friction with ``values`` replacing keys of ``base``."""
    return Friction.model_validate({**base.model_dump(), **{k: float(x) for k, x in values.items()}})


def _covariance(jac: np.ndarray, residuals: np.ndarray) -> np.ndarray:
    """s^2 (J^T J)^-1 with s^2 = SSR / (n - p); inf where J is rank deficient."""
    n, p = jac.shape
    _, sv, vt = np.linalg.svd(jac, full_matrices=False)
    if sv[-1] <= sv[0] * 1e-10:
        return np.full((p, p), np.inf)
    return (vt.T / sv**2) @ vt * float(np.sum(residuals**2)) / (n - p)


def _r_squared(residuals: np.ndarray, data: np.ndarray) -> float:
    ss_tot = float(np.sum((data - data.mean()) ** 2))
    return 1.0 - float(np.sum(residuals**2)) / ss_tot if ss_tot > 0.0 else float("nan")


# -- fitting sigma0 and sigma1 to measured loops ---------------------------------------------

LOOP_PARAMETERS = ("sigma0_per_m", "sigma1_s_per_m")
"""Keys of ``[friction]`` that only the dynamics (loops) determine."""


@dataclass(frozen=True, eq=False)
class LoopFit(_ParameterFit):
    """Fit of sigma0 and sigma1 to measured periodic friction loops."""

    KEYS: ClassVar[tuple[str, ...]] = LOOP_PARAMETERS

    frequency_hz: np.ndarray
    """excitation frequency of each point [Hz]"""
    time_s: np.ndarray
    """time of each point [s]"""
    model_velocity: np.ndarray
    """the periodic velocity that drives the model (Fourier fit of the measured one) [m/s]"""
    model_mu: np.ndarray
    """fitted model's friction coefficient at each point [-]"""
    harmonics: int

    @property
    def residuals(self) -> np.ndarray:
        """measured minus fitted friction coefficient [-]."""
        return self.mu - self.model_mu

    def _dataset(self):
        """xarray Dataset: measured and fitted loops per point, and the covariance."""
        import xarray as xr

        point = lambda values, attrs: ("point", values, attrs)  # noqa: E731
        return xr.Dataset(
            {
                "frequency": point(self.frequency_hz, {"units": "Hz"}),
                "time": point(self.time_s, {"units": "s"}),
                "velocity": point(self.velocity, {"long_name": "measured sliding velocity", "units": "m/s"}),
                "mu": point(self.mu, {"long_name": "measured friction coefficient", "units": "1"}),
                "model_velocity": point(self.model_velocity, {"long_name": "Fourier fit of the velocity",
                                                              "units": "m/s"}),
                "model_mu": point(self.model_mu, {"long_name": "fitted friction coefficient", "units": "1"}),
                "covariance": (("fitted", "fitted_"), self.covariance),
            },
            coords={"fitted": list(self.fitted), "fitted_": list(self.fitted)},
            attrs={**self._attrs("LuGre loop fit (sigma0, sigma1)"), "harmonics": self.harmonics},
        )

    def plot(self, ax=None):
        """Measured loops (points) and the fitted model loops (lines); returns artists."""
        import matplotlib as mpl

        ax = _axes(ax)
        freqs = np.unique(self.frequency_hz)
        colors = mpl.colormaps["viridis"](np.linspace(0.0, 0.85, freqs.size))
        artists = []
        for f, color in zip(freqs, colors):
            at = self.frequency_hz == f
            order = np.argsort(np.mod(self.time_s[at], 1.0 / f))
            artists += ax.plot(self.velocity[at], self.mu[at], "o", ms=3, mfc="none", color=color)
            v, mu = self.model_velocity[at][order], self.model_mu[at][order]
            artists += ax.plot(np.append(v, v[0]), np.append(mu, mu[0]), color=color, lw=1.4, label=f"{f:g} Hz")
        ax.set_xlabel("sliding velocity $v_r$ [m/s]")
        ax.set_ylabel(r"friction coefficient $F/N$ [-]")
        ax.grid(True, alpha=0.3)
        ax.legend(title=f"measured (points), fit (lines), rms {self.rms:.2g}", fontsize="small")
        return artists


def _fourier_velocity(t: np.ndarray, v: np.ndarray, frequency: float, harmonics: int) -> Callable[[Any], Any]:
    """Least-squares Fourier series of v(t) with the given fundamental [Hz]; a callable v(t)."""
    omega = 2.0 * math.pi * frequency
    k = np.arange(1, harmonics + 1)

    def basis(time):
        wt = omega * np.multiply.outer(np.asarray(time, dtype=float), k)
        return np.concatenate([np.ones(np.shape(time) + (1,)), np.cos(wt), np.sin(wt)], axis=-1)

    coef = np.linalg.lstsq(basis(t), v, rcond=None)[0]
    return lambda time: basis(time) @ coef


@dataclass(frozen=True)
class LoopFitSettings:
    """Numerical settings of :func:`fit_loops` (``polywear friction fit-loops --harmonics``)."""

    harmonics: int = 3
    """Fourier harmonics kept of each measured velocity loop [-] (integer >= 1)."""
    sigma0_range: tuple[float, float] = (1.0, 1e6)
    """Search range of sigma0 [1/m] (``0 < low < high``, finite)."""
    rtol: float = 1e-8
    """Relative tolerance of the bristle integration (Radau) [-]."""

    def __post_init__(self) -> None:
        check_count(self, "harmonics")
        check_positive(self, "rtol")
        lo, hi = self.sigma0_range
        if not 0.0 < lo < hi < math.inf:
            raise ValueError(f"LoopFitSettings: sigma0_range = {self.sigma0_range!r}: need 0 < low < high [1/m]")


def fit_loops(
    frequency_hz: ArrayLike,
    time_s: ArrayLike,
    velocity: ArrayLike,
    mu: ArrayLike,
    base: Friction | None = None,
    *,
    settings: LoopFitSettings = LoopFitSettings(),
    confidence: float = 0.95,
    progress: Progress | None = None,
    source: str = "",
) -> LoopFit:
    """Fit sigma0 and sigma1 to measured periodic friction loops.

    Each frequency's points must come from one steady periodic loop (after the
    transient) and cover its period; ``time_s`` may span several periods. The measured
    velocity of each loop is replaced by its least-squares Fourier series
    (``settings.harmonics`` harmonics of the frequency), which drives the bristle ODE; its
    periodic orbit comes from the same fixed-point construction as :func:`hysteresis_loops`
    (tolerance ``settings.rtol``). The static-curve
    keys (mu_s, mu_c, v_s, delta, sigma2) are taken from ``base``: fit them first with
    :func:`fit_steady_curve`.

    The model is linear in sigma1, so for each sigma0 the best sigma1 >= 0 is a linear
    least-squares solution (variable projection); sigma0 is found by a scan of
    ``settings.sigma0_range`` [1/m] in half-decade steps followed by a bounded Brent search
    in log sigma0 (:class:`LoopFitSettings`). Standard errors come from the Jacobian at the optimum (central
    difference in sigma0, analytic in sigma1). ``progress`` (:mod:`polywear.progress`)
    counts the model evaluations (one per sigma0, all loops), total unknown.
    """
    from scipy.optimize import minimize_scalar

    base = base or Friction()
    f_all = np.asarray(frequency_hz, dtype=float).ravel()
    t_all = np.asarray(time_s, dtype=float).ravel()
    v_all = np.asarray(velocity, dtype=float).ravel()
    y = np.asarray(mu, dtype=float).ravel()
    if not f_all.size == t_all.size == v_all.size == y.size:
        raise FrictionDataError("frequency, time, velocity and mu differ in length")
    if not all(np.all(np.isfinite(a)) for a in (f_all, t_all, v_all, y)):
        raise FrictionDataError("data contain NaN or infinite values")
    if np.any(f_all <= 0.0):
        raise FrictionDataError("frequencies must be > 0")
    harmonics, sigma0_range, rtol = settings.harmonics, settings.sigma0_range, settings.rtol
    lo, hi = sigma0_range
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence = {confidence!r}: must lie in (0, 1)")
    min_points = 4 * harmonics + 4
    groups = []
    for f in np.unique(f_all):
        idx = np.nonzero(f_all == f)[0]
        period = 1.0 / f
        phase = np.mod(t_all[idx], period)
        if idx.size < min_points:
            raise FrictionDataError(f"{f:g} Hz: {idx.size} points, need at least {min_points} per loop")
        gaps = np.diff(np.concatenate([np.sort(phase), [np.min(phase) + period]]))
        if gaps.max() > period / 8.0:
            raise FrictionDataError(f"{f:g} Hz: the points leave {gaps.max() / period:.0%} of the period "
                                    "uncovered (need a whole loop)")
        grid, where = np.unique(np.concatenate([[0.0], phase, [period]]), return_inverse=True)
        groups.append((idx, period, _fourier_velocity(t_all[idx], v_all[idx], f, harmonics), grid,
                       where[1:-1]))

    evaluated = StepCounter(progress)

    def model(sigma0: float):
        """z, dz/dt and v of the model at every point, for this sigma0."""
        friction = base.model_copy(update={"sigma0_per_m": sigma0})
        z, zdot, v = (np.empty_like(y) for _ in range(3))
        for idx, period, v_of_t, grid, where in groups:
            loop, _ = _periodic_orbit(friction, v_of_t, period, grid, rtol, None)
            z[idx], zdot[idx], v[idx] = loop.deflection[where], loop.rate[where], loop.velocity[where]
        evaluated(f"sigma0 = {sigma0:.4g} 1/m")
        return z, zdot, v

    evaluations: dict[float, tuple] = {}

    def profile(log_sigma0: float):
        """SSR at the best sigma1 >= 0 for this sigma0; (ssr, sigma1, residuals, z, zdot, v)."""
        if log_sigma0 not in evaluations:
            sigma0 = 10.0**log_sigma0
            z, zdot, v = model(sigma0)
            b = sigma0 * z + base.sigma2_s_per_m * v - y
            sigma1 = max(0.0, -float(zdot @ b) / float(zdot @ zdot))
            r = b + sigma1 * zdot
            evaluations[log_sigma0] = (float(r @ r), sigma1, r, z, zdot, v)
        return evaluations[log_sigma0]

    scan = np.arange(math.log10(lo), math.log10(hi) + 0.25, 0.5).clip(max=math.log10(hi))
    costs = [profile(x)[0] for x in scan]
    i = int(np.argmin(costs))
    bracket = (scan[max(i - 1, 0)], scan[min(i + 1, scan.size - 1)])
    search = minimize_scalar(lambda x: profile(x)[0], bounds=bracket, method="bounded",
                             options={"xatol": 1e-6})
    log_sigma0 = float(search.x)
    _, sigma1, res, z, zdot, v_model = profile(log_sigma0)
    sigma0 = 10.0**log_sigma0
    edge = i in (0, scan.size - 1) and abs(log_sigma0 - scan[i]) < 0.05
    converged = bool(search.success) and not edge
    message = (f"sigma0 at the edge of the search range {sigma0_range}" if edge else str(search.message))

    # Jacobian at the optimum: d r / d sigma0 by central differences (sigma1 held), d r / d sigma1 = dz/dt
    def residual_at(s0: float) -> np.ndarray:
        z_s, zdot_s, v_s = model(s0)
        return s0 * z_s + sigma1 * zdot_s + base.sigma2_s_per_m * v_s - y

    step = 1e-3 * sigma0
    jac = np.column_stack([(residual_at(sigma0 + step) - residual_at(sigma0 - step)) / (2.0 * step), zdot])
    cov = _covariance(jac, res)
    friction = _validated_friction(base, {"sigma0_per_m": sigma0, "sigma1_s_per_m": sigma1})
    return LoopFit(
        velocity=v_all,
        mu=y,
        friction=friction,
        fitted=LOOP_PARAMETERS,
        standard_errors={name: float(math.sqrt(cov[i, i])) for i, name in enumerate(LOOP_PARAMETERS)},
        covariance=cov,
        confidence=confidence,
        rms=float(np.sqrt(np.mean(res**2))),
        r_squared=_r_squared(res, y),
        converged=converged,
        message=message,
        nfev=len(evaluations) + 2,
        at_bound=("sigma1_s_per_m",) if sigma1 == 0.0 else (),
        source=source,
        frequency_hz=f_all,
        time_s=t_all,
        model_velocity=v_model,
        model_mu=y + res,
        harmonics=harmonics,
    )
