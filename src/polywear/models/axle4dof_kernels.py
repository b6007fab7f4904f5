"""Compiled kernels of model ``axle4dof``: ``rhs``, ``jac``, ``dfdv``, ``rhs_jac_dfdv``, ``aux``.

The hand-written numeric part around the generated symbolic expressions of
:mod:`._axle4dof_generated` (mass matrix, inertial forces, contact gradients, sliding
velocity and their partials, derived in :mod:`.axle4dof_derivation`): the LuGre force
(:mod:`polywear.physics.lugre`), the contact-loss clamp, springs, dampers, preloads, the
4x4 linear solve for the accelerations and the chain rule that assembles the Jacobian
from the generated partials.

State ``u = (alpha, beta, gamma, x, alpha', beta', gamma', x', z)``; parameter vector
``p`` laid out by ``PARAM_NAMES`` of the generated module. Each kernel ``(u, V, p, out)``
fills ``out``; ``u``, ``V`` and ``p`` share one dtype, float or complex (complex-step
derivatives).
"""

import numpy as np
from numba import njit
from numpy import sin

from ..physics.lugre import (
    bristle_rate,
    bristle_rate_partials,
    real_sign,
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
    _contact,
    _contact_partials,
    _inertia,
    _inertia_partials,
    _sliding,
    _sliding_partials,
)

__all__ = ["aux", "dfdv", "jac", "preload", "rhs", "rhs_jac_dfdv", "rhs_python", "running_equilibrium"]

_NQ = 4
"""Generalized coordinates alpha, beta, gamma, x (then their rates)."""
_ZB = 8
"""Index of the bristle deflection z in the state."""


@njit(cache=True, error_model="numpy")
def _zero(u, V, p):
    """0 of the common dtype of u, V and p."""
    return 0.0 * (u[0] + V + p[0])


@njit(cache=True, error_model="numpy")
def _solve(M, B):
    """Solve M X = B in place of B (B of shape (4, k)); M symmetric positive definite."""
    A = M.copy()
    n = A.shape[0]
    for j in range(n):
        for i in range(j + 1, n):
            f = A[i, j] / A[j, j]
            for k in range(j, n):
                A[i, k] -= f * A[j, k]
            for k in range(B.shape[1]):
                B[i, k] -= f * B[j, k]
    for j in range(n - 1, -1, -1):
        for k in range(B.shape[1]):
            s = B[j, k]
            for i in range(j + 1, n):
                s -= A[j, i] * B[i, k]
            B[j, k] = s / A[j, j]


@njit(cache=True, error_model="numpy")
def running_equilibrium(V, p, u0):
    """Steady state of the running reference: alpha = beta = gamma = 0, rates 0,
    z0 = sgn(v_r0) G(v_r0)/sigma0, k x0 = F0 G_F,x; fills u0, returns the friction force F0 [N]."""
    vr0 = V * (sin(p[_TOE0]) - p[_EPS] * sin(p[_CAMBER0]))
    g0 = stribeck(vr0, p[_MU_S], p[_MU_C], p[_V_S], p[_DELTA])
    sgn = real_sign(vr0)
    mu0 = sgn * g0 + p[_SIGMA2] * vr0
    for i in range(u0.shape[0]):
        u0[i] = 0.0 * V
    GF = np.empty(_NQ, dtype=u0.dtype)
    GN = np.empty(_NQ, dtype=u0.dtype)
    _contact(u0, p, GF, GN)
    u0[3] = p[_N0] * mu0 * GF[3] / p[_K]
    u0[_ZB] = sgn * g0 / p[_SIGMA0]
    return p[_N0] * mu0


@njit(cache=True, error_model="numpy")
def _running_force_dv(V, p):
    """dF0/dV [N s/m] of the running equilibrium's friction force."""
    slip = sin(p[_TOE0]) - p[_EPS] * sin(p[_CAMBER0])
    vr0 = V * slip
    dmu0 = real_sign(vr0) * stribeck_dv(vr0, p[_MU_S], p[_MU_C], p[_V_S], p[_DELTA]) + p[_SIGMA2]
    return p[_N0] * dmu0 * slip


@njit(cache=True, error_model="numpy")
def preload(V, p, P):
    """Constant generalized preloads P [N m, N m, N m, N].

    running (reference r = 0): the negative generalized forces of friction and load at
    the running equilibrium (so alpha = beta = gamma = 0 there at every speed);
    unloaded (r = 1): the negative generalized force of N0 at alpha = beta = gamma = 0
    only. A value 0 < r < 1 blends the two linearly: the unloaded equilibrium solve
    follows r from 0 to 1 (a homotopy from the running state). When ``p`` caches the
    preloads of this very speed (``preload_speed == V``), those are used."""
    if p[_PRELOAD_SPEED] == V:
        for i in range(_NQ - 1):
            P[i] = p[_PRELOAD_ALPHA + i]
        P[3] = 0.0 * V
        return
    r = p[_REFERENCE].real
    u0 = np.empty(_ZB + 1, dtype=P.dtype)
    GF = np.empty(_NQ, dtype=P.dtype)
    GN = np.empty(_NQ, dtype=P.dtype)
    for i in range(_NQ):
        P[i] = 0.0 * V
    if r > 0.0:
        for i in range(u0.shape[0]):
            u0[i] = 0.0 * V
        _contact(u0, p, GF, GN)
        for i in range(_NQ - 1):
            P[i] = -r * p[_N0] * GN[i]
    if r < 1.0:
        F0 = running_equilibrium(V, p, u0)
        _contact(u0, p, GF, GN)
        for i in range(_NQ - 1):
            P[i] -= (1.0 - r) * (F0 * GF[i] + p[_N0] * GN[i])


@njit(cache=True, error_model="numpy")
def _preload_dv(V, p, dP):
    """dP/dV of :func:`preload` (from the running part only)."""
    r = p[_REFERENCE].real
    for i in range(_NQ):
        dP[i] = 0.0 * V
    if r >= 1.0:
        return
    u0 = np.empty(_ZB + 1, dtype=dP.dtype)
    F0 = running_equilibrium(V, p, u0)
    dF0 = _running_force_dv(V, p)
    GF = np.empty(_NQ, dtype=dP.dtype)
    GN = np.empty(_NQ, dtype=dP.dtype)
    dGF = np.empty((_NQ, _NQ), dtype=dP.dtype)
    dGN = np.empty((_NQ, _NQ), dtype=dP.dtype)
    _contact(u0, p, GF, GN)
    _contact_partials(u0, p, dGF, dGN)
    dx0 = dF0 * GF[3] / p[_K]
    for i in range(_NQ - 1):
        dP[i] = -(1.0 - r) * (dF0 * GF[i] + (F0 * dGF[i, 3] + p[_N0] * dGN[i, 3]) * dx0)


@njit(cache=True, error_model="numpy")
def _workspace(u, V, p):
    """A zero of the common dtype and empty M (4, 4), Q (4, 1), G_F, G_N for :func:`_evaluate`."""
    zero = _zero(u, V, p)
    M = np.empty((_NQ, _NQ), dtype=np.asarray(zero).dtype)
    return zero, M, np.empty((_NQ, 1), dtype=M.dtype), np.empty(_NQ, dtype=M.dtype), np.empty(_NQ, dtype=M.dtype)


@njit(cache=True, error_model="numpy")
def _evaluate(u, V, p, M, Q, GF, GN):
    """Fill M, the total generalized force Q (4, 1), G_F and G_N at u;
    return (v_r, G(v_r), z', F, N, clamped)."""
    h = np.empty(_NQ, dtype=Q.dtype)
    P = np.empty(_NQ, dtype=Q.dtype)
    _inertia(u, V, p, M, h)
    rise = _contact(u, p, GF, GN)
    preload(V, p, P)
    vr = _sliding(u, V, p)
    load = p[_N0] - p[_K_Z] * rise
    for i in range(_NQ):
        load -= p[_C_Z] * GN[i] * u[_NQ + i]
    clamped = load.real < 0.0
    if clamped:
        load = 0.0 * load
    g = stribeck(vr, p[_MU_S], p[_MU_C], p[_V_S], p[_DELTA])
    zd = bristle_rate(vr, u[_ZB], p[_SIGMA0], g)
    force = load * (p[_SIGMA0] * u[_ZB] + p[_SIGMA1] * zd + p[_SIGMA2] * vr)
    stiff = (p[_K_ALPHA], p[_K_BETA], p[_K_GAMMA], p[_K])
    damp = (p[_C_ALPHA], p[_C_BETA], p[_C_GAMMA], p[_C])
    for i in range(_NQ):
        Q[i, 0] = h[i] + force * GF[i] + load * GN[i] + P[i] - stiff[i] * u[i] - damp[i] * u[_NQ + i]
    return vr, g, zd, force, load, clamped


@njit(cache=True, error_model="numpy")
def _accelerations(u, V, p):
    """:func:`_evaluate` at u with Q solved for the accelerations M^-1 Q (4, 1);
    returns (zero, M, Q, G_F, G_N, v_r, G(v_r), z', F, N, clamped)."""
    zero, M, Q, GF, GN = _workspace(u, V, p)
    vr, g, zd, force, load, clamped = _evaluate(u, V, p, M, Q, GF, GN)
    _solve(M, Q)
    return zero, M, Q, GF, GN, vr, g, zd, force, load, clamped


@njit(cache=True, error_model="numpy")
def _first_order(u, V, p, s):
    """Partials that df/du and df/dV share, at the result ``s`` of :func:`_accelerations`:
    (d(M a)/dq, dh/d(q, q'), dh/dV, dv_r/d(q, q'), dv_r/dV, dz'/dv_r, dz'/dz, dF/dv_r)."""
    _zero, _M, Q, _GF, _GN, vr, g, _zd, _force, load, _clamped = s
    dMa = np.empty((_NQ, _NQ), dtype=Q.dtype)
    dh = np.empty((_NQ, 2 * _NQ), dtype=Q.dtype)
    dh_dv = np.empty(_NQ, dtype=Q.dtype)
    _inertia_partials(u, Q[:, 0].copy(), V, p, dMa, dh, dh_dv)
    dvr = np.empty(2 * _NQ, dtype=Q.dtype)
    dvr_dv = _sliding_partials(u, V, p, dvr)
    dg = stribeck_dv(vr, p[_MU_S], p[_MU_C], p[_V_S], p[_DELTA])
    dzd_dvr, dzd_dz = bristle_rate_partials(vr, u[_ZB], p[_SIGMA0], g, dg)
    dF_dvr = load * (p[_SIGMA1] * dzd_dvr + p[_SIGMA2])
    return dMa, dh, dh_dv, dvr, dvr_dv, dzd_dvr, dzd_dz, dF_dvr


@njit(cache=True, error_model="numpy")
def _jac_columns(u, p, s, d, B):
    """B[:, :9] = dQ/d(q, q', z) minus d(M a)/dq: M^-1 of it are the acceleration rows of df/du
    (``s``, ``d``: results of :func:`_accelerations`, :func:`_first_order`)."""
    n2 = 2 * _NQ
    _zero, _M, _Q, GF, GN, vr, _g, zd, force, load, clamped = s
    dMa, dh, _dh_dv, dvr, _dvr_dv, _dzd_dvr, dzd_dz, dF_dvr = d
    dGF = np.empty((_NQ, _NQ), dtype=B.dtype)
    dGN = np.empty((_NQ, _NQ), dtype=B.dtype)
    _contact_partials(u, p, dGF, dGN)
    mu = p[_SIGMA0] * u[_ZB] + p[_SIGMA1] * zd + p[_SIGMA2] * vr
    dF_dz = load * (p[_SIGMA0] + p[_SIGMA1] * dzd_dz)

    # dN/d(q, q'): N = N0 - k_z rise(q) - c_z G_N(q).q', with d rise/dq = G_N
    dN = np.zeros(n2, dtype=B.dtype)
    if not clamped:
        for k in range(_NQ):
            dN[k] = -p[_K_Z] * GN[k]
            dN[_NQ + k] = -p[_C_Z] * GN[k]
            for i in range(_NQ):
                dN[k] -= p[_C_Z] * dGN[i, k] * u[_NQ + i]

    stiff = (p[_K_ALPHA], p[_K_BETA], p[_K_GAMMA], p[_K])
    damp = (p[_C_ALPHA], p[_C_BETA], p[_C_GAMMA], p[_C])
    for i in range(_NQ):
        for k in range(n2):
            dF = dF_dvr * dvr[k] + mu * dN[k]
            B[i, k] = dh[i, k] + GF[i] * dF + GN[i] * dN[k]
        for k in range(_NQ):
            B[i, k] += force * dGF[i, k] + load * dGN[i, k] - dMa[i, k]
        B[i, i] -= stiff[i]
        B[i, _NQ + i] -= damp[i]
        B[i, n2] = GF[i] * dF_dz


@njit(cache=True, error_model="numpy")
def _dfdv_column(V, p, s, d, B, col):
    """B[:, col] = dQ/dV: M^-1 of it are the acceleration rows of df/dV
    (through v_r, the wheel-spin rate V/R_e and the running preloads)."""
    GF = s[3]
    _dMa, _dh, dh_dv, _dvr, dvr_dv, _dzd_dvr, _dzd_dz, dF_dvr = d
    dF_dv = dF_dvr * dvr_dv
    dP = np.empty(_NQ, dtype=B.dtype)
    _preload_dv(V, p, dP)
    for i in range(_NQ):
        B[i, col] = dh_dv[i] + GF[i] * dF_dv + dP[i]


@njit(cache=True, error_model="numpy")
def _rhs_out(u, s, out):
    """du/dt into out from the result ``s`` of :func:`_accelerations`."""
    Q = s[2]
    for i in range(_NQ):
        out[i] = u[_NQ + i]
        out[_NQ + i] = Q[i, 0]
    out[_ZB] = s[7]


@njit(cache=True, error_model="numpy")
def _jac_out(s, d, B, out):
    """df/du (9 x 9) into out from B[:, :9] solved by M (:func:`_jac_columns`)."""
    n2 = 2 * _NQ
    zero = s[0]
    dvr, dzd_dvr, dzd_dz = d[3], d[5], d[6]
    for i in range(n2 + 1):
        for k in range(n2 + 1):
            out[i, k] = 0.0 * zero
    for i in range(_NQ):
        out[i, _NQ + i] = 1.0 + zero
        for k in range(n2 + 1):
            out[_NQ + i, k] = B[i, k]
    for k in range(n2):
        out[_ZB, k] = dzd_dvr * dvr[k]
    out[_ZB, _ZB] = dzd_dz


@njit(cache=True, error_model="numpy")
def _dfdv_out(s, d, B, col, out):
    """df/dV into out from B[:, col] solved by M (:func:`_dfdv_column`)."""
    zero = s[0]
    for i in range(_NQ):
        out[i] = zero
        out[_NQ + i] = B[i, col]
    out[_ZB] = d[5] * d[4]


@njit(cache=True, error_model="numpy")
def rhs(u, V, p, out):
    """du/dt [rad/s, rad/s, rad/s, m/s, rad/s^2, rad/s^2, rad/s^2, m/s^2, m/s]."""
    _rhs_out(u, _accelerations(u, V, p), out)


@njit(cache=True, error_model="numpy")
def jac(u, V, p, out):
    """df/du (9 x 9)."""
    s = _accelerations(u, V, p)
    d = _first_order(u, V, p, s)
    B = np.empty((_NQ, 2 * _NQ + 1), dtype=s[1].dtype)
    _jac_columns(u, p, s, d, B)
    _solve(s[1], B)
    _jac_out(s, d, B, out)


@njit(cache=True, error_model="numpy")
def dfdv(u, V, p, out):
    """df/dV [per m/s]: through v_r, the wheel-spin rate V/R_e and the running preloads."""
    s = _accelerations(u, V, p)
    d = _first_order(u, V, p, s)
    B = np.empty((_NQ, 1), dtype=s[1].dtype)
    _dfdv_column(V, p, s, d, B, 0)
    _solve(s[1], B)
    _dfdv_out(s, d, B, 0, out)


@njit(cache=True, error_model="numpy")
def rhs_jac_dfdv(u, V, p, f, J, fv):
    """:func:`rhs`, :func:`jac` and :func:`dfdv` into f, J and fv at once, bit for bit
    theirs: the state is evaluated once and M solved once for the columns of J and fv."""
    s = _accelerations(u, V, p)
    _rhs_out(u, s, f)
    d = _first_order(u, V, p, s)
    col = 2 * _NQ + 1
    B = np.empty((_NQ, col + 1), dtype=s[1].dtype)
    _jac_columns(u, p, s, d, B)
    _dfdv_column(V, p, s, d, B, col)
    _solve(s[1], B)
    _jac_out(s, d, B, J)
    _dfdv_out(s, d, B, col, fv)


@njit(cache=True, error_model="numpy")
def aux(u, V, p, out):
    """Sliding velocity v_r [m/s], friction force F [N], normal load N [N], contact lost [0/1]."""
    zero, M, Q, GF, GN = _workspace(u, V, p)
    vr, _g, _zd, force, load, clamped = _evaluate(u, V, p, M, Q, GF, GN)
    out[0] = vr
    out[1] = force
    out[2] = load
    out[3] = 1.0 + zero if clamped else zero


def rhs_python(t, u, V, p):
    """du/dt for scipy (t unused). Pure Python only in the twin of this module without numba
    (``polywear.models.axle4dof.rhs_python``); here the helpers it calls are compiled."""
    u = np.asarray(u, dtype=float)
    M = np.empty((_NQ, _NQ))
    h = np.empty(_NQ)
    GF = np.empty(_NQ)
    GN = np.empty(_NQ)
    _inertia(u, V, p, M, h)
    rise = _contact(u, p, GF, GN)
    P = np.empty(_NQ)
    preload(V, p, P)
    vr = _sliding(u, V, p)
    load = max(p[_N0] - p[_K_Z] * rise - p[_C_Z] * (GN @ u[_NQ:2 * _NQ]), 0.0)
    g = stribeck(vr, p[_MU_S], p[_MU_C], p[_V_S], p[_DELTA])
    zd = bristle_rate(vr, u[_ZB], p[_SIGMA0], g)
    force = load * (p[_SIGMA0] * u[_ZB] + p[_SIGMA1] * zd + p[_SIGMA2] * vr)
    stiff = p[[_K_ALPHA, _K_BETA, _K_GAMMA, _K]]
    damp = p[[_C_ALPHA, _C_BETA, _C_GAMMA, _C]]
    Q = h + force * GF + load * GN + P - stiff * u[:_NQ] - damp * u[_NQ:2 * _NQ]
    return np.concatenate((u[_NQ:2 * _NQ], np.linalg.solve(M, Q), [zd]))
