"""Stability maps: Hopf and fold-of-cycles curves in the (speed, parameter) plane.

For one parameter key ``theta`` (any float key or ``adhesion_scale``) over a range:

The two-parameter continuation itself is :mod:`polywear.solvers.curve_continuation`;
this module evaluates the model along it, seeds the curves and builds the map.

* **Hopf curves** by pseudo-arclength continuation of ``Re lambda(V, theta) = 0`` for
  the tracked critical eigenvalue ``lambda``, in coordinates scaled by the widths of the
  speed and parameter ranges. The gradient ``(d Re lambda/dV, d Re lambda/d theta)``
  is exact (:func:`~polywear.dynamics.stability.critical_eigenvalue_derivative`), so the
  tangent is too, and turning points in ``theta`` - where the two Hopf speeds of a
  band merge and the linear band closes - are passed and located (zero of the
  tangent's ``theta`` component). Along every curve the first Lyapunov coefficient
  ``l1`` is evaluated; where it changes sign the curve has a Bautin (generalized Hopf)
  point, located by secant iteration on the arclength: soft on one side, hard on the
  other, and the fold-of-cycles curve starts there.
* **Fold curves** by natural continuation in ``theta``: the predictor is the exact
  derivative ``dV_fold/d theta`` (:func:`~polywear.dynamics.sensitivity.fold_speed_derivative`,
  left null vector of the collocation system), the corrector re-locates the fold at
  the new ``theta`` (:func:`~polywear.solvers.continuation.fold_at`): Newton on the
  fold's defining system (minimally augmented) from the last fold, recentred on the new
  steady state; where that fails, one Newton solve onto the new cycle branch from the
  predicted orbit, a march along the branch until the speed component of its tangent
  (zero at the fold) changes sign, then a secant iteration inside that bracket. A fold curve ends at the range, where the corrector
  fails (a turning point of the fold curve, e.g. a cusp), or where the fold's
  amplitude has shrunk towards a Bautin point.

Seeds: Hopf points of :func:`~polywear.dynamics.stability.stability` and folds
of :func:`~polywear.dynamics.bifurcation.bifurcation` at a few parameter values;
a seed already on a computed curve is skipped, so isolated curves are found too.

Bands per parameter value (for shading and the safe-parameter summary): the linear
band from :func:`~polywear.dynamics.stability.fast_linear_band`; the hard band
between every fold speed and the nearest bound of the linear band (the subcritical
Hopf point the unstable cycle is born at - the topology of all the cases we met; the
one-parameter diagrams in the tests check it); the SEV band is their union.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..models import model_for
from ..results import Result
from ..params import Params, ParameterError
from ..progress import Progress, StepCounter
from ..settings import check_count, check_fraction, check_order, check_positive
from ..solvers.continuation import BranchPoint, ContinuationSettings
from ..solvers.curve_continuation import HopfCurveTracer, HopfState, follow_fold_curve, trace_hopf_curve
from ..units import DEFAULT_SPEED_RANGE_KMH, kmh_to_ms, ms_to_kmh
from .intervals import runs_of, union
from .points import PointKind, SpecialPoint
from .sensitivity import PARAMETER_LABELS, fold_speed_derivative, nominal_value, parameter_direction, perturbed
from .stability import critical_eigenvalue_derivative, first_lyapunov_coefficient

__all__ = ["MapSettings", "HopfCurve", "FoldCurve", "StabilityMap", "stability_map"]

FOLD_SPEED_MARGIN = 1.5
"""Fold curves are followed up to this multiple of the top speed, so that a hard band
reaching beyond the plotted range is shaded up to its edge."""


@dataclass(frozen=True)
class MapSettings:
    """Numerical settings of the two-parameter continuation (arclengths in scaled units)."""

    ds_initial: float = 0.01
    ds_max: float = 0.03
    ds_min: float = 1e-7
    max_steps: int = 2000
    newton_tol: float = 1e-11
    max_newton: int = 8
    max_turn: float = 0.25
    """Largest angle [rad] between consecutive tangents (curvature control)."""
    n_seeds: int = 3
    """Parameter values (evenly spaced, ends included) where curves are seeded."""
    n_grid: int = 81
    """Parameter values of the band table (shading, safe intervals)."""
    fold_step: float = 0.025
    """Initial and largest parameter step of the fold curves [fraction of the range]."""
    fold_min_step: float = 1e-5
    fold_min_amplitude: float = 0.03
    """A fold curve stops when its amplitude falls below this fraction of the seed's."""
    continuation: ContinuationSettings = ContinuationSettings()

    def __post_init__(self) -> None:
        check_positive(self, "ds_initial", "ds_max", "ds_min", "newton_tol", "max_turn", "fold_step",
                       "fold_min_step")
        check_order(self, "ds_min", "ds_initial", "ds_max")
        check_order(self, "fold_min_step", "fold_step")
        check_count(self, "max_steps", "max_newton", "n_seeds")
        check_count(self, "n_grid", minimum=2)
        check_fraction(self, "fold_min_amplitude", closed_low=True)
        if not self.max_turn <= np.pi:
            raise ValueError(f"MapSettings: max_turn = {self.max_turn!r}: must lie in (0, pi] [rad]")
        if not isinstance(self.continuation, ContinuationSettings):
            raise ValueError(f"MapSettings: continuation = {self.continuation!r}: must be a ContinuationSettings")


@dataclass
class HopfCurve:
    """A curve of Hopf points: arrays along the arclength, special points, end reasons."""

    speed_kmh: np.ndarray
    value: np.ndarray
    frequency_hz: np.ndarray
    first_lyapunov_coefficient: np.ndarray
    """l1 along the curve (< 0 soft, > 0 hard)."""
    tangent: np.ndarray  # (n, 2) unit tangent in scaled (speed, value) coordinates
    turning_points: list[SpecialPoint]
    """Where the curve turns back in the parameter and the linear band closes (kind HT)."""
    bautin_points: list[SpecialPoint]
    """Where ``first_lyapunov_coefficient`` changes sign (kind GH)."""
    end_reasons: tuple[str, str]


@dataclass
class FoldCurve:
    """A curve of folds of cycles against the parameter, with dV/d(value) at every point."""

    value: np.ndarray
    speed_kmh: np.ndarray
    derivative: np.ndarray  # dV/d(value) [km/h per unit]
    amplitude_x: np.ndarray  # [m]
    frequency_hz: np.ndarray
    end_reasons: tuple[str, str]

    def speeds_at(self, value: float) -> list[float]:
        """Fold speeds [km/h] at a parameter value, cubic Hermite between the points.

        Beyond an end where the curve left the speed range upwards the fold is taken to stay
        above it (``inf``): the hard band then reaches the top of the range.
        """
        v, s, d = self.value, self.speed_kmh, self.derivative
        for end, reason in ((0, self.end_reasons[0]), (-1, self.end_reasons[1])):
            other = -1 - end
            if reason == "left the speed range" and s[end] > s[other] and (value - v[end]) * (v[end] - v[other]) > 0:
                return [np.inf]
        out = []
        for i in range(len(v) - 1):
            a, b = v[i], v[i + 1]
            if min(a, b) <= value <= max(a, b) and a != b:
                h = b - a
                t = (value - a) / h
                out.append(float((2 * t**3 - 3 * t**2 + 1) * s[i] + (t**3 - 2 * t**2 + t) * h * d[i]
                                 + (-2 * t**3 + 3 * t**2) * s[i + 1] + (t**3 - t**2) * h * d[i + 1]))
                break
        return out


# -- Hopf curves -------------------------------------------------------------------------------
def _eigen_at(model, p_of, direction):
    """``eigen_at(V, theta, lam_guess)`` for :class:`~polywear.solvers.curve_continuation.HopfCurveTracer`:
    equilibrium and the critical eigentriple nearest ``lam_guess`` (Im > 0) at (V [m/s], theta),
    with the exact derivatives of the eigenvalue in V and theta."""
    from scipy.linalg import eig

    def at(V: float, theta: float, lam_guess: complex) -> HopfState | None:
        p = p_of(theta)
        try:
            u = model.equilibrium(V, p)
        except (RuntimeError, ValueError, FloatingPointError):
            return None
        J = model.jacobian(u, V, p)
        vals, vl, vr = eig(J, left=True, right=True)
        oscillatory = np.flatnonzero(vals.imag > 1e-9 * max(np.abs(vals).max(), 1.0))
        if oscillatory.size == 0:
            return None
        i = oscillatory[np.argmin(np.abs(vals[oscillatory] - lam_guess))]
        q = vr[:, i] / np.linalg.norm(vr[:, i])
        w = vl[:, i]
        w = w / np.conj(np.vdot(w, q))  # w^H q = 1
        dV = critical_eigenvalue_derivative(model, u, V, p, q, w, dV=1.0)
        dth = critical_eigenvalue_derivative(model, u, V, p, q, w, dp=direction)
        return HopfState(V, theta, vals[i], u, q, w, J, p, (dV, dth))

    return at


def _hopf_curve(tracer: HopfCurveTracer, start: HopfState, on_step) -> HopfCurve:
    c = trace_hopf_curve(tracer, start, on_step)
    return HopfCurve(
        speed_kmh=np.array([ms_to_kmh(p.V) for p in c.points]),
        value=np.array([p.theta for p in c.points]),
        frequency_hz=np.array([p.lam.imag / (2 * np.pi) for p in c.points]),
        first_lyapunov_coefficient=np.array(c.tests),
        tangent=c.tangents,
        turning_points=[SpecialPoint(PointKind.HOPF_TURN, ms_to_kmh(st.V), value=st.theta) for st in c.turning_points],
        bautin_points=[SpecialPoint(PointKind.GH, ms_to_kmh(st.V), value=st.theta) for st in c.test_zeros],
        end_reasons=c.end_reasons,
    )


def _near_curve(curves, value, speed_kmh, scale_value, scale_speed, tol=5e-3) -> bool:
    """Whether (value, speed) lies within ``tol`` (scaled) of a polyline of the curves."""
    pt = np.array([speed_kmh / scale_speed, value / scale_value])
    for c in curves:
        xy = np.column_stack([c.speed_kmh / scale_speed, c.value / scale_value])
        if len(xy) == 1:
            if np.linalg.norm(xy[0] - pt) < tol:
                return True
            continue
        a, b = xy[:-1], xy[1:]
        d = b - a
        t = np.clip(np.einsum("ij,ij->i", pt - a, d) / np.maximum(np.einsum("ij,ij->i", d, d), 1e-300), 0, 1)
        if np.min(np.linalg.norm(a + t[:, None] * d - pt, axis=1)) < tol:
            return True
    return False


# -- fold curves ---------------------------------------------------------------------------------
def _fold_curve(model, p_of, direction, seed: BranchPoint, scales, theta0, value_box, speed_box,
                settings: MapSettings, on_step) -> FoldCurve:
    rows, reasons = follow_fold_curve(
        model, p_of, seed, scales, theta0, value_box, (speed_box[0], FOLD_SPEED_MARGIN * speed_box[1]), settings,
        lambda p, fold: fold_speed_derivative(model, p, fold, direction), on_step)
    arr = np.array(rows)
    return FoldCurve(
        value=arr[:, 0],
        speed_kmh=ms_to_kmh(arr[:, 1]),
        derivative=ms_to_kmh(arr[:, 2]),
        amplitude_x=arr[:, 3],
        frequency_hz=arr[:, 4],
        end_reasons=reasons,
    )


# -- the map ---------------------------------------------------------------------------------------
@dataclass
class StabilityMap(Result):
    """Hopf and fold curves over (speed, parameter), with the band table for shading."""

    params: Params
    key: str
    value_range: tuple[float, float]
    speed_range_kmh: tuple[float, float]
    operating_range_kmh: tuple[float, float] | None
    hopf_curves: list[HopfCurve]
    fold_curves: list[FoldCurve]
    grid_values: np.ndarray
    grid_bands: list[dict]  # per grid value: {"linear": [...], "hard": [...], "sev": [...]} [km/h], or "error"
    settings: MapSettings = field(default_factory=MapSettings)
    notes: list[str] = field(default_factory=list)
    """Seeds or band-table rows that failed (with the reason)."""

    @property
    def nominal(self) -> float:
        return nominal_value(self.params, self.key)

    @property
    def turning_points(self) -> list[SpecialPoint]:
        return [tp for c in self.hopf_curves for tp in c.turning_points]

    @property
    def bautin_points(self) -> list[SpecialPoint]:
        return [b for c in self.hopf_curves for b in c.bautin_points]

    def bands_at(self, value: float) -> dict:
        """Linear, hard and SEV bands [km/h] at one parameter value (see the module notes)."""
        return _bands(self.params, self.key, value, self.speed_range_kmh, self.fold_curves)

    def safe_values(self) -> list[tuple[float, float]]:
        """Parameter intervals (on the band table) where the SEV band misses the operating range."""
        if self.operating_range_kmh is None:
            return []
        lo, hi = self.operating_range_kmh
        safe = [not ("error" in bands or any(a < hi and b > lo for a, b in bands["sev"])) for bands in self.grid_bands]
        return runs_of(self.grid_values, safe)

    def summary(self) -> dict:
        return {
            "model": self.params.model,
            "param": self.key,
            "nominal": self.nominal,
            "range": list(self.value_range),
            "speed_range_kmh": list(self.speed_range_kmh),
            "operating_range_kmh": list(self.operating_range_kmh) if self.operating_range_kmh else None,
            "hopf_curves": [
                {
                    "n_points": len(c.value),
                    "value_range": [float(c.value.min()), float(c.value.max())],
                    "speed_range_kmh": [float(c.speed_kmh.min()), float(c.speed_kmh.max())],
                    "end_reasons": list(c.end_reasons),
                }
                for c in self.hopf_curves
            ],
            "fold_curves": [
                {
                    "n_points": len(c.value),
                    "value_range": [float(c.value.min()), float(c.value.max())],
                    "speed_range_kmh": [float(c.speed_kmh.min()), float(c.speed_kmh.max())],
                    "end_reasons": list(c.end_reasons),
                }
                for c in self.fold_curves
            ],
            "band_closures": [{"value": p.value, "speed_kmh": p.speed_kmh} for p in self.turning_points],
            "bautin_points": [{"value": p.value, "speed_kmh": p.speed_kmh} for p in self.bautin_points],
            "at_nominal": self.bands_at(self.nominal)
            if self.value_range[0] <= self.nominal <= self.value_range[1] else None,
            "safe_values": [list(iv) for iv in self.safe_values()],
            "notes": self.notes,
        }

    def _dataset(self):
        """xarray Dataset: curve points (curve index per point), band table as a grid of states."""
        import xarray as xr

        def stack(curves, names):
            idx = np.concatenate([np.full(len(c.value), k) for k, c in enumerate(curves)]) if curves else np.zeros(0)
            cols = {n: np.concatenate([getattr(c, n) for c in curves]) if curves else np.zeros(0) for n in names}
            return idx, cols

        h_idx, h = stack(self.hopf_curves, ("value", "speed_kmh", "frequency_hz", "first_lyapunov_coefficient"))
        f_idx, f = stack(self.fold_curves, ("value", "speed_kmh", "derivative", "amplitude_x", "frequency_hz"))
        speeds = np.linspace(*self.speed_range_kmh, 561)
        ds = xr.Dataset(
            {
                **{f"hopf_{k}": ("hopf_point", v) for k, v in h.items()},
                "hopf_curve": ("hopf_point", h_idx.astype(int)),
                **{f"fold_{k}": ("fold_point", v) for k, v in f.items()},
                "fold_curve": ("fold_point", f_idx.astype(int)),
                "state": (("value", "speed_kmh"), self.state_grid(speeds),
                          {"meaning": "0 stable, 1 linear band (unstable rolling), 2 hard (stable SEV and rolling), "
                                      "3 unknown (no equilibrium found)"}),
            },
            coords={"value": self.grid_values, "speed_kmh": speeds},
            attrs={"param": self.key},
        )
        return ds

    def state_grid(self, speeds_kmh) -> np.ndarray:
        """(n_values, n_speeds) of 0 stable, 1 linear band, 2 hard band, 3 unknown (failed row)."""
        out = np.zeros((len(self.grid_values), len(speeds_kmh)), dtype=np.int8)
        for i, bands in enumerate(self.grid_bands):
            if "error" in bands:
                out[i] = 3
            for a, b in bands["hard"]:
                out[i, (speeds_kmh >= a) & (speeds_kmh <= b)] = 2
            for a, b in bands["linear"]:
                out[i, (speeds_kmh >= a) & (speeds_kmh <= b)] = 1
        return out

    def plot(self, ax=None):
        """The map: shaded linear and hard bands, Hopf (solid: soft, dashed: hard) and fold curves."""
        import matplotlib.pyplot as plt
        from matplotlib.colors import ListedColormap

        if ax is None:
            _, ax = plt.subplots(figsize=(8, 5))
        speeds = np.linspace(*self.speed_range_kmh, 561)
        grid = self.state_grid(speeds)
        colors = ["white", "#f4a3a3", "#ffd27f", "0.75"]
        artists = [ax.pcolormesh(speeds, self.grid_values, grid, cmap=ListedColormap(colors), vmin=-0.5, vmax=3.5,
                                 shading="nearest", rasterized=True)]
        from matplotlib.patches import Patch

        handles = [Patch(color="#f4a3a3", label="linear band: rolling unstable"),
                   Patch(color="#ffd27f", label="hard band: SEV after a large disturbance")]
        for k, c in enumerate(self.hopf_curves):
            soft = np.where(c.first_lyapunov_coefficient < 0, c.value, np.nan)
            hard = np.where(c.first_lyapunov_coefficient >= 0, c.value, np.nan)
            artists += ax.plot(c.speed_kmh, soft, "-", color="tab:red", lw=1.6,
                               label="Hopf, soft (l1 < 0)" if k == 0 else None)
            artists += ax.plot(c.speed_kmh, hard, "--", color="tab:red", lw=1.6,
                               label="Hopf, hard (l1 > 0)" if k == 0 else None)
        for k, c in enumerate(self.fold_curves):
            artists += ax.plot(c.speed_kmh, c.value, "-", color="tab:green", lw=1.6,
                               label="fold of cycles" if k == 0 else None)
        for k, tp in enumerate(self.turning_points):
            artists += ax.plot([tp.speed_kmh], [tp.value], "o", color="k", ms=5, label="band closes" if k == 0 else None)
        for k, gh in enumerate(self.bautin_points):
            artists += ax.plot([gh.speed_kmh], [gh.value], "*", color="tab:purple", ms=11, label="Bautin (GH) point" if k == 0 else None)
        if self.operating_range_kmh:
            artists.append(ax.axvspan(*self.operating_range_kmh, fill=False, hatch="//", ec="tab:blue", lw=0.8,
                                      label="operating range"))
        if self.value_range[0] <= self.nominal <= self.value_range[1]:
            artists.append(ax.axhline(self.nominal, color="0.3", lw=0.8, ls=":", label="nominal"))
        ax.set_xlim(*self.speed_range_kmh)
        ax.set_ylim(*self.value_range)
        ax.set_xlabel("speed [km/h]")
        ax.set_ylabel(f"{PARAMETER_LABELS.get(self.key, self.key)} ({self.key})")
        ax.set_title(f"{self.params.model}: stability map", fontsize=10)
        lines, labels = ax.get_legend_handles_labels()
        ax.legend(handles + lines, [h.get_label() for h in handles] + labels, fontsize=7, loc="upper left",
                  bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
        return artists


def _hard_side(curve: HopfCurve, theta_b, speed_b, scale_value, scale_speed, distance=0.05):
    """A parameter value on the subcritical (l1 > 0) side of a Bautin point, ``distance`` away (scaled)."""
    d = np.hypot((curve.value - theta_b) / scale_value, (curve.speed_kmh - speed_b) / scale_speed)
    candidates = np.flatnonzero((curve.first_lyapunov_coefficient > 0) & (d >= distance))
    if candidates.size == 0:
        return None
    return float(curve.value[candidates[np.argmin(d[candidates])]])


def _bands(params, key, value, speed_range_kmh, fold_curves) -> dict:
    from .stability import fast_linear_band

    try:
        linear = fast_linear_band(perturbed(params, key, value), speed_range_kmh)
    except RuntimeError as exc:  # e.g. no equilibrium found (axle4dof, unloaded reference)
        return {"linear": [], "hard": [], "sev": [], "error": str(exc)}
    edges = [v for iv in linear for v in iv]
    lo, hi = speed_range_kmh
    hard = []
    for curve in fold_curves:
        for vf in curve.speeds_at(value):
            if edges:
                vh = min(edges, key=lambda e: abs(e - vf))
                a, b = max(min(vh, vf), lo), min(max(vh, vf), hi)
                if b > a:
                    hard.append((a, b))
    return {"linear": linear, "hard": hard, "sev": union(linear + hard)}


def stability_map(
    params: Params,
    key: str,
    value_range: tuple[float, float],
    speed_range_kmh: tuple[float, float] = DEFAULT_SPEED_RANGE_KMH,
    operating_range_kmh: tuple[float, float] | None = None,
    folds: bool = True,
    settings: MapSettings = MapSettings(),
    progress: Progress | None = None,
) -> StabilityMap:
    """Hopf and fold-of-cycles curves of ``key`` over ``value_range`` and speeds [km/h].

    ``progress(steps done, None)`` is called after every continuation step
    (:mod:`polywear.progress`).
    This is ``polywear map`` and ``pw.stability_map``.

    Parameters
    ----------
    params : Params
        The nominal parameter set.
    key : str
        The mapped configuration key (``"table.key"``) or ``"adhesion_scale"``.
    value_range : (float, float)
        Lowest and highest value of ``key`` [key units].
    speed_range_kmh : (float, float)
        Speeds of the map [km/h].
    operating_range_kmh : (float, float), optional
        Speeds to keep free of SEV [km/h]: the map reports which values of ``key`` do.
    folds : bool
        Also continue the folds of cycles (the SEV band's hard ends), not only Hopf points.
    settings : MapSettings
        Step control of the two-parameter continuation.
    progress : callable, optional
        Progress callback (:mod:`polywear.progress`), total unknown.

    Returns
    -------
    StabilityMap
        Hopf and fold curves in the (speed, value) plane, the linear and SEV regions.
    """
    from .bifurcation import bifurcation
    from .stability import stability

    on_step = StepCounter(progress)  # called by the curve continuation after every step
    lo, hi = (float(v) for v in value_range)
    if not lo < hi:
        raise ValueError(f"range {lo} {hi}: need low < high")
    s_lo, s_hi = (float(v) for v in speed_range_kmh)
    if not 0.0 < s_lo < s_hi:
        raise ValueError(f"speed range {s_lo} {s_hi}: need 0 < low < high [km/h]")
    model = model_for(params)
    direction = parameter_direction(model, params, key)
    if not direction.any():
        raise ParameterError(f"{key} does not enter model {params.model}: nothing to map")
    for v in (lo, hi):
        perturbed(params, key, v)  # raises ParameterError naming the key if an end is invalid
    p0, theta0 = model.pack(params), nominal_value(params, key)

    def p_of(theta):
        return p0 + (theta - theta0) * direction

    speed_box = (kmh_to_ms(s_lo), kmh_to_ms(s_hi))
    tracer = HopfCurveTracer(_eigen_at(model, p_of, direction),
                             lambda st: first_lyapunov_coefficient(model, st.u, st.V, st.p, st.q, st.w, st.lam.imag, st.J),
                             speed_box, (lo, hi), settings)
    seeds = set(np.linspace(lo, hi, settings.n_seeds).tolist())
    if lo <= theta0 <= hi:
        seeds.add(theta0)
    hopf_curves: list[HopfCurve] = []
    fold_curves: list[FoldCurve] = []

    def fold_seeds_at(theta):
        diagram = bifurcation(perturbed(params, key, theta), (s_lo, s_hi), settings.continuation, extend=False)
        seeds = [(pt, b.scales) for b in diagram.branches for label, pt, _ in b.special if PointKind(label) is PointKind.LP]
        return diagram.hopf_points, seeds

    def follow_folds(theta, seeds):
        for pt, scales in seeds:
            if not _near_curve(fold_curves, theta, ms_to_kmh(pt.orbit.speed), hi - lo, s_hi - s_lo):
                fold_curves.append(_fold_curve(model, p_of, direction, pt, scales, theta, (lo, hi), speed_box,
                                               settings, on_step))

    found, notes = [], []
    for theta in sorted(seeds):
        try:
            if folds:
                hopfs, at_theta = fold_seeds_at(theta)
                found.append((theta, at_theta))
            else:
                hopfs = stability(perturbed(params, key, theta), (s_lo, s_hi)).hopf_points
        except RuntimeError as exc:  # e.g. a real eigenvalue crossing, no equilibrium
            notes.append(f"seed at {key} = {theta:.6g} skipped: {exc}")
            continue
        for h in hopfs:
            if _near_curve(hopf_curves, theta, h.speed_kmh, hi - lo, s_hi - s_lo):
                continue
            start = tracer.state(h.speed_ms, theta, complex(0.0, h.omega))
            if start is not None:
                hopf_curves.append(_hopf_curve(tracer, start, on_step))
    for theta, at_theta in found:
        follow_folds(theta, at_theta)
    if folds:  # a fold curve starts at every Bautin point: seed it on the hard side if still missing
        for curve in hopf_curves:
            for gh in curve.bautin_points:
                if _near_curve(fold_curves, gh.value, gh.speed_kmh, hi - lo, s_hi - s_lo, tol=0.02):
                    continue
                theta = _hard_side(curve, gh.value, gh.speed_kmh, hi - lo, s_hi - s_lo)
                try:
                    if theta is not None:
                        follow_folds(theta, fold_seeds_at(theta)[1])
                except RuntimeError as exc:
                    notes.append(f"fold seed at {key} = {theta:.6g} skipped: {exc}")
    grid = np.linspace(lo, hi, settings.n_grid)
    bands = [_bands(params, key, v, (s_lo, s_hi), fold_curves) for v in grid]
    failed = [v for v, b in zip(grid, bands) if "error" in b]
    if failed:
        notes.append(f"band table: no result at {len(failed)} of {len(grid)} values of {key} (shaded grey), "
                     f"first at {failed[0]:.6g}: {next(b['error'] for b in bands if 'error' in b)}")
    return StabilityMap(
        params=params,
        key=key,
        value_range=(lo, hi),
        speed_range_kmh=(s_lo, s_hi),
        operating_range_kmh=tuple(operating_range_kmh) if operating_range_kmh else None,
        hopf_curves=hopf_curves,
        fold_curves=fold_curves,
        grid_values=grid,
        grid_bands=bands,
        settings=settings,
        notes=notes,
    )
