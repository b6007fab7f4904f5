"""What the tread actually does at one speed when no stable period-1 cycle of the continuation does it.

The continuation follows period-1 cycles from Hopf points. Where steady rolling is
unstable but none of those cycles is stable (past a period doubling: stick-slip with
two or more maxima per period; past a torus bifurcation: a quasi-periodic motion; or a
static divergence, a real eigenvalue crossing zero), the motion reached is found by
simulation (:mod:`.simulation`), started from the continuation's last stable cycle (the
stable cycle point nearest in speed) and from steady rolling disturbed (several attractors
can coexist: stick-slip at mu_c = 0.05 and 110 km/h ends on a cycle with two maxima per
period from the one start and three from the other), and named:

``"period-multiplied SEV (stick-slip)"``
    the run settles on a cycle whose lead state has m >= 2 maxima per period (past a
    period doubling, or stick-slip ringing);
``"SEV on a cycle off the continued branches"``
    it settles on a simple cycle (m = 1) that no continued branch holds at that speed;
``"quasi-periodic or chaotic SEV"``
    it keeps oscillating without settling on a cycle, with a sustained swing (a torus or
    chaos; a run still growing or decaying is continued first, up to four pieces);
``"static divergence"``
    it does not oscillate (fewer than ``min_cycles`` periods of its dominant frequency in
    the analysed window) and stays away from steady rolling: it rests on or drifts to
    another state;
``"no SEV"``
    it returns to steady rolling.

Amplitude = half peak-to-peak over the analysed window; the dominant frequency is the
largest peak of the window's spectrum (Hann window, parabolic interpolation of the
log magnitude between bins).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

import numpy as np

from ..results import Result, with_deprecated_keys
from .simulation import SimulationResult, SteadyOutcome, _finite, simulate

__all__ = ["Attractor", "Regime", "reached_attractors", "dominant_frequency"]


class Regime(StrEnum):
    """The motion at one speed (the value is the text of reports and JSON; the module says
    when): one a simulation settled on, or, in the report's operating verdict, a stable
    cycle of the continuation (``SOFT``, ``HARD``)."""

    SOFT = "unstable rolling (soft SEV)"
    """A stable cycle of the continuation where steady rolling is unstable."""
    HARD = "hard SEV region"
    """A stable cycle of the continuation beside stable steady rolling (a disturbance starts it)."""
    PERIOD_MULTIPLIED = "period-multiplied SEV (stick-slip)"
    OFF_BRANCH_CYCLE = "SEV on a cycle off the continued branches"
    QUASI_PERIODIC = "quasi-periodic or chaotic SEV"
    DIVERGENCE = "static divergence"
    NO_SEV = "no SEV"


@dataclass(frozen=True)
class Attractor(Result):
    """The motion a simulation settled on at one speed."""

    regime: Regime
    speed_kmh: float
    amplitude: np.ndarray
    """Half peak-to-peak per state over the analysed window [state units]."""
    dominant_frequency_hz: float
    """Frequency of the largest spectral peak of the lead state [Hz] (NaN at rest)."""
    run: SimulationResult
    start: str
    """Where the simulation started."""
    simulated_s: float
    """Total simulated time [s] (the classified run is its last piece)."""

    @property
    def oscillating(self) -> bool:
        return self.regime not in (Regime.DIVERGENCE, Regime.NO_SEV)

    @property
    def params(self):
        """The parameters of the simulation."""
        return self.run.params

    @property
    def settings(self):
        """The simulation settings."""
        return self.run.settings

    def _dataset(self):
        """The classified piece's data (a :class:`SimulationResult`) with the regime in attrs."""
        ds = self.run._dataset()
        ds.attrs.update(regime=self.regime.value, start=self.start, simulated_s=self.simulated_s,
                        dominant_frequency_hz=self.dominant_frequency_hz)
        return ds

    def figure(self):
        """A new Figure with the phase portraits of the attractor."""
        return self.plot()[0].figure

    def plot(self, ax=None):
        """Phase portraits of the classified piece's last half (the attractor). Returns artists."""
        return self.run.plot(ax, tail_s=self.run.settings.window_fraction * self.run.duration_s)

    def summary(self) -> dict:
        st = self.run.steady
        x = self.run.model.index("x")
        return with_deprecated_keys({
            "regime": self.regime,
            "speed_kmh": self.speed_kmh,
            "amplitude_x_mm": 1e3 * float(self.amplitude[x]),
            "dominant_frequency_hz": _finite(self.dominant_frequency_hz),
            "period_s": _finite(st.period),
            "maxima_per_period": st.maxima_per_period,
            "outcome": st.outcome,
            "offset_x_mm": 1e3 * float(st.mean[x] - self.run.equilibrium[x]),
            "simulated_s": self.simulated_s,
            "start": self.start,
        }, {"amplitude_x_mm": ("amplitude_x_m", 1e-3), "offset_x_mm": ("offset_x_m", 1e-3)})


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


def _starts(diagram, speed_kmh: float) -> list[tuple[np.ndarray | None, str]]:
    """Start states: on the stable continuation cycle nearest in speed (if any), and steady
    rolling with x disturbed by 0.1 mm (None: :func:`simulate`'s disturbance)."""
    starts = []
    stable = [c for c in diagram.cycles if c.stable and c.orbit is not None]
    if stable:
        c = min(stable, key=lambda c: abs(c.speed_kmh - speed_kmh))
        starts.append((np.array(c.orbit.nodes[0], dtype=float), f"the stable cycle at {c.speed_kmh:.1f} km/h"))
    starts.append((None, "steady rolling with x disturbed by 0.1 mm"))
    return starts


def reached_attractors(diagram, speed_kmh: float, duration_s: float = 1.5) -> list[Attractor]:
    """The motions reached at ``speed_kmh`` [km/h] in ``duration_s`` [s] from the
    continuation's last stable cycle and from steady rolling disturbed (see the module
    docstring), distinct ones only (amplitude of x and period differing by more than 1 %):
    several attractors can coexist, and which one the tread ends on depends on its history."""
    found: list[Attractor] = []
    for initial, start in _starts(diagram, speed_kmh):
        a = _attractor(diagram.params, speed_kmh, duration_s, initial, start)
        if not any(_same(a, b) for b in found):
            found.append(a)
    return found


def _same(a: Attractor, b: Attractor) -> bool:
    x = a.run.model.index("x")
    if a.regime != b.regime:
        return False
    if a.regime is Regime.NO_SEV:  # both back on steady rolling (their offsets are rounding noise)
        return True
    if not a.oscillating:  # at rest or drifting: the same if it ends at the same offset (1 %)
        oa, ob = (float(r.run.steady.mean[x] - r.run.equilibrium[x]) for r in (a, b))
        return abs(oa - ob) <= 0.01 * max(abs(oa), abs(ob), 1e-12)
    pa, pb = a.run.steady.period, b.run.steady.period
    same_period = (math.isnan(pa) and math.isnan(pb)) or abs(pa - pb) <= 0.01 * max(abs(pa), abs(pb))
    return same_period and abs(a.amplitude[x] - b.amplitude[x]) <= 0.01 * max(
        a.amplitude[x], b.amplitude[x], 1e-12)


def _attractor(params, speed_kmh, duration_s, initial, start, max_runs: int = 4) -> Attractor:
    """Simulate in pieces of ``duration_s`` [s], each from the end of the last, until the
    run settles (equilibrium or cycle), or its oscillation is sustained (the swing of the
    lead state over the analysed window changes by less than 5 % from the previous piece:
    quasi-periodic or chaotic), or the last quarter of a piece stays within
    ``equilibrium_rtol`` of the largest deviation of all pieces (decayed to rest: measured, a
    chaotic-looking 9e-14 m "swing" of x after a 5e-4 m cycle had decayed), or ``max_runs``
    pieces are done; then classify the last piece."""
    previous_swing, total, scale, decayed = None, 0.0, 0.0, False
    for _ in range(max_runs):
        run = simulate(params, speed_kmh, duration_s, disturbance=1e-4, initial=initial)
        total += duration_s
        if run.steady.steady:
            break
        # a piece judges rest by its own largest deviation; a later piece of a motion that
        # decayed sees only the integrator's noise, which need not shrink: judge it by the
        # largest deviation of the whole simulation instead
        deviation = np.abs(run.u - run.equilibrium)
        scale = np.maximum(scale, deviation.max(axis=0))
        tail = run.t >= (1.0 - 0.5 * run.settings.window_fraction) * duration_s
        if np.all(deviation[tail].max(axis=0) <= run.settings.equilibrium_rtol * scale):
            decayed = True
            break
        lead = run.model.index(run.settings.lead_state)
        swing = float(np.ptp(run.u[run.t >= (1.0 - run.settings.window_fraction) * duration_s, lead]))
        if previous_swing is not None and abs(swing - previous_swing) <= 0.05 * swing:
            break
        previous_swing, initial = swing, run.u[-1]
    st = run.steady
    lead = run.model.index(run.settings.lead_state)
    window = run.t >= (1.0 - run.settings.window_fraction) * run.duration_s
    t, s = run.t[window], run.u[window, lead]
    frequency = dominant_frequency(t, s)
    # an oscillation shows at least min_cycles periods of its dominant frequency in the window
    oscillating = frequency * (t[-1] - t[0]) >= run.settings.min_cycles
    if st.outcome is SteadyOutcome.EQUILIBRIUM or decayed:
        regime = Regime.NO_SEV
    elif st.outcome is SteadyOutcome.CYCLE:
        regime = Regime.PERIOD_MULTIPLIED if st.maxima_per_period > 1 else Regime.OFF_BRANCH_CYCLE
    elif not oscillating:
        regime = Regime.DIVERGENCE  # at rest or drifting, away from steady rolling
    else:
        regime = Regime.QUASI_PERIODIC
    amplitude = st.amplitude if st.outcome is SteadyOutcome.CYCLE else 0.5 * np.ptp(run.u[window], axis=0)
    if regime in (Regime.NO_SEV, Regime.DIVERGENCE):
        frequency = math.nan
    return Attractor(regime, float(speed_kmh), np.asarray(amplitude), frequency, run, start, total)
