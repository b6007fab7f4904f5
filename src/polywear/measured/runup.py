"""Simulation along a speed ramp (run-up or coast-down), as a drum or road test drives it.

The models are autonomous with the speed as a parameter; a ramp is integrated in short
chunks at constant speed (the chunk's mid speed), the state carried over from chunk to
chunk. With chunks of ``chunk_s`` and a ramp of ``r`` km/h/s the speed is never more than
``r chunk_s / 2`` off the exact ramp (0.04 km/h for 4 km/h/s and 20 ms), small against the
passage of a Hopf point, which takes seconds. Output on a uniform time grid: the states,
the speed, and the tread's lateral acceleration (what an accelerometer on the tread or
the knuckle sees of the SEV).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..models import model_for
from ..units import kmh_to_ms
from ..params import Params
from ..solvers.integrate import integrate

__all__ = ["RampRun", "simulate_ramp"]


@dataclass
class RampRun:
    """A simulated ramp: ``t`` [s], ``speed_kmh``, ``states`` (k, n), ``acceleration``
    (lateral tread acceleration [m/s^2]) on the same uniform grid."""

    params: Params
    t: np.ndarray
    speed_kmh: np.ndarray
    states: np.ndarray
    acceleration: np.ndarray
    state_names: tuple[str, ...]


def simulate_ramp(
    params: Params,
    speed_start_kmh: float,
    speed_end_kmh: float,
    rate_kmh_per_s: float,
    sample_rate_hz: float,
    perturbation_m: float = 1e-6,
    kick_m: float = 0.0,
    seed: int = 0,
    chunk_s: float = 0.02,
) -> RampRun:
    """Integrate the model while the speed runs linearly from start to end.

    Parameters
    ----------
    params : Params
    speed_start_kmh, speed_end_kmh : float
        Ramp ends [km/h] (end below start: a coast-down).
    rate_kmh_per_s : float
        Magnitude of the ramp rate [km/h/s].
    sample_rate_hz : float
        Output sampling rate [Hz].
    perturbation_m : float
        Initial lateral tread displacement from the steady state at the start speed [m]
        (the disturbance the growth starts from).
    kick_m : float
        Standard deviation of a random lateral tread displacement added at the start of
        every chunk [m] (road-induced disturbances; 0: none).
    seed : int
        Seed of the kicks (``numpy.random.default_rng``).
    chunk_s : float
        Length of the constant-speed chunks [s] (rounded to whole samples).
    """
    if not rate_kmh_per_s > 0.0 or not sample_rate_hz > 0.0:
        raise ValueError("rate_kmh_per_s and sample_rate_hz must be positive")
    model = model_for(params)
    p = model.pack(params)
    duration = abs(speed_end_kmh - speed_start_kmh) / rate_kmh_per_s
    direction = 1.0 if speed_end_kmh >= speed_start_kmh else -1.0
    n_chunk = max(1, round(chunk_s * sample_rate_hz))
    dt = 1.0 / sample_rate_hz
    n_total = int(np.floor(duration * sample_rate_hz)) + 1
    u = model.equilibrium(kmh_to_ms(speed_start_kmh), p).copy()
    u[model.index("x")] += perturbation_m
    states = np.empty((n_total, model.n))
    accel = np.empty(n_total)
    speeds = speed_start_kmh + direction * rate_kmh_per_s * dt * np.arange(n_total)
    x_index, xdot = model.index("x"), model.index("xdot")
    rng = np.random.default_rng(seed)
    h0 = None
    for start in range(0, n_total, n_chunk):
        if kick_m > 0.0 and start > 0:
            u = u.copy()
            u[x_index] += kick_m * rng.standard_normal()
        stop = min(start + n_chunk, n_total)
        v_mid = kmh_to_ms(0.5 * (speeds[start] + speeds[stop - 1]))
        traj = integrate(model, u, v_mid, p, (stop - start) * dt, dt_out=dt, h0=h0)
        states[start:stop] = traj.u[: stop - start]
        pv = model.prepared(v_mid, p)
        accel[start:stop] = [model.f(s, v_mid, pv)[xdot] for s in traj.u[: stop - start]]
        u, h0 = traj.u_end, traj.h_last
    return RampRun(params, dt * np.arange(n_total), speeds, states, accel, model.state_names)
