"""LuGre friction on its own: static curve, hysteresis loops, fitting to measurements.

The paper's Fig. 1 shows the friction coefficient of the LuGre model against a
sinusoidal sliding velocity: at low frequency the loop lies on the static (Stribeck)
curve, at high frequency it opens. :func:`hysteresis_loops` computes those loops,
:func:`steady_curve` the static curve; :func:`fit_steady_curve` fits the static-curve
parameters to measured steady ``mu(v)`` points and :func:`fit_loops` the bristle
parameters sigma0, sigma1 to measured loops (MODEL.md section 2, docs/friction.md).

All forces are per unit normal load (friction coefficients); velocities are the sliding
velocity of the road relative to the tread [m/s].
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, ClassVar

import numpy as np

from .. import __version__
from ..params import Friction, with_updates
from ..physics.lugre import (
    bristle_decay_rate,
    bristle_rate,
    friction_coefficient,
    steady_deflection,
    steady_friction,
    steady_friction_slope,
    stribeck,
)

__all__ = [
    "SteadyCurve",
    "BristleResponse",
    "HysteresisLoops",
    "FrictionFit",
    "LoopFit",
    "FrictionDataError",
    "STEADY_PARAMETERS",
    "LOOP_PARAMETERS",
    "VELOCITY_COLUMN",
    "FRICTION_COLUMN",
    "FREQUENCY_COLUMN",
    "TIME_COLUMN",
    "LOOP_COLUMNS",
    "steady_curve",
    "falling_branch",
    "bristle_response",
    "hysteresis_loops",
    "steady_friction_jacobian",
    "fit_steady_curve",
    "fit_loops",
    "read_steady_csv",
    "read_loops_csv",
    "synthetic_steady_data",
    "sample_path",
]

STEADY_PARAMETERS = (
    "mu_static",
    "mu_coulomb",
    "stribeck_velocity_m_per_s",
    "stribeck_exponent",
    "sigma2_s_per_m",
)
"""Keys of ``[friction]`` that the steady curve depends on (and that can be fitted)."""

VELOCITY_COLUMN = "sliding_velocity_m_per_s"
FRICTION_COLUMN = "friction_coefficient"


class FrictionDataError(ValueError):
    """Measured friction data cannot be used (one line naming the file, row and problem)."""


def _steady_args(friction: Friction) -> tuple[float, float, float, float, float]:
    """(sigma2, mu_s, mu_c, v_s, delta) in the order of the lugre steady_* functions."""
    f = friction
    return (f.sigma2_s_per_m, f.mu_static, f.mu_coulomb, f.stribeck_velocity_m_per_s, f.stribeck_exponent)


def _friction_toml(friction: Friction, notes: dict[str, str] | None = None) -> str:
    """The ``[friction]`` table of a parameter file, with optional comments per key."""
    notes = notes or {}
    lines = ["[friction]"]
    for name in type(friction).model_fields:
        entry = f"{name} = {float(getattr(friction, name))!r}"
        lines.append(f"{entry:<42} # {notes[name]}" if name in notes else entry)
    return "\n".join(lines) + "\n"


class _Saveable:
    """``save(path)``: the result's ``to_dataset()`` written to netCDF (h5netcdf)."""

    def save(self, path: str | Path) -> Path:
        """Write ``to_dataset()`` to a netCDF file; returns the path."""
        path = Path(path)
        self.to_dataset().to_netcdf(path, engine="h5netcdf")
        return path


def _axes(ax):
    if ax is None:
        import matplotlib.pyplot as plt

        _, ax = plt.subplots(figsize=(6.4, 4.4))
    return ax


# -- static curve --------------------------------------------------------------------------


def falling_branch(friction: Friction) -> tuple[float, float] | None:
    """Sliding speeds ``(v_lo, v_hi)`` [m/s] between which d mu_ss/dv < 0 (v > 0).

    On this branch friction acts as negative damping. ``v_hi`` is ``inf`` when
    sigma2 = 0; ``None`` if the viscous term outweighs the Stribeck drop everywhere.
    """
    from scipy.optimize import brentq

    sigma2, mu_s, mu_c, v_s, delta = _steady_args(friction)

    def slope(v):
        return float(steady_friction_slope(v, sigma2, mu_s, mu_c, v_s, delta))

    # |dG/dv| peaks where (v/v_s)^delta = (delta - 1)/delta (at v -> 0+ for delta = 1)
    v_peak = v_s * ((delta - 1.0) / delta) ** (1.0 / delta)
    if mu_s == mu_c or slope(v_peak) >= 0.0:
        return None
    v_lo = 0.0 if sigma2 == 0.0 or v_peak == 0.0 else brentq(slope, 0.0, v_peak, xtol=1e-15, rtol=1e-13)
    if sigma2 == 0.0:
        return v_lo, math.inf
    v_hi = max(2.0 * v_peak, v_s)
    while slope(v_hi) < 0.0:
        v_hi *= 2.0
    return v_lo, brentq(slope, v_peak, v_hi, xtol=1e-15, rtol=1e-13)


@dataclass(frozen=True, eq=False)
class SteadyCurve(_Saveable):
    """Static (Stribeck) friction curve mu_ss(v) = sgn(v) G(v) + sigma2 v."""

    friction: Friction
    velocity: np.ndarray
    """Sliding velocity [m/s]."""
    mu: np.ndarray
    """Steady friction coefficient [-]."""

    @property
    def falling_branch(self) -> tuple[float, float] | None:
        """See :func:`falling_branch`."""
        return falling_branch(self.friction)

    def summary(self) -> dict[str, Any]:
        branch = self.falling_branch
        return {
            "mu_static": self.friction.mu_static,
            "mu_coulomb": self.friction.mu_coulomb,
            "falling_branch_m_per_s": [x if math.isfinite(x) else None for x in branch] if branch else None,
            "velocity_range_m_per_s": [float(self.velocity.min()), float(self.velocity.max())],
        }

    def to_dataset(self):
        import xarray as xr

        return xr.Dataset(
            {"mu": ("velocity", self.mu, {"long_name": "steady friction coefficient", "units": "1"})},
            coords={"velocity": ("velocity", self.velocity, {"long_name": "sliding velocity", "units": "m/s"})},
            attrs={"title": "LuGre static friction curve", "friction_toml": _friction_toml(self.friction),
                   "polywear_version": __version__},
        )

    def plot(self, ax=None, **kwargs):
        """Draw mu_ss against v; returns the line artists."""
        ax = _axes(ax)
        kwargs.setdefault("color", "k")
        kwargs.setdefault("label", "static curve")
        lines = ax.plot(self.velocity, self.mu, **kwargs)
        ax.set_xlabel("sliding velocity $v_r$ [m/s]")
        ax.set_ylabel(r"friction coefficient $F/N$ [-]")
        ax.grid(True, alpha=0.3)
        return lines


def steady_curve(friction: Friction, velocity) -> SteadyCurve:
    """Static friction curve of ``friction`` at the sliding velocities ``velocity`` [m/s]."""
    v = np.atleast_1d(np.asarray(velocity, dtype=float))
    if not np.all(np.isfinite(v)):
        raise ValueError("velocity: must be finite")
    return SteadyCurve(friction, v, steady_friction(v, *_steady_args(friction)))


# -- bristle dynamics for a prescribed sliding velocity ------------------------------------


@dataclass(frozen=True, eq=False)
class BristleResponse:
    """Bristle state along a prescribed sliding velocity (see :func:`bristle_response`)."""

    time: np.ndarray
    """[s]"""
    velocity: np.ndarray
    """sliding velocity v_r [m/s]"""
    deflection: np.ndarray
    """bristle deflection z [m]"""
    rate: np.ndarray
    """dz/dt [m/s]"""
    mu: np.ndarray
    """friction coefficient F/N [-]"""
    memory: np.ndarray
    """exp(-int sigma0 |v|/G dt) from the start [-]: the weight left on the initial z."""
    nfev: int


def _bristle_rates(friction: Friction, v: np.ndarray, z: np.ndarray) -> np.ndarray:
    f = friction
    return np.array([
        bristle_rate(vi, zi, f.sigma0_per_m, stribeck(vi, f.mu_static, f.mu_coulomb,
                                                      f.stribeck_velocity_m_per_s, f.stribeck_exponent))
        for vi, zi in zip(v.tolist(), z.tolist())
    ])


def bristle_response(
    friction: Friction,
    velocity: Callable[[Any], Any],
    t_eval,
    z0: float = 0.0,
    *,
    rtol: float = 1e-10,
    atol: float | None = None,
    max_step: float = np.inf,
) -> BristleResponse:
    """Integrate the LuGre bristle ODE dz/dt = v - sigma0 |v| z / G(v) for a given v(t).

    Parameters
    ----------
    friction : Friction
    velocity : callable
        ``v(t)`` [m/s] for scalar and array ``t`` [s].
    t_eval : array
        Increasing output times [s]; integration runs from ``t_eval[0]``.
    z0 : float
        Deflection at ``t_eval[0]`` [m].
    rtol, atol : float
        Tolerances of scipy's Radau (stiff: the decay rate sigma0 |v| / G can be large);
        ``atol`` defaults to 1e-9 of the largest steady deflection mu_s / sigma0.
    max_step : float
        Largest step [s] (keep it below the time scale of ``v(t)``).
    """
    from scipy.integrate import solve_ivp

    t = np.asarray(t_eval, dtype=float)
    if t.ndim != 1 or t.size < 2 or not np.all(np.diff(t) > 0):
        raise ValueError("t_eval: need at least two increasing times")
    f = friction
    args = (f.mu_static, f.mu_coulomb, f.stribeck_velocity_m_per_s, f.stribeck_exponent)
    s0 = f.sigma0_per_m
    if atol is None:
        atol = 1e-9 * f.mu_static / s0

    def rhs(time, y):
        v = float(velocity(time))
        g = stribeck(v, *args)
        return np.array([bristle_rate(v, y[0], s0, g), bristle_decay_rate(v, s0, g)])

    def jac(time, y):
        v = float(velocity(time))
        return np.array([[-bristle_decay_rate(v, s0, stribeck(v, *args)), 0.0], [0.0, 0.0]])

    # second state: the integral of the decay rate (its exponential is the memory)
    sol = solve_ivp(rhs, (t[0], t[-1]), [float(z0), 0.0], method="Radau", t_eval=t, jac=jac,
                    rtol=rtol, atol=[atol, 1e-12], max_step=max_step)
    if not sol.success:
        raise RuntimeError(f"bristle integration failed: {sol.message}")
    v = np.asarray(velocity(t), dtype=float) * np.ones_like(t)
    z = sol.y[0]
    zdot = _bristle_rates(f, v, z)
    mu = friction_coefficient(v, z, zdot, s0, f.sigma1_s_per_m, f.sigma2_s_per_m)
    return BristleResponse(t, v, z, zdot, mu, np.exp(-sol.y[1]), sol.nfev)


# -- hysteresis loops ----------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class HysteresisLoops(_Saveable):
    """Periodic friction loops for v_r(t) = v_mean + v_amplitude sin(2 pi f t).

    Arrays are ``(frequency, phase)``; the phase grid covers one period, end excluded.
    """

    friction: Friction
    v_mean: float
    """[m/s]"""
    v_amplitude: float
    """[m/s]"""
    frequencies_hz: np.ndarray
    phase: np.ndarray
    """[rad]"""
    velocity: np.ndarray
    """[m/s]"""
    deflection: np.ndarray
    """bristle deflection z [m]"""
    mu: np.ndarray
    """friction coefficient F/N [-]"""
    periodicity_error: np.ndarray
    """|z(T) - z(0)| on the periodic orbit, relative to mu_s / sigma0 [-]"""
    settings: dict[str, Any] = field(default_factory=dict)

    @property
    def steady_mu(self) -> np.ndarray:
        """Static-curve value at each loop point [-]."""
        return steady_friction(self.velocity, *_steady_args(self.friction))

    @property
    def max_deviation(self) -> np.ndarray:
        """Largest |mu - mu_ss(v)| along each loop [-] (per frequency)."""
        return np.max(np.abs(self.mu - self.steady_mu), axis=1)

    @property
    def area(self) -> np.ndarray:
        """Area enclosed by each loop in the (v, mu) plane [m/s] (per frequency)."""
        v = np.concatenate([self.velocity, self.velocity[:, :1]], axis=1)
        mu = np.concatenate([self.mu, self.mu[:, :1]], axis=1)
        return 0.5 * np.abs(np.sum(v[:, :-1] * mu[:, 1:] - v[:, 1:] * mu[:, :-1], axis=1))

    def static_curve(self, points: int = 400) -> SteadyCurve:
        """The static curve over the loops' velocity range."""
        lo, hi = self.v_mean - self.v_amplitude, self.v_mean + self.v_amplitude
        return steady_curve(self.friction, np.linspace(lo, hi, points))

    def summary(self) -> dict[str, Any]:
        return {
            "v_mean_m_per_s": self.v_mean,
            "v_amplitude_m_per_s": self.v_amplitude,
            "loops": [
                {"frequency_hz": float(f), "max_deviation_from_static": float(d), "area_m_per_s": float(a),
                 "mu_min": float(mu.min()), "mu_max": float(mu.max()), "periodicity_error": float(e)}
                for f, d, a, mu, e in zip(self.frequencies_hz, self.max_deviation, self.area, self.mu,
                                          self.periodicity_error)
            ],
            "settings": self.settings,
        }

    def to_dataset(self):
        import xarray as xr

        dims = ("frequency", "phase")
        return xr.Dataset(
            {
                "velocity": (dims, self.velocity, {"long_name": "sliding velocity", "units": "m/s"}),
                "deflection": (dims, self.deflection, {"long_name": "bristle deflection z", "units": "m"}),
                "mu": (dims, self.mu, {"long_name": "friction coefficient F/N", "units": "1"}),
                "mu_steady": (dims, self.steady_mu, {"long_name": "static-curve friction coefficient",
                                                     "units": "1"}),
                "periodicity_error": ("frequency", self.periodicity_error, {"units": "1"}),
            },
            coords={
                "frequency": ("frequency", self.frequencies_hz, {"units": "Hz"}),
                "phase": ("phase", self.phase, {"units": "rad"}),
            },
            attrs={
                "title": "LuGre friction hysteresis loops",
                "v_mean_m_per_s": self.v_mean,
                "v_amplitude_m_per_s": self.v_amplitude,
                "friction_toml": _friction_toml(self.friction),
                "settings": repr(self.settings),
                "polywear_version": __version__,
            },
        )

    def plot(self, ax=None):
        """Static curve and one closed loop per frequency; returns the line artists."""
        import matplotlib as mpl

        ax = _axes(ax)
        artists = list(self.static_curve().plot(ax=ax, lw=2.5, zorder=3))
        colors = mpl.colormaps["viridis"](np.linspace(0.0, 0.85, len(self.frequencies_hz)))
        for f, v, mu, color in zip(self.frequencies_hz, self.velocity, self.mu, colors):
            artists += ax.plot(np.append(v, v[0]), np.append(mu, mu[0]), color=color, lw=1.4,
                               label=f"{f:g} Hz", zorder=4)
        ax.legend(title=f"$v_r = {self.v_mean:.3g} + {self.v_amplitude:.3g}\\,\\sin 2\\pi f t$ m/s",
                  fontsize="small")
        return artists


def _periodic_orbit(friction, velocity, period, t_eval, rtol, atol):
    """Bristle response on the periodic orbit of a T-periodic v(t), at ``t_eval`` (0 ... T).

    dz/dt is linear in z for a prescribed v(t): z(T) = q z(0) + c with q = memory(T),
    so the periodic start is c / (1 - q); one period from any start gives q and c.
    Returns the response and |z(T) - z(0)| sigma0 / mu_s on the orbit.
    """
    max_step = period / 64.0
    z_start = float(steady_deflection(velocity(0.0), friction.sigma0_per_m, *_steady_args(friction)[1:]))
    shot = bristle_response(friction, velocity, [0.0, period], z_start, rtol=rtol, atol=atol, max_step=max_step)
    q = shot.memory[-1]
    z_periodic = (shot.deflection[-1] - q * z_start) / (1.0 - q)
    loop = bristle_response(friction, velocity, t_eval, z_periodic, rtol=rtol, atol=atol, max_step=max_step)
    error = abs(loop.deflection[-1] - loop.deflection[0]) * friction.sigma0_per_m / friction.mu_static
    return loop, error


def _sinusoid(v_mean: float, v_amplitude: float, frequency: float) -> Callable[[Any], Any]:
    omega = 2.0 * math.pi * frequency
    return lambda t: v_mean + v_amplitude * np.sin(omega * t)


def hysteresis_loops(
    friction: Friction,
    v_mean: float,
    v_amplitude: float,
    frequencies_hz,
    *,
    points_per_period: int = 400,
    rtol: float = 1e-10,
    atol: float | None = None,
    progress: Callable[[], None] | None = None,
) -> HysteresisLoops:
    """Periodic LuGre friction loops for a sinusoidal sliding velocity (the paper's Fig. 1).

    The bristle ODE is driven by v_r(t) = v_mean + v_amplitude sin(2 pi f t). It is
    linear in z for a prescribed v(t), so one period from any start gives the map
    z(0) -> z(T) = q z(0) + c; its fixed point c / (1 - q) starts the periodic orbit
    (the transient is removed exactly, not waited out), which is then integrated once
    more and sampled. ``periodicity_error`` reports how well that orbit closes.

    Parameters
    ----------
    friction : Friction
    v_mean, v_amplitude : float
        Mean and amplitude of the sliding velocity [m/s]; ``v_amplitude > 0``.
    frequencies_hz : sequence of float
        Excitation frequencies [Hz], each > 0.
    points_per_period : int
        Samples per loop.
    rtol, atol : float
        Integration tolerances (see :func:`bristle_response`).
    progress : callable, optional
        Called once per finished frequency.
    """
    freqs = np.atleast_1d(np.asarray(frequencies_hz, dtype=float))
    if freqs.size == 0 or not np.all(np.isfinite(freqs)) or np.any(freqs <= 0.0):
        raise ValueError(f"frequencies_hz = {freqs.tolist()}: need one or more finite frequencies > 0")
    if not (math.isfinite(v_mean) and math.isfinite(v_amplitude)) or v_amplitude <= 0.0:
        raise ValueError(f"v_amplitude = {v_amplitude!r}, v_mean = {v_mean!r}: need finite values, amplitude > 0")
    if points_per_period < 8:
        raise ValueError(f"points_per_period = {points_per_period}: must be at least 8")
    rows = []
    for f in freqs:
        t = np.linspace(0.0, 1.0 / f, points_per_period + 1)
        rows.append(_periodic_orbit(friction, _sinusoid(v_mean, v_amplitude, f), 1.0 / f, t, rtol, atol))
        if progress is not None:
            progress()
    stack = lambda name: np.array([getattr(loop, name)[:-1] for loop, _ in rows])  # noqa: E731
    return HysteresisLoops(
        friction=friction,
        v_mean=float(v_mean),
        v_amplitude=float(v_amplitude),
        frequencies_hz=freqs,
        phase=np.linspace(0.0, 2.0 * math.pi, points_per_period + 1)[:-1],
        velocity=stack("velocity"),
        deflection=stack("deflection"),
        mu=stack("mu"),
        periodicity_error=np.array([err for _, err in rows]),
        settings={"points_per_period": points_per_period, "rtol": rtol, "atol": atol, "method": "Radau"},
    )


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
class _ParameterFit(_Saveable):
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
        return with_updates(params, {f"friction.{n}": self.value(n) for n in type(self.friction).model_fields})

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
            "toml": self.to_toml(),
        }

    def _attrs(self, title: str) -> dict[str, Any]:
        return {
            "title": title,
            "source": self.source,
            "friction_toml": self.to_toml(),
            "rms_residual": self.rms,
            "r_squared": self.r_squared,
            "converged": int(self.converged),
            "message": self.message,
            "polywear_version": __version__,
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
        return {**super().summary(), "negative_velocity_data": "magnitudes" if self.magnitudes else "signed"}

    def to_dataset(self):
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

    bounds = {
        "mu_static": (fields["mu_coulomb"] if "mu_coulomb" not in fit else 0.0, 5.0),
        "mu_coulomb": (0.0, 1.0) if ratio else (0.0, 5.0),
        "stribeck_velocity_m_per_s": (0.0, np.inf),
        "stribeck_exponent": (1.0, 10.0),
        "sigma2_s_per_m": (0.0, np.inf),
    }
    lower = np.array([bounds[n][0] for n in fit])
    upper = np.array([bounds[n][1] for n in fit])

    guess = _initial_guess(fold_v, fold_mu, base)
    if ratio:
        mu_s_guess = guess["mu_static"] if "mu_static" in fit else fields["mu_static"]
        guess["mu_coulomb"] = min(guess["mu_coulomb"] / mu_s_guess, 1.0)
    best = None
    for delta in sorted({1.0, 2.0, 4.0, base.stribeck_exponent}):
        start = np.clip([{**guess, "stribeck_exponent": delta}[n] for n in fit], lower, upper)
        sol = least_squares(residuals, start, jac=jacobian, bounds=(lower, upper), method="trf",
                            x_scale="jac", xtol=1e-14, ftol=1e-14, gtol=1e-14, max_nfev=2000)
        if best is None or sol.cost < best.cost:
            best = sol
        if "stribeck_exponent" not in fit:
            break

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

    def to_dataset(self):
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


def fit_loops(
    frequency_hz,
    time_s,
    velocity,
    mu,
    base: Friction | None = None,
    *,
    harmonics: int = 3,
    sigma0_range: tuple[float, float] = (1.0, 1e6),
    confidence: float = 0.95,
    rtol: float = 1e-8,
    progress: Callable[[], None] | None = None,
    source: str = "",
) -> LoopFit:
    """Fit sigma0 and sigma1 to measured periodic friction loops.

    Each frequency's points must come from one steady periodic loop (after the
    transient) and cover its period; ``time_s`` may span several periods. The measured
    velocity of each loop is replaced by its least-squares Fourier series (``harmonics``
    harmonics of the frequency), which drives the bristle ODE; its periodic orbit comes
    from the same fixed-point construction as :func:`hysteresis_loops`. The static-curve
    keys (mu_s, mu_c, v_s, delta, sigma2) are taken from ``base``: fit them first with
    :func:`fit_steady_curve`.

    The model is linear in sigma1, so for each sigma0 the best sigma1 >= 0 is a linear
    least-squares solution (variable projection); sigma0 is found by a scan of
    ``sigma0_range`` [1/m] in half-decade steps followed by a bounded Brent search in
    log sigma0. Standard errors come from the Jacobian at the optimum (central
    difference in sigma0, analytic in sigma1).
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
    lo, hi = sigma0_range
    if not 0.0 < lo < hi < math.inf:
        raise ValueError(f"sigma0_range = {sigma0_range!r}: need 0 < low < high")
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

    def model(sigma0: float):
        """z, dz/dt and v of the model at every point, for this sigma0."""
        friction = base.model_copy(update={"sigma0_per_m": sigma0})
        z, zdot, v = (np.empty_like(y) for _ in range(3))
        for idx, period, v_of_t, grid, where in groups:
            loop, _ = _periodic_orbit(friction, v_of_t, period, grid, rtol, None)
            z[idx], zdot[idx], v[idx] = loop.deflection[where], loop.rate[where], loop.velocity[where]
        if progress is not None:
            progress()
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


# -- data files ----------------------------------------------------------------------------

FREQUENCY_COLUMN = "frequency_hz"
TIME_COLUMN = "time_s"
LOOP_COLUMNS = (FREQUENCY_COLUMN, TIME_COLUMN, VELOCITY_COLUMN, FRICTION_COLUMN)
_SAMPLES = {"steady": "friction_sample.csv", "loops": "friction_loops_sample.csv"}


def _read_csv_columns(path: str | Path, columns: tuple[str, ...]) -> tuple[list[np.ndarray], list[int]]:
    """Numeric ``columns`` of a CSV file with a header row; also each row's line number."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise FrictionDataError(f"{path}: cannot read ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise FrictionDataError(f"{path}: not a text (CSV) file") from None
    rows = [(n, line) for n, line in enumerate(text.splitlines(), 1) if line.strip() and not line.lstrip().startswith("#")]
    if not rows:
        raise FrictionDataError(f"{path}: empty")
    header_line, header = rows[0][0], [c.strip() for c in next(csv.reader([rows[0][1]]))]
    missing = [c for c in columns if c not in header]
    if missing:
        raise FrictionDataError(
            f"{path} line {header_line}: missing column(s) {', '.join(missing)} "
            f"(header must name {', '.join(columns)}; found {', '.join(header)})"
        )
    index = [header.index(c) for c in columns]
    values: list[list[float]] = [[] for _ in columns]
    for n, line in rows[1:]:
        cells = next(csv.reader([line]))
        if len(cells) != len(header):
            raise FrictionDataError(f"{path} line {n}: {len(cells)} fields, header has {len(header)}")
        for name, i, out in zip(columns, index, values):
            try:
                value = float(cells[i])
            except ValueError:
                raise FrictionDataError(f"{path} line {n}: {name} = {cells[i].strip()!r} is not a number") from None
            if not math.isfinite(value):
                raise FrictionDataError(f"{path} line {n}: {name} = {cells[i].strip()!r} is not finite")
            out.append(value)
    return [np.array(col) for col in values], [n for n, _ in rows[1:]]


def read_steady_csv(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Measured steady points (velocity [m/s], mu [-]) from a CSV file.

    The first row is a header that names the columns ``sliding_velocity_m_per_s``
    [m/s] and ``friction_coefficient`` [-] (in any order; other columns are ignored;
    lines starting with ``#`` are comments). Raises :class:`FrictionDataError` naming
    the file, line and problem.
    """
    (v, mu), lines = _read_csv_columns(path, (VELOCITY_COLUMN, FRICTION_COLUMN))
    if np.any(v == 0.0):
        n = lines[int(np.argmax(v == 0.0))]
        raise FrictionDataError(f"{path} line {n}: {VELOCITY_COLUMN} = 0, where steady friction is not defined")
    return v, mu


def read_loops_csv(path: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Measured loops (frequency [Hz], time [s], velocity [m/s], mu [-]) from a CSV file.

    Like :func:`read_steady_csv`, with the columns ``frequency_hz``, ``time_s``,
    ``sliding_velocity_m_per_s`` and ``friction_coefficient``.
    """
    (f, t, v, mu), lines = _read_csv_columns(path, LOOP_COLUMNS)
    if np.any(f <= 0.0):
        n = lines[int(np.argmax(f <= 0.0))]
        raise FrictionDataError(f"{path} line {n}: {FREQUENCY_COLUMN} must be > 0")
    return f, t, v, mu


def synthetic_steady_data(friction: Friction, velocity, noise_sd: float, seed: int) -> np.ndarray:
    """Steady friction at ``velocity`` [m/s] plus Gaussian noise of s.d. ``noise_sd`` [-].

    Noise from ``numpy.random.default_rng(seed)``; used for the shipped sample and tests.
    """
    v = np.asarray(velocity, dtype=float)
    rng = np.random.default_rng(seed)
    return steady_friction(v, *_steady_args(friction)) + rng.normal(0.0, noise_sd, v.shape)


def sample_path(kind: str = "steady") -> Path:
    """Path of the shipped sample data, ``"steady"`` points or ``"loops"`` (docs/friction.md)."""
    from importlib.resources import files

    if kind not in _SAMPLES:
        raise ValueError(f"kind = {kind!r}: one of {', '.join(_SAMPLES)}")
    return Path(str(files("polywear").joinpath("data", _SAMPLES[kind])))
