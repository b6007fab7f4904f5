"""The bifurcation diagram as a result: cycle points, special points, the speed bands
(:func:`sev_band`, the one definition of the SEV band), tables and plots.

:func:`polywear.dynamics.bifurcation.bifurcation` computes it; this module holds what a
diagram is and what it says:

* linear band: where steady rolling is unstable (between Hopf speeds);
* SEV band: where the tread can vibrate, i.e. where steady rolling is unstable or a stable
  cycle exists; a period doubling or torus bifurcation where rolling is stable leaves the
  gap after it undecided (``gaps_after_pd_ns_kmh``, for a simulation); its bounds are the
  paper's first and second bifurcation speeds;
* hard regions: SEV band minus linear band, where a stable cycle coexists with stable
  steady rolling; the unstable cycle there is the trigger amplitude.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ..models import model_for
from ..results import Result, with_deprecated_keys
from ..params import Params
from ..solvers.continuation import Branch, ContinuationSettings
from ..units import kmh_to_ms, ms_to_kmh, plot_scale
from .intervals import subtract, union
from .points import PointKind, SpecialPoint
from .stability import HopfPoint, StabilityResult

__all__ = ["BifurcationDiagram", "CyclePoint", "sev_band", "statically_divergent"]

_JOIN_KMH = 1e-9
"""Band pieces closer than this [km/h] are one band (cycle ends meet linear-band edges)."""

@dataclass(frozen=True)
class CyclePoint:
    """Summary of one periodic orbit: speed, period [s], amplitude per state, stability."""

    branch: int
    speed_ms: float
    """Speed of the cycle [m/s] (``speed_kmh`` in km/h)."""
    period: float
    amplitude: np.ndarray
    mean: np.ndarray
    stable: bool
    n_unstable: int
    max_multiplier: float
    trivial_multiplier_error: float
    label: str = ""
    orbit: object = field(default=None, repr=False, compare=False)
    """The PeriodicOrbit (None for the zero-amplitude ends at Hopf points)."""
    resolved: bool = True
    """False: certainly unstable, but too strongly for the count of unstable multipliers to be known."""

    @property
    def speed_kmh(self) -> float:
        return ms_to_kmh(self.speed_ms)


RENAMED_KEYS = {"amplitude_x_mm": ("amplitude_x_m", 1e-3), "min_x_mm": ("min_x", 1e-3), "max_x_mm": ("max_x", 1e-3)}
"""New -> (old key, factor) in the folds and trigger amplitudes of :meth:`BifurcationDiagram.summary`
(tread amplitudes were in m; the old keys go in the next release)."""


@dataclass
class BifurcationDiagram(Result):
    """Equilibria, Hopf points, cycle branches, special points and speed bands."""

    params: Params
    stability: StabilityResult
    cycles: list[CyclePoint]
    branches: list[Branch] = field(repr=False)
    branch_info: list[dict]
    special: list[SpecialPoint]
    """Folds (LP), period doublings (PD) and torus bifurcations (NS) of the cycle branches, each once."""
    settings: ContinuationSettings
    speed_range_kmh: tuple[float, float]
    """The analysed range [km/h] (the requested one, extended where needed)."""
    requested_range_kmh: tuple[float, float] | None = None
    """The range [km/h] that was asked for (None: the analysed one)."""
    range_notes: list[str] = field(default_factory=list)
    """Why the analysed range differs from the requested one."""
    continuation_notes: list[str] = field(default_factory=list)
    """Why the cycle branches were continued a second time (with turn-limited steps)."""

    # -- bands ---------------------------------------------------------------------------
    @property
    def state_names(self) -> tuple[str, ...]:
        return self.stability.state_names

    @property
    def hopf_points(self) -> list[HopfPoint]:
        return self.stability.hopf_points

    @property
    def folds(self) -> list[SpecialPoint]:
        return [p for p in self.special if p.kind is PointKind.LP]

    @property
    def special_points(self) -> list[SpecialPoint]:
        """Every special point by speed: Hopf points (HB), real eigenvalue crossings (DIV)
        and the special points of the cycle branches (LP, PD, NS)."""
        points = [h.special_point() for h in self.hopf_points]
        points += [SpecialPoint(PointKind.DIV, v) for v in self.stability.real_crossings_kmh]
        return sorted(points + self.special, key=lambda s: s.speed_kmh)

    @property
    def linear_band_kmh(self) -> list[tuple[float, float]]:
        return list(self.stability.linear_band_kmh)

    def stable_cycle_intervals_kmh(self) -> list[tuple[float, float]]:
        """Speed intervals [km/h] covered by stable cycles.

        A stable run of a branch ends at its Hopf point, at a fold or a PD/NS point
        (located), at the edge of the speed range, or else where the largest multiplier
        modulus crosses 1 (interpolated in log|mu| between the two points).
        """
        intervals = []
        for b, branch in enumerate(self.branches):
            pts = [c for c in self.cycles if c.branch == b]
            if not pts:
                continue
            # cycle points of a branch start with its Hopf end, hence index + 1; the located
            # special point between two points is the edge there (a fold before a PD/NS)
            folds = {}
            for label, pt, idx in branch.special:
                if PointKind(label) is PointKind.LP or idx + 1 not in folds:
                    folds[idx + 1] = ms_to_kmh(pt.orbit.speed)
            info = self.branch_info[b]
            run_start = info["from_hopf_kmh"] if pts[0].stable else None
            for i in range(1, len(pts)):
                a, c = pts[i - 1], pts[i]
                if a.stable == c.stable:
                    continue
                edge = folds.get(i, _crossing_speed(a, c))
                if c.stable:
                    run_start = edge
                else:
                    intervals.append((run_start, edge))
                    run_start = None
            if run_start is not None:
                end = info["to_hopf_kmh"]
                if end is None:
                    end = pts[-1].speed_kmh
                intervals.append((run_start, end))
        lo, hi = self.speed_range_kmh
        clipped = [(max(min(a, b), lo), min(max(a, b), hi)) for a, b in intervals]
        return union([iv for iv in clipped if iv[1] > iv[0]], gap=_JOIN_KMH)

    @cached_property
    def divergence_kmh(self) -> list[tuple[float, float]]:
        """Speed intervals [km/h] where steady rolling is unstable through real eigenvalues
        only (static divergence: the tread drifts to another state, no oscillation grows
        from it). Part of the linear band, but not SEV by itself."""
        if not self.stability.real_crossings_kmh:
            return []
        model = model_for(self.params)
        p = model.pack(self.params)
        edges = sorted([h.speed_kmh for h in self.hopf_points] + list(self.stability.real_crossings_kmh))
        points = [float(self.stability.speeds_kmh[0]), *edges, float(self.stability.speeds_kmh[-1])]
        out = []
        for a, b in zip(points[:-1], points[1:]):
            V = kmh_to_ms(0.5 * (a + b))
            lam = np.linalg.eigvals(model.jacobian(model.equilibrium(V, p), V, p))
            if b > a and statically_divergent(lam):
                out.append((a, b))
        return union(out, gap=_JOIN_KMH)

    @property
    def pd_ns_speeds_kmh(self) -> list[float]:
        """Speeds [km/h] of the period doublings and torus bifurcations of every branch (as
        located on it, so that an end of a stable run there matches exactly)."""
        return sorted(ms_to_kmh(pt.orbit.speed) for branch in self.branches for label, pt, _ in branch.special
                      if PointKind(label) in (PointKind.PD, PointKind.NS))

    @cached_property
    def _band(self) -> tuple[list[tuple[float, float]], list[tuple[float, float]]]:
        oscillatory = subtract(self.linear_band_kmh, self.divergence_kmh)
        return sev_band(oscillatory, self.stable_cycle_intervals_kmh(), self.pd_ns_speeds_kmh)

    @property
    def sev_band_kmh(self) -> list[tuple[float, float]]:
        """Where the tread vibrates after a large disturbance, as far as the branches decide
        it (:func:`sev_band`): stable period-1 cycles, or steady rolling unstable through an
        oscillatory mode (a Hopf pair; static divergence excluded)."""
        return self._band[0]

    @property
    def hard_regions_kmh(self) -> list[tuple[float, float]]:
        """SEV band minus linear band: stable rolling and stable SEV coexist."""
        return subtract(self.sev_band_kmh, self.linear_band_kmh)

    @property
    def gaps_after_pd_ns_kmh(self) -> list[tuple[float, float]]:
        """Gaps of the SEV band [km/h] that a stable run of period-1 cycles ends at, or starts
        from, at a period doubling or torus bifurcation (:func:`sev_band`): steady rolling is
        stable there and the motion past that point may survive; only the doubled branch or
        a simulation tells (the verdict and the fleet's ``simulate_gaps`` run one)."""
        return self._band[1]

    @property
    def open_edges(self) -> list[str]:
        """Ends of the analysed range that the SEV band runs into (``"lower"``, ``"upper"``):
        there the band edge is the range limit, not a bifurcation speed."""
        sev = self.sev_band_kmh
        lo, hi = self.speed_range_kmh
        tol = 1e-9 * hi
        return [edge for edge, hit in (("lower", sev and sev[0][0] <= lo + tol),
                                       ("upper", sev and sev[-1][1] >= hi - tol)) if hit]

    def open_bounds(self, intervals) -> list[list]:
        """Intervals [km/h] for summaries, a bound at a limit of the analysed range as None (a cut, not a bifurcation)."""
        lo, hi = self.speed_range_kmh
        tol = 1e-9 * hi
        return [[None if a <= lo + tol else a, None if b >= hi - tol else b] for a, b in intervals]

    def band_text(self, intervals=None) -> str:
        """Intervals (default: the SEV band) as text, '290.4-open above 1000 km/h' at a cut end; 'none' if empty."""
        lo, hi = self.speed_range_kmh
        pieces = [f"{f'{a:.1f}' if a is not None else f'open below {lo:g}'}-"
                  f"{f'{b:.1f}' if b is not None else f'open above {hi:g}'}"
                  for a, b in self.open_bounds(self.sev_band_kmh if intervals is None else intervals)]
        return f"{', '.join(pieces)} km/h" if pieces else "none"

    def trigger_amplitude(self, state: str = "x") -> list[dict]:
        """Per hard region: range of the unstable-cycle amplitude (the disturbance that starts SEV),
        from 0 at a subcritical Hopf point to the amplitude at the fold that ends the region;
        keys ``min_<state>_<unit>``, ``max_<state>_<unit>`` in mm (or mrad) for a state in m (rad)."""
        i = self.state_names.index(state)
        scale, unit = plot_scale(model_for(self.params).state_units[i])
        out = []
        for lo, hi in self.hard_regions_kmh:
            amps = [c.amplitude[i] for c in [*(c for c in self.cycles if not c.stable), *self.folds]
                    if lo - 1e-9 <= c.speed_kmh <= hi + 1e-9]
            if amps:
                out.append(
                    {"speed_range_kmh": [lo, hi], f"min_{state}_{unit}": scale * float(min(amps)),
                     f"max_{state}_{unit}": scale * float(max(amps))}
                )
        return out

    def cycles_at(self, speed_kmh: float) -> list[CyclePoint]:
        """Every cycle of the diagram at exactly this speed (Newton at fixed speed from the
        two branch points that bracket it, located folds included, or between a branch's
        Hopf point and its first point from that point scaled by the square-root law),
        sorted by amplitude of x."""
        from ..solvers.continuation import orbit_between, orbit_from_hopf, solve_at_speed

        model = model_for(self.params)
        p = model.pack(self.params)
        V = kmh_to_ms(speed_kmh)
        found = []
        for b, branch in enumerate(self.branches):
            pts = _points_with_folds(branch)
            guesses = [orbit_between(a.orbit, c.orbit, V) for a, c in zip(pts[:-1], pts[1:])
                       if min(a.orbit.speed, c.orbit.speed) <= V <= max(a.orbit.speed, c.orbit.speed)
                       and a.orbit.speed != c.orbit.speed]
            if pts:  # between the Hopf point and the branch's first point: the square-root law
                V_hopf, first = kmh_to_ms(self.branch_info[b]["from_hopf_kmh"]), pts[0].orbit
                if min(V_hopf, first.speed) < V < max(V_hopf, first.speed):
                    guesses.append(orbit_from_hopf(model, p, first, V_hopf, V))
            for guess in guesses:
                point = solve_at_speed(model, p, guess, V, self.settings)
                if point is not None:
                    found.append(cycle_point(b, point))
        return sorted(found, key=lambda cp: cp.amplitude[self.state_names.index("x")])

    # -- outputs -------------------------------------------------------------------------
    def summary(self) -> dict:
        """The JSON summary of ``polywear bifurcation``."""
        sev = self.sev_band_kmh
        x = self.state_names.index("x")
        open_at = self.open_edges
        return {
            "model": self.params.model,
            "method": "continuation",
            "speed_range_kmh": list(self.speed_range_kmh),
            "requested_speed_range_kmh": list(self.requested_range_kmh or self.speed_range_kmh),
            "range_notes": list(self.range_notes),
            "continuation_notes": list(self.continuation_notes),
            "open_at": _open_at(open_at),
            "warnings": [_open_warning(edge, self.speed_range_kmh) for edge in open_at] + self.branch_warnings(),
            "hopf_points": [h.summary() for h in self.hopf_points],
            "folds": [
                with_deprecated_keys({
                    "speed_kmh": f.speed_kmh,
                    "amplitude_x_mm": 1e3 * float(f.amplitude[x]),
                    "frequency_hz": f.frequency_hz,
                }, RENAMED_KEYS)
                for f in self.folds
            ],
            "period_doublings": [p.speed_kmh for p in self.special if p.kind is PointKind.PD],
            "torus_bifurcations": [p.speed_kmh for p in self.special if p.kind is PointKind.NS],
            "real_eigenvalue_crossings_kmh": list(self.stability.real_crossings_kmh),
            "linear_band_kmh": self.open_bounds(self.linear_band_kmh),
            "divergence_kmh": self.open_bounds(self.divergence_kmh),
            "sev_band_kmh": self.open_bounds(sev),
            "first_bifurcation_speed_kmh": sev[0][0] if sev and "lower" not in open_at else None,
            "second_bifurcation_speed_kmh": sev[-1][1] if sev and "upper" not in open_at else None,
            "hard_regions_kmh": self.open_bounds(self.hard_regions_kmh),
            "gaps_after_pd_ns_kmh": [list(g) for g in self.gaps_after_pd_ns_kmh],
            "trigger_amplitude": [with_deprecated_keys({**t, "speed_range_kmh": self.open_bounds([t["speed_range_kmh"]])[0]},
                                                       RENAMED_KEYS)
                                  for t in self.trigger_amplitude("x")],
            "branches": self.branch_info,
            "band_edges_from_failed_branches_kmh": self.failed_band_edges_kmh(),
        }

    def failed_band_edges_kmh(self) -> list[float]:
        """SEV band edges [km/h] that are where a failed branch was lost while stable: there
        the band ends because continuation failed, not at a bifurcation (see ``branch_info``)."""
        edges = [v for band in self.sev_band_kmh for v in band]
        out = []
        for info in self.branch_info:
            v = info["at_speed_kmh"]
            if info["failed"] and any(abs(v - e) <= 1e-9 * max(abs(v), 1.0) for e in edges):
                out.append(v)
        return out

    def branch_warnings(self) -> list[str]:
        """One line per failed branch: where and why it was lost, and whether a band edge comes from it."""
        flagged = self.failed_band_edges_kmh()
        out = []
        for info in self.branch_info:
            if not info["failed"]:
                continue
            v = info["at_speed_kmh"]
            text = (f"cycle branch {info['branch']} (from the Hopf point at {info['from_hopf_kmh']:.3f} km/h) was lost "
                    f"after {v:.3f} km/h: {info['end_reason']}; its cycles beyond are unknown")
            if v in flagged:
                text += f"; the SEV band edge at {v:.3f} km/h is where continuation failed, not a bifurcation speed"
            out.append(text)
        return out

    def _dataset(self):
        """Tidy xarray Dataset: one row per cycle point, and the equilibrium line."""
        import xarray as xr

        names = list(self.state_names)
        cyc = self.cycles
        data = {
            "branch": ("cycle", np.array([c.branch for c in cyc], dtype=int)),
            "speed_kmh": ("cycle", np.array([c.speed_kmh for c in cyc]), {"units": "km/h"}),
            "period": ("cycle", np.array([c.period for c in cyc]), {"units": "s"}),
            "frequency": ("cycle", np.array([1.0 / c.period for c in cyc]), {"units": "Hz"}),
            "amplitude": (("cycle", "state"), np.array([c.amplitude for c in cyc]).reshape(len(cyc), len(names)),
                          {"long_name": "half peak-to-peak"}),
            "mean": (("cycle", "state"), np.array([c.mean for c in cyc]).reshape(len(cyc), len(names))),
            "stable": ("cycle", np.array([c.stable for c in cyc], dtype=bool)),
            "n_unstable_multipliers": ("cycle", np.array([c.n_unstable for c in cyc], dtype=int)),
            "max_multiplier_modulus": ("cycle", np.array([c.max_multiplier for c in cyc])),
            "trivial_multiplier_error": ("cycle", np.array([c.trivial_multiplier_error for c in cyc])),
            "multipliers_resolved": ("cycle", np.array([c.resolved for c in cyc], dtype=bool)),
            "label": ("cycle", np.array([c.label for c in cyc], dtype=str)),
            "equilibrium": (("speed", "state"), self.stability.equilibria),
            "equilibrium_stable": ("speed", (self.stability.eigenvalues.real <= 0).all(axis=1)),
            "max_real_eigenvalue": ("speed", self.stability.eigenvalues.real.max(axis=1), {"units": "1/s"}),
        }
        ds = xr.Dataset(
            data,
            coords={"state": names, "speed": ("speed", self.stability.speeds_kmh, {"units": "km/h"})},
            attrs={"summary_json": _json(self.summary())},  # model, params_toml, version, settings: Result
        )
        return ds

    def to_dataframe(self):
        """pandas DataFrame, one row per cycle point (amplitude_<state> columns): the CSV table."""
        import pandas as pd

        rows = []
        for c in self.cycles:
            row = {
                "branch": c.branch,
                "speed_kmh": c.speed_kmh,
                "period_s": c.period,
                "frequency_hz": 1.0 / c.period,
                "stable": c.stable,
                "n_unstable_multipliers": c.n_unstable,
                "max_multiplier_modulus": c.max_multiplier,
                "label": c.label,
            }
            row.update({f"amplitude_{s}": a for s, a in zip(self.state_names, c.amplitude)})
            rows.append(row)
        return pd.DataFrame(rows)

    cycle_table = to_dataframe  # the older name

    def coordinates(self) -> list[str]:
        """Displacement coordinates (states q with a velocity state q + "dot"), tread x first."""
        names = self.state_names
        coords = [q for q in names if q + "dot" in names]
        return sorted(coords, key=lambda q: q != "x")

    def figure(self, states: list[str] | None = None, operating_range_kmh: tuple[float, float] | None = None):
        """Figure with one amplitude panel per coordinate (x large on top), operating speed
        (and ``operating_range_kmh`` [km/h] if given) marked."""
        import matplotlib.pyplot as plt

        states = states or self.coordinates()
        heights = [3] + [1.6] * (len(states) - 1)
        fig, axes = plt.subplots(len(states), 1, figsize=(10, sum(heights) + 1.0), sharex=True,
                                 gridspec_kw={"height_ratios": heights}, squeeze=False)
        for ax, state in zip(axes[:, 0], states):
            self.plot(ax, state=state, operating_range_kmh=operating_range_kmh)
            if ax is not axes[-1, 0]:
                ax.set_xlabel("")
            if ax is not axes[0, 0]:
                ax.set_title("")
                ax.get_legend().remove()
            if len(states) > 1:  # short panel labels ("x [mm]"), one "amplitude" for all: no overlap
                ax.set_ylabel(ax.get_ylabel().removeprefix("amplitude of "))
        if len(states) > 1:
            fig.supylabel("amplitude of the cycle")
            fig.align_ylabels(axes[:, 0])
        fig.tight_layout()
        return fig

    def plot(self, ax=None, state: str = "x", scale: float | None = None, unit: str | None = None,
             operating_range_kmh: tuple[float, float] | None = None):
        """Amplitude of ``state`` against speed: stable cycles solid, unstable dashed, the SEV
        band shaded, the operating speed (``params.operating.speed_kmh``) as a vertical line and
        ``operating_range_kmh`` [km/h], if given, hatched. Returns artists."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(8, 4.5))
        i = self.state_names.index(state)
        if scale is None:
            scale, unit = plot_scale(model_for(self.params).state_units[i])
        artists = []
        # equilibrium line (amplitude zero), stable solid, unstable dotted red
        V = self.stability.speeds_kmh
        stable_eq = (self.stability.eigenvalues.real <= 0).all(axis=1)
        artists += ax.plot(V, np.where(stable_eq, 0.0, np.nan), "k-", lw=2, label="steady rolling, stable")
        artists += ax.plot(V, np.where(~stable_eq, 0.0, np.nan), color="tab:red", ls=":", lw=2,
                           label="steady rolling, unstable")
        for k, (lo, hi) in enumerate(self.sev_band_kmh):
            artists.append(ax.axvspan(lo, hi, color="tab:orange", alpha=0.10, label=None if k else "SEV band"))
        if operating_range_kmh is not None:
            lo, hi = operating_range_kmh
            artists.append(ax.axvspan(lo, hi, facecolor="none", edgecolor=(0.17, 0.63, 0.17, 0.45), hatch="//", lw=0.0,
                                      label=f"operating range {lo:g}-{hi:g} km/h"))
        speed = self.params.operating.speed_kmh
        artists.append(ax.axvline(speed, color="tab:green", ls="-.", lw=1.5, label=f"operating speed {speed:g} km/h"))
        first = True
        for b in range(len(self.branches)):
            pts = [c for c in self.cycles if c.branch == b]
            if not pts:
                continue
            v = np.array([c.speed_kmh for c in pts])
            a = np.array([c.amplitude[i] for c in pts]) * scale
            st = np.array([c.stable for c in pts])
            for flag, style, lab in ((True, "-", "stable cycle"), (False, "--", "unstable cycle")):
                mask = st == flag
                # keep segments contiguous: include the neighbours at a stability change
                seg = mask | np.r_[mask[1:], False] | np.r_[False, mask[:-1]]
                y = np.where(seg, a, np.nan)
                artists += ax.plot(v, y, style, color="tab:blue", lw=1.8, label=lab if first else None)
            first = False
        for k, h in enumerate(self.hopf_points, 1):
            artists += ax.plot([h.speed_kmh], [0.0], "o", color="tab:red", ms=7)
            artists.append(ax.annotate(f"H{k} {h.speed_kmh:.1f}\n({h.criticality})", (h.speed_kmh, 0.0),
                                       textcoords="offset points", xytext=(4, 6), fontsize=8))
        for k, f in enumerate(self.folds, 1):
            y = f.amplitude[i] * scale
            artists += ax.plot([f.speed_kmh], [y], "s", color="tab:green", ms=7)
            artists.append(ax.annotate(f"LP{k} {f.speed_kmh:.1f}", (f.speed_kmh, y),
                                       textcoords="offset points", xytext=(5, 5), fontsize=8))
        for p in self.special:
            if p.kind in (PointKind.PD, PointKind.NS):
                artists += ax.plot([p.speed_kmh], [p.amplitude[i] * scale], "^", color="tab:purple")
                artists.append(ax.annotate(p.label, (p.speed_kmh, p.amplitude[i] * scale), fontsize=8))
        sev = self.sev_band_kmh
        if sev:
            open_at = self.open_edges
            first = f"below {sev[0][0]:g} (open)" if "lower" in open_at else f"{sev[0][0]:.1f}"
            second = f"above {sev[-1][1]:g} (open)" if "upper" in open_at else f"{sev[-1][1]:.1f}"
            ax.set_title(
                f"{self.params.model}: SEV from {first} to {second} km/h "
                f"(first/second bifurcation speeds)", fontsize=10)
        else:
            lo, hi = self.speed_range_kmh
            ax.set_title(f"{self.params.model}: no SEV in {lo:g}-{hi:g} km/h", fontsize=10)
        ax.set_xlabel("speed [km/h]")
        ax.set_ylabel(f"amplitude of {state} [{unit}]" if unit else f"amplitude of {state}")
        ax.set_xlim(*self.speed_range_kmh)
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
        return artists


def sev_band(oscillatory_kmh, stable_cycles_kmh, pd_ns_kmh) -> tuple[list[tuple[float, float]],
                                                                     list[tuple[float, float]]]:
    """The SEV band [km/h] from a diagram's branches, the one definition of the single car,
    the report and the studies: the speeds where the tread can vibrate, i.e. where steady
    rolling is unstable through an oscillatory mode (``oscillatory_kmh``), or a stable
    vibration coexists with stable rolling. Returns (band, undecided).

    * Where rolling is unstable the tread vibrates whatever the stability of the period-1
      cycles, so a period doubling (PD) or torus bifurcation (NS) there ends nothing.
    * ``stable_cycles_kmh``: where a stable period-1 cycle exists; with stable rolling,
      these are the hard regions.
    * A stable run ending at a PD/NS (``pd_ns_kmh``, its speeds) where rolling is stable
      leaves open whether the period-doubled or quasi-periodic motion survives: the gap of
      the band that starts or ends at such a point is returned as undecided, for the doubled
      branch or a simulation to decide there alone. Every other gap is decided: rolling is
      stable and no vibration exists.

    Intervals closer than ``_JOIN_KMH`` are one; a gap's end matches a PD/NS within it.
    """
    band = union(list(stable_cycles_kmh) + list(oscillatory_kmh), gap=_JOIN_KMH)
    at_pd_ns = lambda v: any(abs(v - w) <= _JOIN_KMH for w in pd_ns_kmh)
    undecided = [(b, c) for (_, b), (c, _) in zip(band[:-1], band[1:]) if at_pd_ns(b) or at_pd_ns(c)]
    return band, undecided


def statically_divergent(eigenvalues: np.ndarray) -> bool:
    """True if steady rolling is unstable through a real eigenvalue that crossed zero, not
    through an oscillatory (Hopf) pair: an odd number of real positive eigenvalues (det J
    changed sign) and no growing complex pair. A Hopf pair that split into two real
    positive eigenvalues (strong negative damping) is oscillatory, not divergence."""
    grow = eigenvalues[eigenvalues.real > 0.0]
    return bool(grow.size) and bool(np.all(grow.imag == 0.0)) and grow.size % 2 == 1


def _open_at(edges: list[str]) -> str | None:
    """"lower", "upper", "both" or None."""
    return {0: None, 1: edges[0] if edges else None, 2: "both"}[len(edges)]


def _open_warning(edge: str, speed_range_kmh) -> str:
    limit = speed_range_kmh[0] if edge == "lower" else speed_range_kmh[1]
    which = "first" if edge == "lower" else "second"
    side = "below" if edge == "lower" else "above"
    return (f"the SEV band runs into the {edge} end of the analysed range ({limit:g} km/h): "
            f"the {which} bifurcation speed lies {side} it and is not reported")


def _json(payload) -> str:
    import json

    return json.dumps(payload, default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o))


def _points_with_folds(branch: Branch) -> list:
    """The branch's points with its located folds in their place, so that neighbours
    bracket every speed the branch covers, on both sides of each fold (the steps
    straddle a fold and the turning point itself lies beyond every stored point)."""
    points = list(branch.points)
    for label, point, index in sorted(branch.special, key=lambda s: s[2], reverse=True):
        if PointKind(label) is PointKind.LP:  # between points[index - 1] and points[index]
            points.insert(index, point)
    return points


def _crossing_speed(a: CyclePoint, c: CyclePoint) -> float:
    """Speed [km/h] between two cycle points where the largest multiplier modulus crosses 1."""
    la, lc = np.log(max(a.max_multiplier, 1e-300)), np.log(max(c.max_multiplier, 1e-300))
    s = 0.5 if la == lc else float(np.clip(-la / (lc - la), 0.0, 1.0))
    return ms_to_kmh((1 - s) * a.speed_ms + s * c.speed_ms)


def cycle_point(branch_index, point) -> CyclePoint:
    """The stored cycle of a branch point: speed, period, amplitude and stability."""
    orbit = point.orbit
    lo, hi = orbit.extrema()
    mu = point.multipliers
    trivial = int(np.argmin(np.abs(mu - 1.0)))
    others = np.delete(mu, trivial)
    return CyclePoint(
        branch=branch_index,
        speed_ms=orbit.speed,
        period=orbit.period,
        amplitude=0.5 * (hi - lo),
        mean=0.5 * (hi + lo),
        stable=point.stable,
        n_unstable=point.n_unstable,
        max_multiplier=float(np.abs(others).max()) if others.size else 0.0,
        trivial_multiplier_error=point.trivial_multiplier_error,
        label=point.label,
        orbit=orbit,
        resolved=point.resolved,
    )

