"""The model interface shared by ``tread1dof`` and ``axle4dof``.

A model is data plus compiled kernels. Every kernel is a ``numba.njit`` function of
``(u, V, p, out)`` that fills ``out`` and returns nothing:

``rhs``   du/dt = f(u, V, p)                       out shape (n,)
``jac``   df/du                                      out shape (n, n)
``dfdv``  df/dV                                      out shape (n,)
``aux``   diagnostics (sliding velocity, friction force, normal load, ...)  out shape (n_aux,)

and, optional, ``rhs_jac_dfdv(u, V, p, f, J, fv)`` filling ``f``, ``J`` and ``fv`` with
what ``rhs``, ``jac`` and ``dfdv`` give, bit for bit, sharing their common work (the
collocation assembly needs all three at every point).

``u`` is the state, ``V`` the vehicle speed [m/s] and ``p`` the kernel parameter
vector in SI units (angles in rad), packed from a :class:`~polywear.params.Params` by
:meth:`Model.pack`. Kernels accept complex arrays too, for complex-step derivatives.

Compiled solvers take the kernels as first-class functions (``numba.cfunc``), so that
one cached compilation of a solver serves every model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, Callable

import numpy as np

from ..params import Params, get_value

__all__ = ["ParamSlot", "Model"]


@dataclass(frozen=True)
class ParamSlot:
    """One entry of a kernel parameter vector.

    ``p[i] = factor * value(key)``: ``key`` is the configuration key, ``factor``
    converts its unit to SI (``pi/180`` for degrees). ``key`` is ``None`` for a
    derived entry (e.g. a mode flag), which is never differentiated.
    """

    name: str
    key: str | None
    factor: float = 1.0
    encode: Callable[[Any], float] | None = None


DEG = math.pi / 180.0


@dataclass(frozen=True, eq=False)
class Model:
    """State layout, parameter layout and compiled kernels of one model."""

    name: str
    state_names: tuple[str, ...]
    state_units: tuple[str, ...]
    aux_names: tuple[str, ...]
    slots: tuple[ParamSlot, ...]
    kernels: Any = field(repr=False)
    """Module (or namespace) with njit ``rhs``, ``jac``, ``dfdv``, ``aux``, ``equilibrium`` and
    optional ``rhs_jac_dfdv``, ``prepare``."""
    coordinates: tuple[tuple[str, str], ...] = ()
    """(displacement state, name of its stiffness in ``p``): used to name a mode by the
    coordinate holding most of its potential energy."""

    @property
    def n(self) -> int:
        """Number of states."""
        return len(self.state_names)

    @property
    def param_names(self) -> tuple[str, ...]:
        return tuple(s.name for s in self.slots)

    def index(self, name: str) -> int:
        """Index of a state by name."""
        return self.state_names.index(name)

    def pack(self, params: Params) -> np.ndarray:
        """Kernel parameter vector ``p`` (SI units) from a parameter set."""
        out = np.empty(len(self.slots))
        for i, slot in enumerate(self.slots):
            value = get_value(params, slot.key) if slot.key else None
            out[i] = slot.encode(params) if slot.encode else slot.factor * value
        return out

    # -- convenient float evaluations -------------------------------------------------
    def f(self, u, V, p) -> np.ndarray:
        """du/dt at one state (works for complex arrays too)."""
        u = np.asarray(u)
        dtype = np.result_type(u, p, V)
        out = np.empty(self.n, dtype=dtype)
        self.kernels.rhs(u.astype(dtype), dtype.type(V), np.asarray(p).astype(dtype), out)
        return out

    def jacobian(self, u, V, p) -> np.ndarray:
        """df/du at one state (works for complex arrays too)."""
        u = np.asarray(u)
        dtype = np.result_type(u, p, V)
        out = np.empty((self.n, self.n), dtype=dtype)
        self.kernels.jac(u.astype(dtype), dtype.type(V), np.asarray(p).astype(dtype), out)
        return out

    def df_dspeed(self, u, V, p) -> np.ndarray:
        """df/dV [per (m/s)] at one state."""
        u = np.asarray(u)
        dtype = np.result_type(u, p, V)
        out = np.empty(self.n, dtype=dtype)
        self.kernels.dfdv(u.astype(dtype), dtype.type(V), np.asarray(p).astype(dtype), out)
        return out

    def diagnostics(self, u, V, p) -> np.ndarray:
        """Auxiliary outputs (``aux_names``) for one state or an array of states ``(..., n)``."""
        from .kernels import batch

        u = np.asarray(u, dtype=float)
        flat = np.ascontiguousarray(u.reshape(-1, self.n))
        out = np.empty((flat.shape[0], len(self.aux_names)))
        batch(self.compiled_aux, flat, float(V), np.ascontiguousarray(p, dtype=float), out)
        return out.reshape(u.shape[:-1] + (len(self.aux_names),))

    def prepared(self, V, p) -> np.ndarray:
        """Parameter vector for repeated calls at one speed V [m/s] (time integration):
        the model may cache speed-only quantities in it (``kernels.prepare``); else ``p``."""
        prepare = getattr(self.kernels, "prepare", None)
        return p if prepare is None else prepare(V, p)

    def equilibrium(self, V, p) -> np.ndarray:
        """Steady rolling state at speed ``V`` [m/s] (raises if it cannot be found)."""
        return self.kernels.equilibrium(float(V), np.asarray(p, dtype=float))

    @cached_property
    def compiled(self):
        """First-class (cfunc) kernels ``(rhs, jac, dfdv)`` for compiled solvers."""
        from .kernels import as_cfuncs

        return as_cfuncs(self.kernels)

    @cached_property
    def compiled_fused(self):
        """First-class (cfunc) kernel ``rhs_jac_dfdv`` for compiled solvers (built from
        ``rhs``, ``jac`` and ``dfdv`` if the kernels have none)."""
        from .kernels import fused_cfunc

        return fused_cfunc(self.kernels)

    @cached_property
    def compiled_aux(self):
        """First-class (cfunc) ``aux`` kernel."""
        from .kernels import aux_cfunc

        return aux_cfunc(self.kernels)
