"""The collocation kernels on the systems of the real models: the structured solver against
the explicit sparse matrix, the assembly against its plain form."""

import numba
import numpy as np
import pytest

from polywear.models import get_model
from polywear.params import Params
from polywear.solvers.collocation import Collocation, PeriodicOrbit, _assemble

SPEED_KMH = {"tread1dof": 60.0, "axle4dof": 90.0}


def _system(model_name: str):
    """A collocation system of ``model_name`` about an orbit shaped like its least damped mode
    (equilibrium plus a small sinusoid along the mode, on a non-uniform mesh of 40 intervals)."""
    model = get_model(model_name)
    p = model.pack(Params(model=model_name))
    V = SPEED_KMH[model_name] / 3.6
    u0 = model.equilibrium(V, p)
    lam, vec = np.linalg.eig(model.jacobian(u0, V, p))
    i = int(np.argmax(np.where(lam.imag > 0, lam.real, -np.inf)))
    mode = vec[:, i] / np.abs(vec[:, i]).max() * 1e-4
    s = np.linspace(0.0, 1.0, 41)
    mesh = s + 0.03 * np.sin(2 * np.pi * s)  # graded, ends fixed
    coll = Collocation(model, p, mesh)
    tau = PeriodicOrbit(mesh, np.zeros((40 * 4, model.n)), 1.0, V).node_times()
    nodes = u0 + np.real(mode[None, :] * np.exp(2j * np.pi * tau)[:, None])
    orbit = PeriodicOrbit(mesh, nodes, 2 * np.pi / lam[i].imag, V)
    X = coll.pack(orbit)
    rng = np.random.default_rng(len(model_name))
    border = np.vstack([coll.phase_row(orbit), rng.normal(size=coll.size)])
    return model, coll, X, border


@pytest.mark.parametrize("model_name", ["tread1dof", "axle4dof"])
def test_structured_solution_satisfies_the_explicit_sparse_system(model_name):
    _, coll, X, border = _system(model_name)
    res, blocks, tcol, vcol = coll.evaluate(X)
    rhs = np.zeros((coll.size, 2))
    rhs[:-2, 0] = -res
    rhs[-2:, 0] = [0.3, -0.2]
    rhs[-1, 1] = 1.0
    out = coll.solve_system(blocks, tcol, vcol, border, rhs)
    assert out is not None
    x = out[0]
    A = coll.sparse_matrix(X, border)
    scale = abs(A).max() * np.abs(x).max(axis=0)
    # backward error of a stable elimination: rounding level (1e-19 .. 1e-18 measured)
    assert np.all(np.abs(A @ x - rhs).max(axis=0) <= 1e-15 * scale)


@pytest.mark.parametrize("model_name", ["tread1dof", "axle4dof"])
def test_assembly_is_that_of_the_plain_kernels(model_name):
    """Collocation.evaluate (wrapped kernels, parameters prepared for the orbit's speed)
    gives bit for bit what the plain cfuncs give with the plain parameter vector."""
    model, coll, X, _ = _system(model_name)
    got = coll.evaluate(X)
    N, m, n = coll.N, coll.m, coll.n
    want = (np.empty(N * m * n), np.empty((N, m * n, (m + 1) * n)), np.empty(N * m * n), np.empty(N * m * n))
    _assemble(*(k.cfunc for k in model.compiled), np.ascontiguousarray(X[:-2].reshape(N * m, n)), float(X[-2]),
              float(X[-1]), coll.p, coll.h, coll.sch.basis, coll.sch.dbasis, *want)
    for a, b in zip(got, want):
        assert np.array_equal(a, b)


def test_wrapped_kernels_have_the_type_of_their_cfuncs():
    """Else every compiled solver would be compiled (and cached) a second time for them."""
    for name in ("tread1dof", "axle4dof"):
        model = get_model(name)
        for kernel in (*model.compiled, model.compiled_aux):
            assert numba.typeof(kernel) == numba.typeof(kernel.cfunc)
