"""Two-parameter continuation: curves of Hopf points and of folds of cycles in (speed, theta).

``theta`` is one scalar parameter; the parameter vector is ``p_of(theta)`` [kernel units].

* **Hopf curves**: pseudo-arclength continuation of ``Re lambda(V, theta) = 0`` for the
  tracked critical eigenvalue ``lambda``, in coordinates scaled by the widths of the
  speed and parameter boxes. The caller evaluates the eigenvalue with its exact
  gradient (``eigen_at``), so the tangent is exact too. Predictor, Newton corrector with
  the arclength condition, tangent orientation and step-length control are those of the
  cycle continuation (:mod:`polywear.solvers.arclength`); a step that turns the tangent by
  more than ``max_turn`` or jumps to another mode is halved. Turning points in ``theta``
  (zero of the tangent's ``theta`` component) and sign changes of a test function
  (the first Lyapunov coefficient: Bautin points) are located by secant iteration on the
  arclength. A curve ends at the box (its point on the edge is added), when the step
  underflows, or when it closes.
* **Fold curves**: natural continuation in ``theta``. The predictor is the caller's
  derivative ``dV_fold/d theta``; the corrector is
  :func:`~polywear.solvers.continuation.fold_at` at the new ``theta``: Newton on the
  fold's minimally augmented system from the recentred last fold, and where that fails
  :func:`~polywear.solvers.continuation.locate_fold` (its march and bracketed secant along
  the new cycle branch, with the fold's curvature along its branch for the first step). A curve ends at the box, when the fold's amplitude has shrunk
  towards a Bautin point, or when the corrector fails (a turning point of the fold curve).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol

import numpy as np

from .arclength import correct, next_step, oriented
from .continuation import BranchPoint, ContinuationSettings, fold_at, fold_curvature, on_adapted_mesh

if TYPE_CHECKING:
    from ..models.base import Model

__all__ = [
    "CurveSettings",
    "FoldCurveSettings",
    "HopfState",
    "HopfCurveTracer",
    "TracedHopfCurve",
    "trace_hopf_curve",
    "FoldRow",
    "follow_fold_curve",
]


class CurveSettings(Protocol):
    """Step control of the Hopf curves (arclengths in scaled units), e.g. a ``MapSettings``."""

    @property
    def ds_initial(self) -> float: ...
    @property
    def ds_max(self) -> float: ...
    @property
    def ds_min(self) -> float: ...
    @property
    def max_steps(self) -> int: ...
    @property
    def newton_tol(self) -> float: ...
    @property
    def max_newton(self) -> int: ...
    @property
    def max_turn(self) -> float:
        """Largest angle [rad] between consecutive tangents."""
        ...


class FoldCurveSettings(Protocol):
    """Step control of the fold curves, e.g. a ``MapSettings``."""

    @property
    def fold_step(self) -> float:
        """Initial and largest parameter step [fraction of the range]."""
        ...
    @property
    def fold_min_step(self) -> float: ...
    @property
    def fold_min_amplitude(self) -> float:
        """A curve stops when its amplitude falls below this fraction of the seed's."""
        ...
    @property
    def continuation(self) -> ContinuationSettings: ...


# -- Hopf curves -------------------------------------------------------------------------------
@dataclass
class HopfState:
    """A point of ``Re lambda(V, theta) = 0`` (or near it): the equilibrium ``u``, the
    eigentriple (``lam``, right ``q``, left ``w`` with ``w^H q = 1``), the Jacobian ``J``,
    the parameter vector ``p`` and ``dlam = (dlambda/dV, dlambda/dtheta)``."""

    V: float  # [m/s]
    theta: float
    lam: complex
    u: np.ndarray
    q: np.ndarray
    w: np.ndarray
    J: np.ndarray
    p: np.ndarray
    dlam: tuple[complex, complex]
    tangent: np.ndarray = field(default_factory=lambda: np.zeros(2))
    """Unit tangent of the curve in scaled (speed, theta) coordinates."""


EigenAt = Callable[[float, float, complex], "HopfState | None"]
"""``eigen_at(V [m/s], theta, lam_guess)``: the state with the critical eigenvalue nearest
``lam_guess`` (tangent not set), or None where there is none (no equilibrium, no complex pair)."""


class HopfCurveTracer:
    """Evaluation, corrector and events of ``Re lambda(V, theta) = 0`` in scaled coordinates
    within ``speed_box`` [m/s] x ``value_box``; ``test(state)`` is the function whose sign
    changes are located (the first Lyapunov coefficient)."""

    def __init__(self, eigen_at: EigenAt, test: Callable[[HopfState], float], speed_box: tuple[float, float],
                 value_box: tuple[float, float], settings: CurveSettings) -> None:
        self.eigen_at, self.test = eigen_at, test
        self.speed_box, self.value_box, self.settings = speed_box, value_box, settings
        self.scale = np.array([speed_box[1] - speed_box[0], value_box[1] - value_box[0]])

    def state(self, V: float, theta: float, lam_guess: complex) -> HopfState | None:
        """The state at (V [m/s], theta) with its unit tangent (orthogonal to the scaled gradient)."""
        st = self.eigen_at(V, theta, lam_guess)
        if st is None:
            return None
        g = np.array([st.dlam[0].real, st.dlam[1].real]) * self.scale
        st.tangent = np.array([-g[1], g[0]]) / np.hypot(*g)
        return st

    def scaled(self, st: HopfState) -> np.ndarray:
        return np.array([st.V, st.theta]) / self.scale

    def _state_at(self, y: np.ndarray, lam: complex) -> HopfState | None:
        return self.state(y[0] * self.scale[0], y[1] * self.scale[1], lam)

    def correct(self, start: HopfState, tangent: np.ndarray, ds: float) -> tuple[HopfState, int] | None:
        """Newton from start + ds * tangent on {Re lambda = 0, tangent . (y - y_start) = ds}."""
        y0 = self.scaled(start)
        sc = self.scale
        lam = start.lam + ds * (start.dlam[0] * tangent[0] * sc[0] + start.dlam[1] * tangent[1] * sc[1])

        def newton_step(y: np.ndarray) -> tuple[np.ndarray, None] | None:
            nonlocal lam
            st = self._state_at(y, lam)
            if st is None:
                return None
            F = np.array([st.lam.real, tangent @ (y - y0) - ds])
            A = np.array([[st.dlam[0].real * sc[0], st.dlam[1].real * sc[1]], tangent])
            try:
                dy = np.linalg.solve(A, -F)
            except np.linalg.LinAlgError:
                return None
            lam = st.lam + st.dlam[0] * dy[0] * sc[0] + st.dlam[1] * dy[1] * sc[1]
            return dy, None

        done = correct(newton_step, y0, tangent, ds, self.settings.max_newton,
                       lambda dy: bool(np.max(np.abs(dy)) < self.settings.newton_tol))
        if done is None:
            return None
        final = self._state_at(done[0], lam)
        if final is None or abs(final.lam.real) > 1e-6 * abs(final.lam):
            return None
        final.tangent = oriented(final.tangent, tangent)
        return final, done[2]

    def on_edge(self, inside: HopfState, outside_y: np.ndarray) -> HopfState | None:
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
            st = self._state_at(y, lam)
            if st is None:
                return None
            free = 1 - axis
            slope = st.dlam[free].real * self.scale[free]
            step = -st.lam.real / slope
            y[free] += step
            lam = st.lam
            if abs(step) < self.settings.newton_tol:
                break
        st = self._state_at(y, lam)
        if st is not None:
            st.tangent = oriented(st.tangent, inside.tangent)
        return st

    def locate(self, a: HopfState, fa: float, b_ds: float, fb: float,
               fn: Callable[[HopfState], float]) -> HopfState | None:
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

    def trace(self, start: HopfState, sign: float,
              on_step: Callable[[], None] | None = None) -> tuple[list[HopfState], list[float], list[HopfState],
                                                                 list[HopfState], str]:
        """Points of the curve from ``start`` in direction ``sign * tangent`` until it ends:
        ``(points, test values, turning points, test-function zeros, end reason)``."""
        s = self.settings
        cur = HopfState(**{**start.__dict__, "tangent": sign * start.tangent})
        points, tests = [cur], [self.test(cur)]
        turning: list[HopfState] = []
        zeros: list[HopfState] = []
        ds = s.ds_initial
        y_start = self.scaled(start)
        lo = np.array([self.speed_box[0], self.value_box[0]]) / self.scale
        hi = np.array([self.speed_box[1], self.value_box[1]]) / self.scale
        reason = "maximum number of steps"
        for _ in range(s.max_steps):
            out = self.correct(cur, cur.tangent, ds)
            new = None if out is None else out[0]
            ok = new is not None and new.tangent @ cur.tangent > np.cos(s.max_turn)
            if new is not None and ok:
                ok = abs(new.lam.imag - cur.lam.imag) < 0.1 * abs(cur.lam.imag)  # same mode
            if out is None or new is None or not ok:
                ds *= 0.5
                if ds < s.ds_min:
                    reason = "step size underflow (no nearby Hopf point: the pair became real?)"
                    break
                continue
            y = self.scaled(new)
            if np.any(y < lo) or np.any(y > hi):
                edge = self.on_edge(cur, y)
                if edge is not None:
                    points.append(edge)
                    tests.append(self.test(edge))
                reason = "left the range"
                break
            test_new = self.test(new)
            if np.sign(new.tangent[1]) != np.sign(cur.tangent[1]):
                tp = self.locate(cur, cur.tangent[1], ds, new.tangent[1], lambda st: float(st.tangent[1]))
                if tp is not None:
                    turning.append(tp)
            if np.sign(test_new) != np.sign(tests[-1]):
                zero = self.locate(cur, tests[-1], ds, test_new, self.test)
                if zero is not None:
                    zeros.append(zero)
            points.append(new)
            tests.append(test_new)
            if on_step is not None:
                on_step()
            if len(points) > 10 and np.linalg.norm(y - y_start) < 0.5 * ds:
                reason = "closed curve"
                break
            cur = new
            ds = next_step(ds, out[1], s.ds_max, grow=1.3)
        return points, tests, turning, zeros, reason


@dataclass
class TracedHopfCurve:
    """A Hopf curve traced both ways from its seed, ordered along the arclength."""

    points: list[HopfState]
    tests: list[float]
    """The test function (first Lyapunov coefficient) at every point."""
    tangents: np.ndarray
    """(n, 2) unit tangents in scaled (speed, theta), oriented along the curve."""
    turning_points: list[HopfState]
    """Where the tangent's theta component vanishes (the curve turns back in theta)."""
    test_zeros: list[HopfState]
    """Where the test function changes sign (Bautin points)."""
    end_reasons: tuple[str, str]


def trace_hopf_curve(tracer: HopfCurveTracer, start: HopfState,
                     on_step: Callable[[], None] | None = None) -> TracedHopfCurve:
    """The whole curve through ``start``: forward, then (unless it closed) backward."""
    fwd = tracer.trace(start, 1.0, on_step)
    closed = fwd[4] == "closed curve"
    back = ([start], fwd[1][:1], [], [], "closed curve") if closed else tracer.trace(start, -1.0, on_step)
    return TracedHopfCurve(
        points=back[0][::-1] + fwd[0][1:],
        tests=back[1][::-1] + fwd[1][1:],
        tangents=np.array([-p.tangent for p in back[0][::-1]] + [p.tangent for p in fwd[0][1:]]),
        turning_points=back[2] + fwd[2],
        test_zeros=back[3] + fwd[3],
        end_reasons=(back[4], fwd[4]),
    )


# -- fold curves ---------------------------------------------------------------------------------
FoldRow = tuple[float, float, float, float, float]
"""A point of a fold curve: (theta, V [m/s], dV/dtheta [m/s per unit], amplitude of x [m], frequency [Hz])."""


def follow_fold_curve(
    model: Model,
    p_of: Callable[[float], np.ndarray],
    seed: BranchPoint,
    scales: np.ndarray,
    theta0: float,
    value_box: tuple[float, float],
    speed_bounds: tuple[float, float],
    settings: FoldCurveSettings,
    speed_derivative: Callable[[np.ndarray, BranchPoint], float],
    on_step: Callable[[], None] | None = None,
) -> tuple[list[FoldRow], tuple[str, str]]:
    """The fold curve through ``seed`` (a fold at ``theta0``), both ways within ``value_box``.

    ``speed_derivative(p, fold)`` is dV_fold/dtheta [m/s per unit] (the predictor);
    ``scales`` are the state scales of the seed's branch; the curve stops where the
    fold speed leaves ``speed_bounds`` [m/s]. Returns the rows ordered in theta along
    the curve and the reasons it ended at either end.
    """
    ix = model.index("x")
    width = value_box[1] - value_box[0]
    amp0 = float(seed.orbit.amplitude()[ix])
    sides = []
    for sign in (-1.0, 1.0):
        fold, theta = seed, theta0
        h = settings.fold_step * width
        rows: list[FoldRow] = []
        reason = "maximum number of steps"
        for step in range(settings.continuation.max_steps):
            p = p_of(theta)
            dVdth = speed_derivative(p, fold)
            rows.append((theta, fold.orbit.speed, dVdth, float(fold.orbit.amplitude()[ix]), 1.0 / fold.orbit.period))
            if on_step is not None:
                on_step()
            if rows[-1][3] < settings.fold_min_amplitude * amp0:
                reason = "amplitude vanishing (towards a Bautin point)"
                break
            if not (speed_bounds[0] <= fold.orbit.speed <= speed_bounds[1]):
                reason = "left the speed range"
                break
            if (sign < 0 and theta <= value_box[0]) or (sign > 0 and theta >= value_box[1]):
                reason = "left the range"
                break
            if step % 3 == 2:
                fold = on_adapted_mesh(model, p, fold)
            # evaluated only if the direct fold solver fails and the march needs it
            curvature = functools.cache(lambda: fold_curvature(model, p, fold, scales, settings.continuation))
            while True:
                nxt = float(np.clip(theta + sign * h, *value_box))
                V_pred = fold.orbit.speed + (nxt - theta) * dVdth
                new = fold_at(model, fold, p, p_of(nxt), V_pred, scales, settings.continuation, curvature)
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
    return back[::-1] + fwd[1:], (r_back, r_fwd)
