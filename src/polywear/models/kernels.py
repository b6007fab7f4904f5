"""First-class function types of the model kernels, for compiled solvers.

A compiled solver is written once against these types; each model hands it
``numba.cfunc`` versions of its kernels, so one cached compilation of the solver
serves every model (plain njit dispatchers passed as arguments defeat numba's cache).
"""

from __future__ import annotations

from numba import cfunc, njit, types

VEC = types.float64[::1]
MAT = types.float64[:, ::1]
RHS_SIG = types.void(VEC, types.float64, VEC, VEC)
JAC_SIG = types.void(VEC, types.float64, VEC, MAT)


def as_cfuncs(kernels):
    """``(rhs, jac, dfdv)`` of a kernel namespace as cached cfuncs."""
    return (
        cfunc(RHS_SIG, cache=True, error_model="numpy")(kernels.rhs.py_func),
        cfunc(JAC_SIG, cache=True, error_model="numpy")(kernels.jac.py_func),
        cfunc(RHS_SIG, cache=True, error_model="numpy")(kernels.dfdv.py_func),
    )


def aux_cfunc(kernels):
    """The ``aux`` kernel as a cached cfunc."""
    return cfunc(RHS_SIG, cache=True, error_model="numpy")(kernels.aux.py_func)


@njit(cache=True, error_model="numpy")
def batch(kernel, states, V, p, out):
    """Apply a ``(u, V, p, out)`` kernel to every row of ``states`` (m, n) into ``out`` (m, k)."""
    for i in range(states.shape[0]):
        kernel(states[i], V, p, out[i])
