"""Collocation, the structured linear solver and continuation against closed forms."""

import numpy as np
import pytest

from polywear.dynamics.bifurcation import branch_start
from polywear.dynamics.stability import equilibrium_eigenvalues, locate_hopf
from polywear.solvers.bordered import solve_bordered
from polywear.solvers.collocation import Collocation, PeriodicOrbit, monodromy, scheme
from polywear.solvers.continuation import ContinuationSettings, continue_from_hopf

from .normal_form import MODEL, P, cycle_radius2


def dense_matrix(blocks, tcol, vcol, border, m):
    N, mn, _ = blocks.shape
    n = mn // m
    size = N * mn + 2
    A = np.zeros((size, size))
    for j in range(N):
        for l in range(m + 1):
            node = (j * m + l) % (N * m)
            A[j * mn:(j + 1) * mn, node * n:(node + 1) * n] += blocks[j][:, l * n:(l + 1) * n]
    A[: N * mn, -2] = tcol
    A[: N * mn, -1] = vcol
    A[-2:] = border
    return A


@pytest.mark.parametrize("N,m,n", [(2, 2, 1), (3, 4, 3), (10, 4, 3), (7, 3, 9), (25, 4, 9)])
def test_bordered_solver_matches_dense_lu(N, m, n):
    rng = np.random.default_rng(N * 100 + m * 10 + n)
    mn = m * n
    size = N * mn + 2
    blocks = rng.normal(size=(N, mn, (m + 1) * n))
    tcol, vcol = rng.normal(size=N * mn), rng.normal(size=N * mn)
    border = rng.normal(size=(2, size))
    rhs = rng.normal(size=(size, 2))
    A = dense_matrix(blocks, tcol, vcol, border, m)
    CL, CR = np.empty((N, n, n)), np.empty((N, n, n))
    x = solve_bordered(blocks, tcol, vcol, border, rhs, m, CL, CR)
    assert np.allclose(A @ x, rhs, atol=1e-10 * np.linalg.norm(A) * np.abs(x).max())


def test_scheme_integrates_and_differentiates_polynomials_exactly():
    sch = scheme(4)
    assert np.isclose(sch.weights.sum(), 1.0)
    # Gauss quadrature with 4 points is exact to degree 7
    assert np.isclose(sch.weights @ sch.gauss**7, 1.0 / 8.0)
    # interpolation of a degree-4 polynomial and its derivative at the Gauss points
    poly = np.polynomial.Polynomial([0.3, -1.0, 2.0, 0.5, -0.7])
    vals = poly(sch.nodes)
    assert np.allclose(sch.basis @ vals, poly(sch.gauss))
    assert np.allclose(sch.dbasis @ vals, poly.deriv()(sch.gauss))
    assert np.isclose(sch.mth @ vals, poly.deriv(4)(0.0))


@pytest.mark.parametrize("m, per_interval", [(4, 8), (4, 16), (3, 5)])
def test_dense_samples_are_the_interpolant_on_every_interval(m, per_interval):
    # a non-uniform mesh, each interval holding a different polynomial of degree m: dense()
    # (one basis for all intervals) gives the polynomials' values and agrees with evaluate()
    rng = np.random.default_rng(3)
    mesh = np.concatenate([[0.0], np.sort(rng.random(6)), [1.0]])
    polys = [np.polynomial.Polynomial(rng.normal(size=m + 1)) for _ in range(len(mesh) - 1)]
    for j in range(1, len(polys)):  # continuous: each starts where the one before ends, the last closes the loop
        polys[j] = polys[j] - polys[j](0.0) + polys[j - 1](1.0)
    polys[-1] = polys[-1] + np.polynomial.Polynomial([0.0, polys[0](0.0) - polys[-1](1.0)])
    nodes = np.array([[polys[j](s), 2.0 * polys[j](s)] for j in range(len(mesh) - 1) for s in scheme(m).nodes[:-1]])
    orbit = PeriodicOrbit(mesh, nodes, 1.0, 1.0, m)
    tau, u = orbit.dense(per_interval)
    s = np.arange(per_interval) / per_interval
    exact = np.concatenate([polys[j](s) for j in range(len(mesh) - 1)] + [[nodes[0, 0]]])
    assert tau.shape == (u.shape[0],) and tau[-1] == 1.0
    assert np.allclose(u[:, 0], exact, rtol=0.0, atol=1e-12) and np.allclose(u[:, 1], 2.0 * exact, atol=1e-12)
    assert np.allclose(u, orbit.evaluate(tau), rtol=0.0, atol=1e-13)


def _piecewise_polynomial_orbit(rng, mesh, m, n):
    """A continuous periodic orbit of one random degree-m polynomial per interval and state
    (local coordinate s in [0, 1]), and those polynomials [interval][state]."""
    polys = [[np.polynomial.Polynomial(rng.normal(size=m + 1)) for _ in range(n)] for _ in range(len(mesh) - 1)]
    for j in range(len(polys)):
        for i in range(n):
            if j:
                polys[j][i] = polys[j][i] - polys[j][i](0.0) + polys[j - 1][i](1.0)
            if j == len(polys) - 1:
                polys[j][i] = polys[j][i] + np.polynomial.Polynomial([0.0, polys[0][i](0.0) - polys[j][i](1.0)])
    nodes = np.array([[polys[j][i](s) for i in range(n)] for j in range(len(mesh) - 1) for s in scheme(m).nodes[:-1]])
    return PeriodicOrbit(mesh, nodes, 1.0, 1.0, m), polys


def test_phase_row_is_the_integral_of_u_dot_reference_derivative():
    # for piecewise polynomials of degree m the Gauss quadrature of u . u_ref' (degree 2m - 1) is
    # exact: the row times the nodes equals sum_j int_0^1 p_j(s) . q_j'(s) ds (the h_j cancel)
    rng = np.random.default_rng(5)
    mesh = np.concatenate([[0.0], np.sort(rng.random(7)), [1.0]])
    u, p_u = _piecewise_polynomial_orbit(rng, mesh, 4, 3)
    ref, p_ref = _piecewise_polynomial_orbit(rng, mesh, 4, 3)
    coll = Collocation(MODEL, P, mesh, 4)
    exact = sum((pu * pr.deriv()).integ()(1.0) for pus, prs in zip(p_u, p_ref) for pu, pr in zip(pus, prs))
    assert np.isclose(coll.phase_row(ref) @ coll.pack(u), exact, rtol=1e-12, atol=0.0)


def exact_orbit(V, branch, mesh, m=4):
    r = np.sqrt(cycle_radius2(V, branch))
    orbit = PeriodicOrbit(mesh, np.zeros(((len(mesh) - 1) * m, 3)), 1.0, V, m)
    tau = orbit.node_times()
    nodes = np.stack([r * np.cos(2 * np.pi * tau), r * np.sin(2 * np.pi * tau), 0 * tau], axis=1)
    return PeriodicOrbit(mesh, nodes, 1.0, V, m)


def test_collocation_residual_is_small_on_the_exact_cycle_and_converges_with_order():
    errs = []
    for N in (10, 20, 40):
        mesh = np.linspace(0.0, 1.0, N + 1)
        coll = Collocation(MODEL, P, mesh)
        res, *_ = coll.evaluate(coll.pack(exact_orbit(0.9, +1, mesh)))
        errs.append(np.abs(res).max())
    rates = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(rates > 3.5), rates  # interpolation error of degree-4 polynomials, O(h^4)


def test_monodromy_of_exact_cycle_matches_closed_form_multipliers():
    V = 0.9
    mesh = np.linspace(0.0, 1.0, 41)
    coll = Collocation(MODEL, P, mesh)
    orbit = exact_orbit(V, +1, mesh)
    X = coll.pack(orbit)
    border = np.zeros((2, coll.size))
    border[0] = coll.phase_row(orbit)
    border[1, -1] = 1.0
    _, _, CL, CR = coll.solve(X, border, np.zeros(2))
    mu = np.sort(np.abs(np.linalg.eigvals(monodromy(CL, CR))))
    r2 = cycle_radius2(V, +1)
    expected = np.sort([1.0, np.exp(2 * r2 * (1 - 2 * r2)), np.exp(-P[1])])
    assert np.allclose(mu[1:], expected[1:], rtol=1e-6)
    assert np.isclose(mu[1:].max(), 1.0, atol=1e-8) or np.isclose(mu[-1], 1.0, atol=1e-8)


@pytest.fixture(scope="module")
def normal_form_branch():
    speeds = np.linspace(1.1, 0.9, 3)
    _, eig = equilibrium_eigenvalues(MODEL, P, speeds[[0, -1]])
    lam_hi, lam_lo = (e[np.argmax(e.imag)] for e in eig)
    hopf = locate_hopf(MODEL, P, 0.9, 1.1, lam_lo, lam_hi)
    branch = continue_from_hopf(
        MODEL, P, branch_start(hopf), (0.5, 1.5), ContinuationSettings(n_intervals=20, ds_max=0.2), amplitude_ref=0.3
    )
    return hopf, branch


def test_hopf_point_of_normal_form_is_exact_and_subcritical(normal_form_branch):
    hopf, _ = normal_form_branch
    assert abs(hopf.speed_ms - 1.0) < 1e-12
    assert abs(hopf.omega - P[0]) < 1e-10
    assert hopf.first_lyapunov_coefficient > 0  # subcritical (hard)
    assert abs(hopf.dre_dspeed - 1.0) < 1e-10


def test_continued_cycles_match_closed_form_radius_and_stability(normal_form_branch):
    _, branch = normal_form_branch
    assert len(branch.points) > 10
    for pt in branch.points:
        V = pt.orbit.speed
        r2_num = np.mean(np.sum(pt.orbit.nodes[:, :2] ** 2, axis=1))
        r2_options = [cycle_radius2(V, b) for b in (+1, -1) if 1 + 4 * (V - 1) >= 0]
        err = min(abs(r2_num - r2) for r2 in r2_options)
        assert err < 1e-7, (V, r2_num, r2_options)  # discretisation error, N = 20
        assert abs(pt.orbit.period - 1.0) < 1e-9
        assert pt.trivial_multiplier_error < 1e-8
        assert pt.stable == (r2_num > 0.5)


def test_steps_stopped_on_the_predicted_correction_are_the_strict_points(normal_form_branch, monkeypatch):
    """A branch step stops once quadratic convergence predicts its next correction below
    ``newton_tol``: the same steps as with every iteration run, in fewer solves, and every
    point within a few ``newton_tol`` of the discrete branch. The points are not compared one by one: each
    step starts from the last point and tangent, so a difference of 1e-11 there moves the
    next point along the branch. What is compared is each point's distance from the closed
    form (the discretization error, smooth along the branch) at its own speed."""
    import polywear.solvers.continuation.stepper as stepper

    solves = []
    solve = Collocation.solve
    monkeypatch.setattr(Collocation, "solve", lambda self, *a, **k: solves.append(1) or solve(self, *a, **k))
    hopf, _ = normal_form_branch
    settings = ContinuationSettings(n_intervals=20, ds_max=0.2)
    predicted = continue_from_hopf(MODEL, P, branch_start(hopf), (0.5, 1.5), settings, amplitude_ref=0.3)
    n_predicted = len(solves)
    monkeypatch.setattr(stepper, "PREDICTED_STOP", 0.0)  # every iteration run
    solves.clear()
    strict = continue_from_hopf(MODEL, P, branch_start(hopf), (0.5, 1.5), settings, amplitude_ref=0.3)
    assert len(predicted.points) == len(strict.points)
    def radius_error(pt):
        V = pt.orbit.speed
        r2_num = np.mean(np.sum(pt.orbit.nodes[:, :2] ** 2, axis=1))
        return min((r2_num - cycle_radius2(V, b) for b in (+1, -1) if 1 + 4 * (V - 1) >= 0), key=abs)

    # a stopped step is within a few newton_tol of the discrete branch, not at the rounding
    # floor: 1.9e-10 in r^2 (~5e-10 in the scaled norm) at 0.764, next to the fold at 0.75
    for a, b in zip(predicted.points, strict.points):
        assert abs(a.orbit.speed - b.orbit.speed) < 1e-9
        assert abs(radius_error(a) - radius_error(b)) < 1e-9, (a.orbit.speed, radius_error(a), radius_error(b))
    assert [pt.newton_iterations for pt in predicted.points] == [pt.newton_iterations for pt in strict.points]
    assert n_predicted < len(solves)


def test_fold_of_cycles_located_at_closed_form(normal_form_branch):
    _, branch = normal_form_branch
    folds = [pt for label, pt, _ in branch.special if label == "LP"]
    assert len(folds) == 1
    fold = folds[0]
    assert abs(fold.orbit.speed - 0.75) < 1e-9
    r2 = np.mean(np.sum(fold.orbit.nodes[:, :2] ** 2, axis=1))
    assert abs(r2 - 0.5) < 1e-6  # r^2 is flat in V at the fold: sqrt of the speed error


@pytest.mark.parametrize("model_name", ["tread1dof", "axle4dof"])
def test_kernels_give_inf_or_nan_instead_of_raising(model_name, capfd):
    """A diverged Newton iterate can divide by zero in a kernel. Called through the compiled
    solvers' first-class functions, a raised ZeroDivisionError cannot propagate: numba
    printed it and handed back garbage. The kernels use numpy's error model, so a zero
    friction coefficient (G = 0 in the bristle law) gives inf/NaN that Newton rejects."""
    from polywear.models import get_model
    from polywear.models.kernels import batch
    from polywear.params import Params

    model = get_model(model_name)
    p = model.pack(Params(model=model_name)).copy()
    names = model.param_names
    p[names.index("mu_s")] = p[names.index("mu_c")] = 0.0
    u = model.equilibrium(30.0, model.pack(Params(model=model_name)))
    out = np.empty((1, model.n))
    batch(model.compiled[0], np.ascontiguousarray(u[None, :]), 30.0, p, out)
    err = capfd.readouterr().err
    assert "ZeroDivisionError" not in err and "Exception ignored" not in err
    assert not np.all(np.isfinite(out))
