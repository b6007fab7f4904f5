"""Equations of motion of ``axle4dof`` (docs/model.md section 4) and their code generator.

The equations are derived with :mod:`sympy.physics.mechanics` (Lagrange's method) and
written out as plain Python source of ``numba.njit(cache=True)`` functions in
``_axle4dof_generated.py`` (committed). This module and sympy are needed only to
regenerate that file and by the tests, never at run time. Regenerate with::

    python -m polywear.models.axle4dof_derivation

What is symbolic and what is numeric:

- symbolic (generated here, then compiled): the mass matrix ``M(q)``, the
  velocity-dependent inertial forces ``h(q, q', V)`` (Coriolis, centrifugal, gyroscopic
  wheel spin), the contact gradients ``G_F = (dr_P/dq)^T d`` and ``G_N = (dr_C/dq)^T e_Z``
  that turn the friction force and the normal load into generalized forces, the sliding
  velocity ``v_r`` and the rise of the contact point, and every partial derivative of these;
- numeric, hand-written in :mod:`.axle4dof_kernels` (the kernels ``rhs``, ``jac``,
  ``dfdv``, ``aux``): the LuGre force (``physics.lugre``), the contact-loss clamp,
  springs, dampers, preloads, the 4x4 linear solve for the accelerations and the chain
  rule that assembles the Jacobian from the generated partials.
"""

from __future__ import annotations

import hashlib
import sys
from dataclasses import dataclass
from functools import cache
from pathlib import Path

try:
    import sympy as sp
except ImportError as exc:
    raise ImportError("the axle4dof derivation needs sympy: pip install 'polywear[generate]'") from exc
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

__all__ = ["PARAM_NAMES", "STATE_NAMES", "Derivation", "PatchDerivation", "derive", "derive_patch", "generate_source", "write_generated"]

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


@dataclass(frozen=True)
class PatchDerivation:
    """The patch contact's pieces (docs/patch_contact.md section 6): the arm alone, and one
    tread element of unit mass at ``C + xi x_B + y y_B``.

    Lagrange's equations are linear in the Lagrangian, so the body's equations with M
    elements are the arm's plus the sum of the elements' (each element's mass times its
    unit-mass terms); element j's own equation is the fourth row of its terms."""

    q: tuple[sp.Symbol, ...]
    """Body coordinates (alpha, beta, gamma)."""
    qd: tuple[sp.Symbol, ...]
    element: tuple[sp.Symbol, ...]
    """(xi, y, w): the element's position along the heading [m], its lateral deflection
    along y_B [m] and the material rate of that deflection [m/s]."""
    speed: sp.Symbol
    params: dict[str, sp.Symbol]
    arm_mass_matrix: sp.Matrix
    arm_forces: sp.Matrix
    """Arm and wheel spin: inertial forces (Coriolis, centrifugal, gyroscopic)."""
    normal_gradient: sp.Matrix
    contact_rise: sp.Expr
    element_mass_matrix: sp.Matrix
    """Unit-mass element, coordinates (alpha, beta, gamma, y): 4 x 4."""
    element_forces: sp.Matrix
    element_friction_gradient: sp.Matrix
    element_sliding_velocity: sp.Expr


@cache
def derive_patch() -> PatchDerivation:
    """Derive the patch contact's arm and element terms (cached; a few seconds).

    The element sits at a fixed position ``xi`` of the patch: the transport of the tread
    through the patch (its velocity ``-V cos(toe)`` along x_B) is added by the kernels as
    the upwind transport of the fields y, w, z; its kinetic energy is the wheel's spin,
    counted once in ``I_w`` and ``J2`` as for the point contact."""
    P = {name: sp.Symbol(name, real=True) for name in PARAM_NAMES}
    V = sp.Symbol("V", real=True)
    xi = sp.Symbol("xi", real=True)
    alpha, beta, gamma, y = dynamicsymbols("alpha beta gamma y")
    body_coords = [alpha, beta, gamma]
    psi = P["toe0"] + alpha
    phi = P["camber0"] + beta

    ground = ReferenceFrame("N")
    yawed = ground.orientnew("A", "Axis", (psi, ground.z))
    pitched = yawed.orientnew("Bp", "Axis", (-gamma, yawed.y))
    body = pitched.orientnew("B", "Axis", (phi, pitched.x))

    pivot = Point("O")
    pivot.set_vel(ground, 0)
    contact = pivot.locatenew("C", -P["L"] * body.x - P["b"] * body.y - P["H"] * body.z)
    contact.v2pt_theory(pivot, ground, body)
    element = contact.locatenew("E", xi * body.x + y * body.y)
    element.set_vel(body, y.diff() * body.y)
    element.v1pt_theory(contact, ground, body)

    arm = RigidBody("arm", pivot, body, 0, (inertia(body, P["J1"], P["J2"], P["J3"]), pivot))
    spin = P["I_w"] * V / P["R_e"] * body.ang_vel_in(ground).dot(body.y)
    lateral = -sp.sin(psi) * ground.x + sp.cos(psi) * ground.y
    friction, normal = sp.symbols("F_friction N_normal", real=True)
    arm_method = LagrangesMethod(
        Lagrangian(ground, arm) + spin, body_coords, forcelist=[(contact, normal * ground.z)], frame=ground
    )
    arm_method.form_lagranges_equations()
    element_method = LagrangesMethod(
        Lagrangian(ground, Particle("element", element, 1)),
        [*body_coords, y],
        forcelist=[(element, friction * lateral)],
        frame=ground,
    )
    element_method.form_lagranges_equations()

    names = STATE_NAMES[:3] + STATE_NAMES[4:7]
    q = tuple(sp.Symbol(n, real=True) for n in names[:3])
    qd = tuple(sp.Symbol(n, real=True) for n in names[3:])
    y_s, w_s = sp.Symbol("y", real=True), sp.Symbol("w", real=True)
    plain = (
        {**{c.diff(): s for c, s in zip(body_coords, qd)}, y.diff(): w_s},
        {**dict(zip(body_coords, q)), y: y_s},
    )

    def to_plain(expr):
        return msubs(expr, *plain)

    arm_forcing = to_plain(arm_method.forcing)
    element_forcing = to_plain(element_method.forcing)
    road = -V * ground.x
    v_r = (road - element.vel(ground)).dot(lateral) - P["eps"] * V * sp.sin(phi)
    height = contact.pos_from(pivot).dot(ground.z)
    return PatchDerivation(
        q=q,
        qd=qd,
        element=(xi, y_s, w_s),
        speed=V,
        params=P,
        arm_mass_matrix=to_plain(arm_method.mass_matrix),
        arm_forces=arm_forcing.subs({normal: 0}),
        normal_gradient=arm_forcing.diff(normal),
        contact_rise=to_plain(height - height.subs({alpha: 0, beta: 0, gamma: 0})),
        element_mass_matrix=to_plain(element_method.mass_matrix),
        element_forces=element_forcing.subs({friction: 0}),
        element_friction_gradient=element_forcing.diff(friction),
        element_sliding_velocity=to_plain(v_r),
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


def _patch_groups(d: PatchDerivation) -> list[_Group]:
    q, qd, V = d.q, d.qd, d.speed
    _xi, y, w = d.element
    accel = sp.symbols("a0:4", real=True)
    body_states = q + qd
    element_states = (*q, y, *qd, w)

    def vec(target, exprs):
        return tuple((f"{target}[{i}]", e) for i, e in enumerate(exprs))

    def mat(target, rows, cols, fn):
        return tuple((f"{target}[{i}, {j}]", fn(i, j)) for i in range(rows) for j in range(cols))

    Ma = d.arm_mass_matrix * sp.Matrix(accel[:3])
    h, GN = d.arm_forces, d.normal_gradient
    Me, he, GF, v = d.element_mass_matrix, d.element_forces, d.element_friction_gradient, d.element_sliding_velocity
    Mea = Me * sp.Matrix(accel)
    coords = (*q, y)
    return [
        _Group(
            "_patch_arm",
            "u, V, p, M, h, GN",
            "Arm and wheel spin: mass matrix M (3 x 3), inertial forces h, normal-load gradient G_N; "
            "returns the rise of C [m]. u = (alpha, beta, gamma, their rates, ...).",
            mat("M", 3, 3, lambda i, j: d.arm_mass_matrix[i, j]) + vec("h", h) + vec("GN", GN),
            d.contact_rise,
        ),
        _Group(
            "_patch_arm_partials",
            "u, a, V, p, dMa, dh, dh_dv, dGN",
            "d(M a)/dq at fixed a, dh/d(q, q') (3 x 6), dh/dV, dG_N/dq of the arm.",
            mat("dMa", 3, 3, lambda i, j: Ma[i].diff(q[j]))
            + mat("dh", 3, 6, lambda i, j: h[i].diff(body_states[j]))
            + vec("dh_dv", h.diff(V))
            + mat("dGN", 3, 3, lambda i, j: GN[i].diff(q[j])),
        ),
        _Group(
            "_patch_element",
            "u, e, V, p, M, h, GF",
            "One tread element of unit mass at e = (xi, y, w): mass matrix M and inertial forces h "
            "(coordinates alpha, beta, gamma, y), friction gradient G_F; returns its sliding velocity [m/s].",
            mat("M", 4, 4, lambda i, j: Me[i, j]) + vec("h", he) + vec("GF", GF),
            v,
        ),
        _Group(
            "_patch_element_partials",
            "u, e, a, V, p, dMa, dh, dGF, dv",
            "Of the unit-mass element: d(M a)/d(q, y) at fixed a (4 x 4), dh/d(q, y, q', w) (4 x 8), "
            "dG_F/d(q, y) (4 x 4), dv/d(q, y, q', w) (8); returns dv/dV.",
            mat("dMa", 4, 4, lambda i, j: Mea[i].diff(coords[j]))
            + mat("dh", 4, 8, lambda i, j: he[i].diff(element_states[j]))
            + mat("dGF", 4, 4, lambda i, j: GF[i].diff(coords[j]))
            + vec("dv", [v.diff(s) for s in element_states]),
            v.diff(V),
        ),
    ]


def _patch_inputs(d: PatchDerivation) -> list[tuple[sp.Symbol, str]]:
    """Where the patch's generated functions read their symbols: body states from u[0:6],
    the element from e, accelerations from a, parameters from p."""
    inputs = [(s, f"u[{i}]") for i, s in enumerate(d.q + d.qd)]
    inputs += [(s, f"e[{i}]") for i, s in enumerate(d.element)]
    inputs += [(s, f"a[{i}]") for i, s in enumerate(sp.symbols("a0:4", real=True))]
    return inputs + [(d.params[name], f"p[{i}]") for i, name in enumerate(PARAM_NAMES)]


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


def _point_inputs(d: Derivation) -> list[tuple[sp.Symbol, str]]:
    """Where the point contact's generated functions read their symbols: u, a, p."""
    inputs = [(s, f"u[{i}]") for i, s in enumerate(d.q + d.qd)]
    inputs += [(s, f"a[{i}]") for i, s in enumerate(sp.symbols("a0:4", real=True))]
    return inputs + [(d.params[name], f"p[{i}]") for i, name in enumerate(PARAM_NAMES)]


def _emit(group: _Group, inputs: list[tuple[sp.Symbol, str]], printer: _Printer) -> str:
    exprs = [e for _, e in group.outputs] + ([group.returns] if group.returns is not None else [])
    temps, reduced = sp.cse(exprs, symbols=sp.numbered_symbols("t_"), order="canonical")
    used = set().union(*(e.free_symbols for e in exprs))
    lines = [f"def {group.name}({group.args}):", f'    """{group.doc}"""']
    for s, source in inputs:
        if s in used:
            lines.append(f"    {s.name} = {source}")
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
"""Symbolic part of model ``axle4dof``, compiled (generated; see ``axle4dof_derivation``).

Mass matrix and inertial forces, contact gradients and rise, sliding velocity, and their
partial derivatives, as ``numba.njit`` functions of the state
``u = (alpha, beta, gamma, x, alpha', beta', gamma', x', z)`` and the parameter vector
``p`` laid out by :data:`PARAM_NAMES` (index of entry ``name``: ``_NAME``). Arrays share
one dtype, float or complex. The kernels built on them are in ``axle4dof_kernels``.
"""

from numba import njit
from numpy import cos, sin

STATE_NAMES = {state_names}
PARAM_NAMES = {param_names}
'''

def generate_source() -> str:
    """Source text of the generated module (symbolic part only)."""
    d = derive()
    printer = _Printer()
    parts = [_HEADER.format(sympy=sp.__version__, digest=_inputs_hash(), state_names=repr(STATE_NAMES), param_names=repr(PARAM_NAMES))]
    parts.append("\n".join(f"_{name.upper()} = {i}" for i, name in enumerate(PARAM_NAMES)) + "\n")
    for group in _groups(d):
        parts.append("\n@njit(cache=True, error_model=\"numpy\")\n" + _emit(group, _point_inputs(d), printer))
    patch = derive_patch()
    for group in _patch_groups(patch):
        parts.append("\n@njit(cache=True, error_model=\"numpy\")\n" + _emit(group, _patch_inputs(patch), printer))
    return "\n".join(parts)


def write_generated(path: Path = GENERATED_PATH) -> Path:
    """Write the generated module to ``path``."""
    path.write_text(generate_source())
    return path


if __name__ == "__main__":
    written = write_generated(Path(sys.argv[1]) if len(sys.argv) > 1 else GENERATED_PATH)
    print(f"wrote {written}", file=sys.stderr)
