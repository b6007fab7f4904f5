"""A test model with closed-form periodic orbits: the Bautin-type normal form.

    (x, y)' = (mu + r^2 - r^4) (x, y) + omega (-y, x),   w' = -lam w,   mu = V - 1

Cycles: r^2 = (1 +- sqrt(1 + 4 mu)) / 2, period 2 pi / omega; subcritical Hopf at
V = 1 (mu = 0), fold of cycles at V = 0.75 (r^2 = 1/2). Nontrivial multipliers
exp(2 r^2 (1 - 2 r^2) T) (radial) and exp(-lam T).
"""

import numpy as np
from numba import njit

from polywear.models.base import Model, ParamSlot

OMEGA, LAM = 0, 1


@njit(cache=True)
def rhs(u, V, p, out):
    r2 = u[0] * u[0] + u[1] * u[1]
    g = V - 1.0 + r2 - r2 * r2
    out[0] = g * u[0] - p[OMEGA] * u[1]
    out[1] = g * u[1] + p[OMEGA] * u[0]
    out[2] = -p[LAM] * u[2]


@njit(cache=True)
def jac(u, V, p, out):
    r2 = u[0] * u[0] + u[1] * u[1]
    g = V - 1.0 + r2 - r2 * r2
    dg = 1.0 - 2.0 * r2  # dg/d(r2)
    out[0, 0] = g + 2.0 * u[0] * u[0] * dg
    out[0, 1] = 2.0 * u[0] * u[1] * dg - p[OMEGA]
    out[1, 0] = 2.0 * u[1] * u[0] * dg + p[OMEGA]
    out[1, 1] = g + 2.0 * u[1] * u[1] * dg
    out[0, 2] = 0.0 * g
    out[1, 2] = 0.0 * g
    out[2, 0] = 0.0 * g
    out[2, 1] = 0.0 * g
    out[2, 2] = -p[LAM] + 0.0 * g


@njit(cache=True)
def dfdv(u, V, p, out):
    out[0] = u[0]
    out[1] = u[1]
    out[2] = 0.0 * u[2]


@njit(cache=True)
def aux(u, V, p, out):
    out[0] = u[0] * u[0] + u[1] * u[1]


class _Kernels:
    rhs = rhs
    jac = jac
    dfdv = dfdv
    aux = aux

    @staticmethod
    def equilibrium(V, p):
        return np.zeros(3)


MODEL = Model(
    name="normal_form",
    state_names=("x", "y", "w"),
    state_units=("-", "-", "-"),
    aux_names=("r2",),
    slots=(ParamSlot("omega", None), ParamSlot("lam", None)),
    kernels=_Kernels,
)
P = np.array([2.0 * np.pi, 50.0])  # period 1, a stiff decoupled mode


def cycle_radius2(V, branch):
    """r^2 of the stable (+1) or unstable (-1) cycle at speed V."""
    return (1.0 + branch * np.sqrt(1.0 + 4.0 * (V - 1.0))) / 2.0
