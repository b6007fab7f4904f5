"""Brute-force bifurcation diagram: run to steady state at each speed (the paper's way).

Four kinds of start at every speed of a list:

``"small"``  the equilibrium with ``x`` moved by a small disturbance;
``"large"``  the equilibrium with ``x`` moved by a large disturbance;
``"up"``     the final state of the next lower speed (speeds increasing);
``"down"``   the final state of the next higher speed (speeds decreasing).

The two chains start at their first speed from the small disturbance. Where stable
steady rolling and a stable cycle coexist (hard excitation) the small and large starts
end differently, and the up and down chains show the hysteresis.

Each run (:func:`settle`) integrates in chunks, continuing from the end of the last, and
stops when :func:`polywear.dynamics.simulation.classify_window` finds the equilibrium or
a cycle in the latest chunk, or when ``max_duration_s`` is used up (``steady`` False).
:func:`settle` is a pure function of picklable inputs, so the independent runs (small
and large starts) can go to an executor:
``sweep(..., executor=polywear.parallel.Executor("processes", workers=2))``.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass

import numpy as np

from .. import __version__
from ..models import model_for
from ..results import Result
from ..parallel import Executor
from ..params import Params, to_toml
from ..progress import Progress, StepCounter
from ..settings import check_order, check_positive
from ..solvers.integrate import integrate
from ..units import plot_scale, kmh_to_ms
from .diagram import _open_at, _open_warning
from .intervals import runs_of
from .simulation import SimulationSettings, SteadyOutcome, classify_window, initial_state

__all__ = ["START_TYPES", "SteadyRun", "SweepResult", "SweepSettings", "settle", "sweep", "sweep_bands"]

START_TYPES = ("small", "large", "up", "down")
_MARKERS = {"small": ("o", "C0"), "large": ("s", "C3"), "up": ("^", "C2"), "down": ("v", "C1")}


@dataclass(frozen=True)
class SweepSettings:
    """Starts and run control of :func:`sweep`."""

    small: float = 1e-5
    """Small disturbance of ``x`` [m] (finite, non-zero, either sign)."""
    large: float = 1e-3
    """Large disturbance of ``x`` [m] (finite, non-zero, either sign)."""
    chunk_s: float = 0.25
    """Integration chunk [s]: a run stops after the first chunk that has settled."""
    max_duration_s: float = 4.0
    """Longest run [s] (at least one chunk)."""
    simulation: SimulationSettings = SimulationSettings()
    """Integrator and steady-state test of every chunk."""

    def __post_init__(self) -> None:
        for name in ("small", "large"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value != 0.0):
                raise ValueError(f"SweepSettings: {name} = {value!r}: must be a finite, non-zero disturbance [m]")
        check_positive(self, "chunk_s", "max_duration_s")
        check_order(self, "chunk_s", "max_duration_s")
        if not isinstance(self.simulation, SimulationSettings):
            raise ValueError(f"SweepSettings: simulation = {self.simulation!r}: must be a SimulationSettings")


@dataclass(frozen=True)
class SteadyRun:
    """Where one run from one start settled."""

    speed_kmh: float
    start: str
    outcome: SteadyOutcome
    """Equilibrium, cycle or transient (not settled in time)."""
    amplitude: np.ndarray
    mean: np.ndarray
    maximum: np.ndarray
    minimum: np.ndarray
    frequency_hz: float
    duration_s: float
    """Time simulated until the steady state was recognized [s]."""
    final_state: np.ndarray

    @property
    def steady(self) -> bool:
        return self.outcome is not SteadyOutcome.TRANSIENT


def settle(
    params: Params,
    speed_kmh: float,
    initial,
    *,
    start: str = "",
    settings: SweepSettings = SweepSettings(),
) -> SteadyRun:
    """Integrate from ``initial`` at ``speed_kmh`` [km/h] in chunks of ``settings.chunk_s`` [s]
    until the latest chunk is at the equilibrium or on a cycle, at most
    ``settings.max_duration_s`` [s], with ``settings.simulation`` (:class:`SweepSettings`;
    its disturbances are not used here)."""
    chunk_s, max_duration_s = settings.chunk_s, settings.max_duration_s
    simulation = settings.simulation
    model = model_for(params)
    p = model.pack(params)
    V = float(kmh_to_ms(speed_kmh))
    u_eq = model.equilibrium(V, p)
    u = np.array(initial, dtype=float)
    scale = np.abs(u - u_eq)
    h0 = None
    elapsed = 0.0
    while True:
        traj = integrate(model, u, V, p, chunk_s, dt_out=simulation.dt_out, rtol=simulation.rtol,
                         atol=simulation.atol, method=simulation.method, dense_from=0.0, h0=h0)
        scale = np.maximum(scale, np.abs(traj.u - u_eq).max(axis=0))
        steady = classify_window(model, V, p, traj.t, traj.u, traj.dense, u_eq, scale, simulation)
        elapsed += chunk_s
        u, h0 = traj.u_end, traj.h_last
        if steady.steady or elapsed + chunk_s > max_duration_s * (1.0 + 1e-12):
            break
    return SteadyRun(
        speed_kmh=float(speed_kmh), start=start, outcome=steady.outcome, amplitude=steady.amplitude,
        mean=steady.mean, maximum=steady.maximum, minimum=steady.minimum,
        frequency_hz=steady.frequency, duration_s=elapsed, final_state=u.copy(),
    )


def _settle_job(job) -> SteadyRun:
    """``settle`` for one (params, speed, start, disturbance, settings) tuple."""
    params, speed_kmh, start, disturbance, settings = job
    model = model_for(params)
    p = model.pack(params)
    u0 = initial_state(model, p, float(kmh_to_ms(speed_kmh)), disturbance)
    return settle(params, speed_kmh, u0, start=start, settings=settings)


@dataclass(frozen=True)
class SweepResult(Result):
    """Steady states against speed for each kind of start."""

    params: Params
    speeds_kmh: np.ndarray
    runs: dict
    """start type -> list of :class:`SteadyRun`, one per speed (ascending)."""
    small: float
    large: float
    settings: SimulationSettings
    chunk_s: float
    max_duration_s: float
    version: str = __version__

    @property
    def state_names(self) -> tuple[str, ...]:
        return model_for(self.params).state_names

    def _field(self, name):
        return np.array([[getattr(r, name) for r in self.runs[s]] for s in START_TYPES])

    def summary(self) -> dict:
        """JSON-ready: per start type and speed the outcome, amplitudes and frequency."""
        names = self.state_names
        return {
            "model": self.params.model,
            "speeds_kmh": self.speeds_kmh.tolist(),
            "disturbances_m": {"small": self.small, "large": self.large},
            "runs": {
                s: [
                    {
                        "speed_kmh": r.speed_kmh,
                        "outcome": r.outcome,
                        "amplitude": {q: float(a) if np.isfinite(a) else None for q, a in zip(names, r.amplitude)},
                        "frequency_hz": r.frequency_hz if np.isfinite(r.frequency_hz) else None,
                        "duration_s": r.duration_s,
                    }
                    for r in self.runs[s]
                ]
                for s in START_TYPES
            },
        }

    def _dataset(self):
        """xarray Dataset over (start, speed_kmh, state)."""
        import xarray as xr

        model = model_for(self.params)
        units = " ".join(model.state_units)
        data = {
            name: (("start", "speed_kmh", "state"), self._field(name), {"units": units})
            for name in ("amplitude", "mean", "maximum", "minimum", "final_state")
        }
        data["frequency_hz"] = (("start", "speed_kmh"), self._field("frequency_hz"), {"units": "Hz"})
        data["duration_s"] = (("start", "speed_kmh"), self._field("duration_s"), {"units": "s"})
        data["outcome"] = (("start", "speed_kmh"), self._field("outcome").astype(str))
        data["steady"] = (("start", "speed_kmh"), self._field("steady").astype(np.int8))
        return xr.Dataset(
            data,
            coords={"start": list(START_TYPES), "speed_kmh": ("speed_kmh", self.speeds_kmh, {"units": "km/h"}),
                    "state": list(model.state_names)},
            attrs={
                "model": self.params.model,
                "small_disturbance_m": self.small,
                "large_disturbance_m": self.large,
                "chunk_s": self.chunk_s,
                "max_duration_s": self.max_duration_s,
                "settings": json.dumps(asdict(self.settings)),
                "params_toml": to_toml(self.params),
                "polywear_version": self.version,
            },
        )

    def plot(self, ax=None, state: str = "x"):
        """Amplitude of ``state`` against speed, one marker per start type (hollow: not
        settled). Returns the artists."""
        import matplotlib.pyplot as plt

        model = model_for(self.params)
        q = model.index(state)
        factor, unit = plot_scale(model.state_units[q])
        if ax is None:
            _, ax = plt.subplots(figsize=(7, 4))
        artists = []
        for s in START_TYPES:
            marker, color = _MARKERS[s]
            runs = self.runs[s]
            amp = np.array([factor * r.amplitude[q] for r in runs])
            speed = np.array([r.speed_kmh for r in runs])
            steady = np.array([r.steady for r in runs])
            artists += ax.plot(speed[steady], amp[steady], marker, color=color, ms=5, alpha=0.8,
                               ls="none", label=f"{s} start")
            if (~steady).any():
                artists += ax.plot(speed[~steady], amp[~steady], marker, mfc="none", color=color, ms=5,
                                   ls="none")
        ax.set_xlabel("speed [km/h]")
        ax.set_ylabel(f"{state} amplitude [{unit}]")
        ax.set_title(f"{self.params.model}: steady amplitude by brute-force sweep "
                     f"(small {self.small * 1e3:g} mm, large {self.large * 1e3:g} mm)", fontsize=9)
        ax.legend(fontsize=8)
        return artists


def sweep(
    params: Params,
    speeds_kmh,
    *,
    settings: SweepSettings = SweepSettings(),
    executor: Executor | None = None,
    progress: Progress | None = None,
) -> SweepResult:
    """Steady states at each speed [km/h] from small and large disturbances of ``x`` [m]
    and along increasing and decreasing speed. ``executor`` (:class:`polywear.parallel.Executor`)
    runs the independent small/large starts (None: one after another in this process);
    ``progress(runs done, runs, start)`` is called after every run (:mod:`polywear.progress`;
    with an executor, the independent runs are reported once they are all done). ``settings``: the disturbances,
    chunk and longest run, and the simulation settings (:class:`SweepSettings`)."""
    speeds = np.unique(np.asarray(speeds_kmh, dtype=float))
    if speeds.size == 0 or not np.all(np.isfinite(speeds)) or speeds[0] <= 0.0:
        raise ValueError(f"speeds {speeds_kmh!r}: need at least one positive finite speed [km/h]")
    small, large = settings.small, settings.large
    jobs = [(params, v, s, d, settings) for s, d in (("small", small), ("large", large)) for v in speeds]
    independent = []
    step = StepCounter(progress, 4 * speeds.size)
    for run in map(_settle_job, jobs) if executor is None else executor.map(_settle_job, jobs):
        independent.append(run)
        step(f"{run.start} start at {run.speed_kmh:.1f} km/h")
    runs = {"small": independent[: speeds.size], "large": independent[speeds.size:]}
    for start, order in (("up", speeds), ("down", speeds[::-1])):
        chain = []
        for i, v in enumerate(order):
            if i == 0:
                run = _settle_job((params, v, start, small, settings))
            else:
                run = settle(params, v, chain[-1].final_state, start=start, settings=settings)
            chain.append(run)
            step(f"{start} start at {v:.1f} km/h")
        runs[start] = sorted(chain, key=lambda r: r.speed_kmh)
    return SweepResult(params=params, speeds_kmh=speeds, runs=runs, small=float(small), large=float(large),
                       settings=settings.simulation, chunk_s=float(settings.chunk_s),
                       max_duration_s=float(settings.max_duration_s))


# -- bands as the sweep sees them --------------------------------------------------------------
def sweep_bands(result) -> dict:
    """First/second bifurcation speeds and bands as a brute-force sweep sees them.

    ``result`` is a :class:`polywear.dynamics.sweep.SweepResult`. The SEV band is where a
    large disturbance (or the chain from the neighbouring speed) ends on a cycle; the
    linear band where even a small one does. Bounds are grid speeds (resolution = spacing).
    """
    speeds = np.asarray(result.speeds_kmh)

    def band(starts):
        on = np.zeros(len(speeds), dtype=bool)
        for start in starts:
            on |= np.array([r.outcome == SteadyOutcome.CYCLE for r in result.runs[start]])
        return runs_of(speeds, on)

    sev = band(("large", "up", "down"))
    # a band that reaches the first or last grid speed is cut there: no bifurcation speed
    open_at = [e for e, hit in (("lower", sev and sev[0][0] == speeds[0]), ("upper", sev and sev[-1][1] == speeds[-1]))
               if hit]
    return {
        "model": result.params.model,
        "method": "sweep",
        "speeds_kmh": speeds.tolist(),
        "open_at": _open_at(open_at),
        "warnings": [_open_warning(edge, (speeds[0], speeds[-1])) for edge in open_at],
        "linear_band_kmh": [_grid_bounds(b, speeds) for b in band(("small",))],
        "sev_band_kmh": [_grid_bounds(b, speeds) for b in sev],
        "first_bifurcation_speed_kmh": sev[0][0] if sev and "lower" not in open_at else None,
        "second_bifurcation_speed_kmh": sev[-1][1] if sev and "upper" not in open_at else None,
        "grid_spacing_kmh": float(np.max(np.diff(speeds))) if len(speeds) > 1 else None,
        "unsettled_runs": sum(not r.steady for runs in result.runs.values() for r in runs),
    }


def _grid_bounds(interval, speeds) -> list:
    """A band of the sweep, a bound at the first or last grid speed as None (cut by the grid)."""
    lo, hi = interval
    return [None if lo == speeds[0] else lo, None if hi == speeds[-1] else hi]
