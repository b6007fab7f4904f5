"""First-class function types for model kernels passed into compiled solvers.

A compiled solver is written once against these types; each model hands it
``numba.cfunc`` versions of its kernels, so one cached compilation serves every model.
"""

from __future__ import annotations

from numba import cfunc, types

VEC = types.float64[::1]
MAT = types.float64[:, ::1]
RHS_SIG = types.void(VEC, types.float64, VEC, VEC)
JAC_SIG = types.void(VEC, types.float64, VEC, MAT)
RHS_TYPE = types.FunctionType(RHS_SIG)
JAC_TYPE = types.FunctionType(JAC_SIG)


def as_cfuncs(kernels):
    """``(rhs, jac, dfdv)`` of a kernel namespace as cached cfuncs."""
    return (
        cfunc(RHS_SIG, cache=True)(kernels.rhs.py_func),
        cfunc(JAC_SIG, cache=True)(kernels.jac.py_func),
        cfunc(RHS_SIG, cache=True)(kernels.dfdv.py_func),
    )
