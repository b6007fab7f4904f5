"""Periodic orbits by orthogonal collocation (the AUTO-07p discretisation).

The orbit ``u(tau)``, ``tau in [0, 1]``, of period ``T`` solves ``u' = T f(u, V, p)``.
The unit interval is cut into ``N`` mesh intervals; on each the orbit is a polynomial
of degree ``m`` held by its values at ``m + 1`` equally spaced nodes (the last node of
an interval is the first of the next; periodicity closes the loop, so there are
``N m`` distinct nodes). The differential equation is imposed at the ``m`` Gauss
points of each interval. The Jacobian of these equations is sparse (one
``(m n) x ((m + 1) n)`` block per interval plus the ``T`` and ``V`` columns); it is
filled by a compiled kernel and factorized with SuperLU.

Floquet multipliers come from the same blocks: eliminating the interior nodes of
interval ``j`` gives its transfer matrix, and the monodromy matrix is their product.
The mesh is adapted AUTO-style, equidistributing ``|u^(m+1)|^(1/(m+1))`` estimated
from jumps of the piecewise constant ``m``-th derivative.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np
from numba import njit
from numpy.typing import ArrayLike

from .bordered import solve_bordered

if TYPE_CHECKING:
    from scipy.sparse import csc_matrix

    from ..models.base import Model

__all__ = ["Scheme", "scheme", "PeriodicOrbit", "Collocation", "monodromy"]


@dataclass(frozen=True)
class Scheme:
    """Constants of degree-``m`` collocation on the unit interval."""

    m: int
    gauss: np.ndarray  # (m,) Gauss-Legendre points in [0, 1]
    weights: np.ndarray  # (m,) their quadrature weights (sum 1)
    nodes: np.ndarray  # (m + 1,) equally spaced representation nodes
    basis: np.ndarray  # (m, m + 1) Lagrange basis of the nodes at the Gauss points
    dbasis: np.ndarray  # (m, m + 1) derivative of the basis at the Gauss points
    mth: np.ndarray  # (m + 1,) weights giving the m-th derivative from node values


def _lagrange(nodes: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lagrange basis values and derivatives of ``nodes`` at points ``x``."""
    k = len(nodes)
    val = np.ones((len(x), k))
    der = np.zeros((len(x), k))
    for j in range(k):
        others = [i for i in range(k) if i != j]
        denom = np.prod(nodes[j] - nodes[others])
        for i in others:
            val[:, j] *= x - nodes[i]
        for skip in others:
            term = np.ones(len(x))
            for i in others:
                if i != skip:
                    term *= x - nodes[i]
            der[:, j] += term
        val[:, j] /= denom
        der[:, j] /= denom
    return val, der


@lru_cache(maxsize=8)
def scheme(m: int = 4) -> Scheme:
    """Collocation constants for degree ``m`` (Gauss points, Lagrange matrices)."""
    from math import factorial

    x, w = np.polynomial.legendre.leggauss(m)
    gauss = 0.5 * (x + 1.0)
    nodes = np.linspace(0.0, 1.0, m + 1)
    basis, dbasis = _lagrange(nodes, gauss)
    # m-th derivative of the interpolant = m! * leading coefficient = m! * sum_j y_j / prod(nodes_j - nodes_i)
    mth = np.array([factorial(m) / np.prod([nodes[j] - nodes[i] for i in range(m + 1) if i != j]) for j in range(m + 1)])
    return Scheme(m, gauss, 0.5 * w, nodes, basis, dbasis, mth)


@dataclass(frozen=True)
class PeriodicOrbit:
    """A periodic orbit on a collocation mesh.

    ``mesh``: (N + 1,) interval ends in [0, 1]; ``nodes``: (N m, n) state at the
    representation nodes (node ``j m + l`` is node ``l`` of interval ``j``);
    ``period`` [s]; ``speed`` V [m/s].
    """

    mesh: np.ndarray
    nodes: np.ndarray
    period: float
    speed: float
    m: int = 4

    @property
    def n_intervals(self) -> int:
        return len(self.mesh) - 1

    def interval_nodes(self) -> np.ndarray:
        """(N, m + 1, n) node values per interval, the closing node repeated."""
        return self.nodes[_interval_index(self.n_intervals, self.m)]

    def node_times(self) -> np.ndarray:
        """(N m,) tau of each distinct node."""
        h = np.diff(self.mesh)
        return (self.mesh[:-1, None] + h[:, None] * scheme(self.m).nodes[None, :-1]).ravel()

    def evaluate(self, tau: ArrayLike) -> np.ndarray:
        """State at normalized times ``tau`` (taken modulo 1), shape (len(tau), n)."""
        t = np.mod(np.atleast_1d(np.asarray(tau, dtype=float)), 1.0)
        j = np.clip(np.searchsorted(self.mesh, t, side="right") - 1, 0, self.n_intervals - 1)
        h = np.diff(self.mesh)
        s = (t - self.mesh[j]) / h[j]
        others, denom = _lagrange_factors(self.m)
        basis = np.prod(s[:, None, None] - others[None], axis=2) / denom  # (len(t), m + 1)
        return np.einsum("tl,tln->tn", basis, self.interval_nodes()[j])

    def dense(self, per_interval: int = 16) -> tuple[np.ndarray, np.ndarray]:
        """(tau, u) sampled ``per_interval`` times on every mesh interval (closing point included)."""
        h = np.diff(self.mesh)
        s = np.arange(per_interval) / per_interval
        tau = np.append((self.mesh[:-1, None] + h[:, None] * s[None, :]).ravel(), 1.0)
        # the same samples on every interval: one basis matrix for all (evaluate's arithmetic
        # to round-off, ~4x faster); the closing point is node 0
        u = np.matmul(_sample_basis(self.m, per_interval), self.interval_nodes())
        return tau, np.vstack([u.reshape(-1, self.nodes.shape[1]), self.nodes[:1]])

    def extrema(self, per_interval: int = 16) -> tuple[np.ndarray, np.ndarray]:
        """Minimum and maximum of every state over the orbit, refined by parabolas."""
        _, u = self.dense(per_interval)
        u = u[:-1]
        lo = np.empty(u.shape[1])
        hi = np.empty(u.shape[1])
        for i in range(u.shape[1]):
            hi[i] = _refined_peak(u[:, i])
            lo[i] = -_refined_peak(-u[:, i])
        return lo, hi

    def amplitude(self, per_interval: int = 16) -> np.ndarray:
        """Half peak-to-peak of every state [state units]."""
        lo, hi = self.extrema(per_interval)
        return 0.5 * (hi - lo)

    def with_mesh(self, mesh: np.ndarray) -> PeriodicOrbit:
        """The same orbit interpolated onto another mesh."""
        N = len(mesh) - 1
        h = np.diff(mesh)
        tau = (mesh[:-1, None] + h[:, None] * scheme(self.m).nodes[None, :-1]).ravel()
        return replace(self, mesh=np.asarray(mesh, dtype=float), nodes=self.evaluate(tau).reshape(N * self.m, -1))


@lru_cache(maxsize=64)
def _interval_index(N: int, m: int) -> np.ndarray:
    """(N, m + 1) index of the nodes of each interval, the closing node the next one's first (read-only)."""
    idx = (np.arange(N)[:, None] * m + np.arange(m + 1)[None, :]) % (N * m)
    idx.flags.writeable = False
    return idx


@lru_cache(maxsize=8)
def _lagrange_factors(m: int) -> tuple[np.ndarray, np.ndarray]:
    """The Lagrange basis of the degree-``m`` nodes as products: ``(m + 1, m)`` the other
    nodes of each node and ``(m + 1,)`` the product of its differences to them (read-only)."""
    nodes = scheme(m).nodes
    others = np.array([np.delete(nodes, a) for a in range(m + 1)])
    denom = np.prod(nodes[:, None] - others, axis=1)
    others.flags.writeable = denom.flags.writeable = False
    return others, denom


@lru_cache(maxsize=16)
def _sample_basis(m: int, per_interval: int) -> np.ndarray:
    """(per_interval, m + 1) Lagrange basis of the degree-``m`` nodes at ``k / per_interval``
    of an interval, k = 0 .. per_interval - 1 (read-only)."""
    basis, _ = _lagrange(scheme(m).nodes, np.arange(per_interval) / per_interval)
    basis.flags.writeable = False
    return basis


def _refined_peak(y: np.ndarray) -> float:
    """Maximum of periodic samples ``y`` refined by a parabola through the top three."""
    i = int(np.argmax(y))
    a, b, c = y[i - 1], y[i], y[(i + 1) % len(y)]
    denom = a - 2.0 * b + c
    if denom >= 0.0:
        return float(b)
    return float(b - 0.125 * (c - a) ** 2 / denom)


@njit(cache=True)
def _assemble(rhs_jac_dfdv: Callable[..., None], nodes: np.ndarray, period: float, speed: float, p: np.ndarray,
              h: np.ndarray, basis: np.ndarray, dbasis: np.ndarray, res: np.ndarray, blocks: np.ndarray,
              tcol: np.ndarray, vcol: np.ndarray) -> None:
    """Collocation residual and Jacobian blocks; the model's ``rhs_jac_dfdv`` gives f, df/du
    and df/dV at every Gauss point.

    res (N m n,): u'(c) - T f(u(c)) at every Gauss point c. blocks (N, m n, (m+1) n):
    d res / d nodes of the interval; tcol, vcol (N m n,): d res / dT, d res / dV.
    """
    N = h.shape[0]
    m = basis.shape[0]
    n = nodes.shape[1]
    Nm = N * m
    uc = np.empty(n)
    duc = np.empty(n)
    f = np.empty(n)
    fv = np.empty(n)
    J = np.empty((n, n))
    for j in range(N):
        for k in range(m):
            for i in range(n):
                uc[i] = 0.0
                duc[i] = 0.0
            for l in range(m + 1):
                node = (j * m + l) % Nm
                for i in range(n):
                    uc[i] += basis[k, l] * nodes[node, i]
                    duc[i] += dbasis[k, l] * nodes[node, i] / h[j]
            rhs_jac_dfdv(uc, speed, p, f, J, fv)
            row0 = (j * m + k) * n
            for i in range(n):
                res[row0 + i] = duc[i] - period * f[i]
                tcol[row0 + i] = -f[i]
                vcol[row0 + i] = -period * fv[i]
            for l in range(m + 1):
                for i in range(n):
                    for q in range(n):
                        val = -period * basis[k, l] * J[i, q]
                        if i == q:
                            val += dbasis[k, l] / h[j]
                        blocks[j, k * n + i, l * n + q] = val


@dataclass
class Collocation:
    """The discretised periodic boundary value problem of one model on one mesh.

    Unknown vector ``X = (nodes.ravel(), T, V)``. Equations: collocation (N m n),
    then the phase condition and the pseudo-arclength condition (added by the caller
    through :meth:`solve_linear`).
    """

    model: Model
    p: np.ndarray
    mesh: np.ndarray
    m: int = 4

    def __post_init__(self) -> None:
        self.mesh = np.asarray(self.mesh, dtype=float)
        self.sch = scheme(self.m)
        self.h = np.diff(self.mesh)
        N, m, n = len(self.h), self.m, self.model.n
        self.N, self.n = N, n
        if N < 2:
            raise ValueError("the collocation mesh needs at least 2 intervals")
        self.size = N * m * n + 2
        # quadrature weight of each distinct node for inner products (sum 1)
        wq = np.empty((N, m))
        wq[:, 0] = 0.5 * (self.h + np.roll(self.h, 1)) / m
        wq[:, 1:] = self.h[:, None] / m
        self.node_weights = wq.ravel()

    # -- vectors <-> orbits -----------------------------------------------------------
    def pack(self, orbit: PeriodicOrbit) -> np.ndarray:
        return np.concatenate([orbit.nodes.ravel(), [orbit.period, orbit.speed]])

    def unpack(self, X: np.ndarray) -> PeriodicOrbit:
        nodes = X[:-2].reshape(self.N * self.m, self.n).copy()
        return PeriodicOrbit(self.mesh, nodes, float(X[-2]), float(X[-1]), self.m)

    # -- system ------------------------------------------------------------------------
    def evaluate(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Residual of the collocation equations and their Jacobian parts at X."""
        N, m, n = self.N, self.m, self.n
        nodes = np.ascontiguousarray(X[:-2].reshape(N * m, n))
        res = np.empty(N * m * n)
        blocks = np.empty((N, m * n, (m + 1) * n))
        tcol = np.empty(N * m * n)
        vcol = np.empty(N * m * n)
        speed = float(X[-1])
        # every Gauss point is at this one speed: the model may cache speed-only terms in p
        _assemble(
            self.model.compiled_fused, nodes, float(X[-2]), speed, self.model.prepared(speed, self.p), self.h,
            self.sch.basis, self.sch.dbasis, res, blocks, tcol, vcol,
        )
        return res, blocks, tcol, vcol

    def sparse_matrix(self, X: np.ndarray, border: np.ndarray) -> csc_matrix:
        """The bordered Newton matrix at X as scipy CSC (for transposed solves)."""
        from scipy.sparse import coo_matrix

        _, blocks, tcol, vcol = self.evaluate(X)
        N, m, n = self.N, self.m, self.n
        nc = N * m * n
        rows_local = np.arange(m * n)
        cols_local = np.arange((m + 1) * n)
        r = np.arange(N)[:, None] * m * n + rows_local[None, :]
        node = (np.arange(N)[:, None] * m + cols_local[None, :] // n) % (N * m)
        c = node * n + cols_local[None, :] % n
        brow = np.broadcast_to(r[:, :, None], blocks.shape).ravel()
        bcol = np.broadcast_to(c[:, None, :], blocks.shape).ravel()
        erow = np.repeat(np.arange(nc, nc + 2), self.size)
        ecol = np.tile(np.arange(self.size), 2)
        rows = np.concatenate([brow, np.arange(nc), np.arange(nc), erow])
        cols = np.concatenate([bcol, np.full(nc, nc), np.full(nc, nc + 1), ecol])
        vals = np.concatenate([blocks.ravel(), tcol, vcol, border.ravel()])
        return coo_matrix((vals, (rows, cols)), shape=(self.size, self.size)).tocsc()

    def gauss_states(self, orbit: PeriodicOrbit) -> np.ndarray:
        """(N m, n) states at the Gauss points, interval-major."""
        vals = orbit.interval_nodes() if np.array_equal(orbit.mesh, self.mesh) else orbit.with_mesh(self.mesh).interval_nodes()
        return np.einsum("kl,jln->jkn", self.sch.basis, vals).reshape(self.N * self.m, self.n)

    def phase_row(self, reference: PeriodicOrbit) -> np.ndarray:
        """Row of the integral phase condition  int u . u_ref' dtau = 0  (linear in the nodes)."""
        sch = self.sch
        ref = reference if np.array_equal(reference.mesh, self.mesh) else reference.with_mesh(self.mesh)
        # coefficient of node (j, l): h_j sum_k w_k L_l(c_k) u_ref'(c_jk), u_ref'(c_jk) =
        # sum_l' L_l''(c_k) u_ref(j, l') / h_j: the h_j cancel, one (m+1, m+1) matrix for all j
        coupling = (sch.weights[:, None] * sch.basis).T @ sch.dbasis
        coef = np.matmul(coupling, ref.interval_nodes())  # (N, m+1, n)
        row = coef[:, :-1, :].reshape(self.N * self.m, self.n).copy()
        row[(np.arange(self.N) * self.m + self.m) % (self.N * self.m)] += coef[:, -1, :]  # closing node: next interval's first
        return np.concatenate([row.ravel(), [0.0, 0.0]])

    def solve(
        self, X: np.ndarray, border: np.ndarray, border_values: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
        """Newton correction and tangent at X.

        Solves ``A [dX, t] = [-F, e]`` where A is the collocation Jacobian bordered by
        ``border`` (2, size), F the residual with ``border_values`` appended, and ``e``
        the unit vector of the last (arclength) row. Returns ``(dX, t, CL, CR)`` or
        None if the residual is not finite or the matrix is singular; ``CL``, ``CR``
        give the monodromy matrix.
        """
        res, blocks, tcol, vcol = self.evaluate(X)
        # a diverged Newton iterate (the kernels give inf/NaN, never raise): one sum each
        # carries any inf/NaN (and is not finite for finite entries beyond ~1e300 alone)
        if not np.isfinite(res.sum() + blocks.sum() + tcol.sum() + vcol.sum()):
            return None
        rhs = np.zeros((self.size, 2))
        rhs[:-2, 0] = -res
        rhs[-2:, 0] = -border_values
        rhs[-1, 1] = 1.0
        out = self.solve_system(blocks, tcol, vcol, border, rhs)
        return None if out is None else (out[0][:, 0], out[0][:, 1], out[1], out[2])

    def solve_system(self, blocks: np.ndarray, tcol: np.ndarray, vcol: np.ndarray, border: np.ndarray,
                     rhs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """Solve the bordered system of the parts :meth:`evaluate` returns and ``border``
        (2, size) for the columns of ``rhs`` (size, k). Returns ``(x, CL, CR)`` or None
        if the matrix is singular or the solution not finite."""
        CL = np.empty((self.N, self.n, self.n))
        CR = np.empty((self.N, self.n, self.n))
        x = solve_bordered(blocks, tcol, vcol, np.ascontiguousarray(border), np.ascontiguousarray(rhs), self.m,
                           CL, CR)
        if x.size == 0 or not np.all(np.isfinite(x)):
            return None
        return x, CL, CR

    def product(self, blocks: np.ndarray, tcol: np.ndarray, vcol: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``A v`` for the collocation rows ``A`` given by ``blocks, tcol, vcol`` and a vector
        ``v`` over the unknowns (nodes, T, V): a vector over those rows (N m n,)."""
        N, m, n = self.N, self.m, self.n
        nodes = v[:-2].reshape(N * m, n)
        local = nodes[(np.arange(N)[:, None] * m + np.arange(m + 1)[None, :]) % (N * m)].reshape(N, (m + 1) * n)
        return np.einsum("jrc,jc->jr", blocks, local).ravel() + tcol * v[-2] + vcol * v[-1]

    def adapted_mesh(self, orbit: PeriodicOrbit, n_intervals: int | None = None) -> np.ndarray:
        """New mesh equidistributing |u^(m+1)|^(1/(m+1)) over the orbit (AUTO's rule)."""
        N = orbit.n_intervals
        n_new = n_intervals or N
        sch = scheme(orbit.m)
        h = np.diff(orbit.mesh)
        vals = orbit.interval_nodes()  # (N, m+1, n)
        ptp = np.ptp(orbit.nodes, axis=0)
        moving = ptp > 1e-9 * (np.abs(orbit.nodes).max(axis=0) + 1e-300)  # skip constant states
        dm = np.einsum("l,jln->jn", sch.mth, vals[:, :, moving]) / h[:, None] ** orbit.m / ptp[moving]
        jump_right = np.linalg.norm(np.roll(dm, -1, axis=0) - dm, axis=1) / (0.5 * (h + np.roll(h, -1)))
        jump_left = np.roll(jump_right, 1)
        monitor = (0.5 * (jump_left + jump_right)) ** (1.0 / (orbit.m + 1))
        monitor = np.maximum(monitor, 1e-3 * monitor.max() + 1e-300)
        cumulative = np.concatenate([[0.0], np.cumsum(monitor * h)])
        targets = np.linspace(0.0, cumulative[-1], n_new + 1)
        new = np.interp(targets, cumulative, orbit.mesh)
        new[0], new[-1] = 0.0, 1.0
        return new


def monodromy(CL: np.ndarray, CR: np.ndarray) -> np.ndarray:
    """Monodromy matrix, the product of the interval transfer matrices -CR_j^{-1} CL_j."""
    return _chain(-np.linalg.solve(CR, CL))


@njit(cache=True)
def _chain(transfer: np.ndarray) -> np.ndarray:
    """The product ``transfer[N-1] ... transfer[1] transfer[0]`` of (N, n, n) matrices."""
    M = np.eye(transfer.shape[1])
    for j in range(transfer.shape[0]):
        M = transfer[j] @ M
    return M
