"""Model ``tread1dof``: lateral tread on a rigid rim (docs/model.md section 3).

    m x'' + c x' + k x = F,   v_r = V sin(toe) - x',   F = N (sigma0 z + sigma1 z' + sigma2 v_r)

States ``u = (x [m], x' [m/s], z [m])``. Parameter vector ``p`` is laid out by
:data:`SLOTS`. The kernels are hand-written (the model is small); ``rhs_python`` is a
plain-NumPy reference used by the tests and the benchmark baseline.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..physics.lugre import bristle_rate, bristle_rate_partials, stribeck, stribeck_dv
from .base import DEG, Model, ParamSlot

SLOTS = (
    ParamSlot("m", "tread.mass_kg"),
    ParamSlot("k", "tread.lateral_stiffness_n_per_m"),
    ParamSlot("c", "tread.lateral_damping_ns_per_m"),
    ParamSlot("N", "operating.vertical_load_n"),
    ParamSlot("toe", "operating.toe_deg", DEG),
    ParamSlot("sigma0", "friction.sigma0_per_m"),
    ParamSlot("sigma1", "friction.sigma1_s_per_m"),
    ParamSlot("sigma2", "friction.sigma2_s_per_m"),
    ParamSlot("mu_s", "friction.mu_static"),
    ParamSlot("mu_c", "friction.mu_coulomb"),
    ParamSlot("v_s", "friction.stribeck_velocity_m_per_s"),
    ParamSlot("delta", "friction.stribeck_exponent"),
)
M, K, C, N, TOE, S0, S1, S2, MUS, MUC, VS, DELTA = range(len(SLOTS))


@njit(cache=True, error_model="numpy")
def _slip(u, V, p):
    """Sliding velocity v_r [m/s] and Stribeck value G(v_r) [-] at state u."""
    vr = V * np.sin(p[TOE]) - u[1]
    return vr, stribeck(vr, p[MUS], p[MUC], p[VS], p[DELTA])


@njit(cache=True, error_model="numpy")
def _rhs_out(u, p, vr, g, out):
    """du/dt into out, given v_r and G(v_r)."""
    zd = bristle_rate(vr, u[2], p[S0], g)
    force = p[N] * (p[S0] * u[2] + p[S1] * zd + p[S2] * vr)
    out[0] = u[1]
    out[1] = (force - p[C] * u[1] - p[K] * u[0]) / p[M]
    out[2] = zd


@njit(cache=True, error_model="numpy")
def _partials(u, p, vr, g):
    """dz'/dv_r, dz'/dz, dF/dv_r, dF/dz at state u, given v_r and G(v_r)."""
    dg = stribeck_dv(vr, p[MUS], p[MUC], p[VS], p[DELTA])
    dzd_dvr, dzd_dz = bristle_rate_partials(vr, u[2], p[S0], g, dg)
    df_dvr = p[N] * (p[S1] * dzd_dvr + p[S2])
    df_dz = p[N] * (p[S0] + p[S1] * dzd_dz)
    return dzd_dvr, dzd_dz, df_dvr, df_dz


@njit(cache=True, error_model="numpy")
def _jac_out(p, partials, out):
    """df/du into out from the :func:`_partials`."""
    dzd_dvr, dzd_dz, df_dvr, df_dz = partials
    out[0, 0] = 0.0
    out[0, 1] = 1.0
    out[0, 2] = 0.0
    out[1, 0] = -p[K] / p[M]
    out[1, 1] = (-p[C] - df_dvr) / p[M]
    out[1, 2] = df_dz / p[M]
    out[2, 0] = 0.0
    out[2, 1] = -dzd_dvr
    out[2, 2] = dzd_dz


@njit(cache=True, error_model="numpy")
def _dfdv_out(p, partials, out):
    """df/dV into out from the :func:`_partials`."""
    dzd_dvr, _, df_dvr, _ = partials
    s = np.sin(p[TOE])
    out[0] = 0.0 * s
    out[1] = df_dvr * s / p[M]
    out[2] = dzd_dvr * s


@njit(cache=True, error_model="numpy")
def rhs(u, V, p, out):
    """du/dt [m/s, m/s^2, m/s]."""
    vr, g = _slip(u, V, p)
    _rhs_out(u, p, vr, g, out)


@njit(cache=True, error_model="numpy")
def jac(u, V, p, out):
    """df/du."""
    vr, g = _slip(u, V, p)
    _jac_out(p, _partials(u, p, vr, g), out)


@njit(cache=True, error_model="numpy")
def dfdv(u, V, p, out):
    """df/dV [per m/s]; V enters only through v_r = V sin(toe) - x'."""
    vr, g = _slip(u, V, p)
    _dfdv_out(p, _partials(u, p, vr, g), out)


@njit(cache=True, error_model="numpy")
def rhs_jac_dfdv(u, V, p, f, J, fv):
    """:func:`rhs`, :func:`jac` and :func:`dfdv` into f, J and fv at once, bit for bit theirs."""
    vr, g = _slip(u, V, p)
    _rhs_out(u, p, vr, g, f)
    partials = _partials(u, p, vr, g)
    _jac_out(p, partials, J)
    _dfdv_out(p, partials, fv)


AUX_NAMES = ("sliding_velocity", "friction_force", "normal_load")


@njit(cache=True, error_model="numpy")
def aux(u, V, p, out):
    """Sliding velocity v_r [m/s], friction force F [N], normal load N [N]."""
    vr, g = _slip(u, V, p)
    zd = bristle_rate(vr, u[2], p[S0], g)
    out[0] = vr
    out[1] = p[N] * (p[S0] * u[2] + p[S1] * zd + p[S2] * vr)
    out[2] = p[N]


def equilibrium(V, p):
    """Closed-form steady state: x' = 0, z = sgn(v_r0) G(v_r0)/sigma0, k x = F."""
    vr0 = V * math.sin(p[TOE])
    g0 = p[MUC] + (p[MUS] - p[MUC]) * math.exp(-abs(vr0 / p[VS]) ** p[DELTA])
    z0 = math.copysign(g0, vr0) / p[S0] if vr0 != 0.0 else 0.0
    x0 = p[N] * (p[S0] * z0 + p[S2] * vr0) / p[K]
    return np.array([x0, 0.0, z0])


def rhs_python(t, u, V, p):
    """Plain NumPy/Python right-hand side (reference for tests and benchmarks)."""
    m, k, c, n_load, toe, s0, s1, s2, mu_s, mu_c, v_s, delta = p
    x, xd, z = u
    vr = V * math.sin(toe) - xd
    g = mu_c + (mu_s - mu_c) * math.exp(-abs(vr / v_s) ** delta)
    zd = vr - s0 * abs(vr) * z / g
    force = n_load * (s0 * z + s1 * zd + s2 * vr)
    return np.array([xd, (force - c * xd - k * x) / m, zd])


class _Kernels:
    rhs = rhs
    jac = jac
    dfdv = dfdv
    rhs_jac_dfdv = rhs_jac_dfdv
    aux = aux
    equilibrium = staticmethod(equilibrium)


MODEL = Model(
    name="tread1dof",
    state_names=("x", "xdot", "z"),
    state_units=("m", "m/s", "m"),
    aux_names=AUX_NAMES,
    slots=SLOTS,
    kernels=_Kernels,
    coordinates=(("x", "k"),),
)
