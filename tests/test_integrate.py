"""The compiled Rodas4 integrator: tableau, convergence order, dense output, agreement
with scipy's Radau on tread1dof (smooth and stick-slip), kernels, and error handling."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numba import njit

from polywear.models import get_model
from polywear.models.base import Model
from polywear.models.tread1dof import rhs_python
from polywear.params import Params, with_updates
from polywear.solvers.integrate import (
    RODAS4_A,
    RODAS4_C,
    RODAS4_GAMMA,
    IntegrationError,
    integrate,
)

TREAD = get_model("tread1dof")

# -- test problems with closed-form solutions ------------------------------------------
# Damped oscillator x'' + 2 zeta w x' + w^2 x = 0 with p = (w, zeta).


@njit(cache=True)
def _osc_rhs(u, V, p, out):
    out[0] = u[1]
    out[1] = -p[0] ** 2 * u[0] - 2.0 * p[1] * p[0] * u[1]


@njit(cache=True)
def _osc_jac(u, V, p, out):
    out[0, 0] = 0.0
    out[0, 1] = 1.0
    out[1, 0] = -p[0] ** 2
    out[1, 1] = -2.0 * p[1] * p[0]


@njit(cache=True)
def _zero_dfdv(u, V, p, out):
    out[:] = 0.0


def _model(name, states, rhs, jac):
    kernels = SimpleNamespace(rhs=rhs, jac=jac, dfdv=_zero_dfdv)
    return Model(name, states, ("-",) * len(states), (), (), kernels)


OSCILLATOR = _model("oscillator", ("x", "xdot"), _osc_rhs, _osc_jac)


def _osc_exact(t, w, zeta):
    """x(t), x'(t) for x(0) = 1, x'(0) = 0 (underdamped)."""
    wd = w * math.sqrt(1.0 - zeta**2)
    e = np.exp(-zeta * w * t)
    x = e * (np.cos(wd * t) + zeta * w / wd * np.sin(wd * t))
    xd = -e * (w**2 / wd) * np.sin(wd * t)
    return np.stack([x, xd], axis=-1)


# Stiff linear system u' = A u with eigenvalues -1 and -1e4 (Jacobian constant).
_STIFF = np.array([[-1.0, 1.0], [0.0, -1.0e4]])


@njit(cache=True)
def _stiff_rhs(u, V, p, out):
    out[0] = -u[0] + u[1]
    out[1] = -1.0e4 * u[1]


@njit(cache=True)
def _stiff_jac(u, V, p, out):
    out[0, 0] = -1.0
    out[0, 1] = 1.0
    out[1, 0] = 0.0
    out[1, 1] = -1.0e4


STIFF = _model("stiff", ("a", "b"), _stiff_rhs, _stiff_jac)


@njit(cache=True)
def _blowup_rhs(u, V, p, out):
    out[0] = u[0] * u[0]


@njit(cache=True)
def _blowup_jac(u, V, p, out):
    out[0, 0] = 2.0 * u[0]


BLOWUP = _model("blowup", ("y",), _blowup_rhs, _blowup_jac)


def _fixed_steps(model, u0, p, h, n_steps, dense_at=None):
    """Constant-step Rodas4: n single steps of size h (tolerances so loose every step is
    accepted at its first try). Returns the end state and, if ``dense_at`` (theta in
    (0, 1)) is given, the dense output at ``t_k + theta h`` of every step."""
    u = np.asarray(u0, dtype=float)
    dense = []
    for _ in range(n_steps):
        tr = integrate(model, u, 0.0, p, h, rtol=0.5, atol=1e12, h0=h,
                       dense_from=None if dense_at is None else 0.0)
        assert tr.stats.accepted == 1 and tr.stats.rejected == 0
        if dense_at is not None:
            dense.append(tr.dense(dense_at * h))
        u = tr.u_end
    return u, np.array(dense)


def _order(errors, steps):
    return np.polyfit(np.log(steps), np.log(errors), 1)[0]


# -- the tableau ------------------------------------------------------------------------
def _classical_coefficients():
    """alpha, beta (= alpha + gamma, off-diagonal), b and the embedded b from Hairer's
    transformed coefficients: Gamma^-1 = I/gamma - C, alpha = A Gamma, b = m Gamma."""
    s = 6
    a = np.zeros((s, s))
    a[:, :5] = RODAS4_A
    c = np.zeros((s, s))
    c[:, :5] = RODAS4_C
    gamma_inv = np.eye(s) / RODAS4_GAMMA - c
    gamma = np.linalg.inv(gamma_inv)
    alpha = a @ gamma
    beta = alpha + gamma - np.diag(np.diag(gamma))
    m = np.r_[RODAS4_A[5], 1.0]  # y1 = stage-6 argument + k6
    m_hat = np.r_[RODAS4_A[5]]  # embedded: the stage-6 argument
    m_hat = np.r_[m_hat, 0.0]
    return alpha, beta, m @ gamma, m_hat @ gamma, gamma


def _order_conditions(b, alpha, beta, g):
    """Residuals of the Rosenbrock order conditions up to order 4 (Hairer & Wanner II,
    Table IV.7.1), beta without its diagonal."""
    ai = alpha.sum(axis=1)
    bi = beta.sum(axis=1)
    return np.array([
        b.sum() - 1.0,
        b @ bi - (0.5 - g),
        b @ ai**2 - 1.0 / 3.0,
        b @ (beta @ bi) - (1.0 / 6.0 - g + g**2),
        b @ ai**3 - 0.25,
        b @ (ai * (alpha @ bi)) - (1.0 / 8.0 - g / 3.0),
        b @ (beta @ ai**2) - (1.0 / 12.0 - g / 3.0),
        b @ (beta @ (beta @ bi)) - (1.0 / 24.0 - g / 2.0 + 1.5 * g**2 - g**3),
    ])


def test_tableau_satisfies_order_conditions():
    alpha, beta, b, b_hat, gamma = _classical_coefficients()
    # gamma_ii = 0.25 on the whole diagonal, and the published nodes alpha_i = sum_j alpha_ij
    assert np.allclose(np.diag(gamma), RODAS4_GAMMA)
    assert np.allclose(alpha.sum(axis=1), [0.0, 0.386, 0.21, 0.63, 1.0, 1.0], atol=1e-12)
    assert np.abs(_order_conditions(b, alpha, beta, RODAS4_GAMMA)).max() < 1e-12
    # the embedded solution has order 3 (conditions 1-4), not 4
    res_hat = _order_conditions(b_hat, alpha, beta, RODAS4_GAMMA)
    assert np.abs(res_hat[:4]).max() < 1e-12
    assert np.abs(res_hat[4:]).max() > 1e-4


# -- convergence order on closed-form problems ------------------------------------------
def test_convergence_order_four_on_damped_oscillator():
    w, zeta, t_end = 2.0 * np.pi, 0.1, 1.0
    p = np.array([w, zeta])
    exact = _osc_exact(t_end, w, zeta)
    steps = np.array([10, 20, 40, 80])
    errors = [np.abs(_fixed_steps(OSCILLATOR, [1.0, 0.0], p, t_end / n, n)[0] - exact).max()
              for n in steps]
    order = _order(errors, 1.0 / steps)
    assert 3.8 < order < 4.3, (order, errors)


def test_dense_output_order_on_damped_oscillator():
    w, zeta, t_end = 2.0 * np.pi, 0.1, 1.0
    p = np.array([w, zeta])
    steps = np.array([10, 20, 40, 80])
    errors = []
    for n in steps:
        h = t_end / n
        _, mid = _fixed_steps(OSCILLATOR, [1.0, 0.0], p, h, n, dense_at=0.37)
        exact = _osc_exact((np.arange(n) + 0.37) * h, w, zeta)
        errors.append(np.abs(mid - exact).max())
    # the interpolant is of order 3: local error O(h^4), so the global error is O(h^3) or better
    assert _order(errors, 1.0 / steps) > 2.8, errors


def test_stiff_linear_system_large_steps_are_stable_and_order_four():
    from scipy.linalg import expm

    u0 = np.array([1.0, 1.0])
    t_end = 1.0
    exact = expm(_STIFF * t_end) @ u0
    steps = np.array([10, 20, 40, 80])  # h * 1e4 from 1000 down to 125: far outside stability of explicit methods
    errors = [np.abs(_fixed_steps(STIFF, u0, np.zeros(1), t_end / n, n)[0] - exact).max()
              for n in steps]
    assert max(errors) < 1e-4
    assert 3.5 < _order(errors, 1.0 / steps) < 4.5, errors


def test_adaptive_error_follows_tolerance():
    w, zeta = 2.0 * np.pi, 0.05
    p = np.array([w, zeta])
    exact = _osc_exact(3.0, w, zeta)
    errors = []
    for rtol in (1e-5, 1e-7, 1e-9):
        tr = integrate(OSCILLATOR, [1.0, 0.0], 0.0, p, 3.0, rtol=rtol, atol=rtol)
        errors.append(np.abs(tr.u_end - exact).max())
        assert errors[-1] < 100 * rtol
        assert tr.t[-1] == 3.0
    assert errors[0] > errors[1] > errors[2]


def test_grid_output_matches_dense_output_and_steps():
    p = np.array([2.0 * np.pi, 0.1])
    grid = integrate(OSCILLATOR, [1.0, 0.0], 0.0, p, 1.0, dt_out=0.01, rtol=1e-9, atol=1e-12,
                     dense_from=0.0)
    assert grid.t.shape == (101,) and grid.t[-1] == 1.0
    assert np.array_equal(grid.u[0], [1.0, 0.0])
    assert np.allclose(grid.dense(grid.t), grid.u, rtol=0, atol=1e-14)
    assert np.abs(grid.u - _osc_exact(grid.t, 2.0 * np.pi, 0.1)).max() < 1e-7
    steps = integrate(OSCILLATOR, [1.0, 0.0], 0.0, p, 1.0, rtol=1e-9, atol=1e-12)
    assert len(steps.t) == steps.stats.accepted + 1
    assert np.allclose(steps.u[-1], grid.u[-1], rtol=0, atol=1e-14)


# -- tread1dof against scipy's Radau -----------------------------------------------------
def _tread_case(updates, speed_kmh):
    params = with_updates(Params(), updates)
    return TREAD.pack(params), speed_kmh / 3.6


def _on_cycle(p, V, settle_s):
    """A state on (or near) the attracting cycle: eq + 0.5 mm, run for settle_s."""
    u0 = TREAD.equilibrium(V, p)
    u0[0] += 5e-4
    return integrate(TREAD, u0, V, p, settle_s, rtol=1e-10, atol=1e-13).u_end


@pytest.mark.slow
@pytest.mark.parametrize(
    ("updates", "speed_kmh", "stick_slip"),
    [({}, 110.0, False), ({"friction.mu_coulomb": 0.3}, 80.0, True)],
    ids=["defaults-110kmh", "stick-slip-80kmh"],
)
def test_rodas_agrees_with_radau_on_tread1dof(updates, speed_kmh, stick_slip):
    p, V = _tread_case(updates, speed_kmh)
    u0 = _on_cycle(p, V, 0.3)
    kw = dict(dt_out=1e-4, rtol=1e-10, atol=1e-13)
    fast = integrate(TREAD, u0, V, p, 0.2, **kw)
    ref = integrate(TREAD, u0, V, p, 0.2, method="radau", **kw)
    vr = TREAD.diagnostics(ref.u, V, p)[:, 0]
    # the case really is what it claims: v_r changes sign on the cycle (stick-slip) or not
    assert (vr.min() < 0.0 < vr.max()) == stick_slip, (vr.min(), vr.max())
    scale = np.abs(ref.u).max(axis=0)
    assert np.abs(fast.u - ref.u).max(axis=0) / scale == pytest.approx(0.0, abs=2e-7)


def test_scipy_methods_agree_with_rodas_on_a_short_run():
    p, V = _tread_case({}, 110.0)
    u0 = TREAD.equilibrium(V, p)
    u0[0] += 1e-4
    ref = integrate(TREAD, u0, V, p, 0.02, dt_out=1e-4, rtol=1e-10, atol=1e-13)
    scale = np.abs(ref.u).max(axis=0)
    for method in ("radau", "bdf", "lsoda", "dop853"):
        other = integrate(TREAD, u0, V, p, 0.02, dt_out=1e-4, rtol=1e-7, atol=1e-12, method=method)
        assert other.method == method
        assert np.abs(other.u - ref.u).max(axis=0) / scale == pytest.approx(0.0, abs=1e-4), method


# -- the compiled kernels ----------------------------------------------------------------
@njit
def _call_rhs(fn, u, V, p):
    out = np.empty(u.size)
    fn(u, V, p, out)
    return out


@njit
def _call_jac(fn, u, V, p):
    out = np.empty((u.size, u.size))
    fn(u, V, p, out)
    return out


_STATES = st.tuples(
    st.floats(-5e-3, 5e-3), st.floats(-1.5, 1.5), st.floats(-4e-3, 4e-3)
)


@settings(max_examples=60, deadline=None)
@given(state=_STATES, speed_kmh=st.floats(10.0, 300.0), toe_deg=st.floats(-2.0, 2.0))
def test_compiled_kernels_match_python_reference_and_finite_differences(state, speed_kmh, toe_deg):
    p, V = _tread_case({"operating.toe_deg": toe_deg}, speed_kmh)
    u = np.array(state)
    rhs, jac = TREAD.compiled[:2]
    f = _call_rhs(rhs, u, V, p)
    assert np.allclose(f, rhs_python(0.0, u, V, p), rtol=1e-13, atol=1e-13 * np.abs(f).max())
    vr = V * math.sin(p[4]) - u[1]
    if abs(vr) < 1e-5:  # the |v_r| kink: the Jacobian is one-sided there
        return
    jmat = _call_jac(jac, u, V, p)
    fd = np.empty((3, 3))
    for j, h in enumerate((1e-9, 1e-7, 1e-9)):  # below 1e-5: v_r keeps its sign
        up, um = u.copy(), u.copy()
        up[j] += h
        um[j] -= h
        fd[:, j] = (rhs_python(0.0, up, V, p) - rhs_python(0.0, um, V, p)) / (2 * h)
    col_scale = np.abs(jmat).max(axis=0) + 1e-300
    assert np.all(np.abs(jmat - fd) <= 1e-5 * col_scale + 1e-8), (jmat, fd)


# -- bad input and failures --------------------------------------------------------------
@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        (dict(u0=[np.nan, 0.0, 0.0]), "not finite"),
        (dict(u0=[0.0, 0.0]), "shape"),
        (dict(rtol=0.0), "rtol"),
        (dict(rtol=-1e-6), "rtol"),
        (dict(rtol=1e-16), "rtol"),
        (dict(atol=0.0), "atol"),
        (dict(atol=[1e-9, -1.0, 1e-9]), "atol"),
        (dict(t_end=0.0), "t_end"),
        (dict(t_end=np.inf), "t_end"),
        (dict(dt_out=-1e-3), "dt_out"),
        (dict(method="euler"), "method"),
        (dict(V=np.nan), "speed"),
    ],
)
def test_bad_input_raises_clear_error(kwargs, message):
    p, V = _tread_case({}, 110.0)
    args = dict(u0=TREAD.equilibrium(V, p), V=V, t_end=0.01)
    args.update(kwargs)
    with pytest.raises(ValueError, match=message):
        integrate(TREAD, args.pop("u0"), args.pop("V"), p, args.pop("t_end"), **args)


def test_finite_time_blowup_raises_instead_of_returning():
    # y' = y^2, y(0) = 1 has y = 1/(1 - t): no solution past t = 1
    with pytest.raises(IntegrationError, match=r"stopped at t = (0\.99\d*|1) s of 2 s"):
        integrate(BLOWUP, [1.0], 0.0, np.zeros(1), 2.0)
    with pytest.raises(IntegrationError, match="solve_ivp"):
        integrate(BLOWUP, [1.0], 0.0, np.zeros(1), 2.0, method="radau")


def test_step_budget_exhaustion_raises():
    p, V = _tread_case({}, 110.0)
    u0 = TREAD.equilibrium(V, p)
    u0[0] += 1e-4
    with pytest.raises(IntegrationError, match="max_steps"):
        integrate(TREAD, u0, V, p, 0.1, max_steps=50)


def test_one_compilation_of_the_step_loop_serves_every_model():
    from polywear.solvers.integrate import _rodas4

    p, V = _tread_case({}, 110.0)
    integrate(TREAD, TREAD.equilibrium(V, p), V, p, 1e-3)
    integrate(OSCILLATOR, [1.0, 0.0], 0.0, np.array([1.0, 0.1]), 1e-3, dt_out=1e-4, dense_from=0.0, h0=1e-5)
    assert len(_rodas4.signatures) == 1


@pytest.mark.slow
def test_rodas_agrees_with_radau_on_axle4dof():
    try:
        model = get_model("axle4dof")
    except ImportError as exc:
        pytest.skip(f"axle4dof not available: {exc}")
    params = with_updates(Params(), {"model": "axle4dof"})
    p, V = model.pack(params), 110.0 / 3.6
    u0 = model.equilibrium(V, p)
    u0[model.index("x")] += 1e-4
    kw = dict(dt_out=1e-4, rtol=1e-10, atol=1e-13)
    fast = integrate(model, u0, V, p, 0.05, **kw)
    ref = integrate(model, u0, V, p, 0.05, method="radau", **kw)
    scale = np.abs(ref.u - model.equilibrium(V, p)).max(axis=0)
    assert np.abs(fast.u - ref.u).max(axis=0) / scale == pytest.approx(0.0, abs=1e-6)


def test_a_tiny_first_step_is_taken_however_long_the_run():
    # the underflow bound is relative to t: a first step of 1e-14 s, below 16 eps of t_end = 100 s,
    # is refused only where it would not move t (it was refused at t = 0 against t_end)
    w, zeta = 2.0 * np.pi, 0.05
    p = np.array([w, zeta])
    tr = integrate(OSCILLATOR, [1.0, 0.0], 0.0, p, 100.0, rtol=1e-9, atol=1e-9, h0=1e-14)
    assert tr.t[-1] == 100.0
    assert np.abs(tr.u_end - _osc_exact(100.0, w, zeta)).max() < 1e-6
