"""Nonlinear wear evolution: the worn profile over distance, at one speed or a drive cycle.

Fast dynamics and slow wear alternate (``docs/wear.md``). For a distance step ``h``:

1. **Window.** At each speed of the cycle the coupled model (profile -> load,
   :mod:`polywear.models.profile`) runs with the current profile, from where the last
   window at that speed ended, until the transient has died out, then for ``M`` whole
   revolutions. Each revolution ``k`` writes harmonics ``D_k`` (:func:`~.wear_law.written_harmonics`).
   The window (:mod:`polywear.wear.windows`) tabulates the profile's load over the
   contact angle once instead of summing the harmonics in every right-hand side.
2. **Locking and coherence.** The dominant frequency of the tread velocity gives the
   vibration's order ``nu = f / f_rot``. A spectral line at order ``nu`` writes, on every
   harmonic, a contribution that turns by ``r = exp(2 pi i nu)`` per revolution. The
   per-revolution writes are fitted (least squares, known ratios) as
   ``D_k = S + sum_j C_j r_j^k`` with ``r_j = exp(+-2 pi i j nu)``, ``j = 1..J``: ``S`` is
   what every revolution writes in the same place (the locked or forced part), the
   ``C_j`` what drifts. Over the ``N`` revolutions of the step the drifting parts add up
   to ``C_j r_j^M (1 - r_j^N)/(1 - r_j)``, whose size relative to N coherent writes is
   ``|sin(pi eps N)/(N sin pi eps)|`` (eps = distance of j nu to the nearest integer):
   the cancellation is computed over the whole step, not over the simulated window. A
   vibration is *locked* when its order is an integer to within ``LOCK_TOLERANCE`` or
   when its phase relative to the tire settles over the window (``SETTLED_PHASE``: after
   a profile change a locked vibration relaxes to its new phase, and its order measured
   over the window is off the integer by that transient only); all it writes is coherent.
3. **Update.** Unlocked, the coherent write of harmonic n is proportional to ``W_n``
   (the response to harmonic n lands on harmonic n only): a rate ``a_n = S_n / W_n``;
   locked, the cycle writes its own pattern at a rate ``b = S`` that does not depend on
   ``W`` to first order, except at its locking order m, where it keeps its phase to W_m and
   its write ``c W_m/|W_m|`` turns with W_m (a pattern worn across W_m travels around the
   tire; the next window starts the vibration at its phase to the turned W_m,
   :func:`~.windows.continued`), and at its multiples j m, where its write turns j times as
   fast (:func:`~.step.turning_orders`). ``dW/dN = a W + b (+ c W/|W|)`` is integrated exactly over the step
   (:func:`~.step.update_profile`; harmonics below ``1e-6`` of the profile's RMS, or an exponent above
   ``MAX_EXPONENT`` in a step, take the additive form). A step is a predictor-corrector
   pair (:func:`~.step.predict`, :func:`~.step.corrected`): the writes at its start give the predicted
   profile, where the windows of the step's end are run; the step then takes the mean of
   the start and end rates (trapezoid, second order; the exponents with its curvature term
   from the start of the step before, :func:`~.step.curvature`), and the end windows start the next
   step. **Error control.** The largest difference of a harmonic between the two,
   relative to the largest harmonic, is the step's error estimate: the next step is
   ``h sqrt(tolerance / error)`` (at most twice the last, at most ``MAX_STEP_FACTOR``
   times ``step_km``), a step over ``REJECT`` tolerances is taken again, shorter (down to
   ``SHORTEST_REJECTED`` of ``step_km``). The prediction
   is shortened while what is not integrated exactly would change the profile by more
   than ``MAX_CHANGE``.
4. **Linear regime.** At a speed where rolling is steady and the profile is small
   (``LINEAR_LOAD``), the window's rates ``S_n / W_n`` are reused instead of simulating.
5. **Parallel.** The windows at a step's end are independent: they run in threads at the
   same time (``workers``; the compiled integrator and diagnostics release the GIL, each
   window has its own parameter vector), with the same result bit for bit.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np

from ..errors import NumericalError
from ..models import model_for
from ..models.profile import coupled_model, patch_sinc, profile_vector
from ..parallel import on_one_blas_thread
from ..params import Params, Wear, to_toml
from ..progress import Progress
from ..results import Result
from ..settings import check_count, check_positive
from ..units import kmh_to_ms
from .law import energetic_rate, profile_samples
from .start import start_states
from .step import corrected, predict, step_error
from .windows import (LOCK_TOLERANCE, MAX_WINDOW, SETTLED_PHASE, WindowWear, _detuning, _resolving_window,
                      _separating_window, _settle_times, coherence, continued, window_wear)

__all__ = ["WindowWear", "window_wear", "EvolutionResult", "EvolutionSettings", "wear_evolution", "initial_roughness",
           "coherence", "StepBudgetError", "step_budget",
           "LOCK_TOLERANCE", "SETTLED_PHASE"]

LINEAR_LOAD = 1e-3
"""While the profile can change the load by less than this fraction of N0, a speed where
rolling is steady is in the linear regime: its window is simulated once and its rates
S_n / W_n (those of the linear wear map) are reused [-]."""
LINEAR_GROWTH = math.sqrt(2.0)
"""A reused steady-rolling window is simulated again once the largest harmonic has grown by
this factor since it ran [-]: near the edge of the SEV band the response turns nonlinear far
below LINEAR_LOAD (toe 0.35 deg at 80 km/h: order 11's growth per revolution falls from
1.9e-6 at 5 um to 1.7e-7 at 20 um, the window vibrating, locked, from 5 um; docs/wear.md).
At 2 the forced write of the locked response's second harmonic (order 22), reused as a
rate, left the depth there 3.7 % off the evolution that simulates every window (tolerance
0.01); at sqrt(2), 1e-4."""
MAX_GROWTH = 2.0
"""Most a distance step grows from one step to the next [-]."""
MAX_STEP_FACTOR = 8.0
"""Distance steps stay below ``MAX_STEP_FACTOR * step_km`` [-]."""
SHORTEST_REJECTED = 1e-3
"""A step shorter than this fraction of ``step_km`` is kept whatever its error estimate
(the step budget then bounds the steps) [-]. It was ``1 / MAX_STEP_FACTOR``: a step the
change limit had cut below that was kept with any error, and at k_e 4.2e-3 mm^3/J the
pull into locking at 120 km/h was taken in one step of 104 km with an estimate of 0.96,
order 8 growing tenfold: 3.4 times too deep at 5 575 km (docs/wear.md)."""
REJECT = 2.0
"""A step whose error estimate exceeds this many tolerances is taken again, shorter [-]
(4 before: axle4dof at 110 km/h then took the pull into locking at order 9 in one step of
1515 km with an estimate of 2.8 tolerances, 1.6 % of depth at 60 000 km; docs/wear.md)."""


def initial_roughness(params: Params) -> np.ndarray:
    """Seeded random harmonics W_n [m], n = 1..max_order, of RMS ``initial_roughness_um``
    (complex normal, phases uniform; numpy SeedSequence(seed))."""
    K = params.wear.max_order
    rng = np.random.default_rng(np.random.SeedSequence(params.wear.seed))
    W = rng.standard_normal(K) + 1j * rng.standard_normal(K)
    rms = math.sqrt(0.5 * float(np.sum(np.abs(W) ** 2)))
    return W * (params.wear.initial_roughness_um * 1e-6 / rms)

def peak_to_valley(W: np.ndarray, points: int) -> float:
    """Peak-to-valley depth of the profile with harmonics W [m]."""
    w = profile_samples(W, points)
    return float(w.max() - w.min())


@dataclass
class EvolutionResult(Result):
    """Worn profile against distance."""

    params: Params
    distance_km: np.ndarray
    """(D,) [km]"""
    harmonics: np.ndarray
    """(D, K) complex W_n [m]"""
    mean_depth_m: np.ndarray
    """(D,) uniform wear [m]"""
    cycle: tuple[tuple[float, float], ...]
    """(speed [km/h], share) of the drive cycle"""
    vibration_order: np.ndarray
    """(D-1, S) order nu of the vibration per step and speed (NaN: none)"""
    locked: np.ndarray
    """(D-1, S) bool"""
    friction_energy_j: np.ndarray
    """(D,) cumulative friction energy [J]"""
    settings: dict = field(default_factory=dict)

    @property
    def orders(self) -> np.ndarray:
        return np.arange(1, self.harmonics.shape[1] + 1)

    @property
    def depth_mm(self) -> np.ndarray:
        """Peak-to-valley depth [mm] (D,)."""
        pts = self.params.wear.profile_points
        return np.array([peak_to_valley(W, pts) for W in self.harmonics]) * 1e3

    @property
    def dominant_order(self) -> np.ndarray:
        """Order of the largest harmonic (D,)."""
        return self.orders[np.argmax(np.abs(self.harmonics), axis=1)]

    @property
    def complete(self) -> bool:
        """False where the evolution stopped at its step budget short of the distance asked
        (:class:`StepBudgetError`'s ``partial``): nothing is known beyond ``distance_km[-1]``."""
        return bool(self.settings.get("complete", True))

    @property
    def visible_km(self) -> float | None:
        """Distance at which the depth first reaches ``wear.visible_depth_mm`` [km]
        (log-linear interpolation between steps); None if it does not."""
        d = self.depth_mm
        limit = self.params.wear.visible_depth_mm
        above = np.flatnonzero(d >= limit)
        if not above.size:
            return None
        i = int(above[0])
        if i == 0:
            return 0.0
        lo, hi = math.log(d[i - 1]), math.log(d[i])
        x = (math.log(limit) - lo) / (hi - lo) if hi > lo else 1.0
        return float(self.distance_km[i - 1] + x * (self.distance_km[i] - self.distance_km[i - 1]))

    def profile(self, with_mean: bool = True) -> np.ndarray:
        """w(distance, angle) [m] (D, profile_points)."""
        pts = self.params.wear.profile_points
        mean = self.mean_depth_m if with_mean else np.zeros(len(self.distance_km))
        return np.array([profile_samples(W, pts, m) for W, m in zip(self.harmonics, mean)])

    def summary(self) -> dict:
        depth = self.depth_mm
        visible = self.visible_km
        per_speed = []
        for j, (v, share) in enumerate(self.cycle):
            nu = self.vibration_order[:, j]
            finite = nu[np.isfinite(nu)]
            per_speed.append({
                "speed_kmh": v, "share": share,
                "vibration_order_end": float(finite[-1]) if finite.size else None,
                "locked_fraction": float(np.mean(self.locked[:, j])) if self.locked.size else None,
            })
        return {
            "model": self.params.model,
            "distance_km": float(self.distance_km[-1]),
            "complete": self.complete,
            "requested_km": float(self.settings.get("requested_km", self.distance_km[-1])),
            "cycle": per_speed,
            "initial_depth_mm": float(depth[0]),
            "final_depth_mm": float(depth[-1]),
            "dominant_order": int(self.dominant_order[-1]),
            "visible_depth_mm": self.params.wear.visible_depth_mm,
            "visible_km": visible,
            "mean_wear_mm": float(self.mean_depth_m[-1] * 1e3),
            "energetic_rate_mm3_per_j": self.params.wear.energetic_rate_mm3_per_j,
            "distances_scale_as": "1/k_e",
        }

    def to_dataset(self):
        import xarray as xr

        from .. import __version__

        pts = self.params.wear.profile_points
        angle = np.degrees(2.0 * math.pi * np.arange(pts) / pts)
        return xr.Dataset(
            {
                "w": (("distance_km", "angle_deg"), self.profile() * 1e3, {"units": "mm", "long_name": "worn depth"}),
                "harmonic_amplitude": (("distance_km", "order"), np.abs(self.harmonics) * 1e3, {"units": "mm"}),
                "harmonic_phase": (("distance_km", "order"), np.angle(self.harmonics), {"units": "rad"}),
                "depth_ptv": ("distance_km", self.depth_mm, {"units": "mm"}),
                "mean_depth": ("distance_km", self.mean_depth_m * 1e3, {"units": "mm"}),
                "friction_energy": ("distance_km", self.friction_energy_j, {"units": "J"}),
            },
            coords={"distance_km": self.distance_km, "angle_deg": angle, "order": self.orders},
            attrs={"model": self.params.model, "params_toml": to_toml(self.params), "polywear_version": __version__,
                   "note": "distances scale as 1/k_e", **{k: str(v) for k, v in self.settings.items()}},
        )

    def _dataset(self):
        return self.to_dataset()

    def plot(self, ax=None):
        """Peak-to-valley depth (log) and dominant order against distance. Returns artists."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(7, 4))
        artists = ax.semilogy(self.distance_km, self.depth_mm, color="tab:red", label="peak-to-valley depth")
        artists.append(ax.axhline(self.params.wear.visible_depth_mm, color="0.4", ls="--", lw=0.8,
                                  label="visible"))
        ax.set_xlabel("distance [km] (scales as 1/k_e)")
        ax.set_ylabel("depth [mm]")
        twin = ax.twinx()
        artists += twin.plot(self.distance_km, self.dominant_order, ".", color="tab:blue", ms=3,
                             label="dominant order")
        twin.set_ylabel("dominant order")
        visible = self.visible_km
        title = f"{self.params.model}: polygon " + (
            f"visible after {visible:,.0f} km" if visible is not None else "not visible" if self.complete
            else f"not visible within {self.distance_km[-1]:,.0f} km (the evolution stopped there at its step budget)")
        ax.set_title(title)
        ax.legend(loc="upper left", fontsize=7)
        return artists

    def plot_polar(self, ax=None, distances_km=None, exaggeration: float | None = None):
        """The worn tire in polar form at chosen distances (radius minus exaggerated depth)."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(subplot_kw={"projection": "polar"}, figsize=(5, 5))
        d = self.distance_km
        chosen = distances_km if distances_km is not None else d[np.unique(np.linspace(0, d.size - 1, 4).astype(int))]
        pts = self.params.wear.profile_points
        phi = 2.0 * math.pi * np.arange(pts + 1) / pts
        depth = self.depth_mm
        scale = exaggeration or (0.1 / max(float(depth.max()), 1e-12))  # deepest shown as 10 % of the radius
        artists = []
        for dist in chosen:
            i = int(np.argmin(np.abs(d - dist)))
            w = profile_samples(self.harmonics[i], pts) * 1e3
            r = 1.0 - scale * (w - w.min())
            artists += ax.plot(phi, np.append(r, r[0]), lw=1.0, label=f"{d[i]:,.0f} km")
        ax.set_ylim(0.75, 1.01)  # the centre is at 75 % of the radius: the shape, magnified
        ax.set_yticklabels([])
        ax.set_title(f"worn tread (depth x{scale:.3g} of the radius per mm)", fontsize=9)
        ax.legend(fontsize=7, loc="lower right")
        return artists

    def plot_waterfall(self, ax=None):
        """Order amplitudes over distance (log colour). Returns the mesh."""
        import matplotlib.pyplot as plt
        from matplotlib.colors import LogNorm

        if ax is None:
            _, ax = plt.subplots(figsize=(7, 4))
        amp = np.abs(self.harmonics) * 1e3
        mesh = ax.pcolormesh(self.orders, self.distance_km, amp, shading="nearest",
                             norm=LogNorm(vmin=max(amp.max() * 1e-4, 1e-12), vmax=max(amp.max(), 1e-11)))
        ax.figure.colorbar(mesh, ax=ax, label="harmonic amplitude [mm]")
        ax.set_xlabel("order n")
        ax.set_ylabel("distance [km]")
        ax.set_title("order amplitudes over distance")
        return mesh


@dataclass(frozen=True)
class EvolutionSettings:
    """Numerical settings of :func:`wear_evolution` (``polywear wear evolve --step-km, --revolutions``)."""

    step_km: float = 1000.0
    """First distance step between simulated windows [km] (> 0); later steps follow the
    error estimate (``tolerance``) up to ``8 step_km``, shortened where
    the profile would change by more than ``MAX_CHANGE`` in one step."""
    revolutions: int = 16
    """Simulated revolutions per window where the tread vibrates [-] (integer >= 6; 3 where
    steady rolling is stable: nothing drifts there; lengthened up to ``MAX_WINDOW`` to
    separate the vibration from its nearest integer order, beyond where it drifts by less
    than ``SEPARATED_BEATS`` periods over ``MAX_WINDOW``, up to ``LONG_WINDOW``)."""

    tolerance: float = 0.01
    """Error allowed per distance step [-]: the largest difference between the first-order
    profile (writes at the start of the step) and the second-order one (mean of the writes
    at its start and end), relative to the largest harmonic. A minor harmonic may be off by
    this fraction of the largest, and the depth (peak to valley) with it: at 0.025 the depth
    of axle4dof at 110 km/h, 2 500 km after its pull into locking, scattered by -0.5 to +5.8 %
    with numerically irrelevant changes (the window's sampling); at 0.01 the cars of
    docs/wear.md are within 1 % of the step-converged answer but one (+1.6 %, docs/wear.md)."""

    max_steps: int = 500
    """Step budget [-]: an evolution that needs more distance steps than this (rejected ones
    included) plus the fewest its distance takes at the longest step, ``distance / (8 step_km)``,
    stops with a :class:`~polywear.errors.NumericalError` that says what to change: the profile
    then changes too fast for the steps (a k_e far above the default wears the polygon ever
    deeper within the distance; at the default k_e, writes that change faster than the
    tolerance from window to window). The default settings take 15-40 steps over
    60 000 km on the cars of docs/wear.md."""
    max_revolutions: int | None = None
    """Work budget [simulated revolutions, summed over the windows]: an evolution whose
    windows need more stops like one over its step budget (None: no such budget). A
    vibration within a thousandth of an integer order needs windows of up to LONG_WINDOW
    revolutions in every step (tread1dof at toe 0.54 deg, 120 km/h, order 7.9993: 98 km
    in 39 steps and 73 s CPU); the wear design's probes set it (``PROBE_MAX_REVOLUTIONS``)."""
    until_visible: bool = False
    """Stop at the first step whose depth reaches ``wear.visible_depth_mm`` (the visible
    distance and the order there are then known; what a fleet's wear risk needs). The
    steps up to there are those of the whole evolution."""

    def __post_init__(self) -> None:
        check_positive(self, "step_km")
        check_count(self, "revolutions", minimum=6)
        check_positive(self, "tolerance")
        check_count(self, "max_steps", minimum=1)
        if self.max_revolutions is not None:
            check_count(self, "max_revolutions", minimum=1)
        if not isinstance(self.until_visible, bool):
            raise ValueError(f"until_visible = {self.until_visible!r}: must be True or False")


class StepBudgetError(NumericalError):
    """An evolution stopped at its step budget (:func:`step_budget`), or at its work budget
    (``EvolutionSettings.max_revolutions``): ``budget`` in ``unit`` ("distance steps" or
    "simulated revolutions"),
    ``done_km``, the distance it had reached [km], and ``partial``, the evolution up to there
    (an :class:`EvolutionResult` whose ``complete`` is False; None before the first step)."""

    def __init__(self, message: str, budget: int, done_km: float, partial: EvolutionResult | None = None,
                 unit: str = "distance steps") -> None:
        super().__init__(message)
        self.budget = budget
        self.unit = unit
        self.done_km = done_km
        self.partial = partial


def step_budget(distance_km: float, settings: EvolutionSettings) -> int:
    """Most distance steps (rejected ones included) of an evolution over ``distance_km`` [km]:
    ``settings.max_steps`` beyond the fewest the distance takes at the longest step."""
    return settings.max_steps + math.ceil(distance_km / (MAX_STEP_FACTOR * settings.step_km))


@on_one_blas_thread
def wear_evolution(params: Params, distance_km: float, cycle: Iterable[tuple[float, float]] | None = None,
                  settings: EvolutionSettings = EvolutionSettings(),
                  progress: Progress | None = None, workers: int | None = None,
                  start: str = "rest") -> EvolutionResult:
    """Worn profile from seeded roughness over ``distance_km`` [km] on a drive cycle, with
    BLAS on one thread (as from the command line and in worker processes, so that a Python
    call takes the same path to the last bit: an evolution that creeps near its budget
    amplifies last-bit differences).

    ``cycle``: ((speed [km/h], share), ...), default ``params.wear.cycle_shares()``;
    ``settings``: the distance step [km] and the revolutions per window
    (:class:`EvolutionSettings`);
    ``progress(km done, distance_km)`` after every step (:mod:`polywear.progress`);
    ``workers``: threads that simulate the windows of the cycle's speeds at the same
    time (default: one per speed, at most the CPU count; 1: all in this thread, e.g. where
    the caller already runs evolutions in parallel; the result is the same);
    ``start``: ``"rest"`` (steady rolling) or ``"cycle"`` (on the large stable cycle where it
    coexists with stable rolling, :mod:`polywear.wear.start`).
    """
    if not (math.isfinite(distance_km) and distance_km > 0):
        raise ValueError(f"distance {distance_km!r} km: must be positive")
    if workers is not None and workers < 1:
        raise ValueError(f"workers = {workers!r}: must be at least 1")
    cycle = tuple(cycle) if cycle is not None else params.wear.cycle_shares()
    starts = start_states(params, cycle, start)
    threads = min(workers or os.cpu_count() or 1, len(cycle))
    if threads == 1:
        return _evolve(params, distance_km, cycle, settings, progress, None, starts)
    with ThreadPoolExecutor(threads) as pool:
        return _evolve(params, distance_km, cycle, settings, progress, pool, starts)


def _windows(pool, jobs, base, longest: int) -> list[WindowWear]:
    """:func:`window_wear` of every job ``(params, V, W, state, settle_s, revolutions)``:
    in ``pool`` when there is one and more than one job (the cycle's speeds at the same
    time), else here."""
    if pool is None or len(jobs) < 2:
        return [window_wear(*job, base=base, max_revolutions=longest) for job in jobs]
    futures = [pool.submit(window_wear, *job, base=base, max_revolutions=longest) for job in jobs]
    return [future.result() for future in futures]


def _evolve(params: Params, distance_km: float, cycle, settings: EvolutionSettings, progress, pool,
            starts=None) -> EvolutionResult:
    """:func:`wear_evolution` on a given cycle: error-controlled distance steps (module notes), the
    windows at the end of each step run by :func:`_windows` and reused for the next."""
    base = model_for(params)
    coupled = coupled_model(base)
    R = params.operating.rolling_radius_m
    k_e = energetic_rate(params)
    revolutions, tolerance = settings.revolutions, settings.tolerance
    W = initial_roughness(params)
    states, settles, windows = [], [], []
    for v_kmh, _ in cycle:
        V = float(kmh_to_ms(v_kmh))
        first, nxt, unstable = _settle_times(base, params, V)
        on_cycle = v_kmh in (starts or {})  # start="cycle": on the large stable cycle (wear/start.py)
        windows.append(revolutions if unstable or on_cycle else min(revolutions, 3))
        u0 = coupled.equilibrium(V, profile_vector(base, params, V))
        u0[base.index("x")] += 1e-5  # a small disturbance: steady rolling as a car drives
        if on_cycle:  # already on the attractor: the settling of the next windows
            u0[:-1], first = starts[v_kmh], nxt
        states.append(u0)
        settles.append([first, nxt])
    shortest = list(windows)  # per speed; a vibrating window is lengthened up to `longest`
    longest = max(MAX_WINDOW, revolutions)
    linear = [None] * len(cycle)  # per speed: the steady-rolling window whose rates S_n / W_n are reused
    sinc = patch_sinc(np.arange(1, W.size + 1), params.tire.contact_length_m, R)
    load_scale = LINEAR_LOAD * params.operating.vertical_load_n / params.tire.vertical_stiffness_n_per_m \
        if params.tire.vertical_stiffness_n_per_m > 0 else math.inf
    simulated_windows, simulated_revolutions = [0], [0]

    last = [None] * len(cycle)  # per speed: the last simulated window, whose vibration the next continues

    def window_set(W):
        """The windows of every speed at profile W (simulated, or rescaled in the linear regime),
        a locked vibration started at its phase to the worn profile (:func:`~.windows.continued`)."""
        small = float(np.sum(np.abs(sinc * W))) < load_scale  # |w_c| bounded by the sum of |sinc_n W_n|
        run = [j for j in range(len(cycle)) if not (small and linear[j] is not None and np.max(np.abs(W))
                                                     <= LINEAR_GROWTH * np.max(np.abs(linear[j].profile)))]
        jobs = [(params, float(kmh_to_ms(cycle[j][0])), W,
                 states[j] if last[j] is None else continued(states[j], last[j], W), settles[j][0], windows[j])
                for j in run]
        simulated = dict(zip(run, _windows(pool, jobs, base, longest)))
        simulated_windows[0] += len(run)
        simulated_revolutions[0] += sum(win.revolutions for win in simulated.values())
        out = []
        for j in range(len(cycle)):
            if j not in simulated:
                out.append(linear[j].rescaled(W))
                continue
            win = simulated[j]
            if math.isfinite(win.order):  # the next window at this speed starts long enough
                drifting = 0 if win.locked else max(_separating_window(_detuning(win.order), longest),
                                                     _resolving_window(win.order, longest))
                windows[j] = max(shortest[j], drifting)
            settles[j][0] = settles[j][1]
            states[j] = win.end_state
            last[j] = win
            linear[j] = win if (small and not math.isfinite(win.order)) else None
            out.append(win)
        return out

    history, means, energies, distance = [W.copy()], [0.0], [0.0], [0.0]
    orders_hist, locked_hist = [], []
    mean = energy = done = 0.0
    rejected = 0
    h = min(settings.step_km, distance_km)
    longest_step = MAX_STEP_FACTOR * settings.step_km
    wins = window_set(W)
    before, h_before = None, h  # the windows at the start of the step before, and its length [km]
    budget = step_budget(distance_km, settings)
    visible_m = params.wear.visible_depth_mm * 1e-3

    def result(complete: bool) -> EvolutionResult:
        """The evolution so far (``complete``: it reached the distance asked, or the visible
        depth with ``until_visible``)."""
        steps = np.diff(distance)
        return EvolutionResult(params=params, distance_km=np.array(distance), harmonics=np.array(history),
                               mean_depth_m=np.array(means), cycle=cycle,
                               vibration_order=np.array(orders_hist).reshape(len(orders_hist), len(cycle)),
                               locked=np.array(locked_hist, dtype=bool).reshape(len(locked_hist), len(cycle)),
                               friction_energy_j=np.array(energies),
                               settings={"step_km": settings.step_km,
                                         "smallest_step_km": float(steps.min()) if steps.size else None,
                                         "largest_step_km": float(steps.max()) if steps.size else None,
                                         "tolerance": tolerance, "rejected_steps": rejected,
                                         "windows": simulated_windows[0], "revolutions": revolutions,
                                         "simulated_revolutions": simulated_revolutions[0],
                                         "k_e_m3_per_j": k_e, "until_visible": settings.until_visible,
                                         "requested_km": distance_km, "complete": complete})

    while done < distance_km * (1.0 - 1e-12):
        if len(distance) - 1 + rejected >= budget:
            raise StepBudgetError(
                f"wear evolution: over its budget of {budget} distance steps at {done:,.0f} of {distance_km:,.0f} km "
                f"(EvolutionSettings.max_steps = {settings.max_steps}): the profile changes too fast for the steps; "
                + _budget_hint(params), budget, done, result(False) if len(distance) > 1 else None)
        if settings.max_revolutions is not None and simulated_revolutions[0] > settings.max_revolutions:
            raise StepBudgetError(
                f"wear evolution: over its budget of {settings.max_revolutions:,} simulated revolutions at {done:,.0f} "
                f"of {distance_km:,.0f} km (EvolutionSettings.max_revolutions): its windows are long (a vibration "
                f"very close to an integer order)", settings.max_revolutions, done,
                result(False) if len(distance) > 1 else None, unit="simulated revolutions")
        h = min(h, distance_km - done)
        saved = ([s.copy() for s in states], [list(s) for s in settles], list(windows), list(linear),
                 list(last))
        W_pred, h, n_revs = predict(W, wins, h, cycle, R)
        ends = window_set(W_pred)
        W_new = corrected(W, wins, n_revs, ends, W_pred, before, h / h_before if before is not None else 1.0)
        error = step_error(W_new, W_pred)
        if error > REJECT * tolerance and h > SHORTEST_REJECTED * settings.step_km:
            states, settles, windows, linear, last[:] = saved  # the step again, shorter
            h *= max(0.2, 0.9 * math.sqrt(tolerance / error))
            rejected += 1
            continue
        W = W_new
        done += h
        mean += 0.5 * sum(n * (w.mean_per_rev + e.mean_per_rev) for n, w, e in zip(n_revs, wins, ends))
        energy += 0.5 * sum(n * (w.energy_per_rev + e.energy_per_rev) for n, w, e in zip(n_revs, wins, ends))
        history.append(W.copy())
        means.append(mean)
        energies.append(energy)
        distance.append(done)
        orders_hist.append([w.order for w in wins])
        locked_hist.append([w.locked and math.isfinite(w.order) for w in wins])
        before, h_before, wins = wins, h, ends
        h = min(longest_step, h * min(MAX_GROWTH, 0.9 * math.sqrt(tolerance / max(error, 1e-12))))
        if progress is not None:
            progress(done, distance_km, "")
        if settings.until_visible and peak_to_valley(W, params.wear.profile_points) >= visible_m:
            break
    return result(True)


def _budget_hint(params: Params) -> str:
    """What to change when the step budget runs out: k_e where it is above its default
    (distances scale as 1/k_e), else the steps themselves (the writes then change from
    window to window faster than the tolerance, e.g. on the way into locking)."""
    k_e = params.wear.energetic_rate_mm3_per_j
    if k_e > Wear.model_fields["energetic_rate_mm3_per_j"].default:
        return (f"wear.energetic_rate_mm3_per_j = {k_e:g} mm^3/J is above its default (distances scale as "
                f"1/k_e: evolve a proportionally shorter distance, or lower it)")
    return (f"wear.energetic_rate_mm3_per_j = {k_e:g} mm^3/J is not above its default: the writes change "
            f"from window to window faster than the tolerance here (a larger EvolutionSettings.max_steps "
            f"or tolerance lets the evolution go on)")
