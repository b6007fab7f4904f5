"""The collocation kernels on the systems of the real models: the structured solver against
the explicit sparse matrix, the assembly against its plain form; the fused model kernel
``rhs_jac_dfdv`` against ``rhs``, ``jac`` and ``dfdv``."""

from types import SimpleNamespace

import numba
import numpy as np
import pytest

from polywear.models import get_model
from polywear.models.kernels import fused_cfunc
from polywear.models.profile import coupled_model, patch_sinc, profile_vector
from polywear.params import Params, with_updates
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
    """Collocation.evaluate (the wrapped fused kernel, parameters prepared for the orbit's speed)
    gives bit for bit what the plain fused cfunc gives with the plain parameter vector, and
    what the separate kernels rhs, jac, dfdv give in the same arithmetic written out in NumPy."""
    model, coll, X, _ = _system(model_name)
    got = coll.evaluate(X)
    N, m, n = coll.N, coll.m, coll.n
    nodes = np.ascontiguousarray(X[:-2].reshape(N * m, n))
    period, speed = float(X[-2]), float(X[-1])
    want = (np.empty(N * m * n), np.empty((N, m * n, (m + 1) * n)), np.empty(N * m * n), np.empty(N * m * n))
    _assemble(model.compiled_fused.cfunc, nodes, period, speed, coll.p, coll.h, coll.sch.basis, coll.sch.dbasis,
              *want)
    for a, b in zip(got, want):
        assert np.array_equal(a, b)

    basis, dbasis = coll.sch.basis, coll.sch.dbasis
    res, blocks, tcol, vcol = (np.empty_like(a) for a in want)
    for j in range(N):
        for k in range(m):
            uc = np.zeros(n)
            duc = np.zeros(n)
            for l in range(m + 1):
                node = nodes[(j * m + l) % (N * m)]
                uc += basis[k, l] * node
                duc += dbasis[k, l] * node / coll.h[j]
            rows = slice((j * m + k) * n, (j * m + k + 1) * n)
            f = model.f(uc, speed, coll.p)
            res[rows] = duc - period * f
            tcol[rows] = -f
            vcol[rows] = -period * model.df_dspeed(uc, speed, coll.p)
            J = model.jacobian(uc, speed, coll.p)
            for l in range(m + 1):
                block = -period * basis[k, l] * J
                block[np.diag_indices(n)] += dbasis[k, l] / coll.h[j]
                blocks[j, k * n:(k + 1) * n, l * n:(l + 1) * n] = block
    for a, b in zip(got, (res, blocks, tcol, vcol)):
        assert np.array_equal(a, b)


def _kernel_cases():
    """(model, p, V, states) of both models, plain and prepared for V, and of their profile-coupled
    versions (no wear, a worn profile, a worn profile without tire damping, and a profile worn so
    deep that the tread1dof load clamps); states about the equilibrium, some far from it."""
    rng = np.random.default_rng(7)
    cases = []
    for name, v_kmh in SPEED_KMH.items():
        model = get_model(name)
        params = Params(model=name)
        V = v_kmh / 3.6
        p = model.pack(params)
        u0 = model.equilibrium(V, p)
        scale = np.maximum(np.abs(u0), 1e-4)
        states = [u0 + s * scale * rng.standard_normal(model.n) for s in (0.0, 0.05, 0.05, 0.5, 30.0)]
        if name == "axle4dof":
            states.append(u0 - 0.05 * np.eye(model.n)[model.index("gamma")])  # C lifted: contact lost
        cases += [(model, p, V, states), (model, model.prepared(V, p), V, states)]
        coupled = coupled_model(model)
        sinc = patch_sinc(np.arange(1, 10), params.tire.contact_length_m, params.operating.rolling_radius_m)
        undamped = with_updates(params, {"tire.vertical_damping_ns_per_m": 0.0})
        for prm, depth in ((params, 0.0), (params, 2e-5), (undamped, 2e-5), (params, 0.05)):
            pw = profile_vector(model, prm, V, depth * sinc * rng.standard_normal(9),
                                depth * sinc * rng.standard_normal(9))
            cases.append((coupled, pw, V, [np.append(u, a) for u in states for a in (0.0, 1.3)]))
    return cases


def _separate_and_fused(kernels, u, V, p):
    """(f, J, fv) from the separate kernels and from ``rhs_jac_dfdv``, in u's dtype."""
    n = u.size
    sep = (np.empty(n, u.dtype), np.empty((n, n), u.dtype), np.empty(n, u.dtype))
    kernels.rhs(u, V, p, sep[0])
    kernels.jac(u, V, p, sep[1])
    kernels.dfdv(u, V, p, sep[2])
    fused = tuple(np.full_like(a, np.nan) for a in sep)
    kernels.rhs_jac_dfdv(u, V, p, *fused)
    return sep, fused


def test_fused_kernel_is_bit_for_bit_the_separate_kernels():
    """rhs_jac_dfdv gives what rhs, jac and dfdv give, to the last bit, on every model, in real
    arithmetic and (base models) in complex arithmetic (complex-step derivatives); so does its
    cfunc, which the assembly calls."""
    clamped = set()
    for model, p, V, states in _kernel_cases():
        dtypes = (np.float64,) if model.name.endswith("+profile") else (np.float64, np.complex128)
        for u in states:
            for dtype in dtypes:
                uu = u.astype(dtype) + (1e-20j * np.arange(u.size) if dtype is np.complex128 else 0.0)
                sep, fused = _separate_and_fused(model.kernels, uu, dtype(V), p.astype(dtype))
                for a, b in zip(sep, fused):
                    assert a.tobytes() == b.tobytes()
            sep = _separate_and_fused(model.kernels, u, V, p)[0]
            compiled = tuple(np.full_like(a, np.nan) for a in sep)
            _call_fused(model.compiled_fused, u, V, p, *compiled)  # the cfunc the assembly calls
            for a, b in zip(sep, compiled):
                assert a.tobytes() == b.tobytes()
            lost = model.diagnostics(u, V, p)[-1] == (0.0 if model.name.startswith("tread1dof") else 1.0)
            if lost and model.name != "tread1dof":
                clamped.add(model.name)
    # the clamped load (contact lost) is among the cases
    assert clamped == {"axle4dof", "tread1dof+profile", "axle4dof+profile"}


@numba.njit
def _call_fused(kernel, u, V, p, f, J, fv):
    kernel(u, V, p, f, J, fv)


def test_kernels_without_a_fused_one_get_one_calling_them_in_turn():
    """A model's kernels without ``rhs_jac_dfdv`` (e.g. a test model) still give the assembly
    its fused kernel: rhs, jac and dfdv called in turn, bit for bit theirs."""
    model, coll, X, _ = _system("axle4dof")
    plain = fused_cfunc(SimpleNamespace(rhs=model.kernels.rhs, jac=model.kernels.jac, dfdv=model.kernels.dfdv))
    assert numba.typeof(plain) == numba.typeof(model.compiled_fused)
    speed = float(X[-1])
    for u in coll.gauss_states(coll.unpack(X))[::40]:
        sep, _ = _separate_and_fused(model.kernels, u, speed, coll.p)
        fused = tuple(np.full_like(a, np.nan) for a in sep)
        _call_fused(plain, u, speed, coll.p, *fused)
        for a, b in zip(sep, fused):
            assert a.tobytes() == b.tobytes()


def test_wrapped_kernels_have_the_type_of_their_cfuncs():
    """Else every compiled solver would be compiled (and cached) a second time for them."""
    for name in ("tread1dof", "axle4dof"):
        model = get_model(name)
        for kernel in (*model.compiled, model.compiled_fused, model.compiled_aux):
            assert numba.typeof(kernel) == numba.typeof(kernel.cfunc)
