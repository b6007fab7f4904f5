"""First-class function types of the model kernels, for compiled solvers.

A compiled solver is written once against these types; each model hands it
``numba.cfunc`` versions of its kernels, so one cached compilation of the solver
serves every model (plain njit dispatchers passed as arguments defeat numba's cache).
The cfuncs are handed over wrapped in :class:`FirstClass`, which makes the call of a
compiled solver cheaper.
"""

from __future__ import annotations

from numba import cfunc, njit, types
from numba.core.types import FunctionType

VEC = types.float64[::1]
MAT = types.float64[:, ::1]
RHS_SIG = types.void(VEC, types.float64, VEC, VEC)
JAC_SIG = types.void(VEC, types.float64, VEC, MAT)
FUSED_SIG = types.void(VEC, types.float64, VEC, VEC, MAT, VEC)
"""``rhs_jac_dfdv(u, V, p, f, J, fv)``."""


class FirstClass:
    """A compiled kernel (``numba.cfunc``) as a first-class function argument.

    Passed to a compiled function, a cfunc has its numba type built anew at every call
    (about 7 us per function argument). This wrapper
    carries the type, built once (``_numba_type_``), and gives numba the cfunc's address
    through numba's wrapper address protocol (``__wrapper_address__``), as numba does
    for the cfunc itself. It holds the cfunc, which owns the compiled code, so the
    address is valid for as long as the wrapper is alive (at least during the call).
    """

    __slots__ = ("_numba_type_", "cfunc")

    def __init__(self, kernel, signature) -> None:
        self.cfunc = kernel
        self._numba_type_ = FunctionType(signature)

    def __wrapper_address__(self) -> int:
        return self.cfunc.address


def _first_class(py_func, signature) -> FirstClass:
    """``py_func`` compiled as a cached cfunc of ``signature``, wrapped."""
    return FirstClass(cfunc(signature, cache=True, error_model="numpy")(py_func), signature)


def as_cfuncs(kernels):
    """``(rhs, jac, dfdv)`` of a kernel namespace as cached cfuncs (:class:`FirstClass`)."""
    return (
        _first_class(kernels.rhs.py_func, RHS_SIG),
        _first_class(kernels.jac.py_func, JAC_SIG),
        _first_class(kernels.dfdv.py_func, RHS_SIG),
    )


def fused_cfunc(kernels):
    """The ``rhs_jac_dfdv`` kernel as a cached cfunc (:class:`FirstClass`).

    Kernels without one (e.g. a small test model) get a cfunc calling their ``rhs``, ``jac``
    and ``dfdv`` in turn, compiled anew in every process: numba keys a cached closure by its
    pickled cells, and a pickled dispatcher carries a per-process id, so every process would
    miss the cache, compile again (0.6-1.0 s for ``axle4dof``) and add a cache file."""
    fused = getattr(kernels, "rhs_jac_dfdv", None)
    if fused is not None:
        return _first_class(fused.py_func, FUSED_SIG)
    return FirstClass(cfunc(FUSED_SIG, error_model="numpy")(_in_turn(kernels.rhs, kernels.jac, kernels.dfdv)),
                      FUSED_SIG)


def _in_turn(rhs, jac, dfdv):
    """``rhs_jac_dfdv`` calling the three kernels."""

    def rhs_jac_dfdv(u, V, p, f, J, fv):
        rhs(u, V, p, f)
        jac(u, V, p, J)
        dfdv(u, V, p, fv)

    return rhs_jac_dfdv


def aux_cfunc(kernels):
    """The ``aux`` kernel as a cached cfunc (:class:`FirstClass`)."""
    return _first_class(kernels.aux.py_func, RHS_SIG)


@njit(cache=True, nogil=True, error_model="numpy")
def batch(kernel, states, V, p, out):
    """Apply a ``(u, V, p, out)`` kernel to every row of ``states`` (m, n) into ``out`` (m, k)."""
    for i in range(states.shape[0]):
        kernel(states[i], V, p, out[i])
