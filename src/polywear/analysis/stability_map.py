"""Stability maps: Hopf and fold-of-cycles curves in the (speed, parameter) plane.

For one parameter key ``theta`` (any float key or ``adhesion_scale``) over a range:

* **Hopf curves** by pseudo-arclength continuation of ``Re lambda(V, theta) = 0`` for
  the tracked critical eigenvalue ``lambda``, in coordinates scaled by the widths of the
  speed and parameter ranges. The gradient ``(d Re lambda/dV, d Re lambda/d theta)``
  is exact (:func:`~polywear.analysis.stability.critical_eigenvalue_derivative`), so the
  tangent is too, and turning points in ``theta`` - where the two Hopf speeds of a
  band merge and the linear band closes - are passed and located (zero of the
  tangent's ``theta`` component). Along every curve the first Lyapunov coefficient
  ``l1`` is evaluated; where it changes sign the curve has a Bautin (generalized Hopf)
  point, located by secant iteration on the arclength: soft on one side, hard on the
  other, and the fold-of-cycles curve starts there.
* **Fold curves** by natural continuation in ``theta``: the predictor is the exact
  derivative ``dV_fold/d theta`` (:func:`~polywear.analysis.sensitivity.fold_speed_derivative`,
  left null vector of the collocation system), the corrector re-locates the fold at
  the new ``theta``: one Newton solve onto the new cycle branch from the predicted
  orbit, then a secant iteration along the branch on the speed component of its
  tangent (the fold condition). A fold curve ends at the range, where the corrector
  fails (a turning point of the fold curve, e.g. a cusp), or where the fold's
  amplitude has shrunk towards a Bautin point.

Seeds: Hopf points of :func:`~polywear.analysis.stability.stability_analysis` and folds
of :func:`~polywear.analysis.bifurcation.bifurcation_diagram` at a few parameter values;
a seed already on a computed curve is skipped, so isolated curves are found too.

Bands per parameter value (for shading and the safe-parameter summary): the linear
band from :func:`~polywear.analysis.stability.fast_linear_band`; the hard band
between every fold speed and the nearest bound of the linear band (the subcritical
Hopf point the unstable cycle is born at - the topology of all the cases we met; the
one-parameter diagrams in the tests check it); the SEV band is their union.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..models import get_model
from ..results import Result
from ..models.base import kmh_to_ms, ms_to_kmh
from ..params import Params, ParameterError
from ..progress import Progress, StepCounter
from ..settings import check_count, check_fraction, check_order, check_positive
from ..solvers.continuation import BranchPoint, ContinuationSettings, fold_near
from ..units import DEFAULT_SPEED_RANGE_KMH
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
    l1: np.ndarray
    tangent: np.ndarray  # (n, 2) unit tangent in scaled (speed, value) coordinates
    turning_points: list[SpecialPoint]
    """Where the curve turns back in the parameter and the linear band closes (kind HT)."""
    bautin_points: list[SpecialPoint]
    """Where ``l1`` changes sign (kind GH)."""
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
@dataclass
class _HopfState:
    V: float  # [m/s]
    theta: float
    lam: complex
    u: np.ndarray
    q: np.ndarray
    w: np.ndarray
    J: np.ndarray
    p: np.ndarray
    dlam: tuple[complex, complex]  # (dlambda/dV, dlambda/dtheta)
    tangent: np.ndarray = field(default_factory=lambda: np.zeros(2))


class _HopfTracer:
    """Evaluation, corrector and events of Re lambda(V, theta) = 0 in scaled coordinates."""

    def __init__(self, model, p_of, direction, speed_box, value_box, settings: MapSettings):
        self.model, self.p_of, self.direction = model, p_of, direction
        self.speed_box, self.value_box, self.settings = speed_box, value_box, settings
        self.scale = np.array([speed_box[1] - speed_box[0], value_box[1] - value_box[0]])

    def state(self, V, theta, lam_guess) -> _HopfState | None:
        """Equilibrium and the critical eigentriple nearest ``lam_guess`` (Im > 0) at (V, theta)."""
        from scipy.linalg import eig

        p = self.p_of(theta)
        try:
            u = self.model.equilibrium(V, p)
        except (RuntimeError, ValueError, FloatingPointError):
            return None
        J = self.model.jacobian(u, V, p)
        vals, vl, vr = eig(J, left=True, right=True)
        oscillatory = np.flatnonzero(vals.imag > 1e-9 * max(np.abs(vals).max(), 1.0))
        if oscillatory.size == 0:
            return None
        i = oscillatory[np.argmin(np.abs(vals[oscillatory] - lam_guess))]
        q = vr[:, i] / np.linalg.norm(vr[:, i])
        w = vl[:, i]
        w = w / np.conj(np.vdot(w, q))  # w^H q = 1
        dV = critical_eigenvalue_derivative(self.model, u, V, p, q, w, dV=1.0)
        dth = critical_eigenvalue_derivative(self.model, u, V, p, q, w, dp=self.direction)
        st = _HopfState(V, theta, vals[i], u, q, w, J, p, (dV, dth))
        g = np.array([dV.real, dth.real]) * self.scale
        st.tangent = np.array([-g[1], g[0]]) / np.hypot(*g)
        return st

    def scaled(self, st: _HopfState) -> np.ndarray:
        return np.array([st.V, st.theta]) / self.scale

    def correct(self, start: _HopfState, tangent: np.ndarray, ds: float) -> tuple[_HopfState, int] | None:
        """Newton from start + ds * tangent on {Re lambda = 0, tangent . (y - y_start) = ds}."""
        y0 = self.scaled(start)
        y = y0 + ds * tangent
        lam = start.lam + ds * (start.dlam[0] * tangent[0] * self.scale[0] + start.dlam[1] * tangent[1] * self.scale[1])
        for it in range(1, self.settings.max_newton + 1):
            st = self.state(y[0] * self.scale[0], y[1] * self.scale[1], lam)
            if st is None:
                return None
            F = np.array([st.lam.real, tangent @ (y - y0) - ds])
            A = np.array([[st.dlam[0].real * self.scale[0], st.dlam[1].real * self.scale[1]], tangent])
            try:
                dy = np.linalg.solve(A, -F)
            except np.linalg.LinAlgError:
                return None
            y = y + dy
            lam = st.lam + st.dlam[0] * dy[0] * self.scale[0] + st.dlam[1] * dy[1] * self.scale[1]
            if np.max(np.abs(dy)) < self.settings.newton_tol:
                final = self.state(y[0] * self.scale[0], y[1] * self.scale[1], lam)
                if final is None or abs(final.lam.real) > 1e-6 * abs(final.lam):
                    return None
                if final.tangent @ tangent < 0:
                    final.tangent = -final.tangent
                return final, it
        return None

    def on_edge(self, inside: _HopfState, outside_y: np.ndarray) -> _HopfState | None:
        """The curve's point on the box edge crossed between ``inside`` and ``outside_y`` (scaled)."""
        y0 = self.scaled(inside)
        lo = np.array([self.speed_box[0], self.value_box[0]]) / self.scale
        hi = np.array([self.speed_box[1], self.value_box[1]]) / self.scale
        best, axis, bound = 2.0, 0, 0.0
        for k in range(2):
            for edge in (lo[k], hi[k]):
                d = outside_y[k] - y0[k]
                if d != 0.0 and 0.0 <= (edge - y0[k]) / d < best:
                    best, axis, bound = (edge - y0[k]) / d, k, edge
        # Newton on the free coordinate with the crossed one fixed at the edge
        y = y0 + best * (outside_y - y0)
        y[axis] = bound
        lam = inside.lam
        for _ in range(self.settings.max_newton):
            st = self.state(y[0] * self.scale[0], y[1] * self.scale[1], lam)
            if st is None:
                return None
            free = 1 - axis
            slope = st.dlam[free].real * self.scale[free]
            step = -st.lam.real / slope
            y[free] += step
            lam = st.lam
            if abs(step) < self.settings.newton_tol:
                break
        st = self.state(y[0] * self.scale[0], y[1] * self.scale[1], lam)
        if st is not None and st.tangent @ inside.tangent < 0:
            st.tangent = -st.tangent
        return st

    def l1(self, st: _HopfState) -> float:
        return first_lyapunov_coefficient(self.model, st.u, st.V, st.p, st.q, st.w, st.lam.imag, st.J)

    def locate(self, a: _HopfState, fa: float, b_ds: float, fb: float, fn) -> _HopfState | None:
        """Secant on the arclength from ``a`` for a zero of ``fn(state)`` between 0 and ``b_ds``."""
        s0, f0, s1, f1 = 0.0, fa, b_ds, fb
        best = None
        for _ in range(40):
            s = s1 - f1 * (s1 - s0) / (f1 - f0) if f1 != f0 else 0.5 * (s0 + s1)
            out = self.correct(a, a.tangent, s)
            if out is None:
                return best
            best = out[0]
            f = fn(best)
            if abs(s - s1) < 1e-13 or f == 0.0:
                break
            s0, f0, s1, f1 = s1, f1, s, f
        return best

    def trace(self, start: _HopfState, sign: float, on_step=None):
        """Points of the curve from ``start`` in direction ``sign * tangent`` until it ends."""
        s = self.settings
        cur = _HopfState(**{**start.__dict__, "tangent": sign * start.tangent})
        points, l1s, turning, bautin = [cur], [self.l1(cur)], [], []
        ds = s.ds_initial
        y_start = self.scaled(start)
        reason = "maximum number of steps"
        for _ in range(s.max_steps):
            out = self.correct(cur, cur.tangent, ds)
            ok = out is not None and out[0].tangent @ cur.tangent > np.cos(s.max_turn)
            if ok:
                new = out[0]
                ok = abs(new.lam.imag - cur.lam.imag) < 0.1 * abs(cur.lam.imag)  # same mode
            if not ok:
                ds *= 0.5
                if ds < s.ds_min:
                    reason = "step size underflow (no nearby Hopf point: the pair became real?)"
                    break
                continue
            y = self.scaled(new)
            lo = np.array([self.speed_box[0], self.value_box[0]]) / self.scale
            hi = np.array([self.speed_box[1], self.value_box[1]]) / self.scale
            if np.any(y < lo) or np.any(y > hi):
                edge = self.on_edge(cur, y)
                if edge is not None:
                    points.append(edge)
                    l1s.append(self.l1(edge))
                reason = "left the range"
                break
            l1_new = self.l1(new)
            if np.sign(new.tangent[1]) != np.sign(cur.tangent[1]):
                tp = self.locate(cur, cur.tangent[1], ds, new.tangent[1], lambda st: st.tangent[1])
                if tp is not None:
                    turning.append((tp.theta, ms_to_kmh(tp.V)))
            if np.sign(l1_new) != np.sign(l1s[-1]):
                l1_cur = l1s[-1]
                gh = self.locate(cur, l1_cur, ds, l1_new, self.l1)
                if gh is not None:
                    bautin.append((gh.theta, ms_to_kmh(gh.V)))
            points.append(new)
            l1s.append(l1_new)
            if on_step is not None:
                on_step()
            if len(points) > 10 and np.linalg.norm(y - y_start) < 0.5 * ds:
                reason = "closed curve"
                break
            cur = new
            ds = min(s.ds_max, ds * (1.3 if out[1] <= 3 else 1.0))
        return points, l1s, turning, bautin, reason


def _hopf_curve(tracer: _HopfTracer, start: _HopfState, on_step) -> HopfCurve:
    fwd = tracer.trace(start, 1.0, on_step)
    closed = fwd[4] == "closed curve"
    back = ([start], fwd[1][:1], [], [], "closed curve") if closed else tracer.trace(start, -1.0, on_step)
    points = back[0][::-1] + fwd[0][1:]
    l1s = back[1][::-1] + fwd[1][1:]
    tangents = [-p.tangent for p in back[0][::-1]] + [p.tangent for p in fwd[0][1:]]
    return HopfCurve(
        speed_kmh=np.array([ms_to_kmh(p.V) for p in points]),
        value=np.array([p.theta for p in points]),
        frequency_hz=np.array([p.lam.imag / (2 * np.pi) for p in points]),
        l1=np.array(l1s),
        tangent=np.array(tangents),
        turning_points=[SpecialPoint(PointKind.HOPF_TURN, s, value=v) for v, s in back[2] + fwd[2]],
        bautin_points=[SpecialPoint(PointKind.GH, s, value=v) for v, s in back[3] + fwd[3]],
        end_reasons=(back[4], fwd[4]),
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
def _relocate_fold(model, p, guess: BranchPoint, V_pred, scales, settings: MapSettings):
    """The fold of cycles at parameter vector ``p`` near ``guess`` (an orbit and tangent at a nearby p)."""
    return fold_near(model, p, guess, V_pred, scales, settings.continuation)


def _adapt(model, p, fold: BranchPoint, settings: MapSettings) -> BranchPoint:
    """The fold's orbit and tangent moved onto a mesh adapted to the orbit."""
    from ..solvers.collocation import Collocation

    c = Collocation(model, p, fold.orbit.mesh, fold.orbit.m)
    mesh = c.adapted_mesh(fold.orbit)
    new = Collocation(model, p, mesh, fold.orbit.m)
    tangent = new.pack(c.unpack(fold.tangent).with_mesh(mesh))
    return BranchPoint(fold.orbit.with_mesh(mesh), fold.multipliers, tangent, fold.newton_iterations, "LP")


def _fold_curve(model, p_of, direction, seed: BranchPoint, scales, theta0, value_box, speed_box,
                settings: MapSettings, on_step) -> FoldCurve:
    ix = model.index("x")
    width = value_box[1] - value_box[0]
    amp0 = float(seed.orbit.amplitude()[ix])
    sides = []
    for sign in (-1.0, 1.0):
        fold, theta = seed, theta0
        h = settings.fold_step * width
        rows, reason = [], "maximum number of steps"
        for step in range(settings.continuation.max_steps):
            p = p_of(theta)
            dVdth = fold_speed_derivative(model, p, fold, direction)
            rows.append((theta, fold.orbit.speed, dVdth, float(fold.orbit.amplitude()[ix]), 1.0 / fold.orbit.period))
            if on_step is not None:
                on_step()
            if rows[-1][3] < settings.fold_min_amplitude * amp0:
                reason = "amplitude vanishing (towards a Bautin point)"
                break
            if not (speed_box[0] <= fold.orbit.speed <= FOLD_SPEED_MARGIN * speed_box[1]):
                reason = "left the speed range"
                break
            if (sign < 0 and theta <= value_box[0]) or (sign > 0 and theta >= value_box[1]):
                reason = "left the range"
                break
            if step % 3 == 2:
                fold = _adapt(model, p, fold, settings)
            while True:
                nxt = float(np.clip(theta + sign * h, *value_box))
                V_pred = fold.orbit.speed + (nxt - theta) * dVdth
                new = _relocate_fold(model, p_of(nxt), fold, V_pred, scales, settings)
                bad = new is None or abs(new.orbit.speed - V_pred) > 0.2 * abs(V_pred - fold.orbit.speed) + 1e-6 * V_pred
                if not bad:
                    break
                h *= 0.5
                if h < settings.fold_min_step * width:
                    new = None
                    break
            if new is None:
                reason = "corrector failed (turning point of the fold curve?)"
                break
            if abs(new.orbit.speed - V_pred) < 0.02 * abs(V_pred - fold.orbit.speed):
                h = min(h * 1.5, settings.fold_step * width)
            fold, theta = new, nxt
        sides.append((rows, reason))
    (back, r_back), (fwd, r_fwd) = sides
    rows = back[::-1] + fwd[1:]
    arr = np.array(rows)
    return FoldCurve(
        value=arr[:, 0],
        speed_kmh=ms_to_kmh(arr[:, 1]),
        derivative=ms_to_kmh(arr[:, 2]),
        amplitude_x=arr[:, 3],
        frequency_hz=arr[:, 4],
        end_reasons=(r_back, r_fwd),
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

        h_idx, h = stack(self.hopf_curves, ("value", "speed_kmh", "frequency_hz", "l1"))
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
            soft = np.where(c.l1 < 0, c.value, np.nan)
            hard = np.where(c.l1 >= 0, c.value, np.nan)
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
    candidates = np.flatnonzero((curve.l1 > 0) & (d >= distance))
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
    from .bifurcation import bifurcation_diagram
    from .stability import stability_analysis

    on_step = StepCounter(progress)  # called by the curve continuation after every step
    lo, hi = (float(v) for v in value_range)
    if not lo < hi:
        raise ValueError(f"range {lo} {hi}: need low < high")
    s_lo, s_hi = (float(v) for v in speed_range_kmh)
    if not 0.0 < s_lo < s_hi:
        raise ValueError(f"speed range {s_lo} {s_hi}: need 0 < low < high [km/h]")
    model = get_model(params.model)
    direction = parameter_direction(model, params, key)
    if not direction.any():
        raise ParameterError(f"{key} does not enter model {params.model}: nothing to map")
    for v in (lo, hi):
        perturbed(params, key, v)  # raises ParameterError naming the key if an end is invalid
    p0, theta0 = model.pack(params), nominal_value(params, key)

    def p_of(theta):
        return p0 + (theta - theta0) * direction

    speed_box = (kmh_to_ms(s_lo), kmh_to_ms(s_hi))
    tracer = _HopfTracer(model, p_of, direction, speed_box, (lo, hi), settings)
    seeds = set(np.linspace(lo, hi, settings.n_seeds).tolist())
    if lo <= theta0 <= hi:
        seeds.add(theta0)
    hopf_curves: list[HopfCurve] = []
    fold_curves: list[FoldCurve] = []

    def fold_seeds_at(theta):
        diagram = bifurcation_diagram(perturbed(params, key, theta), (s_lo, s_hi), settings.continuation, extend=False)
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
                hopfs = stability_analysis(perturbed(params, key, theta), (s_lo, s_hi)).hopf_points
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
