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

The matrices being eliminated are stored transposed (a column of the system is
contiguous): the update by one pivot is then, per column, one loop over all rows, which
the compiler vectorizes. Row by row, the updates ran over rows of only 20-50 entries and
the condensation of ``axle4dof`` took a third longer (``docs/continuation.md``, Speed).
The pivots and the arithmetic, back substitution included, are those of the row-wise
elimination, so the solution is the same to the last bit. (A column-oriented back
substitution was 10 % faster still, but changes the rounding, and the default
``axle4dof`` branch is sensitive to it: its step sizes changed from the second point on.)
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["solve_bordered"]


@njit(cache=True)
def _eliminate(cols: np.ndarray, col0: int, n_cols: int, used: np.ndarray, border: np.ndarray,
               pivots_out: np.ndarray, factors: np.ndarray) -> bool:
    """Partial-pivot elimination of columns col0 .. col0+n_cols-1 of a matrix stored
    transposed, ``cols[q, r]`` = entry (row r, column q), in place.

    Pivot rows are chosen among the rows not ``used`` (ties: the first); each pivot row
    index is written to ``pivots_out``. The border rows ``border[b, q]`` are reduced with
    the same pivots. Per pivot, only the columns before ``col0`` and those after the pivot
    column are updated, as in LU: the eliminated columns are zero in the pivot row, and
    their entries are not read again (so not written either). A used row gets the factor
    0 and keeps its values. ``factors`` is workspace (at least one entry per row).
    """
    width, n_rows = cols.shape
    for c in range(n_cols):
        col = col0 + c
        best = -1
        best_val = -1.0
        for r in range(n_rows):
            if not used[r]:
                v = abs(cols[col, r])
                if v > best_val:
                    best_val = v
                    best = r
        if not best_val > 0.0:  # singular, or NaN entries (no pivot found: best stays -1)
            return False
        used[best] = True
        pivots_out[c] = best
        piv = cols[col, best]
        for r in range(n_rows):
            factors[r] = 0.0 if used[r] else cols[col, r] / piv
        for q in range(col0):
            p = cols[q, best]
            for r in range(n_rows):
                cols[q, r] -= factors[r] * p
        for q in range(col + 1, width):
            p = cols[q, best]
            for r in range(n_rows):
                cols[q, r] -= factors[r] * p
        for b in range(border.shape[0]):
            factor = border[b, col] / piv
            if factor != 0.0:
                for q in range(col0):
                    border[b, q] -= factor * cols[q, best]
                for q in range(col + 1, width):
                    border[b, q] -= factor * cols[q, best]
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
    # local columns: [L (n) | I (ni) | R (n) | T | V | rhs (k)], stored transposed: loc[j, column, row]
    width1 = (m + 1) * n + 2 + k
    loc = np.empty((N, width1, mn))
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
    factors = np.empty(max(mn, 2 * n))
    for j in range(N):
        jn = (j + 1) % N
        L = loc[j]
        for r in range(mn):
            g = j * mn + r
            for q in range((m + 1) * n):
                L[q, r] = blocks[j, r, q]
            L[(m + 1) * n, r] = tcol[g]
            L[(m + 1) * n + 1, r] = vcol[g]
            for q in range(k):
                L[(m + 1) * n + 2 + q, r] = rhs[g, q]
        # border restricted to this interval: only interior nodes belong to it alone
        for b in range(2):
            for q in range(width1):
                bloc[b, q] = 0.0
            for q in range(ni):
                bloc[b, n + q] = border[b, (j * m + 1) * n + q]
        for r in range(mn):
            used[r] = False
        if not _eliminate(L, n, ni, used, bloc, piv1[j], factors):
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
                CL[j, a, q] = L[q, r]
                CR[j, a, q] = L[n + ni + q, r]
    # mesh-node border coefficients that were set directly (not via interiors)
    for b in range(2):
        for j in range(N):
            for q in range(n):
                b_mesh[b, j, q] += border[b, j * mn + q]
    # ---- 2. stair elimination of u_1 .. u_{N-1} ----------------------------------------
    # stage columns: [u_j (n) | u_{j+1} (n) | u_0 fill (n) | T | V | rhs (k)], stored transposed
    width2 = 3 * n + 2 + k
    stage = np.zeros((N, width2, 2 * n))
    piv2 = np.empty((N, n), dtype=np.int64)
    active = np.zeros((n, width2))
    # active rows from interval 0: u_1 <- CR_0 (goes to the 'u_j' slot of stage 1), fill <- CL_0
    for a in range(n):
        r = rest1[0, a]
        for q in range(n):
            active[a, q] = loc[0, n + ni + q, r]
            active[a, 2 * n + q] = loc[0, q, r]
        for q in range(2 + k):
            active[a, 3 * n + q] = loc[0, (m + 1) * n + q, r]
    bst = np.zeros((2, width2))
    used2 = np.zeros(2 * n, dtype=np.bool_)
    for j in range(1, N):
        S = stage[j]
        for a in range(n):
            for q in range(width2):
                S[q, a] = active[a, q]
        for a in range(n):
            r = rest1[j, a]
            row = n + a
            for q in range(width2):
                S[q, row] = 0.0
            for q in range(n):
                S[q, row] = loc[j, q, r]
                if j + 1 < N:
                    S[n + q, row] = loc[j, n + ni + q, r]
                else:
                    S[2 * n + q, row] += loc[j, n + ni + q, r]
            for q in range(2 + k):
                S[3 * n + q, row] = loc[j, (m + 1) * n + q, r]
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
        if not _eliminate(S, 0, n, used2, bst, piv2[j], factors):
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
                    active[c, q] = S[n + q, r]
                    active[c, 2 * n + q] = S[2 * n + q, r]
                for q in range(2 + k):
                    active[c, 3 * n + q] = S[3 * n + q, r]
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
                acc = S[3 * n + 2 + q, r] - S[3 * n, r] * x[size - 2, q] - S[3 * n + 1, r] * x[size - 1, q]
                for cc in range(c + 1, n):
                    acc -= S[cc, r] * U[j, cc, q]
                for cc in range(n):
                    acc -= S[n + cc, r] * U[j + 1, cc, q] * (1.0 if j + 1 < N else 0.0)
                    acc -= S[2 * n + cc, r] * U[0, cc, q]
                U[j, c, q] = acc / S[c, r]
    for j in range(N):
        for q in range(k):
            for a in range(n):
                x[j * mn + a, q] = U[j, a, q]
            # interior nodes of interval j, back substitution in elimination order
            for c in range(ni - 1, -1, -1):
                r = piv1[j, c]
                L = loc[j]
                acc = L[(m + 1) * n + 2 + q, r] - L[(m + 1) * n, r] * x[size - 2, q] - L[(m + 1) * n + 1, r] * x[size - 1, q]
                for cc in range(n):
                    acc -= L[cc, r] * U[j, cc, q] + L[n + ni + cc, r] * U[j + 1, cc, q]
                for cc in range(c + 1, ni):
                    acc -= L[n + cc, r] * x[j * mn + n + cc, q]
                x[j * mn + n + c, q] = acc / L[n + c, r]
    return x
