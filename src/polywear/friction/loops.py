"""LuGre bristle dynamics for a prescribed sliding velocity and periodic hysteresis loops.

The paper's Fig. 1 shows the friction coefficient against a sinusoidal sliding velocity:
at low frequency the loop lies on the static curve, at high frequency it opens.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any, Callable

import numpy as np
from numpy.typing import ArrayLike

from ..errors import NumericalError
from ..params import Friction
from ..physics.lugre import (
    bristle_decay_rate,
    bristle_rate,
    friction_coefficient,
    steady_deflection,
    steady_friction,
    stribeck,
)
from ..progress import Progress, StepCounter
from ..results import Result
from ..settings import check_count, check_positive
from .curve import SteadyCurve, _axes, _friction_toml, _steady_args, steady_curve

__all__ = ["BristleResponse", "HysteresisLoops", "LoopSettings", "bristle_response", "hysteresis_loops",
           "MAX_LOOP_FREQUENCY_HZ", "MAX_SLIDING_SPEED_M_PER_S"]

MAX_LOOP_FREQUENCY_HZ = 1.0e4
"""Highest excitation frequency of a loop [Hz]: far above the tread (100-150 Hz) and belt modes."""
MAX_SLIDING_SPEED_M_PER_S = 1000.0
"""Largest sliding velocity accepted in data and loops [m/s] (far beyond any tire)."""


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
        raise NumericalError(f"bristle integration failed: {sol.message}")
    v = np.asarray(velocity(t), dtype=float) * np.ones_like(t)
    z = sol.y[0]
    zdot = _bristle_rates(f, v, z)
    mu = friction_coefficient(v, z, zdot, s0, f.sigma1_s_per_m, f.sigma2_s_per_m)
    return BristleResponse(t, v, z, zdot, mu, np.exp(-sol.y[1]), sol.nfev)


# -- hysteresis loops ----------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class HysteresisLoops(Result):
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
        """What ``polywear friction loops --json`` prints: per frequency, deviation and area."""
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

    def _dataset(self):
        """xarray Dataset over (frequency, phase): velocity, deflection, friction, static curve."""
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


@dataclass(frozen=True)
class LoopSettings:
    """Numerical settings of :func:`hysteresis_loops` (``polywear friction loops --points``)."""

    points_per_period: int = 400
    """Samples per loop [-] (integer >= 8)."""
    rtol: float = 1e-10
    """Relative tolerance of the bristle integration (Radau, see :func:`bristle_response`) [-]."""
    atol: float | None = None
    """Absolute tolerance on the bristle deflection [m]; None: 1e-9 of mu_s / sigma0."""

    def __post_init__(self) -> None:
        check_count(self, "points_per_period", minimum=8)
        check_positive(self, "rtol")
        if self.atol is not None:
            check_positive(self, "atol")


def _sinusoid(v_mean: float, v_amplitude: float, frequency: float) -> Callable[[Any], Any]:
    omega = 2.0 * math.pi * frequency
    return lambda t: v_mean + v_amplitude * np.sin(omega * t)


def hysteresis_loops(
    friction: Friction,
    v_mean: float,
    v_amplitude: float,
    frequencies_hz: ArrayLike,
    *,
    settings: LoopSettings = LoopSettings(),
    progress: Progress | None = None,
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
    settings : LoopSettings
        Samples per loop and integration tolerances (:class:`LoopSettings`).
    progress : callable, optional
        Progress callback (:mod:`polywear.progress`), once per finished frequency.
    """
    freqs = np.atleast_1d(np.asarray(frequencies_hz, dtype=float))
    if freqs.size == 0 or not np.all(np.isfinite(freqs)) or np.any(freqs <= 0.0) or np.any(freqs > MAX_LOOP_FREQUENCY_HZ):
        raise ValueError(f"frequencies_hz = {freqs.tolist()}: need one or more frequencies in "
                         f"(0, {MAX_LOOP_FREQUENCY_HZ:g}] Hz")
    if not (math.isfinite(v_mean) and math.isfinite(v_amplitude)) or v_amplitude <= 0.0:
        raise ValueError(f"v_amplitude = {v_amplitude!r}, v_mean = {v_mean!r}: need finite values, amplitude > 0")
    points_per_period = settings.points_per_period
    rows = []
    step = StepCounter(progress, freqs.size)
    for f in freqs:
        t = np.linspace(0.0, 1.0 / f, points_per_period + 1)
        rows.append(_periodic_orbit(friction, _sinusoid(v_mean, v_amplitude, f), 1.0 / f, t, settings.rtol,
                                    settings.atol))
        step(f"{f:g} Hz")
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
        settings={**asdict(settings), "method": "Radau"},
    )
