"""Soft and hard self-excitation in the phase plane (the paper's Fig. 2).

At a chosen speed, the limit cycles of the bifurcation diagram (stable and unstable)
are drawn in the (x, x') plane together with trajectories started just inside and
just outside every cycle and near steady rolling: in a soft region every start ends
on the stable cycle; in a hard region starts inside the unstable cycle decay to
steady rolling and starts outside it grow to the stable cycle.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, replace
from enum import StrEnum

import numpy as np

from ..models import model_for
from ..params import Params
from ..units import kmh_to_ms
from ..results import Result, with_deprecated_keys
from ..progress import Progress, StepCounter
from ..settings import check_order, check_positive
from .diagram import BifurcationDiagram, CyclePoint
from .simulation import SimulationResult, phase_labels, simulate

__all__ = ["ExcitationPortrait", "ExcitationResult", "ExcitationSettings", "SelfExcitation", "excitation",
           "default_speeds", "portraits_figure", "settling_time"]


RENAMED_KEYS = {"amplitude_x_mm": ("amplitude_x_m", 1e-3), "initial_x_mm": ("initial_x_m", 1e-3),
                "final_amplitude_x_mm": ("final_amplitude_x_m", 1e-3)}
"""New -> (old key, factor) of the cycles and runs of :meth:`ExcitationPortrait.summary`
(tread amplitudes were in m; the old keys go in the next release)."""


class SelfExcitation(StrEnum):
    """How the tread can start to vibrate at a portrait's speed, from the diagram (the value
    is the text of figures and JSON)."""

    SOFT = "soft self-excitation"
    """Steady rolling is unstable (the linear band): any disturbance grows into SEV."""
    HARD = "hard self-excitation"
    """In the SEV band with steady rolling stable: only a start beyond the unstable cycle grows into SEV."""
    NO_SEV = "no SEV"
    """Outside the SEV band: every start returns to steady rolling."""


@dataclass
class ExcitationPortrait(Result):
    """Cycles and trajectories at one speed."""

    speed_kmh: float
    regime: SelfExcitation
    cycles: list[CyclePoint]
    runs: list[SimulationResult]
    settings: ExcitationSettings | None = None
    """The settings of :func:`excitation` that made the portrait."""

    @property
    def params(self):
        """The parameters of the simulations (None without runs)."""
        return self.runs[0].params if self.runs else None

    def _dataset(self):
        """The cycles (amplitude of x [m], stability) and the runs (start, outcome, amplitudes [m])."""
        import xarray as xr

        s = self.summary()
        return xr.Dataset(
            {
                "cycle_amplitude_x": ("cycle", 1e-3 * np.array([c["amplitude_x_mm"] for c in s["cycles"]], dtype=float),
                                      {"units": "m"}),
                "cycle_stable": ("cycle", np.array([c["stable"] for c in s["cycles"]], dtype=np.int8)),
                "initial_x": ("run", 1e-3 * np.array([r["initial_x_mm"] for r in s["runs"]], dtype=float),
                              {"units": "m"}),
                "final_amplitude_x": ("run", 1e-3 * np.array([r["final_amplitude_x_mm"] for r in s["runs"]], dtype=float),
                                      {"units": "m"}),
                "outcome": ("run", np.array([r["outcome"] for r in s["runs"]], dtype=str)),
            },
            coords={"run": np.array([r["start"] for r in s["runs"]], dtype=str)},
            attrs={"speed_kmh": self.speed_kmh, "regime": str(self.regime)},
        )

    def to_dataframe(self):
        """pandas DataFrame: one row per run (start, initial offset [mm], outcome, final amplitude [mm])."""
        import pandas as pd

        return pd.DataFrame(self.summary()["runs"], columns=["start", "initial_x_mm", "outcome", "final_amplitude_x_mm"])

    def summary(self) -> dict:
        x = self.runs[0].model.index("x") if self.runs else 0
        return {
            "speed_kmh": self.speed_kmh,
            "regime": self.regime,
            "cycles": [with_deprecated_keys({"amplitude_x_mm": 1e3 * float(c.amplitude[x]), "stable": c.stable},
                                            RENAMED_KEYS) for c in self.cycles],
            "runs": [
                with_deprecated_keys({"start": r.label, "initial_x_mm": 1e3 * float(r.initial[x] - r.equilibrium[x]),
                                      "outcome": r.steady.outcome,
                                      "final_amplitude_x_mm": 1e3 * float(r.steady.amplitude[x])}, RENAMED_KEYS)
                for r in self.runs
            ],
        }

    def plot(self, ax=None):
        """dx/dt against x − x_eq (:func:`~.simulation.phase_labels`): cycles (stable solid,
        unstable dashed), trajectories thin. Returns artists."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(5, 4.5))
        artists = []
        for k, run in enumerate(self.runs):
            model = run.model
            i, j = model.index("x"), model.index("xdot")
            artists += ax.plot(1e3 * (run.u[:, i] - run.equilibrium[i]), run.u[:, j], lw=0.5, color=f"C{k + 2}",
                               label=f"start {run.label}: {run.steady.outcome}")
            artists += ax.plot(1e3 * (run.u[0, i] - run.equilibrium[i]), run.u[0, j], "o", ms=3, color=f"C{k + 2}")
        for c in self.cycles:
            tau, u = c.orbit.dense(32)
            model = self.runs[0].model
            i, j = model.index("x"), model.index("xdot")
            eq = self.runs[0].equilibrium
            style = "-" if c.stable else "--"
            artists += ax.plot(1e3 * (u[:, i] - eq[i]), u[:, j], style, color="k", lw=2,
                               label=f"{'stable' if c.stable else 'unstable'} cycle {c.amplitude[i] * 1e3:.3f} mm")
        artists += ax.plot([0.0], [0.0], "k+", ms=10)
        ax.set_xlabel(phase_labels("x", "mm", "m/s")[0])
        ax.set_ylabel(phase_labels("x", "mm", "m/s")[1])
        ax.set_title(f"{self.speed_kmh:g} km/h: {self.regime}", fontsize=10)
        ax.legend(fontsize=7, loc="upper right")
        return artists


def default_speeds(diagram: BifurcationDiagram, operating_kmh: float) -> list[float]:
    """A soft speed (the operating speed if it is in the linear band) and the middle of the first hard region."""
    speeds = []
    soft = [b for b in diagram.linear_band_kmh]
    if any(a <= operating_kmh <= b for a, b in soft):
        speeds.append(operating_kmh)
    elif soft:
        speeds.append(0.5 * (soft[0][0] + soft[0][1]))
    if diagram.hard_regions_kmh:
        a, b = diagram.hard_regions_kmh[0]
        speeds.append(0.5 * (a + b))
    return speeds


@dataclass(frozen=True)
class ExcitationSettings:
    """Numerical settings of :func:`excitation` (``polywear excitation --duration``)."""

    duration_s: float | None = None
    """Simulated time per start [s]; None: long enough for the slowest attractor at the
    speed to settle (:func:`settling_time` with the two fields below)."""
    settling_efoldings: float = 8.0
    """e-foldings of the slowest attractor simulated by default [-]."""
    settling_min_s: float = 0.6
    """Shortest default simulated time [s]."""
    settling_max_s: float = 8.0
    """Longest default simulated time [s]."""

    def __post_init__(self) -> None:
        if self.duration_s is not None:
            check_positive(self, "duration_s")
        check_positive(self, "settling_efoldings", "settling_min_s", "settling_max_s")
        check_order(self, "settling_min_s", "settling_max_s")


def settling_time(diagram: BifurcationDiagram, speed_kmh: float, cycles,
                  settings: ExcitationSettings = ExcitationSettings()) -> float:
    """Simulated time [s] for ``settings.settling_efoldings`` e-foldings of the slowest
    attractor at a speed: the equilibrium's decay rate and each stable cycle's (from its
    largest nontrivial Floquet multiplier), clipped to [``settling_min_s``, ``settling_max_s``]."""
    bounds = (settings.settling_min_s, settings.settling_max_s)
    factor = settings.settling_efoldings
    rates = []
    model = model_for(diagram.params)
    p = model.pack(diagram.params)
    V = kmh_to_ms(speed_kmh)
    growth = np.linalg.eigvals(model.jacobian(model.equilibrium(V, p), V, p)).real.max()
    if growth < 0.0:
        rates.append(-growth)
    for c in cycles:
        if c.stable and 0.0 < c.max_multiplier < 1.0:
            rates.append(-np.log(c.max_multiplier) / c.period)
    if not rates:
        return bounds[0]
    return float(np.clip(factor / min(rates), *bounds))


@dataclass(frozen=True)
class ExcitationResult(Result):
    """The portraits of :func:`excitation`, one per speed (indexable and iterable over them)."""

    params: Params
    settings: ExcitationSettings
    portraits: list[ExcitationPortrait]

    def __len__(self) -> int:
        return len(self.portraits)

    def __iter__(self):
        return iter(self.portraits)

    def __getitem__(self, index: int) -> ExcitationPortrait:
        return self.portraits[index]

    def summary(self) -> dict:
        """The model and each speed's portrait (what ``polywear excitation --json`` prints)."""
        return {"model": self.params.model, "portraits": [p.summary() for p in self.portraits]}

    def to_dataframe(self):
        """pandas DataFrame: one row per speed [km/h] and start (regime, initial offset of x [mm],
        outcome, final amplitude of x [mm])."""
        import pandas as pd

        rows = [{"speed_kmh": p.speed_kmh, "regime": p.regime, **r} for p in self.portraits for r in p.summary()["runs"]]
        columns = ["speed_kmh", "regime", "start", "initial_x_mm", "outcome", "final_amplitude_x_mm"]
        return pd.DataFrame(rows, columns=columns).astype({"regime": str, "start": str, "outcome": str})

    def _dataset(self):
        """The table of :meth:`to_dataframe` along ``row``."""
        return self._table_dataset()

    def plot(self, ax=None):
        """One phase portrait per speed onto ``ax``: axes in a sequence, one per speed (a new
        row of axes if None). Returns artists."""
        axes = _axes_row(len(self.portraits))[1] if ax is None else list(np.atleast_1d(ax))
        if len(axes) < len(self.portraits):
            raise ValueError(f"{len(self.portraits)} portraits need as many axes, got {len(axes)}")
        return [artist for a, portrait in zip(axes, self.portraits) for artist in portrait.plot(a)]

    def figure(self):
        """A new Figure, one panel per speed."""
        return portraits_figure(self.portraits)


def excitation(diagram: BifurcationDiagram, speeds_kmh: Iterable[float],
               settings: ExcitationSettings = ExcitationSettings(),
               progress: Progress | None = None) -> ExcitationResult:
    """Cycles from the diagram and trajectories from inside/outside each cycle at every speed.

    ``settings.duration_s`` [s] per start; by default long enough for the slowest attractor
    there to settle (:func:`settling_time`). ``progress(runs done, None, "speed, start")`` is
    called after each simulation (:mod:`polywear.progress`)."""
    params = diagram.params
    model = model_for(params)
    p = model.pack(params)
    x = diagram.state_names.index("x")
    out = []
    step = StepCounter(progress)
    for speed in speeds_kmh:
        in_linear = any(a <= speed <= b for a, b in diagram.linear_band_kmh)
        in_sev = any(a <= speed <= b for a, b in diagram.sev_band_kmh)
        regime = (SelfExcitation.SOFT if in_linear else SelfExcitation.HARD if in_sev else SelfExcitation.NO_SEV)
        cycles = diagram.cycles_at(speed)
        u_eq = model.equilibrium(kmh_to_ms(speed), p)
        # starts on the ray from steady rolling through each cycle's point farthest from it
        # in x: s < 1 is inside that cycle, s > 1 outside
        starts = {}
        for k, c in enumerate(sorted(cycles, key=lambda c: c.amplitude[x]), 1):
            if k == 1:
                tau, u = c.orbit.dense(32)
                starts["near steady rolling"] = u_eq + 0.02 * (u[np.argmax(np.abs(u[:, x] - u_eq[x]))] - u_eq)
            tau, u = c.orbit.dense(32)
            tip = u[np.argmax(np.abs(u[:, x] - u_eq[x]))]
            starts[f"inside cycle {k}"] = u_eq + 0.8 * (tip - u_eq)
            starts[f"outside cycle {k}"] = u_eq + 1.25 * (tip - u_eq)
        if not cycles:
            starts["small"] = u_eq + np.eye(model.n)[x] * 1e-5
        duration = settings.duration_s if settings.duration_s is not None else settling_time(
            diagram, speed, cycles, settings)
        runs = []
        for label, initial in starts.items():
            runs.append(replace(simulate(params, speed, duration, initial=initial), label=label))
            step(f"{speed:.1f} km/h, {label}")
        out.append(ExcitationPortrait(speed, regime, cycles, runs, settings))
    return ExcitationResult(params, settings, out)


def _axes_row(n: int):
    """A new Figure with a row of ``max(n, 1)`` axes: (figure, list of axes)."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, max(n, 1), figsize=(5.2 * max(n, 1), 4.6), squeeze=False)
    return fig, list(axes[0])


def portraits_figure(portraits: Iterable[ExcitationPortrait]):
    """One panel per speed (an :class:`ExcitationResult` or any sequence of portraits)."""
    portraits = list(portraits)
    fig, axes = _axes_row(len(portraits))
    for ax, portrait in zip(axes, portraits):
        portrait.plot(ax)
    fig.tight_layout()
    return fig

