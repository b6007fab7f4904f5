"""Time integration of a model: a compiled Rodas4 and the scipy references, one interface.

``integrate(model, u0, V, p, t_end, method=...)``

``"rodas"`` (default, the fast path)
    Rodas4, the stiffly accurate 6-stage Rosenbrock method of order 4 with an embedded
    order-3 solution and an order-3 dense output (Hairer & Wanner, *Solving Ordinary
    Differential Equations II*, section IV.7; the coefficients of their ``rodas.f``,
    METH = 1). The whole step loop runs compiled in numba with the model's analytic
    Jacobian; the kernels come in as first-class functions (``model.compiled``), so one
    cached compilation of the loop serves every model.
``"radau"``, ``"lsoda"``, ``"bdf"``, ``"dop853"``
    ``scipy.integrate.solve_ivp`` with the njit right-hand side (and Jacobian for the
    implicit methods): the reference the fast path is checked against.

The models are autonomous (speed ``V`` is a parameter), so time starts at 0.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numba import njit
from numpy.typing import ArrayLike

from ..errors import NumericalError

if TYPE_CHECKING:
    from ..models.base import Model

__all__ = [
    "METHODS",
    "IntegrationError",
    "StepStats",
    "DenseOutput",
    "Trajectory",
    "integrate",
    "output_grid",
    "RODAS4_GAMMA",
    "RODAS4_A",
    "RODAS4_C",
    "RODAS4_H",
]

METHODS = ("rodas", "radau", "bdf", "lsoda", "dop853")
_SCIPY_NAMES = {"radau": "Radau", "bdf": "BDF", "lsoda": "LSODA", "dop853": "DOP853"}


class IntegrationError(NumericalError):
    """The integration failed (step size underflow, too many steps, non-finite state)."""


# -- Rodas4 tableau in Hairer's transformed form -----------------------------------------
# Stage i solves (I/(h gamma) - J) k_i = f(y + sum_j A[i, j] k_j) + sum_j C[i, j]/h k_j.
# The method is stiffly accurate: stage 6 is evaluated at the embedded (order 3) solution
# y + sum_j A[5, j] k_j, so y_new = that + k_6 and the error estimate is k_6 itself.
# Dense output: y(theta) = (1 - theta) y0 + theta (y1 + (1 - theta)(K1 + theta K2)) with
# K1 = sum_j H[0, j] k_j, K2 = sum_j H[1, j] k_j. Sources that agree digit for digit:
# rodas.f (Hairer), OrdinaryDiffEq.jl's Rodas4Tableau, Numerical Recipes 3rd ed. StepperRoss.
# The d_i (time-derivative) coefficients are not needed: the models are autonomous.
RODAS4_GAMMA = 0.25
RODAS4_A = np.array(
    [
        [0.0, 0.0, 0.0, 0.0, 0.0],
        [1.544, 0.0, 0.0, 0.0, 0.0],
        [0.9466785280815826, 0.2557011698983284, 0.0, 0.0, 0.0],
        [3.314825187068521, 2.896124015972201, 0.9986419139977817, 0.0, 0.0],
        [1.221224509226641, 6.019134481288629, 12.53708332932087, -0.6878860361058950, 0.0],
        [1.221224509226641, 6.019134481288629, 12.53708332932087, -0.6878860361058950, 1.0],
    ]
)
RODAS4_C = np.array(
    [
        [0.0, 0.0, 0.0, 0.0, 0.0],
        [-5.6688, 0.0, 0.0, 0.0, 0.0],
        [-2.430093356833875, -0.2063599157091915, 0.0, 0.0, 0.0],
        [-0.1073529058151375, -9.594562251023355, -20.47028614809616, 0.0, 0.0],
        [7.496443313967647, -10.24680431464352, -33.99990352819905, 11.70890893206160, 0.0],
        [8.083246795921522, -7.981132988064893, -31.52159432874371, 16.31930543123136,
         -6.058818238834054],
    ]
)
RODAS4_H = np.array(
    [
        [10.12623508344586, -7.487995877610167, -34.80091861555747, -7.992771707568823,
         1.025137723295662],
        [-0.6762803392801253, 6.087714651680015, 16.43084320892478, 24.76722511418386,
         -6.594389125716872],
    ]
)

# step-size controller (Hairer's rodas.f defaults, with Gustafsson's predictive rule)
_SAFETY = 0.9
_FAC_MIN = 0.2  # h_new >= h / 5
_FAC_MAX = 6.0  # h_new <= 6 h

_OK, _UNDERFLOW, _MAX_STEPS, _NONFINITE = 0, 1, 2, 3
_UNDERFLOW_FLOOR = 1e-6
"""A step underflows where it is below 16 machine epsilons of max(|t|, this fraction of
t_end) [-]. Relative to t_end itself, a first step of 1.4e-13 s (tread1dof at 80 km/h
from steady rolling, damping 60 N s/m) was refused over 43.9 s and taken over 35 s."""


@dataclass(frozen=True)
class StepStats:
    """Work done by an integration; ``None`` where the method does not report it."""

    accepted: int | None
    rejected: int | None
    rhs_evals: int
    jac_evals: int
    lu_decompositions: int


@dataclass(frozen=True)
class DenseOutput:
    """Rodas4 dense output: one cubic (in theta) per accepted step over ``[t_min, t_max]``."""

    t_start: np.ndarray
    """Step start times (m,) [s]."""
    h: np.ndarray
    """Step sizes (m,) [s]."""
    coefficients: np.ndarray
    """(m, 4, n): y0, y1, K1, K2 per step."""

    @property
    def t_min(self) -> float:
        return float(self.t_start[0])

    @property
    def t_max(self) -> float:
        return float(self.t_start[-1] + self.h[-1])

    def __call__(self, t: ArrayLike) -> np.ndarray:
        """State at time(s) ``t`` [s]: shape (n,) for a scalar, (len(t), n) for an array."""
        t_arr = np.atleast_1d(np.asarray(t, dtype=float))
        out = np.empty((t_arr.size, self.coefficients.shape[2]))
        if not _dense_eval(self.t_start, self.h, self.coefficients, t_arr, out):
            raise ValueError(f"t outside the dense-output window [{self.t_min}, {self.t_max}] s")
        return out[0] if np.ndim(t) == 0 else out


@njit(cache=True, nogil=True)
def _dense_eval(t_start: np.ndarray, h: np.ndarray, coef: np.ndarray, times: np.ndarray, out: np.ndarray) -> bool:
    """Fill ``out[i]`` with the dense output at ``times[i]``; False if a time is outside."""
    m = h.size
    slack = 1e-12 * max(1.0, abs(t_start[m - 1] + h[m - 1]))
    for i in range(times.size):
        tau = times[i]
        if tau < t_start[0] - slack or tau > t_start[m - 1] + h[m - 1] + slack:
            return False
        j = min(max(np.searchsorted(t_start, tau, side="right") - 1, 0), m - 1)
        theta = (tau - t_start[j]) / h[j]
        for q in range(coef.shape[2]):
            out[i, q] = (1.0 - theta) * coef[j, 0, q] + theta * (
                coef[j, 1, q] + (1.0 - theta) * (coef[j, 2, q] + theta * coef[j, 3, q])
            )
    return True


@dataclass(frozen=True)
class _ScipyDense:
    """``solve_ivp``'s OdeSolution behind the :class:`DenseOutput` call signature."""

    solution: Any
    t_min: float
    t_max: float

    def __call__(self, t: ArrayLike) -> np.ndarray:
        return np.asarray(self.solution(t)).T


@dataclass(frozen=True)
class Trajectory:
    """Result of :func:`integrate`."""

    t: np.ndarray
    """Output times (k,) [s]: the uniform grid, or the accepted steps if no ``dt_out``."""
    u: np.ndarray
    """States (k, n) at ``t``."""
    stats: StepStats
    method: str
    rtol: float
    atol: np.ndarray
    dense: DenseOutput | _ScipyDense | None
    """Continuous solution over ``[dense_from, t_end]`` if it was asked for."""
    h_last: float | None
    """Last step size taken (Rodas only): a good first step for a continuation run."""

    @property
    def u_end(self) -> np.ndarray:
        """Final state (n,)."""
        return self.u[-1]


# -- compiled Rodas4 ---------------------------------------------------------------------
@njit(cache=True)
def _lu_factor(a: np.ndarray, piv: np.ndarray) -> bool:
    """In-place LU with partial pivoting of a small dense matrix; False if singular.

    Written out because numba offers ``np.linalg.solve`` but no factor/solve pair, and
    each Rodas step solves six systems with one matrix.
    """
    n = a.shape[0]
    for k in range(n):
        pivot = k
        big = abs(a[k, k])
        for i in range(k + 1, n):
            if abs(a[i, k]) > big:
                big = abs(a[i, k])
                pivot = i
        if big == 0.0 or not np.isfinite(big):
            return False
        piv[k] = pivot
        if pivot != k:
            for j in range(n):
                tmp = a[k, j]
                a[k, j] = a[pivot, j]
                a[pivot, j] = tmp
        inv = 1.0 / a[k, k]
        for i in range(k + 1, n):
            a[i, k] *= inv
            lik = a[i, k]
            if lik != 0.0:
                for j in range(k + 1, n):
                    a[i, j] -= lik * a[k, j]
    return True


@njit(cache=True)
def _lu_solve(lu: np.ndarray, piv: np.ndarray, b: np.ndarray) -> None:
    """Solve in place: ``b`` <- A^-1 b for A factored by :func:`_lu_factor`."""
    n = lu.shape[0]
    for k in range(n):
        p = piv[k]
        if p != k:
            tmp = b[k]
            b[k] = b[p]
            b[p] = tmp
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= lu[i, j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= lu[i, j] * b[j]
        b[i] = s / lu[i, i]


@njit(cache=True)
def _grow_rows(a: np.ndarray, used: int) -> np.ndarray:
    """``a`` with twice the rows, the first ``used`` copied."""
    out = np.empty((2 * a.shape[0], a.shape[1]))
    out[:used] = a[:used]
    return out


@njit(cache=True, nogil=True)
def _rodas4(rhs: Callable[..., None], jac: Callable[..., None], u0: np.ndarray, V: float, p: np.ndarray,
            t_end: float, rtol: float, atol: np.ndarray, h0: float, t_out: np.ndarray, record_steps: bool,
            dense_from: float, max_steps: int) -> tuple[int, float, np.ndarray, float, np.ndarray, np.ndarray,
                                                         np.ndarray, np.ndarray]:
    """The Rodas4 step loop. Returns status, final t, y, h, stats and the recorded output.
    Releases the GIL (the wear evolution runs the windows of its speeds in threads)."""
    n = u0.size
    y = u0.copy()
    y_new = np.empty(n)
    arg = np.empty(n)
    f = np.empty(n)
    f0 = np.empty(n)
    k = np.empty((6, n))
    kd = np.empty((2, n))  # dense-output K1, K2 of the last step
    jmat = np.empty((n, n))
    w = np.empty((n, n))
    piv = np.zeros(n, dtype=np.int64)
    stats = np.zeros(5, dtype=np.int64)  # accepted, rejected, rhs, jac, lu
    u_out = np.full((t_out.size, n), np.nan)
    steps = np.empty((1024 if record_steps else 1, 1 + n))
    n_steps = 0
    dense = np.empty((1024 if dense_from <= t_end else 1, 2 + 4 * n))
    n_dense = 0
    i_out = 0
    t = 0.0
    while i_out < t_out.size and t_out[i_out] <= 0.0:
        u_out[i_out] = y
        i_out += 1
    if record_steps:
        steps[0, 0] = 0.0
        steps[0, 1:] = y
        n_steps = 1

    rhs(y, V, p, f0)
    stats[2] += 1
    if not np.all(np.isfinite(f0)):
        return _NONFINITE, t, y, 0.0, stats, u_out, steps[:n_steps], dense[:n_dense]
    h = h0
    if h <= 0.0:  # Hairer & Wanner I, II.4: h = 0.01 ||y|| / ||f|| in the error norm
        d0 = 0.0
        d1 = 0.0
        for i in range(n):
            sc = atol[i] + rtol * abs(y[i])
            d0 += (y[i] / sc) ** 2
            d1 += (f0[i] / sc) ** 2
        d0 = math.sqrt(d0 / n)
        d1 = math.sqrt(d1 / n)
        h = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
        h = min(h, 1e-3 * t_end)
    h_min_rel = 16.0 * np.finfo(np.float64).eps
    first = True
    rejected_last = False
    need_jac = True
    h_old = h
    err_old = 1.0
    status = _OK
    last_nonfinite = False
    while t < t_end:
        if stats[0] >= max_steps:
            status = _MAX_STEPS
            break
        if h <= h_min_rel * max(abs(t), _UNDERFLOW_FLOOR * t_end):  # relative to t: a first step may be tiny
            status = _NONFINITE if last_nonfinite else _UNDERFLOW
            break
        if t + 1.01 * h > t_end:
            h = t_end - t
        if need_jac:
            jac(y, V, p, jmat)
            stats[3] += 1
            need_jac = False
        inv_hg = 1.0 / (h * RODAS4_GAMMA)
        for i in range(n):
            for j in range(n):
                w[i, j] = -jmat[i, j]
            w[i, i] += inv_hg
        stats[4] += 1
        if not _lu_factor(w, piv):
            h *= 0.25
            rejected_last = True
            last_nonfinite = True
            stats[1] += 1
            continue
        for s in range(6):
            if s == 0:
                f[:] = f0
            else:
                for i in range(n):
                    acc = y[i]
                    for j in range(s):
                        acc += RODAS4_A[s, j] * k[j, i]
                    arg[i] = acc
                rhs(arg, V, p, f)
                stats[2] += 1
            for i in range(n):
                acc = f[i]
                for j in range(s):
                    acc += RODAS4_C[s, j] / h * k[j, i]
                k[s, i] = acc
            _lu_solve(w, piv, k[s])
        err = 0.0
        for i in range(n):
            y_new[i] = arg[i] + k[5, i]
            sc = atol[i] + rtol * max(abs(y[i]), abs(y_new[i]))
            err += (k[5, i] / sc) ** 2
        err = math.sqrt(err / n)
        if not np.isfinite(err):
            h *= 0.25
            rejected_last = True
            last_nonfinite = True
            stats[1] += 1
            continue
        last_nonfinite = False
        fac = min(_FAC_MAX, max(_FAC_MIN, _SAFETY * max(err, 1e-10) ** -0.25))
        if err <= 1.0:
            if not first:
                pred = (h / h_old) * (err_old / max(err * err, 1e-20)) ** 0.25 * _SAFETY
                fac = min(fac, min(_FAC_MAX, max(_FAC_MIN, pred)))
            first = False
            h_old = h
            err_old = max(0.01, err)
            stats[0] += 1
            t_new = t + h
            if t_end - t_new < h_min_rel * t_end:
                t_new = t_end
            # dense-output polynomials of this step: y(theta) = ... (see module notes)
            if (i_out < t_out.size and t_out[i_out] <= t_new) or t_new > dense_from:
                for i in range(n):
                    acc1 = 0.0
                    acc2 = 0.0
                    for j in range(5):
                        acc1 += RODAS4_H[0, j] * k[j, i]
                        acc2 += RODAS4_H[1, j] * k[j, i]
                    kd[0, i] = acc1
                    kd[1, i] = acc2
                while i_out < t_out.size and t_out[i_out] <= t_new:
                    theta = (t_out[i_out] - t) / h
                    for i in range(n):
                        u_out[i_out, i] = (1.0 - theta) * y[i] + theta * (
                            y_new[i] + (1.0 - theta) * (kd[0, i] + theta * kd[1, i])
                        )
                    i_out += 1
                if t_new > dense_from:
                    if n_dense == dense.shape[0]:
                        dense = _grow_rows(dense, n_dense)
                    dense[n_dense, 0] = t
                    dense[n_dense, 1] = h
                    dense[n_dense, 2 : 2 + n] = y
                    dense[n_dense, 2 + n : 2 + 2 * n] = y_new
                    dense[n_dense, 2 + 2 * n : 2 + 3 * n] = kd[0]
                    dense[n_dense, 2 + 3 * n : 2 + 4 * n] = kd[1]
                    n_dense += 1
            t = t_new
            y[:] = y_new
            rhs(y, V, p, f0)
            stats[2] += 1
            if record_steps:
                if n_steps == steps.shape[0]:
                    steps = _grow_rows(steps, n_steps)
                steps[n_steps, 0] = t
                steps[n_steps, 1:] = y
                n_steps += 1
            if rejected_last:
                fac = min(fac, 1.0)
            rejected_last = False
            need_jac = True
            h *= fac
        else:
            stats[1] += 1
            rejected_last = True
            h *= fac
    return status, t, y, h, stats, u_out, steps[:n_steps], dense[:n_dense]


# -- the interface -----------------------------------------------------------------------
def _check_inputs(model: Model, u0: ArrayLike, V: float, p: np.ndarray, t_end: float, rtol: float,
                  atol: float | np.ndarray, dt_out: float | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    u0 = np.ascontiguousarray(u0, dtype=float)
    if u0.shape != (model.n,):
        raise ValueError(f"initial state: expected shape ({model.n},) for {model.name}, got {u0.shape}")
    if not np.all(np.isfinite(u0)):
        raise ValueError(f"initial state is not finite: {u0}")
    p = np.ascontiguousarray(p, dtype=float)
    if not np.all(np.isfinite(p)):
        raise ValueError("parameter vector p is not finite")
    if not math.isfinite(V):
        raise ValueError(f"speed V = {V!r} m/s: must be finite")
    if not (math.isfinite(t_end) and t_end > 0.0):
        raise ValueError(f"t_end = {t_end!r} s: must be a positive finite number")
    if not (math.isfinite(rtol) and 0.0 < rtol < 1.0):
        raise ValueError(f"rtol = {rtol!r}: must be in (0, 1)")
    if rtol < 1e-13:
        raise ValueError(f"rtol = {rtol!r}: below 1e-13 the round-off dominates; use >= 1e-13")
    atol = np.broadcast_to(np.asarray(atol, dtype=float), (model.n,)).copy()
    if not (np.all(np.isfinite(atol)) and np.all(atol > 0.0)):
        raise ValueError(f"atol = {atol}: must be positive and finite")
    if dt_out is not None and not (math.isfinite(dt_out) and dt_out > 0.0):
        raise ValueError(f"dt_out = {dt_out!r} s: must be a positive finite number")
    return u0, p, atol


def output_grid(t_end: float, dt_out: float) -> np.ndarray:
    """Uniform grid 0, dt_out, 2 dt_out, ... <= t_end [s]."""
    count = int(math.floor(t_end / dt_out * (1.0 + 1e-12))) + 1
    return np.minimum(np.arange(count) * dt_out, t_end)


def integrate(
    model: Model,
    u0: ArrayLike,
    V: float,
    p: np.ndarray,
    t_end: float,
    *,
    dt_out: float | None = None,
    rtol: float = 1e-8,
    atol: float | np.ndarray = 1e-10,
    method: str = "rodas",
    dense_from: float | None = None,
    h0: float | None = None,
    max_steps: int = 10_000_000,
) -> Trajectory:
    """Integrate ``du/dt = f(u, V, p)`` from ``u0`` at time 0 to ``t_end``.

    Parameters
    ----------
    model : Model
        The model (``polywear.models.get_model(name)``).
    u0 : array (n,)
        Initial state [state units].
    V : float
        Vehicle speed [m/s].
    p : array
        Kernel parameter vector, ``model.pack(params)``.
    t_end : float
        End time [s].
    dt_out : float, optional
        Output on the uniform grid ``0, dt_out, ...`` [s] (from the dense output); by
        default the accepted steps.
    rtol, atol : float
        Relative and absolute (scalar or per state) tolerances of the local error.
    method : str
        ``"rodas"`` (compiled) or a scipy method: ``"radau"``, ``"bdf"``, ``"lsoda"``,
        ``"dop853"``.
    dense_from : float, optional
        Keep the continuous solution over ``[dense_from, t_end]`` [s].
    h0 : float, optional
        First step size [s] (default: estimated).
    max_steps : int
        Give up after this many accepted steps (Rodas only).

    Raises
    ------
    ValueError
        Bad input (shape, non-finite values, non-positive tolerances or times).
    IntegrationError
        The step size underflowed, the state became non-finite, or ``max_steps`` ran out.
    """
    if method not in METHODS:
        raise ValueError(f"method = {method!r}: must be one of {', '.join(METHODS)}")
    if not math.isfinite(float(V)):
        raise ValueError(f"speed V = {V!r} m/s: must be finite")
    p = model.prepared(float(V), np.asarray(p, dtype=float))  # speed-only quantities cached once
    u0, p, atol = _check_inputs(model, u0, float(V), p, float(t_end), float(rtol), atol, dt_out)
    t_out = output_grid(t_end, dt_out) if dt_out is not None else np.empty(0)
    if method == "rodas":
        return _integrate_rodas(model, u0, float(V), p, float(t_end), float(rtol), atol, t_out,
                                dt_out is None, dense_from, h0, max_steps)
    return _integrate_scipy(model, u0, float(V), p, float(t_end), float(rtol), atol, t_out,
                            dt_out is None, dense_from, method, h0)


def _integrate_rodas(model: Model, u0: np.ndarray, V: float, p: np.ndarray, t_end: float, rtol: float,
                     atol: np.ndarray, t_out: np.ndarray, record_steps: bool, dense_from: float | None,
                     h0: float | None, max_steps: int) -> Trajectory:
    rhs, jac = model.compiled[:2]
    status, t, y, h, stats, u_out, steps, dense = _rodas4(
        rhs, jac, u0, V, p, t_end, rtol, atol, 0.0 if h0 is None else float(h0), t_out,
        record_steps, math.inf if dense_from is None else float(dense_from), int(max_steps),
    )
    if status != _OK:
        reason = {
            _UNDERFLOW: f"step size underflow (h = {h:.3g} s)",
            _MAX_STEPS: f"max_steps = {max_steps} accepted steps used up",
            _NONFINITE: "the state or its derivative became non-finite",
        }[status]
        raise IntegrationError(
            f"{model.name} at V = {V:.6g} m/s: integration stopped at t = {t:.9g} s of {t_end:.6g} s: "
            f"{reason}"
        )
    n = model.n
    dense_out = None
    if dense_from is not None and len(dense):
        dense_out = DenseOutput(
            t_start=dense[:, 0].copy(),
            h=dense[:, 1].copy(),
            coefficients=dense[:, 2:].reshape(-1, 4, n).copy(),
        )
    if record_steps:
        t_res, u_res = steps[:, 0].copy(), steps[:, 1:].copy()
    else:
        t_res, u_res = t_out, u_out
    return Trajectory(
        t=t_res,
        u=u_res,
        stats=StepStats(*(int(s) for s in stats)),
        method="rodas",
        rtol=rtol,
        atol=atol,
        dense=dense_out,
        h_last=float(h),
    )


def _integrate_scipy(model: Model, u0: np.ndarray, V: float, p: np.ndarray, t_end: float, rtol: float,
                     atol: np.ndarray, t_out: np.ndarray, record_steps: bool, dense_from: float | None,
                     method: str, h0: float | None) -> Trajectory:
    from scipy.integrate import solve_ivp

    options: dict[str, Any] = {} if h0 is None else {"first_step": float(h0)}
    if method in ("radau", "bdf", "lsoda"):
        options["jac"] = lambda t, u: model.jacobian(u, V, p)
    sol = solve_ivp(
        lambda t, u: model.f(u, V, p),
        (0.0, t_end),
        u0,
        method=_SCIPY_NAMES[method],
        rtol=rtol,
        atol=atol,
        dense_output=not record_steps or dense_from is not None,
        **options,
    )
    if sol.status != 0 or not np.all(np.isfinite(sol.y[:, -1])):
        raise IntegrationError(
            f"{model.name} at V = {V:.6g} m/s: solve_ivp({_SCIPY_NAMES[method]}) stopped at "
            f"t = {sol.t[-1]:.6g} s of {t_end:.6g} s: {sol.message}"
        )
    if record_steps:
        t_res, u_res = sol.t, sol.y.T
    else:
        t_res, u_res = t_out, sol.sol(t_out).T
    dense = None
    if dense_from is not None:
        dense = _ScipyDense(sol.sol, float(dense_from), t_end)
    return Trajectory(
        t=t_res,
        u=np.ascontiguousarray(u_res),
        stats=StepStats(
            accepted=len(sol.t) - 1, rejected=None, rhs_evals=int(sol.nfev),
            jac_evals=int(sol.njev), lu_decompositions=int(sol.nlu),
        ),
        method=method,
        rtol=rtol,
        atol=atol,
        dense=dense,
        h_last=None,
    )
