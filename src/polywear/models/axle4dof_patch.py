"""Model ``axle4dof`` with the patch contact: the arm carries M tread elements that travel
through the contact patch (docs/patch_contact.md section 6; kernels in
:mod:`.axle4dof_patch_kernels`, derived terms in :mod:`.axle4dof_derivation`).

States ``u = (alpha, beta, gamma [rad], alpha', beta', gamma' [rad/s], then per element
y [m], w [m/s], z [m])``, leading edge first; the trailing element is named ``x, xdot, z``
like the point contact's tread. Parameters: ``axle4dof``'s, the patch length
``tire.contact_length_m`` and the M load shares of ``friction.patch_pressure``.
"""

from __future__ import annotations

import math
from functools import cache

import numpy as np

from ..errors import NumericalError
from ..units import ms_to_kmh
from . import axle4dof_patch_kernels as _kernels
from ._axle4dof_generated import _PRELOAD_SPEED, _REFERENCE
from .axle4dof import SLOTS as POINT_SLOTS
from .axle4dof import relax_preload, running_alignment
from .base import Model, ParamSlot
from .patch import M_MAX, _share_slot, load_shares

__all__ = ["axle4dof_patch_model", "equilibrium", "prepare"]

AUX_NAMES = ("sliding_velocity", "friction_force", "normal_load", "contact_lost", "sliding_velocity_rear", "sliding_share")


def equilibrium(V, p):
    """Steady rolling state at speed ``V`` [m/s]: the carrier at rest with the patch's
    steady state (running reference), or the one the preload homotopy reaches from it
    (unloaded reference, as for the point contact)."""
    p = np.asarray(p, dtype=float)
    n_el = len(p) - _kernels.SHARE0
    u = np.empty(_kernels.E0 + 3 * n_el)
    if not _kernels.rest_state(float(V), p, u):
        raise NumericalError(f"axle4dof+patch: no steady state of the patch at V = {ms_to_kmh(V):.3f} km/h")
    if p[_REFERENCE] == 0.0:
        return u
    # the kernels read the load shares from p: the model of either pressure evaluates them
    return relax_preload(axle4dof_patch_model(n_el, "uniform"), u, V, p)


def prepare(V, p):
    """``p`` with the preloads of speed ``V`` [m/s] cached (time integration at fixed V)."""
    q = np.array(p, dtype=float)
    q[_PRELOAD_SPEED] = math.nan
    P = np.empty(3)
    _kernels.preload(float(V), q, P)
    q[_PRELOAD_SPEED + 1 : _PRELOAD_SPEED + 4] = P
    q[_PRELOAD_SPEED] = float(V)
    return q


class _Kernels:
    rhs = _kernels.rhs
    jac = _kernels.jac
    dfdv = _kernels.dfdv
    rhs_jac_dfdv = _kernels.rhs_jac_dfdv
    aux = _kernels.aux
    equilibrium = staticmethod(equilibrium)
    prepare = staticmethod(prepare)
    running_alignment = staticmethod(running_alignment)


def _state_names(elements: int) -> tuple[str, ...]:
    names = ["alpha", "beta", "gamma", "alphadot", "betadot", "gammadot"]
    for j in range(elements - 1):
        names += [f"y{j}", f"w{j}", f"z{j}"]
    return (*names, "x", "xdot", "z")


@cache
def axle4dof_patch_model(elements: int, pressure: str) -> Model:
    """``axle4dof`` with a patch of ``elements`` tread elements under the ``pressure``
    distribution ("parabolic" or "uniform"). One element (below ``friction.patch_elements``'
    bounds) sits at the centre of the patch: with no transport (an infinitely long patch)
    it is the point contact (docs/patch_contact.md section 6)."""
    if not 1 <= elements <= M_MAX:
        raise ValueError(f"patch elements = {elements!r}: must be 1 to {M_MAX}")
    load_shares(pressure, elements)
    slots = (
        *POINT_SLOTS,
        ParamSlot("L", "tire.contact_length_m"),
        *(_share_slot(pressure, elements, j) for j in range(elements)),
    )
    return Model(
        name="axle4dof+patch",
        state_names=_state_names(elements),
        state_units=("rad",) * 3 + ("rad/s",) * 3 + ("m", "m/s", "m") * elements,
        aux_names=AUX_NAMES,
        slots=slots,
        kernels=_Kernels,
        coordinates=(("alpha", "k_alpha"), ("beta", "k_beta"), ("gamma", "k_gamma"), ("x", "k")),
    )
