"""Time simulation from a disturbed steady rolling state; steady state, amplitudes, phase portraits.

A run starts from the equilibrium ``u_eq(V)`` plus a disturbance of the tread
displacement ``x`` (or from any full state), is integrated by
:func:`polywear.solvers.integrate.integrate`, and its final part is classified
(:func:`classify_window`):

``"equilibrium"``
    every state has come back to ``u_eq`` to within ``equilibrium_rtol`` times the
    largest deviation it had during the run, and is not moving away again (or what is
    left is below the integrator's resolution ``atol + rtol |u_eq|``: rounding noise,
    not an oscillation);
``"cycle"``
    the maxima of the lead state (``x``) repeat every m-th one (m = 1 for a simple
    cycle, more for stick-slip ringing or period doubling), there are at least
    ``min_cycles`` such periods in the window, and the period and the maxima are
    settled to ``cycle_rtol`` (relative to the period and to the lead state's range):
    their change over the window plus the change still to come, extrapolated
    geometrically from the two halves of the window (a slowly converging run near a
    Hopf point or a fold is not taken for a cycle);
``"transient"``
    neither (still growing or decaying; ``steady`` is False).

Amplitude of a state = half its peak-to-peak over the whole periods in the window;
each peak is refined to the time where the state's derivative (the model's rhs)
vanishes, by Brent's method on the continuous (dense) solution, so it does not depend
on the output grid. Frequency = 1 / mean period between refined maxima of the lead state.

Speeds are km/h at the interface, m/s inside.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from enum import StrEnum

import numpy as np
from numpy.typing import ArrayLike

from .. import __version__, units
from ..units import plot_scale, kmh_to_ms
from ..models import model_for
from ..results import Result, with_deprecated_keys
from ..params import Params, get_value, to_toml, with_updates
from ..progress import Progress, StepCounter
from ..settings import check_count, check_fraction, check_positive
from ..solvers.integrate import METHODS, StepStats, integrate

__all__ = [
    "SimulationSettings",
    "SteadyOutcome",
    "SteadyState",
    "SimulationResult",
    "SimulationSet",
    "simulate",
    "simulate_disturbances",
    "simulate_values",
    "classify_window",
    "initial_state",
    "phase_pairs",
    "phase_labels",
    "frequency_order",
]

AUX_UNITS = {"sliding_velocity": "m/s", "friction_force": "N", "normal_load": "N", "contact_lost": "1"}


@dataclass(frozen=True)
class SimulationSettings:
    """Integrator and steady-state settings of a simulation."""

    method: str = "rodas"
    rtol: float = 1e-8
    atol: float = 1e-12
    dt_out: float = 2e-5
    """Output grid [s] (the peaks are refined on the continuous solution, not on this grid)."""
    lead_state: str = "x"
    """State whose maxima define the period and the cycle test."""
    min_cycles: int = 5
    cycle_rtol: float = 1e-3
    equilibrium_rtol: float = 1e-4
    window_fraction: float = 0.5
    """Final fraction of a run that is analysed."""

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"SimulationSettings: method = {self.method!r}: must be one of {', '.join(METHODS)}")
        check_positive(self, "rtol", "atol", "dt_out", "cycle_rtol", "equilibrium_rtol")
        check_fraction(self, "window_fraction")
        check_count(self, "min_cycles", minimum=2)


class SteadyOutcome(StrEnum):
    """What the end of a run settled on (the value is the text of summaries and files)."""

    EQUILIBRIUM = "equilibrium"
    """Back at rest: steady rolling, or another equilibrium."""
    CYCLE = "cycle"
    """On a cycle: period and amplitude settled within ``cycle_rtol``."""
    TRANSIENT = "transient"
    """Neither yet (still growing or decaying, or not periodic)."""


@dataclass(frozen=True)
class SteadyState:
    """What the end of a run settled on, with amplitudes per state."""

    outcome: SteadyOutcome
    amplitude: np.ndarray
    """Half peak-to-peak per state over the analysed periods [state units]."""
    mean: np.ndarray
    """Time average per state over the analysed periods [state units]."""
    maximum: np.ndarray
    minimum: np.ndarray
    period: float
    """Mean period of the lead state [s] (NaN at equilibrium or with too few cycles)."""
    n_cycles: int
    """Whole periods in the analysed window."""
    maxima_per_period: int
    """Maxima of the lead state per period (1 for a simple cycle)."""
    period_change: float
    """Relative change of the period over the window plus its extrapolated remainder
    (NaN with < 2 periods)."""
    amplitude_change: float
    """The same for the lead state's per-period peak-to-peak value."""

    @property
    def steady(self) -> bool:
        """True if the run ended on the equilibrium or on a cycle."""
        return self.outcome is not SteadyOutcome.TRANSIENT

    @property
    def frequency(self) -> float:
        """1 / period [Hz]."""
        return 1.0 / self.period if self.period > 0 else math.nan


def phase_pairs(model) -> list[tuple[str, str]]:
    """(displacement, velocity) state pairs: ``q`` and ``q + "dot"``."""
    return [(q, q + "dot") for q in model.state_names if q + "dot" in model.state_names]


def frequency_order(frequency_hz: float, speed_kmh: float, rolling_radius_m: float) -> float:
    """Frequency order f_SEV / f_rot, a ratio, with f_rot = V / (2 pi R_e), V in km/h [-]."""
    return units.frequency_order(frequency_hz, float(kmh_to_ms(speed_kmh)), rolling_radius_m)


def initial_state(model, p, V: float, disturbance: float = 0.0, initial=None) -> np.ndarray:
    """Start state: ``initial`` if given, else the equilibrium with ``x`` moved by
    ``disturbance`` [m]."""
    if initial is not None:
        u0 = np.array(initial, dtype=float)
        if u0.shape != (model.n,):
            raise ValueError(f"initial state: expected {model.n} values {model.state_names}, got {u0.shape}")
        return u0
    if not math.isfinite(disturbance):
        raise ValueError(f"disturbance = {disturbance!r} m: must be finite")
    u0 = model.equilibrium(V, p).copy()
    u0[model.index("x")] += disturbance
    return u0


# -- steady-state analysis ---------------------------------------------------------------
def _refined_extrema(model, V, p, t, s, dense, q, kind, largest=None):
    """Times and values of the local maxima (kind = 1) or minima (-1) of state q.

    Sample extrema of ``s`` on the grid ``t`` (only the ``largest`` ones by value, if
    given) are refined by Brent's method on d u_q/dt = f_q(u(t)) = 0 with u(t) from the
    dense output; where the derivative does not change sign over the two neighbouring
    intervals the sample is kept.
    """
    from scipy.optimize import brentq

    d = np.diff(kind * s)
    idx = np.nonzero((d[:-1] > 0.0) & (d[1:] <= 0.0))[0] + 1
    if largest is not None:
        idx = idx[np.argsort(-kind * s[idx])[:largest]]
    times = t[idx].copy()
    values = s[idx].copy()

    def slope(tau):
        return model.f(dense(tau), V, p)[q]

    for j, i in enumerate(idx):
        lo, hi = t[i - 1], t[i + 1]
        g_lo, g_hi = slope(lo), slope(hi)
        if kind * g_lo > 0.0 > kind * g_hi:
            tau = brentq(slope, lo, hi, xtol=1e-14, rtol=4 * np.finfo(float).eps)
            value = dense(tau)[q]
            if kind * value >= kind * values[j]:
                times[j], values[j] = tau, value
    return times, values


def _settling_change(seq, scale, tol) -> float:
    """Change of a per-period sequence over the window plus its geometric extrapolation,
    relative to ``scale``: with changes s1, s2 over the two halves, rho = s2/s1 and the
    change still to come is s2 rho / (1 - rho) (infinite if the change is not shrinking).
    Changes in the second half below 1e-3 tol (round-off) count as settled."""
    if len(seq) < 2:
        return math.nan
    mid = len(seq) // 2
    s1, s2 = abs(seq[mid] - seq[0]), abs(seq[-1] - seq[mid])
    spread = float(np.ptp(seq)) / scale
    if s2 <= 1e-3 * tol * scale:
        return spread
    if s2 >= s1:
        return math.inf
    rho = s2 / s1
    return spread + s2 * rho / (1.0 - rho) / scale


def _maxima_per_period(t_max, v_max, span, tol, most=20) -> int:
    """Smallest m for which the maxima repeat every m-th one (value to tol * span, time
    to tol); 1 if none does. m > 1: a cycle with several maxima per period (stick-slip
    ringing, period doubling)."""
    for m in range(1, min(most, (len(t_max) - 1) // 2) + 1):
        periods = t_max[m:] - t_max[:-m]
        if (np.abs(v_max[m:] - v_max[:-m]).max() < tol * span
                and np.ptp(periods) < tol * periods.mean()):
            return m
    return 1


def classify_window(model, V, p, t, u, dense, u_eq, deviation_scale, settings: SimulationSettings) -> SteadyState:
    """Classify the window ``t, u`` (grid samples, with its dense output) of a run.

    ``deviation_scale`` (n,) is the largest ``|u - u_eq|`` per state seen during the run.
    """
    n = model.n
    dev = np.abs(u - u_eq)
    half = len(t) // 2
    last, previous = dev[half:].max(axis=0), dev[: max(half, 1)].max(axis=0)
    lead = model.index(settings.lead_state)
    nan = np.full(n, np.nan)
    # deviations below what the integrator resolves (atol + rtol |u_eq|) are rounding noise:
    # a motion decayed to that level is at the equilibrium whether or not the noise "grows"
    resolved = settings.atol + settings.rtol * np.abs(u_eq)
    if np.all(last <= np.maximum(settings.equilibrium_rtol * deviation_scale, resolved)) and np.all(
        (last <= previous) | (last <= resolved)
    ):
        return SteadyState(
            outcome=SteadyOutcome.EQUILIBRIUM, amplitude=0.5 * np.ptp(u[half:], axis=0), mean=u[half:].mean(axis=0),
            maximum=u[half:].max(axis=0), minimum=u[half:].min(axis=0), period=math.nan,
            n_cycles=0, maxima_per_period=0, period_change=math.nan, amplitude_change=math.nan,
        )
    s = u[:, lead]
    span = float(np.ptp(s))
    t_max, v_max = _refined_extrema(model, V, p, t, s, dense, lead, 1)
    m = _maxima_per_period(t_max, v_max, span, settings.cycle_rtol) if len(t_max) > 2 else 1
    n_cycles = max(len(t_max) - 1, 0) // m
    if n_cycles < 1:
        return SteadyState(SteadyOutcome.TRANSIENT, nan, u.mean(axis=0), u.max(axis=0), u.min(axis=0),
                           math.nan, 0, m, math.nan, math.nan)
    first = len(t_max) - 1 - n_cycles * m  # whole periods ending at the last maximum
    t_max, v_max = t_max[first:], v_max[first:]
    periods = t_max[m:] - t_max[:-m]
    period_change = _settling_change(periods, periods.mean(), settings.cycle_rtol)
    amplitude_change = max(_settling_change(v_max[j::m], span, settings.cycle_rtol) for j in range(m))
    steady_cycle = (
        n_cycles >= settings.min_cycles
        and period_change < settings.cycle_rtol
        and amplitude_change < settings.cycle_rtol
    )
    # every state over the whole periods [t_max[0], t_max[-1]]: its extreme values are
    # among the refinements of the few most extreme samples
    inside = (t >= t_max[0]) & (t <= t_max[-1])
    maximum, minimum = np.empty(n), np.empty(n)
    for q in range(n):
        for kind, out in ((1, maximum), (-1, minimum)):
            _, vq = _refined_extrema(model, V, p, t[inside], u[inside, q], dense, q, kind, largest=3)
            sample = kind * u[inside, q]
            out[q] = kind * max(sample.max(), (kind * vq).max() if len(vq) else -np.inf)
    tw = t[inside]
    mean = np.trapezoid(u[inside], tw, axis=0) / (tw[-1] - tw[0]) if tw[-1] > tw[0] else u[inside].mean(axis=0)
    return SteadyState(
        outcome=SteadyOutcome.CYCLE if steady_cycle else SteadyOutcome.TRANSIENT,
        amplitude=0.5 * (maximum - minimum), mean=mean, maximum=maximum, minimum=minimum,
        period=float((t_max[-1] - t_max[0]) / n_cycles), n_cycles=n_cycles, maxima_per_period=m,
        period_change=float(period_change), amplitude_change=float(amplitude_change),
    )


# -- results -----------------------------------------------------------------------------
RENAMED_KEYS = {"frequency_order": "polygon_order"}
"""New -> old keys of :meth:`SimulationResult.summary` (the old ones go in the next release)."""


@dataclass(frozen=True)
class SimulationResult(Result):
    """One simulation run: inputs, settings, time series, steady state."""

    params: Params
    speed_kmh: float
    duration_s: float
    initial: np.ndarray
    equilibrium: np.ndarray
    settings: SimulationSettings
    t: np.ndarray
    u: np.ndarray
    aux: np.ndarray
    steady: SteadyState
    stats: StepStats
    label: str = ""
    version: str = __version__

    @property
    def model(self):
        return model_for(self.params)

    @property
    def frequency_order(self) -> float:
        """f_SEV / f_rot, a ratio [-] (NaN without a frequency)."""
        return frequency_order(self.steady.frequency, self.speed_kmh, self.params.operating.rolling_radius_m)

    @property
    def contact_lost(self) -> bool:
        """True if the tire left the road at any output time (models with a normal-load state)."""
        aux = self.model.aux_names
        return bool("contact_lost" in aux and (self.aux[:, aux.index("contact_lost")] > 0.5).any())

    def summary(self) -> dict:
        """JSON-ready summary: model, speed, per-state amplitude, frequency, steady flag, n."""
        names = self.model.state_names
        st = self.steady
        return with_deprecated_keys({
            "model": self.params.model,
            "speed_kmh": self.speed_kmh,
            "duration_s": self.duration_s,
            **({"label": self.label} if self.label else {}),
            "outcome": st.outcome,
            "steady_state": st.steady,
            "amplitude": {q: _finite(a) for q, a in zip(names, st.amplitude)},
            "units": dict(zip(names, self.model.state_units)),
            "frequency_hz": _finite(st.frequency),
            "frequency_order": _finite(self.frequency_order),
            "cycles_analysed": st.n_cycles,
            "steps": {"accepted": self.stats.accepted, "rejected": self.stats.rejected},
            **({"contact_lost": self.contact_lost} if "contact_lost" in self.model.aux_names else {}),
        }, RENAMED_KEYS)

    def _dataset(self):
        """xarray Dataset: states and diagnostics against time, steady-state values per state."""
        import xarray as xr

        model = self.model
        data = {
            q: ("time", self.u[:, i], {"units": unit})
            for i, (q, unit) in enumerate(zip(model.state_names, model.state_units))
        }
        for j, name in enumerate(model.aux_names):
            data[name] = ("time", self.aux[:, j], {"units": AUX_UNITS.get(name, "")})
        st = self.steady
        for name, values in (("amplitude", st.amplitude), ("mean", st.mean), ("maximum", st.maximum),
                             ("minimum", st.minimum), ("initial", self.initial),
                             ("equilibrium", self.equilibrium)):
            data[name] = ("state", values, {"units": " ".join(model.state_units)})
        ds = xr.Dataset(
            data,
            coords={"time": ("time", self.t, {"units": "s"}), "state": list(model.state_names)},
            attrs={
                "model": self.params.model,
                "speed_kmh": self.speed_kmh,
                "duration_s": self.duration_s,
                "label": self.label,
                "outcome": st.outcome.value,
                "steady_state": int(st.steady),
                "frequency_hz": st.frequency,
                "period_s": st.period,
                "frequency_order": self.frequency_order,
                "cycles_analysed": st.n_cycles,
                "maxima_per_period": st.maxima_per_period,
                "period_change": st.period_change,
                "amplitude_change": st.amplitude_change,
                "steps_accepted": -1 if self.stats.accepted is None else self.stats.accepted,
                "steps_rejected": -1 if self.stats.rejected is None else self.stats.rejected,
                "rhs_evaluations": self.stats.rhs_evals,
                "settings": json.dumps(asdict(self.settings)),
                "params_toml": to_toml(self.params),
                "polywear_version": self.version,
            },
        )
        return ds

    def plot(self, ax=None, pairs=None, tail_s=None, **line_kw):
        """Phase portraits, one axes per (displacement, velocity) pair. Returns the artists.

        ``ax``: one Axes (with one pair) or a sequence of Axes, one per pair; by default a
        new figure. ``tail_s``: draw only the last ``tail_s`` seconds (default: all, with
        the start marked by a dot).
        """
        return _phase_portraits([self], ax, pairs, tail_s, **line_kw)

    def figure(self):
        """A new Figure with the phase portraits, one axes per (displacement, velocity) pair."""
        return self.plot()[0].figure


@dataclass(frozen=True)
class SimulationSet(Result):
    """Several runs that differ in one thing (disturbance or a parameter value)."""

    runs: tuple[SimulationResult, ...]
    label: str
    """What differs: ``"disturbance_m"`` or a configuration key."""
    values: tuple = field(default=())

    @property
    def params(self) -> Params:
        """The first run's parameters (a set that varies a key has it in ``values``)."""
        return self.runs[0].params

    @property
    def settings(self) -> SimulationSettings:
        return self.runs[0].settings

    def summary(self) -> dict:
        return {"varied": self.label, "values": list(self.values), "runs": [r.summary() for r in self.runs]}

    def _dataset(self):
        """The runs' datasets stacked along ``run`` (the varied value as coordinate)."""
        import xarray as xr

        sets = [r.to_dataset() for r in self.runs]
        if any(len(ds.time) != len(sets[0].time) for ds in sets):
            raise ValueError("runs of different length cannot be stacked")
        per_run = ("speed_kmh", "label", "outcome", "steady_state", "frequency_hz", "period_s",
                   "frequency_order", "cycles_analysed", "maxima_per_period", "period_change", "amplitude_change",
                   "steps_accepted", "steps_rejected", "rhs_evaluations", "params_toml")
        stacked = xr.concat([ds.drop_attrs() for ds in sets], dim="run")
        for key in per_run:
            values = [ds.attrs[key] for ds in sets]
            stacked[key] = ("run", np.asarray(values))
        for name in stacked.data_vars:
            if name in sets[0]:
                stacked[name].attrs = sets[0][name].attrs
        stacked = stacked.assign_coords(run=("run", np.asarray(self.values, dtype=float)))
        stacked.attrs = {
            "varied": self.label, "model": sets[0].attrs["model"],
            "settings": sets[0].attrs["settings"], "polywear_version": sets[0].attrs["polywear_version"],
            "duration_s": sets[0].attrs["duration_s"],
        }
        return stacked

    def plot(self, ax=None, pairs=None, tail_s=None, **line_kw):
        """Overlaid phase portraits of all runs, one axes per pair (see
        :meth:`SimulationResult.plot`). Returns the artists."""
        return _phase_portraits(list(self.runs), ax, pairs, tail_s, **line_kw)

    def figure(self):
        """A new Figure with the overlaid phase portraits, one axes per pair."""
        return self.plot()[0].figure


def _finite(value):
    return float(value) if np.isfinite(value) else None


def phase_labels(q: str, unit_q: str, unit_qd: str) -> tuple[str, str]:
    """Axis labels of a phase portrait of coordinate ``q``, the one convention of every
    phase portrait (simulation and self-excitation figures): the deflection from steady
    rolling ``q − q_eq`` (the state's own sign) and its rate ``dq/dt``, in ``unit_q`` and
    ``unit_qd``."""
    return f"{q} − {q}_eq [{unit_q}]", f"d{q}/dt [{unit_qd}]"


def _phase_portraits(runs, ax, pairs, tail_s, **line_kw):
    import matplotlib.pyplot as plt

    model = runs[0].model
    pairs = phase_pairs(model) if pairs is None else list(pairs)
    if ax is None:
        cols = min(len(pairs), 2)
        rows = math.ceil(len(pairs) / cols)
        _, axes = plt.subplots(rows, cols, figsize=(5.0 * cols, 4.2 * rows), squeeze=False,
                               layout="constrained")
        axes = list(axes.ravel())
        for extra in axes[len(pairs):]:
            extra.set_visible(False)
    else:
        axes = list(np.atleast_1d(ax))
    if len(axes) < len(pairs):
        raise ValueError(f"{len(pairs)} phase pairs {pairs} need as many axes, got {len(axes)}")
    artists = []
    for axis, (q, qd) in zip(axes, pairs):
        i, j = model.index(q), model.index(qd)
        fx, ux = plot_scale(model.state_units[i])
        fy, uy = plot_scale(model.state_units[j])
        for k, run in enumerate(runs):
            kw = {"lw": 0.6, "color": f"C{k % 10}", **line_kw}
            shown = slice(None) if tail_s is None else run.t >= run.t[-1] - tail_s
            dq = run.u[:, i] - run.equilibrium[i]  # deflection from steady rolling (phase_labels)
            artists += axis.plot(fx * dq[shown], fy * run.u[shown, j], label=run.label or None, **kw)
            if tail_s is None:
                artists += axis.plot(fx * dq[0], fy * run.u[0, j], "o", ms=3, color=kw["color"])
        axis.set_xlabel(phase_labels(q, ux, uy)[0])
        axis.set_ylabel(phase_labels(q, ux, uy)[1])
        axis.set_title(f"{q}: phase portrait", fontsize=10)
        axis.ticklabel_format(style="sci", scilimits=(-3, 4), useMathText=True)
    if any(run.label for run in runs):
        axes[0].legend(fontsize=7, loc="best")
    first = runs[0]
    axes[0].figure.suptitle(f"{first.params.model} at {first.speed_kmh:g} km/h", fontsize=10)
    return artists


# -- running -----------------------------------------------------------------------------
def _run(params: Params, speed_kmh, duration_s, disturbance, initial, settings, label):
    model = model_for(params)
    p = model.pack(params)
    speed_kmh = float(params.operating.speed_kmh if speed_kmh is None else speed_kmh)
    if not (math.isfinite(duration_s) and duration_s > 0.0):
        raise ValueError(f"duration = {duration_s!r} s: must be positive and finite")
    V = float(kmh_to_ms(speed_kmh))
    u_eq = model.equilibrium(V, p)
    u0 = initial_state(model, p, V, disturbance, initial)
    window_start = (1.0 - settings.window_fraction) * duration_s
    traj = integrate(model, u0, V, p, duration_s, dt_out=settings.dt_out, rtol=settings.rtol,
                     atol=settings.atol, method=settings.method, dense_from=window_start)
    in_window = traj.t >= window_start
    deviation_scale = np.abs(traj.u - u_eq).max(axis=0)
    steady = classify_window(model, V, p, traj.t[in_window], traj.u[in_window], traj.dense, u_eq,
                             deviation_scale, settings)
    return SimulationResult(
        params=params, speed_kmh=speed_kmh, duration_s=float(duration_s), initial=u0,
        equilibrium=u_eq, settings=settings, t=traj.t, u=traj.u,
        aux=model.diagnostics(traj.u, V, p), steady=steady, stats=traj.stats, label=label,
    )


def simulate(
    params: Params,
    speed_kmh: float | None = None,
    duration_s: float = 1.0,
    *,
    disturbance: float = 1e-4,
    initial: ArrayLike | None = None,
    settings: SimulationSettings = SimulationSettings(),
) -> SimulationResult:
    """Simulate ``duration_s`` [s] at ``speed_kmh`` [km/h] (default: operating.speed_kmh).

    Starts from the equilibrium with the tread displacement ``x`` moved by
    ``disturbance`` [m], or from the full state ``initial`` if given; the last
    ``settings.window_fraction`` of the run decides the steady state.
    This is ``polywear simulate`` and ``pw.simulate``.

    Parameters
    ----------
    params : Params
        The parameter set.
    speed_kmh : float, optional
        Vehicle speed [km/h]; default ``params.operating.speed_kmh``.
    duration_s : float
        Simulated time [s].
    disturbance : float
        Initial displacement of the tread ``x`` from the equilibrium [m].
    initial : array, optional
        Full initial state in the model's state order (overrides ``disturbance``).
    settings : SimulationSettings
        Integrator, tolerances, output step and steady-state criteria.

    Returns
    -------
    SimulationResult
        Trajectory, diagnostics (sliding velocity, friction force, normal load) and
        ``steady``: outcome (equilibrium, cycle, transient), amplitude of every state,
        frequency [Hz]; ``summary()`` is what ``polywear simulate --json`` prints.
    """
    return _run(params, speed_kmh, duration_s, disturbance, initial, settings, "")


def simulate_disturbances(
    params: Params,
    disturbances,
    speed_kmh: float | None = None,
    duration_s: float = 1.0,
    *,
    settings: SimulationSettings = SimulationSettings(),
    progress: Progress | None = None,
) -> SimulationSet:
    """One run per disturbance of ``x`` [m] (the paper's Fig. 5); ``progress(runs done,
    runs, label)`` after each (:mod:`polywear.progress`)."""
    runs = []
    step = StepCounter(progress, len(disturbances))
    for d in disturbances:
        runs.append(_run(params, speed_kmh, duration_s, float(d), None, settings, f"x0 {d * 1e3:+g} mm"))
        step(runs[-1].label)
    return SimulationSet(tuple(runs), "disturbance_m", tuple(float(d) for d in disturbances))


def simulate_values(
    params: Params,
    key: str,
    values,
    speed_kmh: float | None = None,
    duration_s: float = 1.0,
    *,
    disturbance: float = 1e-4,
    settings: SimulationSettings = SimulationSettings(),
    progress: Progress | None = None,
) -> SimulationSet:
    """One run per value of the configuration ``key`` (the paper's Figs. 7 and 8);
    ``progress(runs done, runs, label)`` after each (:mod:`polywear.progress`)."""
    get_value(params, key)  # an unknown key fails here, before any run
    runs = []
    step = StepCounter(progress, len(values))
    for v in values:
        varied = with_updates(params, {key: v})
        runs.append(_run(varied, speed_kmh, duration_s, disturbance, None, settings, f"{key} = {v:g}"))
        step(runs[-1].label)
    return SimulationSet(tuple(runs), key, tuple(float(v) for v in values))
