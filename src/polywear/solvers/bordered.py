"""Structured solver for the bordered, cyclic, almost block diagonal collocation system.

The Newton matrix of the periodic collocation problem has, for each mesh interval
``j``, an ``(m n) x ((m + 1) n)`` block coupling its left mesh node ``u_j``, its
``m - 1`` interior nodes ``w_j`` and its right mesh node ``u_{j+1}`` (``u_N = u_0``),
two full columns (period T, speed V) and two full rows (phase and arclength
conditions). It is solved in three compiled passes, as AUTO-07p does:

1. *condensation*: in every interval the interior nodes are eliminated by Gaussian
   elimination with partial pivoting, leaving ``n`` equations
   ``CL_j u_j + CR_j u_{j+1} + ct_j dT + cv_j dV = r_j``;
2. *stair elimination* of ``u_1 ... u_{N-1}`` along the chain (partial pivoting over
   the ``2 n`` rows of two consecutive stages), the wrap-around ``u_0`` kept as a
   fill-in column, the border rows reduced alongside;
3. a dense ``(n + 2)`` system for ``(u_0, dT, dV)``, then back substitution.

Cost is linear in the number of mesh intervals. ``CL`` and ``CR`` also give the
transfer matrices ``-CR_j^{-1} CL_j`` whose product is the monodromy matrix.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["solve_bordered"]


@njit(cache=True)
def _eliminate(rows: np.ndarray, n_rows: int, col0: int, n_cols: int, used: np.ndarray, border: np.ndarray,
               pivots_out: np.ndarray) -> bool:
    """Partial-pivot elimination of columns col0 .. col0+n_cols-1 of ``rows`` (in place).

    Pivot rows are chosen among ``rows[:n_rows]`` not ``used``; each pivot row index is
    written to ``pivots_out``. The border rows are reduced with the same pivots.
    """
    width = rows.shape[1]
    for c in range(n_cols):
        col = col0 + c
        best = -1
        best_val = -1.0
        for r in range(n_rows):
            if not used[r]:
                v = abs(rows[r, col])
                if v > best_val:
                    best_val = v
                    best = r
        if not best_val > 0.0:  # singular, or NaN entries (no pivot found: best stays -1)
            return False
        used[best] = True
        pivots_out[c] = best
        piv = rows[best, col]
        for r in range(n_rows):
            if not used[r]:
                factor = rows[r, col] / piv
                if factor != 0.0:
                    for q in range(width):
                        rows[r, q] -= factor * rows[best, q]
        for b in range(border.shape[0]):
            factor = border[b, col] / piv
            if factor != 0.0:
                for q in range(width):
                    border[b, q] -= factor * rows[best, q]
    return True


@njit(cache=True)
def solve_bordered(blocks: np.ndarray, tcol: np.ndarray, vcol: np.ndarray, border: np.ndarray, rhs: np.ndarray,
                   m: int, CL: np.ndarray, CR: np.ndarray) -> np.ndarray:
    """Solve the bordered cyclic collocation system for several right-hand sides.

    Parameters
    ----------
    blocks : (N, m n, (m + 1) n) interval blocks; tcol, vcol : (N m n,) T and V columns.
    border : (2, N m n + 2) the two border rows over all unknowns.
    rhs : (N m n + 2, k) right-hand sides. m : collocation degree.
    CL, CR : (N, n, n) outputs, the condensed blocks (for the monodromy matrix).

    Returns the solution (N m n + 2, k), or an empty array if the matrix is singular.
    """
    N = blocks.shape[0]
    n = blocks.shape[2] // (m + 1)
    mn = m * n
    ni = (m - 1) * n
    k = rhs.shape[1]
    size = N * mn + 2
    # ---- 1. condensation of interior nodes --------------------------------------------
    # local columns: [L (n) | I (ni) | R (n) | T | V | rhs (k)]
    width1 = (m + 1) * n + 2 + k
    loc = np.empty((N, mn, width1))
    piv1 = np.empty((N, ni), dtype=np.int64)
    rest1 = np.empty((N, n), dtype=np.int64)
    # border in reduced form: mesh-node coefficients, T, V, rhs
    b_mesh = np.zeros((2, N, n))
    b_tv = np.empty((2, 2 + k))
    for b in range(2):
        b_tv[b, 0] = border[b, size - 2]
        b_tv[b, 1] = border[b, size - 1]
        for q in range(k):
            b_tv[b, 2 + q] = rhs[size - 2 + b, q]
    bloc = np.empty((2, width1))
    used = np.zeros(mn, dtype=np.bool_)
    for j in range(N):
        jn = (j + 1) % N
        for r in range(mn):
            g = j * mn + r
            for q in range((m + 1) * n):
                loc[j, r, q] = blocks[j, r, q]
            loc[j, r, (m + 1) * n] = tcol[g]
            loc[j, r, (m + 1) * n + 1] = vcol[g]
            for q in range(k):
                loc[j, r, (m + 1) * n + 2 + q] = rhs[g, q]
        # border restricted to this interval: only interior nodes belong to it alone
        for b in range(2):
            for q in range(width1):
                bloc[b, q] = 0.0
            for q in range(ni):
                bloc[b, n + q] = border[b, (j * m + 1) * n + q]
        for r in range(mn):
            used[r] = False
        if not _eliminate(loc[j], mn, n, ni, used, bloc, piv1[j]):
            return np.empty((0, 0))
        c = 0
        for r in range(mn):
            if not used[r]:
                rest1[j, c] = r
                c += 1
        for b in range(2):
            for q in range(n):
                b_mesh[b, j, q] += bloc[b, q]
                b_mesh[b, jn, q] += bloc[b, n + ni + q]
            b_tv[b, 0] += bloc[b, (m + 1) * n]
            b_tv[b, 1] += bloc[b, (m + 1) * n + 1]
            for q in range(k):
                b_tv[b, 2 + q] += bloc[b, (m + 1) * n + 2 + q]
        for a in range(n):
            r = rest1[j, a]
            for q in range(n):
                CL[j, a, q] = loc[j, r, q]
                CR[j, a, q] = loc[j, r, n + ni + q]
    # mesh-node border coefficients that were set directly (not via interiors)
    for b in range(2):
        for j in range(N):
            for q in range(n):
                b_mesh[b, j, q] += border[b, j * mn + q]
    # ---- 2. stair elimination of u_1 .. u_{N-1} ----------------------------------------
    # stage columns: [u_j (n) | u_{j+1} (n) | u_0 fill (n) | T | V | rhs (k)]
    width2 = 3 * n + 2 + k
    stage = np.zeros((N, 2 * n, width2))
    piv2 = np.empty((N, n), dtype=np.int64)
    active = np.zeros((n, width2))
    # active rows from interval 0: u_1 <- CR_0 (goes to the 'u_j' slot of stage 1), fill <- CL_0
    for a in range(n):
        r = rest1[0, a]
        for q in range(n):
            active[a, q] = loc[0, r, n + ni + q]
            active[a, 2 * n + q] = loc[0, r, q]
        for q in range(2 + k):
            active[a, 3 * n + q] = loc[0, r, (m + 1) * n + q]
    bst = np.zeros((2, width2))
    used2 = np.zeros(2 * n, dtype=np.bool_)
    for j in range(1, N):
        S = stage[j]
        for a in range(n):
            for q in range(width2):
                S[a, q] = active[a, q]
        for a in range(n):
            r = rest1[j, a]
            row = n + a
            for q in range(width2):
                S[row, q] = 0.0
            for q in range(n):
                S[row, q] = loc[j, r, q]
                if j + 1 < N:
                    S[row, n + q] = loc[j, r, n + ni + q]
                else:
                    S[row, 2 * n + q] += loc[j, r, n + ni + q]
            for q in range(2 + k):
                S[row, 3 * n + q] = loc[j, r, (m + 1) * n + q]
        for b in range(2):
            for q in range(width2):
                bst[b, q] = 0.0
            for q in range(n):
                bst[b, q] = b_mesh[b, j, q]
                if j + 1 < N:
                    bst[b, n + q] = b_mesh[b, j + 1, q]
                bst[b, 2 * n + q] = b_mesh[b, 0, q]
            for q in range(2 + k):
                bst[b, 3 * n + q] = b_tv[b, q]
        for r in range(2 * n):
            used2[r] = False
        if not _eliminate(S, 2 * n, 0, n, used2, bst, piv2[j]):
            return np.empty((0, 0))
        for b in range(2):
            for q in range(n):
                if j + 1 < N:
                    b_mesh[b, j + 1, q] = bst[b, n + q]
                b_mesh[b, 0, q] = bst[b, 2 * n + q]
            for q in range(2 + k):
                b_tv[b, q] = bst[b, 3 * n + q]
        c = 0
        for r in range(2 * n):
            if not used2[r]:
                for q in range(width2):
                    active[c, q] = 0.0
                # shift: the u_{j+1} slot becomes the next stage's u_j slot
                for q in range(n):
                    active[c, q] = S[r, n + q]
                    active[c, 2 * n + q] = S[r, 2 * n + q]
                for q in range(2 + k):
                    active[c, 3 * n + q] = S[r, 3 * n + q]
                c += 1
    # ---- 3. final dense system in (u_0, T, V) -------------------------------------------
    A = np.zeros((n + 2, n + 2))
    B = np.zeros((n + 2, k))
    for a in range(n):
        for q in range(n):
            A[a, q] = active[a, 2 * n + q] + (active[a, q] if N == 1 else 0.0)
        A[a, n] = active[a, 3 * n]
        A[a, n + 1] = active[a, 3 * n + 1]
        for q in range(k):
            B[a, q] = active[a, 3 * n + 2 + q]
    for b in range(2):
        for q in range(n):
            A[n + b, q] = b_mesh[b, 0, q]
        A[n + b, n] = b_tv[b, 0]
        A[n + b, n + 1] = b_tv[b, 1]
        for q in range(k):
            B[n + b, q] = b_tv[b, 2 + q]
    if abs(np.linalg.det(A)) == 0.0:
        return np.empty((0, 0))
    top = np.linalg.solve(A, B)
    # ---- back substitution -----------------------------------------------------------
    x = np.zeros((size, k))
    U = np.zeros((N + 1, n, k))
    for q in range(k):
        for a in range(n):
            U[0, a, q] = top[a, q]
            U[N, a, q] = top[a, q]
        x[size - 2, q] = top[n, q]
        x[size - 1, q] = top[n + 1, q]
    for j in range(N - 1, 0, -1):
        S = stage[j]
        for q in range(k):
            for c in range(n - 1, -1, -1):
                r = piv2[j, c]
                acc = S[r, 3 * n + 2 + q] - S[r, 3 * n] * x[size - 2, q] - S[r, 3 * n + 1] * x[size - 1, q]
                for cc in range(c + 1, n):
                    acc -= S[r, cc] * U[j, cc, q]
                for cc in range(n):
                    acc -= S[r, n + cc] * U[j + 1, cc, q] * (1.0 if j + 1 < N else 0.0)
                    acc -= S[r, 2 * n + cc] * U[0, cc, q]
                U[j, c, q] = acc / S[r, c]
    for j in range(N):
        for q in range(k):
            for a in range(n):
                x[j * mn + a, q] = U[j, a, q]
            # interior nodes of interval j, back substitution in elimination order
            for c in range(ni - 1, -1, -1):
                r = piv1[j, c]
                L = loc[j, r]
                acc = L[(m + 1) * n + 2 + q] - L[(m + 1) * n] * x[size - 2, q] - L[(m + 1) * n + 1] * x[size - 1, q]
                for cc in range(n):
                    acc -= L[cc] * U[j, cc, q] + L[n + ni + cc] * U[j + 1, cc, q]
                for cc in range(c + 1, ni):
                    acc -= L[n + cc] * x[j * mn + n + cc, q]
                x[j * mn + n + c, q] = acc / L[n + c]
    return x
