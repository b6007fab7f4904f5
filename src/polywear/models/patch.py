"""Distributed ("patch") contact of ``tread1dof``: the tread elements along the patch (docs/patch_contact.md).

The contact patch of length ``L = 2a`` (``tire.contact_length_m``) is cut into M equal
cells. Cell j (j = 0 at the leading edge, M - 1 at the trailing edge) holds one tread
element: the paper's element spread along the patch (mass m/M, lateral stiffness k/M,
damping c/M on the rigid rim) with a LuGre bristle under its share ``s_j`` of the normal
load (the integral of the pressure distribution over the cell). The tread material moves
rearward through the patch at the rolling speed V cos(toe) (the speed along the wheel
plane), entering undeflected; in the frame of the patch every field q(x, t) of the tread
(deflection y, its material rate w = Dy/Dt, bristle deflection z) obeys
``dq/dt + V cos(toe) dq/dx = (material rate of q)``. Method of lines, first-order upwind
in x (lambda = V cos(toe) M / L, inflow value 0 at the leading edge):

    y_j' = w_j - lambda (y_j - y_{j-1})
    w_j' = (M N s_j f_j - c w_j - k y_j)/m - lambda (w_j - w_{j-1})
    z_j' = zdot(v_j, z_j) - lambda (z_j - z_{j-1}),   v_j = V sin(toe) - w_j
    f_j  = sigma0 z_j + sigma1 zdot(v_j, z_j) + sigma2 v_j     (LuGre, per unit load)

States ``u = (y_0, w_0, z_0, ..., y_{M-1}, w_{M-1}, z_{M-1})``; the trailing element,
which slides first, is named ``x, xdot, z`` like the point contact's tread (the state the
analyses report amplitudes of). The parameter vector is ``tread1dof``'s followed by ``L``
and the M load shares, so one compiled kernel serves every M. The Jacobian is analytic:
lower block-bidiagonal, 3x3 blocks.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from numba import njit

from ..physics.lugre import bristle_rate, bristle_rate_partials, real_abs, stribeck, stribeck_dv
from .base import Model, ParamSlot
from .tread1dof import SLOTS as POINT_SLOTS

__all__ = ["patch_model", "load_shares", "PRESSURES", "brush_force", "steady_lateral_force", "M_MIN", "M_MAX"]

PRESSURES = ("parabolic", "uniform")
M_MIN, M_MAX = 2, 400
"""Bounds of ``friction.patch_elements``."""

M, K, C, N, TOE, S0, S1, S2, MUS, MUC, VS, DELTA = range(12)
LEN = 12
SHARE0 = 13


def load_shares(pressure: str, elements: int) -> np.ndarray:
    """Share of the normal load on each of ``elements`` equal cells, leading edge first [-].

    ``"uniform"``: 1/M each; ``"parabolic"``: q(x) = (3/2)(1 - xi^2)/(2a), xi = x/a in
    [-1, 1], integrated exactly over each cell (the shares sum to 1)."""
    edges = np.linspace(-1.0, 1.0, elements + 1)
    if pressure == "uniform":
        return np.diff(edges) / 2.0
    if pressure == "parabolic":
        cdf = 0.75 * (edges - edges**3 / 3.0)
        return np.diff(cdf)
    raise ValueError(f"pressure = {pressure!r}: must be one of {', '.join(PRESSURES)}")


@njit(cache=True, error_model="numpy")
def _element(u, p, j, vt):
    """LuGre terms of element j: v_j, f_j (per unit load), zdot_j, and the partials
    d zdot/dv, d zdot/dz, d f/dv, d f/dz."""
    w = u[3 * j + 1]
    z = u[3 * j + 2]
    v = vt - w
    g = stribeck(v, p[MUS], p[MUC], p[VS], p[DELTA])
    dg = stribeck_dv(v, p[MUS], p[MUC], p[VS], p[DELTA])
    zd = bristle_rate(v, z, p[S0], g)
    dzd_dv, dzd_dz = bristle_rate_partials(v, z, p[S0], g, dg)
    f = p[S0] * z + p[S1] * zd + p[S2] * v
    return v, f, zd, dzd_dv, dzd_dz, p[S1] * dzd_dv + p[S2], p[S0] + p[S1] * dzd_dz


@njit(cache=True, error_model="numpy")
def rhs_jac_dfdv(u, V, p, f, J, fv):
    """du/dt into f, df/du into J, df/dV into fv (all three at once)."""
    n_el = u.size // 3
    lam = V * np.cos(p[TOE]) * n_el / p[LEN]
    dlam = np.cos(p[TOE]) * n_el / p[LEN]
    s = np.sin(p[TOE])
    vt = V * s
    for r in range(J.shape[0]):
        for c_ in range(J.shape[1]):
            J[r, c_] = 0.0 * u[0]
    for j in range(n_el):
        i = 3 * j
        load = n_el * p[N] * p[SHARE0 + j]
        v, fr, zd, dzd_dv, dzd_dz, df_dv, df_dz = _element(u, p, j, vt)
        y, w, z = u[i], u[i + 1], u[i + 2]
        if j > 0:
            yp, wp, zp = u[i - 3], u[i - 2], u[i - 1]
        else:
            yp, wp, zp = 0.0 * y, 0.0 * y, 0.0 * y
        f[i] = w - lam * (y - yp)
        f[i + 1] = (load * fr - p[C] * w - p[K] * y) / p[M] - lam * (w - wp)
        f[i + 2] = zd - lam * (z - zp)
        J[i, i] = -lam
        J[i, i + 1] = 1.0
        J[i + 1, i] = -p[K] / p[M]
        J[i + 1, i + 1] = (-load * df_dv - p[C]) / p[M] - lam
        J[i + 1, i + 2] = load * df_dz / p[M]
        J[i + 2, i + 1] = -dzd_dv
        J[i + 2, i + 2] = dzd_dz - lam
        if j > 0:
            J[i, i - 3] = lam
            J[i + 1, i - 2] = lam
            J[i + 2, i - 1] = lam
        fv[i] = -dlam * (y - yp)
        fv[i + 1] = load * df_dv * s / p[M] - dlam * (w - wp)
        fv[i + 2] = dzd_dv * s - dlam * (z - zp)


@njit(cache=True, error_model="numpy")
def rhs(u, V, p, out):
    """du/dt [m/s, m/s^2, m/s per element]."""
    n_el = u.size // 3
    lam = V * np.cos(p[TOE]) * n_el / p[LEN]
    vt = V * np.sin(p[TOE])
    for j in range(n_el):
        i = 3 * j
        load = n_el * p[N] * p[SHARE0 + j]
        v, fr, zd, _, _, _, _ = _element(u, p, j, vt)
        if j > 0:
            yp, wp, zp = u[i - 3], u[i - 2], u[i - 1]
        else:
            yp, wp, zp = 0.0 * u[i], 0.0 * u[i], 0.0 * u[i]
        out[i] = u[i + 1] - lam * (u[i] - yp)
        out[i + 1] = (load * fr - p[C] * u[i + 1] - p[K] * u[i]) / p[M] - lam * (u[i + 1] - wp)
        out[i + 2] = zd - lam * (u[i + 2] - zp)


@njit(cache=True, error_model="numpy")
def jac(u, V, p, out):
    """df/du (lower block-bidiagonal)."""
    f = np.empty(u.size, dtype=out.dtype)
    fv = np.empty(u.size, dtype=out.dtype)
    rhs_jac_dfdv(u, V, p, f, out, fv)


@njit(cache=True, error_model="numpy")
def dfdv(u, V, p, out):
    """df/dV [per m/s]: through v_j = V sin(toe) - w_j and the transport rate lambda = V cos(toe) M/L."""
    f = np.empty(u.size, dtype=out.dtype)
    J = np.empty((u.size, u.size), dtype=out.dtype)
    rhs_jac_dfdv(u, V, p, f, J, out)


AUX_NAMES = ("sliding_velocity", "friction_force", "normal_load", "sliding_velocity_rear", "sliding_share")


@njit(cache=True, error_model="numpy")
def aux(u, V, p, out):
    """Power-equivalent sliding velocity P/F [m/s] (so that friction_force times it is the
    friction power P = sum F_j v_j [W]; the load-weighted mean v_j where F = 0), total
    lateral friction force F [N], normal load N [N], sliding velocity of the trailing
    element [m/s], share of the normal load on elements whose bristle is past half its
    steady (sliding) deflection [-]."""
    n_el = u.size // 3
    vt = V * np.sin(p[TOE])
    force = 0.0 * u[0]
    power = 0.0 * u[0]
    vmean = 0.0 * u[0]
    sliding = 0.0
    v = vt
    for j in range(n_el):
        load = p[N] * p[SHARE0 + j]
        v, fr, _, _, _, _, _ = _element(u, p, j, vt)
        force += load * fr
        power += load * fr * v
        vmean += p[SHARE0 + j] * v
        g = stribeck(v, p[MUS], p[MUC], p[VS], p[DELTA])
        if (p[S0] * real_abs(u[3 * j + 2])).real > 0.5 * g.real:
            sliding += p[SHARE0 + j].real
    out[0] = power / force if force.real != 0.0 else vmean
    out[1] = force
    out[2] = p[N]
    out[3] = v
    out[4] = sliding


@njit(cache=True, error_model="numpy")
def _march(V, p, n_el, out):
    """Steady rolling of the discretized patch, element by element from the leading edge:
    each element solves its three steady equations given the one ahead of it (an implicit
    Euler step in x). z and y are explicit in w; the scalar equation in w is solved by
    Newton's method kept inside a bracket by bisection. Returns False if one fails."""
    lam = V * math.cos(p[TOE]) * n_el / p[LEN]
    vt = V * math.sin(p[TOE])
    yp, wp, zp = 0.0, 0.0, 0.0
    for j in range(n_el):
        load = n_el * p[N] * p[SHARE0 + j]
        b = p[MUS] / p[S0] + abs(zp)  # |z| <= G/sigma0 + |z_prev|
        bound = load * (p[S0] * b + p[S1] * lam * (b + abs(zp)))
        dd = p[C] + p[K] / lam + p[M] * lam + load * p[S2]
        rest = load * p[S2] * vt - p[K] * yp + p[M] * lam * wp
        lo = (rest - bound) / dd - 1e-12
        hi = (rest + bound) / dd + 1e-12
        w = min(max(wp, lo), hi)
        ok = False
        for _ in range(200):
            v = vt - w
            g = p[MUC] + (p[MUS] - p[MUC]) * math.exp(-abs(v / p[VS]) ** p[DELTA])
            a = p[S0] * abs(v) / g
            z = (v + lam * zp) / (a + lam)
            zd = lam * (z - zp)
            r = load * (p[S0] * z + p[S1] * zd + p[S2] * v) - p[C] * w - p[K] * (yp + w / lam) - p[M] * lam * (w - wp)
            if r == 0.0:
                ok = True
                break
            if r > 0.0:
                lo = w
            else:
                hi = w
            # dr/dw through v = vt - w: dz/dv = (1 - z da/dv)/(a + lam)
            av = abs(v / p[VS])
            dgdv = 0.0
            if av > 0.0:
                dgdv = -(p[MUS] - p[MUC]) * math.exp(-(av ** p[DELTA])) * p[DELTA] * av ** (p[DELTA] - 1.0) * math.copysign(1.0, v) / p[VS]
            sg = 0.0 if v == 0.0 else math.copysign(1.0, v)
            da = p[S0] * (sg * g - abs(v) * dgdv) / (g * g)
            dz = (1.0 - z * da) / (a + lam)
            dr = -(load * ((p[S0] + p[S1] * lam) * dz + p[S2])) - p[C] - p[K] / lam - p[M] * lam
            step = w - r / dr if dr != 0.0 else 0.5 * (lo + hi)
            if not (lo < step < hi):
                step = 0.5 * (lo + hi)
            tol = 1e-14 * (abs(w) + abs(vt)) + 1e-300
            if abs(step - w) <= tol or hi - lo <= tol:
                w = step
                ok = True
                break
            w = step
        if not ok:
            return False
        v = vt - w
        g = p[MUC] + (p[MUS] - p[MUC]) * math.exp(-abs(v / p[VS]) ** p[DELTA])
        z = (v + lam * zp) / (p[S0] * abs(v) / g + lam)
        y = yp + w / lam
        out[3 * j] = y
        out[3 * j + 1] = w
        out[3 * j + 2] = z
        yp, wp, zp = y, w, z
    return True


def equilibrium(V, p):
    """Steady rolling state at speed V [m/s] (the patch marched from its leading edge)."""
    n_el = len(p) - SHARE0
    out = np.empty(3 * n_el)
    if V <= 0.0 or not _march(float(V), np.asarray(p, dtype=float), n_el, out):
        raise ValueError(f"patch contact: no steady state found at V = {V!r} m/s")
    return out


def brush_force(slip_rad, stiffness_per_length, half_length, mu, load, pressure: str = "parabolic"):
    """Steady lateral force [N] of the brush model (rigid carcass, elastic bristles of lateral
    stiffness ``stiffness_per_length`` [N/m^2], Coulomb friction ``mu``) at slip angle(s)
    ``slip_rad`` over a patch of half length ``half_length`` [m] under ``load`` [N].

    Parabolic pressure: ``F = mu N (1 - (1 - psi)^3)`` with
    ``psi = C_alpha tan(alpha) / (3 mu N)``, ``C_alpha = 2 c_p a^2``, for psi < 1, else mu N.
    Uniform pressure, ``t = C_alpha tan(alpha)/(mu N)``: the whole patch adheres up to
    t = 1/2 (``F = mu N t``); above, the rear of the patch slides from ``x_s = a/t``
    behind the leading edge and ``F = mu N (1 - 1/(4 t))`` (full sliding only as t grows
    without bound).
    """
    alpha = np.asarray(slip_rad, dtype=float)
    c_alpha = 2.0 * stiffness_per_length * half_length**2
    sign = np.sign(alpha)
    t = c_alpha * np.tan(np.abs(alpha)) / (mu * load)
    if pressure == "parabolic":
        psi = np.minimum(t / 3.0, 1.0)
        return sign * mu * load * (1.0 - (1.0 - psi) ** 3)
    if pressure == "uniform":
        return sign * mu * load * np.where(t <= 0.5, t, 1.0 - 0.25 / np.maximum(t, 0.5))
    raise ValueError(f"pressure = {pressure!r}: must be one of {', '.join(PRESSURES)}")


class _Kernels:
    rhs = rhs
    jac = jac
    dfdv = dfdv
    rhs_jac_dfdv = rhs_jac_dfdv
    aux = aux
    equilibrium = staticmethod(equilibrium)


def _share_slot(pressure: str, elements: int, j: int) -> ParamSlot:
    return ParamSlot(f"share{j}", None, encode=lambda params: float(load_shares(pressure, elements)[j]))


def _state_names(elements: int) -> tuple[str, ...]:
    names: list[str] = []
    for j in range(elements - 1):
        names += [f"y{j}", f"w{j}", f"z{j}"]
    return (*names, "x", "xdot", "z")


@lru_cache(maxsize=None)
def patch_model(elements: int, pressure: str) -> Model:
    """The ``tread1dof`` model with a patch of ``elements`` tread elements under the
    ``pressure`` distribution ("parabolic" or "uniform")."""
    if not M_MIN <= elements <= M_MAX:
        raise ValueError(f"patch elements = {elements!r}: must be {M_MIN} to {M_MAX}")
    load_shares(pressure, elements)
    slots = (
        *POINT_SLOTS,
        ParamSlot("L", "tire.contact_length_m"),
        *(_share_slot(pressure, elements, j) for j in range(elements)),
    )
    return Model(
        name="tread1dof+patch",
        state_names=_state_names(elements),
        state_units=("m", "m/s", "m") * elements,
        aux_names=AUX_NAMES,
        slots=slots,
        kernels=_Kernels,
        coordinates=(("x", "k"),),
    )


CORNERING_SLIP_DEG = 1e-3
"""Slip angle [deg] at which the patch's cornering stiffness is taken as F / tan(alpha)
(deep in the linear range: the force is linear in the slip there to about 1e-5)."""


def steady_lateral_force(params, slip_deg) -> dict:
    """Steady lateral force of the contact ``params`` asks for (``friction.contact``) at the
    operating speed and load, one per slip angle [deg] (the toe angle of tread1dof):
    ``{"contact", "load_n", "cornering_stiffness_n_per_rad", "rows": [{"slip_deg", "force_n"}]}``.

    The cornering stiffness is the patch contact's (its force at
    :data:`CORNERING_SLIP_DEG` over the tangent), whichever contact is asked for: the point
    contact has none (its force jumps to about mu_s N at any slip), and this is what its force
    is to be compared with (with ``model = axle4dof`` the patch on tread1dof gives it)."""
    from . import model_for
    from ..units import kmh_to_ms

    V = kmh_to_ms(params.operating.speed_kmh)

    def force(p, deg):
        model = model_for(p)
        q = model.pack(p.with_updates({"operating.toe_deg": float(deg)}))
        u = model.equilibrium(V, q)
        return float(model.diagnostics(u, V, q)[model.aux_names.index("friction_force")])

    patch = params.with_updates({"model": "tread1dof", "friction.contact": "patch"})
    c_alpha = force(patch, CORNERING_SLIP_DEG) / math.tan(math.radians(CORNERING_SLIP_DEG))
    return {
        "contact": params.friction.contact,
        "load_n": params.operating.vertical_load_n,
        "cornering_stiffness_n_per_rad": c_alpha,
        "rows": [{"slip_deg": float(d), "force_n": force(params, d)} for d in slip_deg],
    }
