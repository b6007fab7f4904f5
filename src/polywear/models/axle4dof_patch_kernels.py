"""Compiled kernels of ``axle4dof`` with the patch contact (docs/patch_contact.md section 6).

The arm of ``axle4dof`` carries M tread elements at the cell centres ``xi_j`` of the patch
(``xi`` along the body x axis, the heading; j = 0 at the leading edge, ``xi_0 > 0``). Each
element is the derived unit-mass element of :mod:`._axle4dof_generated` (``_patch_element``)
scaled by ``m/M``, with lateral stiffness ``k/M`` and damping ``c/M`` on the carrier and a
LuGre bristle under its share ``s_j`` of the load ``N = N0 - k_z rise_C - c_z dz_C/dt``;
its friction acts at its own position, so the patch's aligning moment sum ``F_j (xi_j - L)``
enters the toe equation. The element fields (deflection y, material rate w, bristle z) are
transported through the patch at ``lambda = V cos(toe0 + alpha) M / L`` (first-order upwind,
inflow 0), as in :mod:`.patch`.

State ``u = (alpha, beta, gamma, alpha', beta', gamma', y_0, w_0, z_0, ..., y_{M-1}, w_{M-1},
z_{M-1})`` (3M + 6); parameter vector: ``axle4dof``'s, then ``L`` and the M load shares.
The mass matrix (3 + M square) is solved by its Schur complement on the body (3 x 3): the
element block is diagonal. The Jacobian is analytic (generated partials, chain rule), as
is df/dV; the running preloads (body at rest at every speed) come from the steady patch on
the held carrier, which is marched (:func:`.patch._march`) and then corrected by one
Newton step in the kernels' dtype, so that complex-step derivatives through it are exact.
"""

import numpy as np
from numba import njit
from numpy import cos, sin

from ..physics.lugre import (
    bristle_rate,
    bristle_rate_partials,
    real_abs,
    stribeck,
    stribeck_dv,
)
from ._axle4dof_generated import (
    _C,
    _C_ALPHA,
    _C_BETA,
    _C_GAMMA,
    _C_Z,
    _CAMBER0,
    _DELTA,
    _EPS,
    _K,
    _K_ALPHA,
    _K_BETA,
    _K_GAMMA,
    _K_Z,
    _M,
    _MU_C,
    _MU_S,
    _N0,
    _PRELOAD_ALPHA,
    _PRELOAD_SPEED,
    _REFERENCE,
    _SIGMA0,
    _SIGMA1,
    _SIGMA2,
    _TOE0,
    _V_S,
    PARAM_NAMES,
    _patch_arm,
    _patch_arm_partials,
    _patch_element,
    _patch_element_partials,
)
from .axle4dof_kernels import _solve
from .patch import _march

__all__ = ["aux", "dfdv", "jac", "preload", "rest_state", "rhs", "rhs_jac_dfdv"]

NB = 3
"""Body coordinates alpha, beta, gamma (then their rates)."""
E0 = 2 * NB
"""Index of the first element state."""
LEN = len(PARAM_NAMES)
"""Index of the patch length L [m] in p; the load shares follow."""
SHARE0 = LEN + 1


@njit(cache=True, error_model="numpy")
def _zero(u, V, p):
    """0 of the common dtype of u, V and p."""
    return 0.0 * (u[0] + V + p[0])


@njit(cache=True, error_model="numpy")
def _transport(u, V, p):
    """(M, lambda, dlambda/dalpha, dlambda/dV): the upwind transport rate [1/s]."""
    n_el = (u.shape[0] - E0) // 3
    psi = p[_TOE0] + u[0]
    scale = n_el / p[LEN]
    return n_el, V * cos(psi) * scale, -V * sin(psi) * scale, cos(psi) * scale


@njit(cache=True, error_model="numpy")
def _position(p, n_el, j):
    """Cell centre xi_j [m] of element j along the heading (leading edge at +L/2)."""
    return p[LEN] * (0.5 - (j + 0.5) / n_el)


@njit(cache=True, error_model="numpy")
def _evaluate(u, V, p, P):
    """Mass-matrix blocks, forces and per-element LuGre terms at u (preload P, 3).

    Returns (A (3,3) body block, Bv (M,3) body-element coupling, Dm (M,) element masses,
    Qb (3,) and Qe (M,) generalized forces, load N [N], clamped, GN (3,), per element:
    GF (M,4), v, G(v), z', f (per unit load), F [N])."""
    zero = _zero(u, V, p)
    dt = np.asarray(zero).dtype
    n_el = (u.shape[0] - E0) // 3
    A = np.empty((NB, NB), dtype=dt)
    h = np.empty(NB, dtype=dt)
    GN = np.empty(NB, dtype=dt)
    rise = _patch_arm(u, V, p, A, h, GN)
    load = p[_N0] - p[_K_Z] * rise
    for i in range(NB):
        load -= p[_C_Z] * GN[i] * u[NB + i]
    clamped = load.real < 0.0
    if clamped:
        load = 0.0 * load
    me, ke, ce = p[_M] / n_el, p[_K] / n_el, p[_C] / n_el
    stiff = (p[_K_ALPHA], p[_K_BETA], p[_K_GAMMA])
    damp = (p[_C_ALPHA], p[_C_BETA], p[_C_GAMMA])
    Qb = np.empty(NB, dtype=dt)
    for i in range(NB):
        Qb[i] = h[i] + load * GN[i] + P[i] - stiff[i] * u[i] - damp[i] * u[NB + i]
    Bv = np.empty((n_el, NB), dtype=dt)
    Dm = np.empty(n_el, dtype=dt)
    Qe = np.empty(n_el, dtype=dt)
    GF = np.empty((n_el, 4), dtype=dt)
    vs = np.empty(n_el, dtype=dt)
    gs = np.empty(n_el, dtype=dt)
    zds = np.empty(n_el, dtype=dt)
    fs = np.empty(n_el, dtype=dt)
    Fs = np.empty(n_el, dtype=dt)
    Me = np.empty((4, 4), dtype=dt)
    he = np.empty(4, dtype=dt)
    gf = np.empty(4, dtype=dt)
    e = np.empty(3, dtype=dt)
    for j in range(n_el):
        i = E0 + 3 * j
        e[0] = _position(p, n_el, j) + zero
        e[1] = u[i]
        e[2] = u[i + 1]
        v = _patch_element(u, e, V, p, Me, he, gf)
        g = stribeck(v, p[_MU_S], p[_MU_C], p[_V_S], p[_DELTA])
        zd = bristle_rate(v, u[i + 2], p[_SIGMA0], g)
        f = p[_SIGMA0] * u[i + 2] + p[_SIGMA1] * zd + p[_SIGMA2] * v
        F = load * p[SHARE0 + j] * f
        for a in range(NB):
            for b in range(NB):
                A[a, b] += me * Me[a, b]
            Bv[j, a] = me * Me[a, 3]
            Qb[a] += me * he[a] + F * gf[a]
        Dm[j] = me * Me[3, 3]
        Qe[j] = me * he[3] + F * gf[3] - ke * e[1] - ce * e[2]
        for a in range(4):
            GF[j, a] = gf[a]
        vs[j], gs[j], zds[j], fs[j], Fs[j] = v, g, zd, f, F
    return A, Bv, Dm, Qb, Qe, load, clamped, GN, GF, vs, gs, zds, fs, Fs


@njit(cache=True, error_model="numpy")
def _schur(A, Bv, Dm):
    """Schur complement S = A - sum_j Bv_j Bv_j^T / Dm_j of the element block (3 x 3)."""
    S = A.copy()
    for j in range(Dm.shape[0]):
        for a in range(NB):
            for b in range(NB):
                S[a, b] -= Bv[j, a] * Bv[j, b] / Dm[j]
    return S


@njit(cache=True, error_model="numpy")
def _body_residual(Bv, Dm, X):
    """X[:3] - sum_j Bv_j X[3 + j] / Dm_j, column by column (3, k)."""
    R = X[:NB, :].copy()
    for j in range(Dm.shape[0]):
        for a in range(NB):
            for c in range(X.shape[1]):
                R[a, c] -= Bv[j, a] * X[NB + j, c] / Dm[j]
    return R


@njit(cache=True, error_model="numpy")
def _apply_inverse(S, Bv, Dm, X):
    """X <- (mass matrix)^-1 X in place (X: 3 + M rows, body first), by the Schur complement."""
    R = _body_residual(Bv, Dm, X)
    _solve(S, R)
    for c in range(X.shape[1]):
        for a in range(NB):
            X[a, c] = R[a, c]
        for j in range(Dm.shape[0]):
            s = X[NB + j, c]
            for a in range(NB):
                s -= Bv[j, a] * R[a, c]
            X[NB + j, c] = s / Dm[j]


@njit(cache=True, error_model="numpy")
def _partials(u, V, p, s, acc):
    """B = dQ/d(u, V) - d(M a)/du at fixed accelerations ``acc`` (3 + M) (rows body then
    elements, columns the states then V), and per element dz'/dv, dz'/dz, dv/d(element
    states, 8) and dv/dV, for the state ``s`` of :func:`_evaluate` (without dP/dV)."""
    A, Dm, load, clamped, GN, GF, vs, gs, fs, Fs = s[0], s[2], s[5], s[6], s[7], s[8], s[9], s[10], s[12], s[13]
    dt = A.dtype
    n_el = Dm.shape[0]
    n = E0 + 3 * n_el
    B = np.zeros((NB + n_el, n + 1), dtype=dt)
    dMa = np.empty((NB, NB), dtype=dt)
    dh = np.empty((NB, 2 * NB), dtype=dt)
    dh_dv = np.empty(NB, dtype=dt)
    dGN = np.empty((NB, NB), dtype=dt)
    a3 = acc[:NB].copy()
    _patch_arm_partials(u, a3, V, p, dMa, dh, dh_dv, dGN)
    dN = np.zeros(2 * NB, dtype=dt)
    if not clamped:
        for k in range(NB):
            dN[k] = -p[_K_Z] * GN[k]
            dN[NB + k] = -p[_C_Z] * GN[k]
            for i in range(NB):
                dN[k] -= p[_C_Z] * dGN[i, k] * u[NB + i]
    stiff = (p[_K_ALPHA], p[_K_BETA], p[_K_GAMMA])
    damp = (p[_C_ALPHA], p[_C_BETA], p[_C_GAMMA])
    for i in range(NB):
        for k in range(NB):
            B[i, k] = dh[i, k] - dMa[i, k] + load * dGN[i, k] + GN[i] * dN[k]
            B[i, NB + k] = dh[i, NB + k] + GN[i] * dN[NB + k]
        B[i, i] -= stiff[i]
        B[i, NB + i] -= damp[i]
        B[i, n] = dh_dv[i]

    me, ke, ce = p[_M] / n_el, p[_K] / n_el, p[_C] / n_el
    dzd_dv = np.empty(n_el, dtype=dt)
    dzd_dz = np.empty(n_el, dtype=dt)
    dv = np.empty((n_el, 8), dtype=dt)
    dv_dV = np.empty(n_el, dtype=dt)
    dMe = np.empty((4, 4), dtype=dt)
    dhe = np.empty((4, 8), dtype=dt)
    dGF = np.empty((4, 4), dtype=dt)
    dvj = np.empty(8, dtype=dt)
    e = np.empty(3, dtype=dt)
    a4 = np.empty(4, dtype=dt)
    dF = np.empty(8, dtype=dt)
    col = np.empty(8, dtype=np.int64)
    zero = 0.0 * load
    for k in range(NB):
        col[k] = k
        col[4 + k] = NB + k
    for j in range(n_el):
        i = E0 + 3 * j
        r = NB + j
        e[0] = _position(p, n_el, j) + zero
        e[1] = u[i]
        e[2] = u[i + 1]
        for a in range(NB):
            a4[a] = acc[a]
        a4[3] = acc[r]
        dvdv = _patch_element_partials(u, e, a4, V, p, dMe, dhe, dGF, dvj)
        dg = stribeck_dv(vs[j], p[_MU_S], p[_MU_C], p[_V_S], p[_DELTA])
        dzv, dzz = bristle_rate_partials(vs[j], u[i + 2], p[_SIGMA0], gs[j], dg)
        share = p[SHARE0 + j]
        df_dv = p[_SIGMA1] * dzv + p[_SIGMA2]
        df_dz = p[_SIGMA0] + p[_SIGMA1] * dzz
        col[3] = i
        col[7] = i + 1
        for k in range(8):
            dF[k] = load * share * df_dv * dvj[k]
        for k in range(NB):
            dF[k] += share * fs[j] * dN[k]
            dF[4 + k] += share * fs[j] * dN[NB + k]
        dF_dz = load * share * df_dz
        dF_dV = load * share * df_dv * dvdv
        for a in range(4):
            row = a if a < NB else r
            for k in range(8):
                val = me * dhe[a, k] + GF[j, a] * dF[k]
                if k < 4:
                    val += Fs[j] * dGF[a, k] - me * dMe[a, k]
                B[row, col[k]] += val
            B[row, i + 2] += GF[j, a] * dF_dz
            B[row, n] += GF[j, a] * dF_dV
        B[r, i] -= ke
        B[r, i + 1] -= ce
        dzd_dv[j], dzd_dz[j], dv_dV[j] = dzv, dzz, dvdv
        for k in range(8):
            dv[j, k] = dvj[k]
    return B, dzd_dv, dzd_dz, dv, dv_dV


@njit(cache=True, error_model="numpy")
def _accelerations(u, V, p, P):
    """:func:`_evaluate` and the accelerations (3 + M, 1): body, then element material ones."""
    s = _evaluate(u, V, p, P)
    A, Bv, Dm, Qb, Qe = s[0], s[1], s[2], s[3], s[4]
    X = np.empty((NB + Dm.shape[0], 1), dtype=A.dtype)
    for a in range(NB):
        X[a, 0] = Qb[a]
    for j in range(Dm.shape[0]):
        X[NB + j, 0] = Qe[j]
    S = _schur(A, Bv, Dm)
    _apply_inverse(S, Bv, Dm, X)
    return s, S, X


@njit(cache=True, error_model="numpy")
def _upstream(u, i, j, k):
    """Value of field k (0 y, 1 w, 2 z) of the element ahead of element j (0 at inflow)."""
    if j == 0:
        return 0.0 * u[i]
    return u[i - 3 + k]


@njit(cache=True, error_model="numpy")
def _rhs_out(u, V, p, s, X, out):
    """du/dt into out from :func:`_accelerations`."""
    zds = s[11]
    n_el, lam, _, _ = _transport(u, V, p)
    for a in range(NB):
        out[a] = u[NB + a]
        out[NB + a] = X[a, 0]
    for j in range(n_el):
        i = E0 + 3 * j
        out[i] = u[i + 1] - lam * (u[i] - _upstream(u, i, j, 0))
        out[i + 1] = X[NB + j, 0] - lam * (u[i + 1] - _upstream(u, i, j, 1))
        out[i + 2] = zds[j] - lam * (u[i + 2] - _upstream(u, i, j, 2))


@njit(cache=True, error_model="numpy")
def _held_steady(u, V, p):
    """Residual g and block-bidiagonal Jacobian (M, 3, 3) of the element equations on the
    held carrier (body at its state in u with zero acceleration) at u, and d g/dV; also the
    evaluation ``s`` and partials ``d`` there (accelerations: body 0, elements Qe/Dm)."""
    zero = _zero(u, V, p)
    P = np.zeros(NB, dtype=np.asarray(zero).dtype)
    s = _evaluate(u, V, p, P)
    Dm, Qe, zds = s[2], s[4], s[11]
    n_el, lam, _, dlam_dv = _transport(u, V, p)
    acc = np.zeros(NB + n_el, dtype=Dm.dtype)
    for j in range(n_el):
        acc[NB + j] = Qe[j] / Dm[j]
    d = _partials(u, V, p, s, acc)
    B, dzd_dv, dzd_dz, dv, dv_dV = d
    n = u.shape[0]
    g = np.empty(3 * n_el, dtype=Dm.dtype)
    gv = np.empty(3 * n_el, dtype=Dm.dtype)
    Jb = np.zeros((n_el, 3, 3), dtype=Dm.dtype)
    for j in range(n_el):
        i = E0 + 3 * j
        r = NB + j
        dy = u[i] - _upstream(u, i, j, 0)
        dw = u[i + 1] - _upstream(u, i, j, 1)
        dz = u[i + 2] - _upstream(u, i, j, 2)
        g[3 * j] = u[i + 1] - lam * dy
        g[3 * j + 1] = acc[r] - lam * dw
        g[3 * j + 2] = zds[j] - lam * dz
        gv[3 * j] = -dlam_dv * dy
        gv[3 * j + 1] = B[r, n] / Dm[j] - dlam_dv * dw
        gv[3 * j + 2] = dzd_dv[j] * dv_dV[j] - dlam_dv * dz
        Jb[j, 0, 0] = -lam
        Jb[j, 0, 1] = 1.0 + zero
        for k in range(3):
            Jb[j, 1, k] = B[r, i + k] / Dm[j]
        Jb[j, 1, 1] -= lam
        Jb[j, 2, 0] = dzd_dv[j] * dv[j, 3]
        Jb[j, 2, 1] = dzd_dv[j] * dv[j, 7]
        Jb[j, 2, 2] = dzd_dz[j] - lam
    return g, Jb, gv, lam, s, d


@njit(cache=True, error_model="numpy")
def _block_solve(Jb, lam, rhs):
    """Solve the lower block-bidiagonal system (diagonal blocks Jb, sub-diagonal lambda I)
    for x, in place of rhs (3M)."""
    n_el = Jb.shape[0]
    blk = np.empty((3, 1), dtype=rhs.dtype)
    for j in range(n_el):
        for k in range(3):
            blk[k, 0] = rhs[3 * j + k]
            if j > 0:
                blk[k, 0] -= lam * rhs[3 * j - 3 + k]
        _solve(Jb[j].copy(), blk)
        for k in range(3):
            rhs[3 * j + k] = blk[k, 0]


@njit(cache=True, error_model="numpy")
def rest_state(V, p, u0):
    """Steady rolling with the carrier held at alpha = beta = gamma = 0 (rates 0): fills u0
    (3M + 6) and returns True, or False if the march fails. The march (float, on the real
    parts) solves the element equations as a tread1dof patch (scaled by the projection
    cos(camber0) of y_B on the road plane); one Newton step in u0's dtype makes the result
    exact to rounding and carries complex-step perturbations of V and p."""
    n_el = (u0.shape[0] - E0) // 3
    Vr = V.real
    g = np.cos(p[_CAMBER0].real)
    slip = np.sin(p[_TOE0].real) - p[_EPS].real * np.sin(p[_CAMBER0].real)
    toe = np.arcsin(slip)
    q = np.empty(13 + n_el)
    q[0] = p[_M].real / g**2
    q[1] = p[_K].real / g**2
    q[2] = p[_C].real / g**2
    q[3] = p[_N0].real
    q[4] = toe
    q[5] = p[_SIGMA0].real
    q[6] = p[_SIGMA1].real
    q[7] = p[_SIGMA2].real
    q[8] = p[_MU_S].real
    q[9] = p[_MU_C].real
    q[10] = p[_V_S].real
    q[11] = p[_DELTA].real
    q[12] = p[LEN].real * np.cos(toe) / np.cos(p[_TOE0].real)
    for j in range(n_el):
        q[13 + j] = p[SHARE0 + j].real
    marched = np.empty(3 * n_el)
    if Vr <= 0.0 or not _march(Vr, q, n_el, marched):
        return False
    zero = 0.0 * (V + p[0])
    for i in range(E0):
        u0[i] = zero
    for j in range(n_el):
        u0[E0 + 3 * j] = marched[3 * j] / g + zero
        u0[E0 + 3 * j + 1] = marched[3 * j + 1] / g + zero
        u0[E0 + 3 * j + 2] = marched[3 * j + 2] + zero
    res, Jb, _gv, lam, _s, _d = _held_steady(u0, V, p)
    _block_solve(Jb, lam, res)
    for k in range(3 * n_el):
        u0[E0 + k] -= res[k]
    return True


@njit(cache=True, error_model="numpy")
def preload(V, p, P):
    """Constant generalized preloads P [N m] on alpha, beta, gamma, as for the point
    contact: running (r = 0) holds the body at rest in steady rolling at every speed (the
    negative of the body's generalized force, net of the elements' inertia, at
    :func:`rest_state`); unloaded (r = 1) the negative generalized force of N0 at the
    reference pose; 0 < r < 1 blends them. Uses the cache of ``p`` at its own speed."""
    if p[_PRELOAD_SPEED] == V:
        for i in range(NB):
            P[i] = p[_PRELOAD_ALPHA + i]
        return
    n_el = p.shape[0] - SHARE0
    r = p[_REFERENCE].real
    for i in range(NB):
        P[i] = 0.0 * V
    u0 = np.empty(E0 + 3 * n_el, dtype=P.dtype)
    if r > 0.0:
        for i in range(u0.shape[0]):
            u0[i] = 0.0 * V
        A = np.empty((NB, NB), dtype=P.dtype)
        h = np.empty(NB, dtype=P.dtype)
        GN = np.empty(NB, dtype=P.dtype)
        _patch_arm(u0, V, p, A, h, GN)
        for i in range(NB):
            P[i] = -r * p[_N0] * GN[i]
    if r < 1.0:
        if not rest_state(V, p, u0):
            for i in range(NB):
                P[i] = np.nan + 0.0 * V
            return
        zero = np.zeros(NB, dtype=P.dtype)
        s = _evaluate(u0, V, p, zero)
        Bv, Dm, Qb, Qe = s[1], s[2], s[3], s[4]
        for i in range(NB):
            held = Qb[i]
            for j in range(n_el):
                held -= Bv[j, i] * Qe[j] / Dm[j]
            P[i] -= (1.0 - r) * held


@njit(cache=True, error_model="numpy")
def _preload_dv(V, p, dP):
    """dP/dV of :func:`preload` (its running part): the held body force along the rest
    state's speed derivative du0/dV (implicit, block-bidiagonal)."""
    n_el = p.shape[0] - SHARE0
    r = p[_REFERENCE].real
    for i in range(NB):
        dP[i] = 0.0 * V
    if r >= 1.0:
        return
    u0 = np.empty(E0 + 3 * n_el, dtype=dP.dtype)
    if not rest_state(V, p, u0):
        for i in range(NB):
            dP[i] = np.nan + 0.0 * V
        return
    _g, Jb, gv, lam, s, d = _held_steady(u0, V, p)
    for k in range(gv.shape[0]):
        gv[k] = -gv[k]
    _block_solve(Jb, lam, gv)  # du0/dV of the elements
    B = d[0]
    n = u0.shape[0]
    X = np.empty((NB + n_el, 1), dtype=dP.dtype)
    for row in range(NB + n_el):
        t = B[row, n]
        for j in range(n_el):
            i = E0 + 3 * j
            for k in range(3):
                t += B[row, i + k] * gv[3 * j + k]
        X[row, 0] = t
    R = _body_residual(s[1], s[2], X)
    for i in range(NB):
        dP[i] = -(1.0 - r) * R[i, 0]


@njit(cache=True, error_model="numpy")
def _jacobian(u, V, p, with_dv, f, J, fv):
    """Fill f, J and (if with_dv) fv."""
    n = u.shape[0]
    zero = _zero(u, V, p)
    P = np.empty(NB, dtype=np.asarray(zero).dtype)
    preload(V, p, P)
    s, S, X = _accelerations(u, V, p, P)
    _rhs_out(u, V, p, s, X, f)
    B, dzd_dv, dzd_dz, dv, dv_dV = _partials(u, V, p, s, X[:, 0])
    if with_dv:
        dP = np.empty(NB, dtype=P.dtype)
        _preload_dv(V, p, dP)
        for i in range(NB):
            B[i, n] += dP[i]
    _apply_inverse(S, s[1], s[2], B)
    n_el, lam, dlam_da, dlam_dv = _transport(u, V, p)
    for r_ in range(n):
        for c in range(n):
            J[r_, c] = 0.0 * zero
    for a in range(NB):
        J[a, NB + a] = 1.0 + zero
        for c in range(n):
            J[NB + a, c] = B[a, c]
        fv[a] = zero
        fv[NB + a] = B[a, n]
    for j in range(n_el):
        i = E0 + 3 * j
        r = NB + j
        dy = u[i] - _upstream(u, i, j, 0)
        dw = u[i + 1] - _upstream(u, i, j, 1)
        dz = u[i + 2] - _upstream(u, i, j, 2)
        J[i, i] = -lam
        J[i, i + 1] = 1.0 + zero
        J[i, 0] -= dlam_da * dy
        for c in range(n):
            J[i + 1, c] = B[r, c]
        J[i + 1, i + 1] -= lam
        J[i + 1, 0] -= dlam_da * dw
        for k in range(NB):
            J[i + 2, k] = dzd_dv[j] * dv[j, k]
            J[i + 2, NB + k] = dzd_dv[j] * dv[j, 4 + k]
        J[i + 2, i] = dzd_dv[j] * dv[j, 3]
        J[i + 2, i + 1] = dzd_dv[j] * dv[j, 7]
        J[i + 2, i + 2] = dzd_dz[j] - lam
        J[i + 2, 0] -= dlam_da * dz
        if j > 0:
            J[i, i - 3] += lam
            J[i + 1, i - 2] += lam
            J[i + 2, i - 1] += lam
        fv[i] = -dlam_dv * dy
        fv[i + 1] = B[r, n] - dlam_dv * dw
        fv[i + 2] = dzd_dv[j] * dv_dV[j] - dlam_dv * dz


@njit(cache=True, error_model="numpy")
def rhs(u, V, p, out):
    """du/dt [rad/s (3), rad/s^2 (3), then m/s, m/s^2, m/s per element]."""
    zero = _zero(u, V, p)
    P = np.empty(NB, dtype=np.asarray(zero).dtype)
    preload(V, p, P)
    s, _S, X = _accelerations(u, V, p, P)
    _rhs_out(u, V, p, s, X, out)


@njit(cache=True, error_model="numpy")
def jac(u, V, p, out):
    """df/du (3M + 6 square; the acceleration rows are full)."""
    f = np.empty(u.shape[0], dtype=out.dtype)
    fv = np.empty(u.shape[0], dtype=out.dtype)
    _jacobian(u, V, p, False, f, out, fv)


@njit(cache=True, error_model="numpy")
def dfdv(u, V, p, out):
    """df/dV [per m/s]: through the sliding velocities, the transport rate, the wheel-spin
    rate V/R_e and the running preloads."""
    f = np.empty(u.shape[0], dtype=out.dtype)
    J = np.empty((u.shape[0], u.shape[0]), dtype=out.dtype)
    _jacobian(u, V, p, True, f, J, out)


@njit(cache=True, error_model="numpy")
def rhs_jac_dfdv(u, V, p, f, J, fv):
    """:func:`rhs`, :func:`jac` and :func:`dfdv` at once."""
    _jacobian(u, V, p, True, f, J, fv)


@njit(cache=True, error_model="numpy")
def aux(u, V, p, out):
    """Power-equivalent sliding velocity P/F [m/s] (friction power P = sum F_j v_j over the
    total lateral force F; the load-weighted mean v_j where F = 0), total friction force F
    [N], normal load N [N], contact lost [0/1], sliding velocity of the trailing element
    [m/s], share of the load on elements whose bristle is past half its sliding deflection."""
    zero = _zero(u, V, p)
    P = np.zeros(NB, dtype=np.asarray(zero).dtype)
    s = _evaluate(u, V, p, P)
    load, clamped, vs, gs, Fs = s[5], s[6], s[9], s[10], s[13]
    n_el = vs.shape[0]
    force = zero
    power = zero
    vmean = zero
    sliding = 0.0
    for j in range(n_el):
        force += Fs[j]
        power += Fs[j] * vs[j]
        vmean += p[SHARE0 + j] * vs[j]
        if (p[_SIGMA0] * real_abs(u[E0 + 3 * j + 2])).real > 0.5 * gs[j].real:
            sliding += p[SHARE0 + j].real
    out[0] = power / force if force.real != 0.0 else vmean
    out[1] = force
    out[2] = load
    out[3] = 1.0 + zero if clamped else zero
    out[4] = vs[n_el - 1]
    out[5] = sliding + zero
