"""Model ``axle4dof``: twist-beam trailing arm + lateral tread (docs/model.md section 4).

One trailing arm of the twist beam with its wheel carrier and wheel is a rigid body
rotating about the bushing centre O, ``R = Rz(toe0 + alpha) Ry(-gamma) Rx(camber0 + beta)``;
the tread is a particle at the contact point C, sliding along the body y axis on a
spring and damper, with LuGre friction against the drum and a vertical tire spring.
The equations are derived in :mod:`.axle4dof_derivation` into the generated module
``_axle4dof_generated`` (symbolic expressions); the kernels built on them are in
:mod:`.axle4dof_kernels` (see ``docs/model_axle4dof.md``).

States ``u = (alpha, beta, gamma [rad], x [m], alpha', beta', gamma' [rad/s], x' [m/s],
z [m])``: dynamic toe (toe-in positive), dynamic camber (top outward positive), arm
pitch (positive moves C down), lateral tread deflection (inboard positive), rates and
the LuGre bristle deflection.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from . import _axle4dof_generated as _gen
from . import axle4dof_kernels as _kernels
from ..errors import NumericalError
from ..units import ms_to_kmh
from .base import DEG, Model, ParamSlot

_KEYS = {
    "m": ("tread.mass_kg", 1.0),
    "k": ("tread.lateral_stiffness_n_per_m", 1.0),
    "c": ("tread.lateral_damping_ns_per_m", 1.0),
    "N0": ("operating.vertical_load_n", 1.0),
    "toe0": ("operating.toe_deg", DEG),
    "camber0": ("operating.camber_deg", DEG),
    "R_e": ("operating.rolling_radius_m", 1.0),
    "sigma0": ("friction.sigma0_per_m", 1.0),
    "sigma1": ("friction.sigma1_s_per_m", 1.0),
    "sigma2": ("friction.sigma2_s_per_m", 1.0),
    "mu_s": ("friction.mu_static", 1.0),
    "mu_c": ("friction.mu_coulomb", 1.0),
    "v_s": ("friction.stribeck_velocity_m_per_s", 1.0),
    "delta": ("friction.stribeck_exponent", 1.0),
    "J1": ("axle.inertia_x_kgm2", 1.0),
    "J2": ("axle.inertia_y_kgm2", 1.0),
    "J3": ("axle.inertia_z_kgm2", 1.0),
    "k_alpha": ("axle.toe_stiffness_nm_per_rad", 1.0),
    "c_alpha": ("axle.toe_damping_nms_per_rad", 1.0),
    "k_beta": ("axle.camber_stiffness_nm_per_rad", 1.0),
    "c_beta": ("axle.camber_damping_nms_per_rad", 1.0),
    "k_gamma": ("axle.pitch_stiffness_nm_per_rad", 1.0),
    "c_gamma": ("axle.pitch_damping_nms_per_rad", 1.0),
    "L": ("axle.arm_length_m", 1.0),
    "b": ("axle.lateral_offset_m", 1.0),
    "H": ("axle.pivot_height_m", 1.0),
    "eps": ("axle.camber_thrust_factor", 1.0),
    "I_w": ("axle.wheel_spin_inertia_kgm2", 1.0),
    "k_z": ("tire.vertical_stiffness_n_per_m", 1.0),
    "c_z": ("tire.vertical_damping_ns_per_m", 1.0),
}

REFERENCES = ("running", "unloaded")
"""Values of ``axle.reference``; the kernel flag is the index (0 = running, 1 = unloaded)."""


def _reference_flag(params) -> float:
    return float(REFERENCES.index(params.axle.reference))


def _not_cached(params) -> float:
    return math.nan


def _slot(name: str) -> ParamSlot:
    if name == "reference":
        return ParamSlot(name, None, encode=_reference_flag)
    if name.startswith("preload_"):
        return ParamSlot(name, None, encode=_not_cached)
    return ParamSlot(name, _KEYS[name][0], _KEYS[name][1])


SLOTS = tuple(_slot(name) for name in _gen.PARAM_NAMES)
"""Kernel parameter vector layout (order fixed by the derivation); the ``preload_*``
entries are a per-speed cache, empty (NaN) in a packed vector (see :func:`prepare`)."""

STATE_NAMES = _gen.STATE_NAMES
AUX_NAMES = ("sliding_velocity", "friction_force", "normal_load", "contact_lost")

_TOE0 = _gen.PARAM_NAMES.index("toe0")
_CAMBER0 = _gen.PARAM_NAMES.index("camber0")
_REFERENCE = _gen.PARAM_NAMES.index("reference")
_PRELOAD_SPEED = _gen.PARAM_NAMES.index("preload_speed")
_EQUILIBRIUM_TOL = 1e-12
"""Accept a solution when the Newton step is below this [rad, m, rad/s, m/s]."""


def equilibrium(V, p):
    """Steady rolling state at speed ``V`` [m/s].

    ``running`` reference: closed form, alpha = beta = gamma = 0, x' = 0 and the steady
    LuGre state. ``unloaded``: the steady tire force deflects the axle; the equilibrium
    is the one connected to the running state, found by following the preload blend
    r from 0 (running) to 1 (unloaded) with Newton steps (step in r halved when Newton
    fails). Where the friction curve allows several equilibria (e.g. a sticking one
    with zero sliding velocity) this picks the one reached by relaxing the preload,
    deterministically. :func:`running_alignment` gives the resulting toe and camber.
    """
    u = np.empty(len(STATE_NAMES))
    _kernels.running_equilibrium(float(V), p, u)
    if p[_REFERENCE] == 0.0:
        return u
    return relax_preload(MODEL, u, V, p)


def relax_preload(model, u, V, p):
    """The unloaded-reference equilibrium of ``model`` (``axle4dof`` with either contact)
    connected to its running one ``u``: Newton steps along the preload blend r from 0 to 1
    (see :func:`equilibrium`)."""
    q = np.array(p, dtype=float)
    q[_REFERENCE] = 1.0
    f1 = model.f(u, V, q)
    q[_REFERENCE] = 0.0
    df_dr = f1 - model.f(u, V, q)  # the preload, hence f, is linear in r: exact
    r, dr = 0.0, 0.1
    while r < 1.0:
        r_new = min(1.0, r + dr)
        q[_REFERENCE] = r
        predicted = u - (r_new - r) * np.linalg.solve(model.jacobian(u, V, q), df_dr)
        q[_REFERENCE] = r_new
        corrected = _newton(model, predicted, V, q)
        # accept only a small correction of the sliding velocity against its predicted change:
        # no jump across the |v_r| kink onto another (e.g. sticking) equilibrium
        if corrected is not None:
            v0, vp, vc = (model.diagnostics(w, V, q)[0] for w in (u, predicted, corrected))
            jump = abs(vc - vp)
            if np.sign(vc) == np.sign(v0) and jump <= 0.2 * abs(vp - v0) + 1e-12 and jump <= 0.1 * abs(vc):
                u, r = corrected, r_new
                dr = min(2.0 * dr, 0.1)
                continue
        dr *= 0.5
        if dr < 1e-6:
            raise NumericalError(
                f"{model.name}: no unloaded-reference equilibrium connected to the running state at "
                f"V = {ms_to_kmh(V):.3f} km/h (the preload homotopy stalled at r = {r:.6f})"
            )
    return u


def _newton(model, u, V, p, max_iter=20):
    """Newton from ``u``: the converged state, or None."""
    for _ in range(max_iter):
        step = np.linalg.solve(model.jacobian(u, V, p), model.f(u, V, p))
        if not np.all(np.isfinite(step)):
            return None
        u = u - step
        if np.abs(step).max() < _EQUILIBRIUM_TOL:
            return u
    return None


def prepare(V, p):
    """``p`` with the preloads of speed ``V`` [m/s] cached, for time integration at fixed V.

    The running-reference preloads depend on V only, yet the kernels would otherwise
    recompute them (a quarter of the rhs cost) at every call. The kernels use the cache
    only when called with exactly this V, so a prepared vector stays correct at other
    speeds; do not use it for complex-step derivatives with respect to ``p``."""
    q = np.array(p, dtype=float)
    q[_PRELOAD_SPEED] = math.nan
    P = np.empty(4)
    _kernels.preload(float(V), q, P)
    q[_PRELOAD_SPEED + 1 : _PRELOAD_SPEED + 4] = P[:3]
    q[_PRELOAD_SPEED] = float(V)
    return q


def running_alignment(u, p) -> tuple[float, float]:
    """Running toe and camber [rad] of state ``u``: ``toe0 + alpha``, ``camber0 + beta``."""
    return p[_TOE0] + u[0], p[_CAMBER0] + u[1]


class _Kernels:
    rhs = _kernels.rhs
    jac = _kernels.jac
    dfdv = _kernels.dfdv
    rhs_jac_dfdv = _kernels.rhs_jac_dfdv
    aux = _kernels.aux
    equilibrium = staticmethod(equilibrium)
    prepare = staticmethod(prepare)
    running_alignment = staticmethod(running_alignment)


def rhs_python(t, u, V, p):
    """du/dt in pure Python/NumPy (no numba anywhere), from the same generated source:
    the reference right-hand side for tests and the benchmark baseline."""
    return _pure_rhs()(t, u, V, p)


@functools.cache
def _pure_rhs():
    from ..physics import lugre
    from .pure import pure_python_namespace

    return pure_python_namespace(lugre, _gen, _kernels)["rhs_python"]

MODEL = Model(
    name="axle4dof",
    state_names=STATE_NAMES,
    state_units=("rad", "rad", "rad", "m", "rad/s", "rad/s", "rad/s", "m/s", "m"),
    aux_names=AUX_NAMES,
    slots=SLOTS,
    kernels=_Kernels,
    coordinates=(("alpha", "k_alpha"), ("beta", "k_beta"), ("gamma", "k_gamma"), ("x", "k")),
)
