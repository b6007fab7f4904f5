"""What the tread actually does at one speed when no stable period-1 cycle of the continuation does it.

The continuation follows period-1 cycles from Hopf points. Where steady rolling is
unstable but none of those cycles is stable (past a period doubling: stick-slip with
two or more maxima per period; past a torus bifurcation: a quasi-periodic motion; or a
static divergence, a real eigenvalue crossing zero), the motion reached is found by
simulation (:mod:`.simulation`), started from the continuation's last stable cycle (the
stable cycle point nearest in speed), or from steady rolling disturbed when there is
none, and named:

``"period-doubled SEV (stick-slip)"``
    the run settles on a cycle whose lead state has m >= 2 maxima per period;
``"SEV on a cycle off the continued branches"``
    it settles on a simple cycle (m = 1) that no continued branch holds at that speed;
``"quasi-periodic or chaotic SEV"``
    it keeps oscillating without settling (a torus or chaos);
``"static divergence"``
    it comes to rest away from steady rolling (another steady state);
``"no SEV"``
    it returns to steady rolling.

Amplitude = half peak-to-peak over the analysed window; the dominant frequency is the
largest peak of the window's spectrum (Hann window, parabolic interpolation of the
log magnitude between bins).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..models import get_model
from ..models.base import kmh_to_ms, ms_to_kmh
from .simulation import SimulationResult, simulate

__all__ = ["Attractor", "reached_attractor", "dominant_frequency"]

PERIOD_DOUBLED = "period-doubled SEV (stick-slip)"
OFF_BRANCH_CYCLE = "SEV on a cycle off the continued branches"
QUASI_PERIODIC = "quasi-periodic or chaotic SEV"
DIVERGENCE = "static divergence"
NO_SEV = "no SEV"


@dataclass(frozen=True)
class Attractor:
    """The motion a simulation settled on at one speed."""

    regime: str
    speed_kmh: float
    amplitude: np.ndarray
    """Half peak-to-peak per state over the analysed window [state units]."""
    dominant_frequency_hz: float
    """Frequency of the largest spectral peak of the lead state [Hz] (NaN at rest)."""
    run: SimulationResult
    start: str
    """Where the simulation started."""

    @property
    def oscillating(self) -> bool:
        return self.regime not in (DIVERGENCE, NO_SEV)

    def summary(self) -> dict:
        st = self.run.steady
        x = self.run.model.index("x")
        return {
            "regime": self.regime,
            "speed_kmh": self.speed_kmh,
            "amplitude_x_m": float(self.amplitude[x]),
            "dominant_frequency_hz": _finite(self.dominant_frequency_hz),
            "period_s": _finite(st.period),
            "maxima_per_period": st.maxima_per_period,
            "outcome": st.outcome,
            "offset_x_m": float(st.mean[x] - self.run.equilibrium[x]),
            "simulated_s": self.run.duration_s,
            "start": self.start,
        }


def _finite(value):
    return float(value) if np.isfinite(value) else None


def dominant_frequency(t: np.ndarray, s: np.ndarray) -> float:
    """Frequency [Hz] of the largest peak of the spectrum of ``s`` sampled uniformly at ``t``."""
    s = np.asarray(s, dtype=float) - np.mean(s)
    if len(s) < 8 or not np.any(s):
        return math.nan
    dt = float(t[1] - t[0])
    mag = np.abs(np.fft.rfft(s * np.hanning(len(s))))
    k = int(np.argmax(mag[1:])) + 1
    shift = 0.0
    if 1 <= k < len(mag) - 1:
        a, b, c = np.log(mag[k - 1 : k + 2] + 1e-300)
        denom = a - 2.0 * b + c
        shift = 0.5 * (a - c) / denom if denom != 0.0 else 0.0
    return (k + shift) / (len(s) * dt)


def _start_state(diagram, speed_kmh: float) -> tuple[np.ndarray | None, str]:
    """State on the stable continuation cycle nearest in speed, or None (steady rolling disturbed)."""
    stable = [c for c in diagram.cycles if c.stable and c.orbit is not None]
    if not stable:
        return None, "steady rolling with x disturbed by 0.1 mm"
    c = min(stable, key=lambda c: abs(ms_to_kmh(c.speed) - speed_kmh))
    return np.array(c.orbit.nodes[0], dtype=float), f"the stable cycle at {ms_to_kmh(c.speed):.1f} km/h"


def reached_attractor(diagram, speed_kmh: float, duration_s: float = 1.5) -> Attractor:
    """Simulate ``duration_s`` [s] at ``speed_kmh`` [km/h] from the continuation's last
    stable cycle (see the module docstring) and name the motion reached."""
    params = diagram.params
    model = get_model(params.model)
    p = model.pack(params)
    initial, start = _start_state(diagram, speed_kmh)
    run = simulate(params, speed_kmh, duration_s, disturbance=1e-4, initial=initial)
    st = run.steady
    lead = model.index(run.settings.lead_state)
    window = run.t >= (1.0 - run.settings.window_fraction) * run.duration_s
    t, s = run.t[window], run.u[window, lead]
    u_eq = model.equilibrium(kmh_to_ms(speed_kmh), p)
    offset = abs(float(np.mean(s)) - u_eq[lead])
    swing = 0.5 * float(np.ptp(s))
    if st.outcome == "equilibrium":
        regime = NO_SEV
    elif swing <= 1e-3 * max(offset, 1e-300) or (st.outcome != "cycle" and swing < 1e-9):
        regime = DIVERGENCE  # at rest, away from steady rolling
    elif st.outcome == "cycle":
        regime = PERIOD_DOUBLED if st.maxima_per_period > 1 else OFF_BRANCH_CYCLE
    else:
        regime = QUASI_PERIODIC
    amplitude = st.amplitude if st.outcome == "cycle" else 0.5 * np.ptp(run.u[window], axis=0)
    frequency = dominant_frequency(t, s) if regime not in (NO_SEV, DIVERGENCE) else math.nan
    return Attractor(regime, float(speed_kmh), np.asarray(amplitude), frequency, run, start)
