"""Equations of motion of ``axle4dof`` (docs/model.md section 4) and their code generator.

The equations are derived with :mod:`sympy.physics.mechanics` (Lagrange's method) and
written out as plain Python source of ``numba.njit(cache=True)`` kernels in
``_axle4dof_generated.py``. This module is imported only by the generator and the tests,
never by the solver path. Regenerate with::

    python -m polywear.models.axle4dof_derivation

What is symbolic and what is numeric:

- symbolic (then compiled): the mass matrix ``M(q)``, the velocity-dependent inertial
  forces ``h(q, q', V)`` (Coriolis, centrifugal, gyroscopic wheel spin), the contact
  gradients ``G_F = (dr_P/dq)^T d`` and ``G_N = (dr_C/dq)^T e_Z`` that turn the friction
  force and the normal load into generalized forces, the sliding velocity ``v_r`` and the
  rise of the contact point, and every partial derivative of these;
- numeric, in the kernels: the LuGre force (``physics.lugre``), the contact-loss clamp,
  springs, dampers, preloads, the 4x4 linear solve for the accelerations and the chain
  rule that assembles the Jacobian from the generated partials.
"""

from __future__ import annotations

import hashlib
import sys
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import sympy as sp
from sympy.physics.mechanics import (
    LagrangesMethod,
    Lagrangian,
    Particle,
    Point,
    ReferenceFrame,
    RigidBody,
    dynamicsymbols,
    inertia,
    msubs,
)
from sympy.printing.numpy import NumPyPrinter

__all__ = ["PARAM_NAMES", "STATE_NAMES", "Derivation", "derive", "generate_source", "write_generated"]

STATE_NAMES = ("alpha", "beta", "gamma", "x", "alphadot", "betadot", "gammadot", "xdot", "z")
"""Kernel state vector: toe, camber, pitch [rad], tread deflection [m], their rates, bristle z [m]."""

PARAM_NAMES = (
    "m", "k", "c", "N0", "toe0", "camber0", "R_e",
    "sigma0", "sigma1", "sigma2", "mu_s", "mu_c", "v_s", "delta",
    "J1", "J2", "J3",
    "k_alpha", "c_alpha", "k_beta", "c_beta", "k_gamma", "c_gamma",
    "L", "b", "H", "eps", "I_w", "k_z", "c_z", "reference",
    "preload_speed", "preload_alpha", "preload_beta", "preload_gamma",
)  # fmt: skip
"""Kernel parameter vector layout (SI units, angles in rad); ``reference`` is 0 = running,
1 = unloaded. The last four entries cache the preloads for one speed (NaN: not cached);
see ``axle4dof.prepare``."""

GENERATED_PATH = Path(__file__).with_name("_axle4dof_generated.py")


@dataclass(frozen=True)
class Derivation:
    """Symbolic equations of motion ``M(q) q'' = h + F G_F + N G_N + (springs, dampers, preloads)``."""

    q: tuple[sp.Symbol, ...]
    """Generalized coordinates (alpha, beta, gamma, x)."""
    qd: tuple[sp.Symbol, ...]
    """Generalized velocities."""
    speed: sp.Symbol
    """Drum speed V [m/s]."""
    params: dict[str, sp.Symbol]
    mass_matrix: sp.Matrix
    inertial_forces: sp.Matrix
    """h: forcing of the Lagrangian alone (Coriolis, centrifugal, wheel-spin gyroscopic)."""
    friction_gradient: sp.Matrix
    """G_F: generalized force per newton of friction acting on the tread along d."""
    normal_gradient: sp.Matrix
    """G_N: generalized force per newton of normal load acting on the body at C along +Z."""
    sliding_velocity: sp.Expr
    contact_rise: sp.Expr
    """Rise of C above its position at alpha = beta = gamma = 0 [m]."""


@cache
def derive() -> Derivation:
    """Derive the equations of motion (cached; takes a few seconds)."""
    P = {name: sp.Symbol(name, real=True) for name in PARAM_NAMES}
    V = sp.Symbol("V", real=True)
    alpha, beta, gamma, x = dynamicsymbols("alpha beta gamma x")
    coords = [alpha, beta, gamma, x]
    psi = P["toe0"] + alpha  # running toe
    phi = P["camber0"] + beta  # running camber

    ground = ReferenceFrame("N")
    yawed = ground.orientnew("A", "Axis", (psi, ground.z))
    pitched = yawed.orientnew("Bp", "Axis", (-gamma, yawed.y))
    body = pitched.orientnew("B", "Axis", (phi, pitched.x))  # R = Rz(psi) Ry(-gamma) Rx(phi)

    pivot = Point("O")
    pivot.set_vel(ground, 0)
    contact = pivot.locatenew("C", -P["L"] * body.x - P["b"] * body.y - P["H"] * body.z)
    contact.v2pt_theory(pivot, ground, body)
    tread = contact.locatenew("P", x * body.y)
    tread.set_vel(body, x.diff() * body.y)
    tread.v1pt_theory(contact, ground, body)

    arm = RigidBody("arm", pivot, body, 0, (inertia(body, P["J1"], P["J2"], P["J3"]), pivot))
    tread_mass = Particle("tread", tread, P["m"])
    # The wheel spins at V/R_e about the body y axis. J2 already holds the wheel's spin-axis
    # inertia as part of the rigid body, so the spin adds I_w * Omega * omega_y (+ const) to T.
    spin = P["I_w"] * V / P["R_e"] * body.ang_vel_in(ground).dot(body.y)
    lagrangian = Lagrangian(ground, arm, tread_mass) + spin

    lateral = -sp.sin(psi) * ground.x + sp.cos(psi) * ground.y  # d: road plane, normal to heading
    friction, normal = sp.symbols("F_friction N_normal", real=True)
    forces = [(tread, friction * lateral), (contact, normal * ground.z)]
    method = LagrangesMethod(lagrangian, coords, forcelist=forces, frame=ground)
    method.form_lagranges_equations()

    q = tuple(sp.Symbol(n, real=True) for n in STATE_NAMES[:4])
    qd = tuple(sp.Symbol(n, real=True) for n in STATE_NAMES[4:8])
    plain = ({c.diff(): s for c, s in zip(coords, qd)}, dict(zip(coords, q)))

    def to_plain(expr):
        return msubs(expr, *plain)

    forcing = to_plain(method.forcing)
    road = -V * ground.x
    v_r = (road - tread.vel(ground)).dot(lateral) - P["eps"] * V * sp.sin(phi)
    height = contact.pos_from(pivot).dot(ground.z)
    return Derivation(
        q=q,
        qd=qd,
        speed=V,
        params=P,
        mass_matrix=to_plain(method.mass_matrix),
        inertial_forces=forcing.subs({friction: 0, normal: 0}),
        friction_gradient=forcing.diff(friction),
        normal_gradient=forcing.diff(normal),
        sliding_velocity=to_plain(v_r),
        contact_rise=to_plain(height - height.subs({alpha: 0, beta: 0, gamma: 0})),
    )


# -- code generation ------------------------------------------------------------------


@dataclass(frozen=True)
class _Group:
    """One generated function: ``def name(args): <cse> <outputs> [return value]``."""

    name: str
    args: str
    doc: str
    outputs: tuple[tuple[str, sp.Expr], ...]
    returns: sp.Expr | None = None


def _groups(d: Derivation) -> list[_Group]:
    q, qd, V = d.q, d.qd, d.speed
    accel = sp.symbols("a0:4", real=True)
    n = len(q)

    def vec(target, exprs):
        return tuple((f"{target}[{i}]", e) for i, e in enumerate(exprs))

    def mat(target, rows, cols, fn):
        return tuple((f"{target}[{i}, {j}]", fn(i, j)) for i in range(rows) for j in range(cols))

    M, h, GF, GN = d.mass_matrix, d.inertial_forces, d.friction_gradient, d.normal_gradient
    Ma = M * sp.Matrix(accel)
    states = q + qd
    return [
        _Group(
            "_contact",
            "u, p, GF, GN",
            "Contact gradients G_F, G_N [m or m/rad] at u; returns the rise of C [m].",
            vec("GF", GF) + vec("GN", GN),
            d.contact_rise,
        ),
        _Group(
            "_contact_partials",
            "u, p, dGF, dGN",
            "dG_F/dq, dG_N/dq (row = component, column = coordinate).",
            mat("dGF", n, n, lambda i, j: GF[i].diff(q[j])) + mat("dGN", n, n, lambda i, j: GN[i].diff(q[j])),
        ),
        _Group(
            "_inertia",
            "u, V, p, M, h",
            "Mass matrix M(q) and inertial forces h(q, q', V) (Coriolis, centrifugal, spin).",
            mat("M", n, n, lambda i, j: M[i, j]) + vec("h", h),
        ),
        _Group(
            "_inertia_partials",
            "u, a, V, p, dMa, dh, dh_dv",
            "d(M a)/dq at fixed a, dh/d(q, q') (n x 2n), dh/dV.",
            mat("dMa", n, n, lambda i, j: Ma[i].diff(q[j]))
            + mat("dh", n, 2 * n, lambda i, j: h[i].diff(states[j]))
            + vec("dh_dv", h.diff(V)),
        ),
        _Group("_sliding", "u, V, p", "Sliding velocity v_r [m/s] of the road relative to the tread.", (), d.sliding_velocity),
        _Group(
            "_sliding_partials",
            "u, V, p, dvr",
            "dv_r/d(q, q') into dvr (2n); returns dv_r/dV.",
            vec("dvr", [d.sliding_velocity.diff(s) for s in states]),
            d.sliding_velocity.diff(V),
        ),
    ]


class _Printer(NumPyPrinter):
    """NumPy printer with bare function names (the module imports them from numpy)."""

    def __init__(self):
        super().__init__({"fully_qualified_modules": False, "allow_unknown_functions": False})

    def _print_Pow(self, expr, rational=False):
        if expr.exp == -1:
            return f"1/({self._print(expr.base)})"
        if expr.exp.is_Integer and expr.exp < 0:
            return f"1/({self._print(expr.base)})**{-int(expr.exp)}"
        return super()._print_Pow(expr, rational=rational)


def _emit(group: _Group, d: Derivation, printer: _Printer) -> str:
    exprs = [e for _, e in group.outputs] + ([group.returns] if group.returns is not None else [])
    temps, reduced = sp.cse(exprs, symbols=sp.numbered_symbols("t_"), order="canonical")
    used = set().union(*(e.free_symbols for e in exprs))
    lines = [f"def {group.name}({group.args}):", f'    """{group.doc}"""']
    for i, s in enumerate(d.q + d.qd):
        if s in used:
            lines.append(f"    {s.name} = u[{i}]")
    for i, s in enumerate(sp.symbols("a0:4", real=True)):
        if s in used:
            lines.append(f"    {s.name} = a[{i}]")
    for i, name in enumerate(PARAM_NAMES):
        if d.params[name] in used:
            lines.append(f"    {name} = p[{i}]")
    for sym, expr in temps:
        lines.append(f"    {sym.name} = {printer.doprint(expr)}")
    for (target, _), expr in zip(group.outputs, reduced):
        lines.append(f"    {target} = {printer.doprint(expr)}")
    if group.returns is not None:
        lines.append(f"    return {printer.doprint(reduced[-1])}")
    return "\n".join(lines) + "\n"


def _inputs_hash() -> str:
    """sha256 of this generator's source and the sympy version."""
    digest = hashlib.sha256(Path(__file__).read_bytes())
    digest.update(sp.__version__.encode())
    return digest.hexdigest()


_HEADER = '''\
# Generated by polywear.models.axle4dof_derivation -- do not edit; regenerate with
#   python -m polywear.models.axle4dof_derivation
# inputs sha256 (derivation source + sympy {sympy}): {digest}
"""Compiled kernels of model ``axle4dof`` (generated; see ``axle4dof_derivation``).

State ``u = (alpha, beta, gamma, x, alpha', beta', gamma', x', z)``; parameter vector
``p`` laid out by :data:`PARAM_NAMES`. Each kernel ``(u, V, p, out)`` fills ``out``;
``u``, ``V`` and ``p`` share one dtype, float or complex (complex-step derivatives).
"""

import numpy as np
from numba import njit
from numpy import cos, sin

from ..physics.lugre import bristle_rate, bristle_rate_partials, real_sign, stribeck, stribeck_dv

STATE_NAMES = {state_names}
PARAM_NAMES = {param_names}
'''

# Hand-written numeric part of the kernels: LuGre force, clamp, springs, preloads,
# linear solve and the chain rule. Generated expression functions are compiled with njit.
_KERNELS = '''
_NQ = 4
_ZB = 8


@njit(cache=True)
def _zero(u, V, p):
    """0 of the common dtype of u, V and p."""
    return 0.0 * (u[0] + V + p[0])


@njit(cache=True)
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


@njit(cache=True)
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


@njit(cache=True)
def _running_force_dv(V, p):
    """dF0/dV [N s/m] of the running equilibrium's friction force."""
    slip = sin(p[_TOE0]) - p[_EPS] * sin(p[_CAMBER0])
    vr0 = V * slip
    dmu0 = real_sign(vr0) * stribeck_dv(vr0, p[_MU_S], p[_MU_C], p[_V_S], p[_DELTA]) + p[_SIGMA2]
    return p[_N0] * dmu0 * slip


@njit(cache=True)
def _preload(V, p, P):
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


@njit(cache=True)
def _preload_dv(V, p, dP):
    """dP/dV of :func:`_preload` (from the running part only)."""
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


@njit(cache=True)
def _workspace(u, V, p):
    """A zero of the common dtype and empty M (4, 4), Q (4, 1), G_F, G_N for :func:`_evaluate`."""
    zero = _zero(u, V, p)
    M = np.empty((_NQ, _NQ), dtype=np.asarray(zero).dtype)
    return zero, M, np.empty((_NQ, 1), dtype=M.dtype), np.empty(_NQ, dtype=M.dtype), np.empty(_NQ, dtype=M.dtype)


@njit(cache=True)
def _evaluate(u, V, p, M, Q, GF, GN):
    """Fill M, the total generalized force Q (4, 1), G_F and G_N at u;
    return (v_r, G(v_r), z', F, N, clamped)."""
    h = np.empty(_NQ, dtype=Q.dtype)
    P = np.empty(_NQ, dtype=Q.dtype)
    _inertia(u, V, p, M, h)
    rise = _contact(u, p, GF, GN)
    _preload(V, p, P)
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


@njit(cache=True)
def rhs(u, V, p, out):
    """du/dt [rad/s, rad/s, rad/s, m/s, rad/s^2, rad/s^2, rad/s^2, m/s^2, m/s]."""
    zero, M, Q, GF, GN = _workspace(u, V, p)
    zd = _evaluate(u, V, p, M, Q, GF, GN)[2]
    _solve(M, Q)
    for i in range(_NQ):
        out[i] = u[_NQ + i]
        out[_NQ + i] = Q[i, 0]
    out[_ZB] = zd


@njit(cache=True)
def jac(u, V, p, out):
    """df/du (9 x 9)."""
    n2 = 2 * _NQ
    zero, M, Q, GF, GN = _workspace(u, V, p)
    vr, g, zd, force, load, clamped = _evaluate(u, V, p, M, Q, GF, GN)
    _solve(M, Q)
    a = Q[:, 0].copy()
    dMa = np.empty((_NQ, _NQ), dtype=M.dtype)
    dh = np.empty((_NQ, n2), dtype=M.dtype)
    dh_dv = np.empty(_NQ, dtype=M.dtype)
    _inertia_partials(u, a, V, p, dMa, dh, dh_dv)
    dGF = np.empty((_NQ, _NQ), dtype=M.dtype)
    dGN = np.empty((_NQ, _NQ), dtype=M.dtype)
    _contact_partials(u, p, dGF, dGN)
    dvr = np.empty(n2, dtype=M.dtype)
    _sliding_partials(u, V, p, dvr)

    dg = stribeck_dv(vr, p[_MU_S], p[_MU_C], p[_V_S], p[_DELTA])
    dzd_dvr, dzd_dz = bristle_rate_partials(vr, u[_ZB], p[_SIGMA0], g, dg)
    mu = p[_SIGMA0] * u[_ZB] + p[_SIGMA1] * zd + p[_SIGMA2] * vr
    dF_dvr = load * (p[_SIGMA1] * dzd_dvr + p[_SIGMA2])
    dF_dz = load * (p[_SIGMA0] + p[_SIGMA1] * dzd_dz)

    # dN/d(q, q'): N = N0 - k_z rise(q) - c_z G_N(q).q', with d rise/dq = G_N
    dN = np.zeros(n2, dtype=M.dtype)
    if not clamped:
        for k in range(_NQ):
            dN[k] = -p[_K_Z] * GN[k]
            dN[_NQ + k] = -p[_C_Z] * GN[k]
            for i in range(_NQ):
                dN[k] -= p[_C_Z] * dGN[i, k] * u[_NQ + i]

    # dQ/d(q, q', z) minus d(M a)/dq, then the accelerations' rows: M^-1 of that
    B = np.zeros((_NQ, n2 + 1), dtype=M.dtype)
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
    _solve(M, B)

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


@njit(cache=True)
def dfdv(u, V, p, out):
    """df/dV [per m/s]: through v_r, the wheel-spin rate V/R_e and the running preloads."""
    zero, M, Q, GF, GN = _workspace(u, V, p)
    vr, g, zd, force, load, clamped = _evaluate(u, V, p, M, Q, GF, GN)
    dvr = np.empty(2 * _NQ, dtype=M.dtype)
    dvr_dv = _sliding_partials(u, V, p, dvr)
    _solve(M, Q)
    dMa = np.empty((_NQ, _NQ), dtype=M.dtype)
    dh = np.empty((_NQ, 2 * _NQ), dtype=M.dtype)
    dh_dv = np.empty(_NQ, dtype=M.dtype)
    _inertia_partials(u, Q[:, 0].copy(), V, p, dMa, dh, dh_dv)
    dg = stribeck_dv(vr, p[_MU_S], p[_MU_C], p[_V_S], p[_DELTA])
    dzd_dvr = bristle_rate_partials(vr, u[_ZB], p[_SIGMA0], g, dg)[0]
    dF_dv = load * (p[_SIGMA1] * dzd_dvr + p[_SIGMA2]) * dvr_dv
    dP = np.empty(_NQ, dtype=M.dtype)
    _preload_dv(V, p, dP)
    B = np.empty((_NQ, 1), dtype=M.dtype)
    for i in range(_NQ):
        B[i, 0] = dh_dv[i] + GF[i] * dF_dv + dP[i]
    _solve(M, B)
    for i in range(_NQ):
        out[i] = zero
        out[_NQ + i] = B[i, 0]
    out[_ZB] = dzd_dvr * dvr_dv


@njit(cache=True)
def aux(u, V, p, out):
    """Sliding velocity v_r [m/s], friction force F [N], normal load N [N], contact lost [0/1]."""
    zero, M, Q, GF, GN = _workspace(u, V, p)
    vr, g, zd, force, load, clamped = _evaluate(u, V, p, M, Q, GF, GN)
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
    _preload(V, p, P)
    vr = _sliding(u, V, p)
    load = max(p[_N0] - p[_K_Z] * rise - p[_C_Z] * (GN @ u[_NQ:2 * _NQ]), 0.0)
    g = stribeck(vr, p[_MU_S], p[_MU_C], p[_V_S], p[_DELTA])
    zd = bristle_rate(vr, u[_ZB], p[_SIGMA0], g)
    force = load * (p[_SIGMA0] * u[_ZB] + p[_SIGMA1] * zd + p[_SIGMA2] * vr)
    stiff = p[[_K_ALPHA, _K_BETA, _K_GAMMA, _K]]
    damp = p[[_C_ALPHA, _C_BETA, _C_GAMMA, _C]]
    Q = h + force * GF + load * GN + P - stiff * u[:_NQ] - damp * u[_NQ:2 * _NQ]
    return np.concatenate((u[_NQ:2 * _NQ], np.linalg.solve(M, Q), [zd]))
'''


def generate_source() -> str:
    """Source text of the generated kernel module."""
    d = derive()
    printer = _Printer()
    parts = [_HEADER.format(sympy=sp.__version__, digest=_inputs_hash(), state_names=repr(STATE_NAMES), param_names=repr(PARAM_NAMES))]
    parts.append("\n".join(f"_{name.upper()} = {i}" for i, name in enumerate(PARAM_NAMES)) + "\n")
    for group in _groups(d):
        parts.append("\n@njit(cache=True)\n" + _emit(group, d, printer))
    parts.append(_KERNELS)
    return "\n".join(parts)


def write_generated(path: Path = GENERATED_PATH) -> Path:
    """Write the generated module to ``path``."""
    path.write_text(generate_source())
    return path


if __name__ == "__main__":
    written = write_generated(Path(sys.argv[1]) if len(sys.argv) > 1 else GENERATED_PATH)
    print(f"wrote {written}", file=sys.stderr)
