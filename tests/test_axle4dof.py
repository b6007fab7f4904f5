"""Model axle4dof: derivation against the paper and an independent kinematics, reduction
to tread1dof, energy conservation, analytic derivatives, contact loss, equilibria and the
linear-stability picture of docs/model.md section 7."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import simpson, solve_ivp
from scipy.optimize import brentq

from polywear.models import _axle4dof_generated as gen
from polywear.models import axle4dof, axle4dof_kernels, tread1dof
from polywear.models.axle4dof import MODEL
from polywear.units import kmh_to_ms
from polywear.params import Params, with_updates

NQ = 4
SCHEMATIC_SCRIPT = Path(__file__).resolve().parents[1] / "docs" / "figures" / "make_schematic.py"


def pack(**updates) -> np.ndarray:
    """Kernel parameter vector of the defaults with ``{"table.key": value}`` updates."""
    return MODEL.pack(with_updates(Params(), {"model": "axle4dof", **updates}))


def slot(name: str) -> int:
    return MODEL.param_names.index(name)


# -- independent kinematics: rotation matrices and complex-step velocities (no sympy) ---


def _rotation(q, p):
    """R = Rz(toe0 + alpha) Ry(-gamma) Rx(camber0 + beta) (complex-safe)."""
    psi, gam, phi = p[slot("toe0")] + q[0], -q[2], p[slot("camber0")] + q[1]
    one, zero = np.ones_like(psi), np.zeros_like(psi)
    rz = np.array([[np.cos(psi), -np.sin(psi), zero], [np.sin(psi), np.cos(psi), zero], [zero, zero, one]])
    ry = np.array([[np.cos(gam), zero, np.sin(gam)], [zero, one, zero], [-np.sin(gam), zero, np.cos(gam)]])
    rx = np.array([[one, zero, zero], [zero, np.cos(phi), -np.sin(phi)], [zero, np.sin(phi), np.cos(phi)]])
    return rz @ ry @ rx


def _points(q, p):
    """World positions of the contact point C and the tread particle P, and R."""
    R = _rotation(q, p)
    c = R @ np.array([-p[slot("L")], -p[slot("b")], -p[slot("H")]])
    return c, c + q[3] * R[:, 1], R


def _rates(q, qd, p):
    """dC/dt, dP/dt and the body angular velocity (body axes), by complex step."""
    h = 1e-30
    c, tread, R = _points(q + 1j * h * np.asarray(qd, dtype=float), p)
    w = R.real.T @ (R.imag / h)
    return c.imag / h, tread.imag / h, np.array([w[2, 1], w[0, 2], w[1, 0]])


def kinetic_energy(q, qd, p):
    """T = 1/2 w.J.w + 1/2 m |v_P|^2 (the quadratic part; wheel spin excluded)."""
    _, v_tread, w = _rates(q, qd, p)
    inertia = p[[slot("J1"), slot("J2"), slot("J3")]]
    return 0.5 * np.sum(inertia * w**2) + 0.5 * p[slot("m")] * v_tread @ v_tread


def mass_matrix(q, p):
    """M by polarization of the quadratic form T(q, .)."""
    e = np.eye(NQ)
    t = [kinetic_energy(q, e[i], p) for i in range(NQ)]
    return np.array(
        [[kinetic_energy(q, e[i] + e[j], p) - t[i] - t[j] if i != j else 2 * t[i] for j in range(NQ)] for i in range(NQ)]
    )


def lateral(q, p):
    psi = p[slot("toe0")] + q[0]
    return np.array([-np.sin(psi), np.cos(psi), 0.0])


def rise(q, p):
    return _points(q, p)[0][2] - _points(np.r_[0.0, 0.0, 0.0, q[3]], p)[0][2]


def potential_energy(q, V, p):
    """Springs, tire spring, and the potentials of the constant load N0 and preloads."""
    preload = np.empty(NQ)
    axle4dof_kernels.preload(V, p, preload)
    k = p[[slot("k_alpha"), slot("k_beta"), slot("k_gamma"), slot("k")]]
    dz = rise(q, p)
    return 0.5 * np.sum(k * q**2) + 0.5 * p[slot("k_z")] * dz**2 - p[slot("N0")] * dz - preload @ q


def random_state(rng, p, V, scale=1.0):
    """The running-reference equilibrium plus a random disturbance."""
    u = MODEL.equilibrium(V, p).copy()
    u += scale * rng.normal(size=9) * np.array([5e-3, 5e-3, 5e-3, 1e-3, 0.5, 0.5, 0.5, 0.1, 2e-4])
    return u


# -- (i) the paper's mass matrix and inertial forces --------------------------------


@pytest.mark.slow
def test_rotational_mass_matrix_and_inertial_forces_equal_paper_eq2():
    """With m = 0 and I_w = 0 the alpha-beta-gamma block of M equals eq. (2)'s left side
    term by term (paper's beta = camber0 + beta). The velocity terms equal eq. (2)'s right
    side after three corrections: F_x -> F_alpha in row 1, alpha' -> alpha'^2 in row 3,
    and no cos^2(gamma) on row 3's beta' gamma' term."""
    import sympy as sp

    from polywear.models.axle4dof_derivation import derive

    d = derive()
    a, b0, g = d.q[:3]
    ad, bd, gd = d.qd[:3]
    P = d.params
    J1, J2, J3 = P["J1"], P["J2"], P["J3"]
    no_tread = {P["m"]: 0, P["I_w"]: 0}
    b = b0 + P["camber0"]
    s, c = sp.sin, sp.cos
    paper_mass = sp.Matrix(
        [
            [J1 * s(g) ** 2 + J2 * s(b) ** 2 * c(g) ** 2 + J3 * c(b) ** 2 * c(g) ** 2, J1 * s(g), (J3 - J2) * s(b) * c(b) * c(g)],
            [J1 * s(g), J1, 0],
            [(J3 - J2) * s(b) * c(b) * c(g), 0, J2 * c(b) ** 2 + J3 * s(b) ** 2],
        ]
    )
    derived_mass = d.mass_matrix[:3, :3].subs(no_tread)
    assert sp.simplify(derived_mass - paper_mass) == sp.zeros(3, 3)

    paper_forces = [
        (J3 - J2) * s(b) * c(b) * s(g) * gd**2
        - (J1 + (J3 - J2) * c(2 * b)) * c(g) * bd * gd
        + (J3 - J2) * s(2 * b) * c(g) ** 2 * ad * bd
        - (J1 - J2 * s(b) ** 2 - J3 * c(b) ** 2) * s(2 * g) * ad * gd,
        (J3 - J2) * s(b) * c(b) * (gd**2 - c(g) ** 2 * ad**2) - (J1 - (J3 - J2) * c(2 * b)) * c(g) * ad * gd,
        -(J3 - J2) * s(2 * b) * bd * gd  # paper: ... * cos(gamma)**2 * beta' gamma'
        - (J2 * s(b) ** 2 + J3 * c(b) ** 2 - J1) * s(g) * c(g) * ad**2  # paper: alpha'
        - ((J3 - J2) * c(2 * b) - J1) * c(g) * ad * bd,
    ]
    derived_forces = d.inertial_forces.subs(no_tread)
    for i in range(3):
        assert sp.simplify(sp.expand_trig(derived_forces[i] - paper_forces[i])) == 0, i


def test_paper_row3_as_printed_differs_from_the_derivation():
    """The third typo is real: eq. (2)'s cos^2(gamma) beta' gamma' term is not what
    Lagrange gives (checked numerically at a state with gamma != 0)."""
    import sympy as sp

    from polywear.models.axle4dof_derivation import derive

    d = derive()
    P = d.params
    b = d.q[1] + P["camber0"]
    printed = -(P["J3"] - P["J2"]) * sp.sin(2 * b) * sp.cos(d.q[2]) ** 2 * d.qd[1] * d.qd[2]
    at = {d.q[1]: 0.3, d.q[2]: 0.4, d.qd[1]: 1.0, d.qd[2]: 1.0, P["camber0"]: 0.0, P["J2"]: 2.0, P["J3"]: 5.0}
    coefficient = d.inertial_forces[2].subs({P["m"]: 0, P["I_w"]: 0}).diff(d.qd[1]).diff(d.qd[2])
    derived = (coefficient * d.qd[1] * d.qd[2]).subs(at)
    assert abs(float(derived - printed.subs(at))) > 0.1 * abs(float(derived))


# -- generated kinematics against an independent numeric kinematics -------------------


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_generated_kinematics_match_independent_rotation_matrices(seed):
    rng = np.random.default_rng(seed)
    p = pack(**{"axle.lateral_offset_m": 0.05, "axle.wheel_spin_inertia_kgm2": 1.5})
    q, qd = rng.normal(size=NQ) * 0.2, rng.normal(size=NQ)
    u = np.r_[q, qd, 1e-3]
    V = 25.0
    M, h = np.empty((NQ, NQ)), np.empty(NQ)
    GF, GN = np.empty(NQ), np.empty(NQ)
    gen._inertia(u, V, p, M, h)
    dz = gen._contact(u, p, GF, GN)
    np.testing.assert_allclose(M, mass_matrix(q, p), rtol=1e-12, atol=1e-12)
    e, d = np.eye(NQ), lateral(q, p)
    np.testing.assert_allclose(GF, [d @ _rates(q, e[i], p)[1] for i in range(NQ)], atol=1e-13)
    np.testing.assert_allclose(GN, [_rates(q, e[i], p)[0][2] for i in range(NQ)], atol=1e-13)
    assert dz == pytest.approx(rise(q, p), abs=1e-14)
    v_tread = _rates(q, qd, p)[1]
    expected = (np.array([-V, 0.0, 0.0]) - v_tread) @ d - p[slot("eps")] * V * np.sin(p[slot("camber0")] + q[1])
    assert gen._sliding(u, V, p) == pytest.approx(expected, abs=1e-12)


def _partials(fn, q, step=1e-5):
    """Central differences of fn(q) with respect to each coordinate, stacked last."""
    e = np.eye(NQ) * step
    return np.stack([(fn(q + e[k]) - fn(q - e[k])) / (2 * step) for k in range(NQ)], axis=-1)


def inertial_forces(q, qd, V, p):
    """h by Lagrange's equations applied numerically to the independent T and the spin term
    I_w (V/R_e) omega_y: h_i = dT/dq_i - d/dt dT/dqd_i + spin part (gyroscopic)."""
    dM = _partials(lambda x: mass_matrix(x, p), q)  # dM[i, j, k] = dM_ij/dq_k
    quadratic = 0.5 * np.einsum("j,jlk,l->k", qd, dM, qd) - np.einsum("ijk,j,k->i", dM, qd, qd)
    w = lambda x: np.array([_rates(x, e, p)[2][1] for e in np.eye(NQ)])  # noqa: E731
    dw = _partials(w, q)  # dw[i, k] = d w_i / dq_k
    spin = p[slot("I_w")] * V / p[slot("R_e")] * (dw.T - dw) @ qd
    return quadratic + spin


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_generated_inertial_forces_match_numeric_lagrange_equations(seed):
    rng = np.random.default_rng(seed)
    p = pack(**{"axle.lateral_offset_m": 0.05, "axle.wheel_spin_inertia_kgm2": 1.5})
    q, qd, V = rng.normal(size=NQ) * 0.2, rng.normal(size=NQ), 30.0
    M, h = np.empty((NQ, NQ)), np.empty(NQ)
    gen._inertia(np.r_[q, qd, 0.0], V, p, M, h)
    expected = inertial_forces(q, qd, V, p)
    np.testing.assert_allclose(h, expected, rtol=1e-7, atol=1e-7 * np.abs(expected).max())


# -- (ii) reduction to tread1dof ----------------------------------------------------------

REDUCED = {
    "axle.arm_length_m": 0.0,
    "axle.lateral_offset_m": 0.0,
    "axle.pivot_height_m": 0.0,
    "axle.camber_thrust_factor": 0.0,
    "tire.vertical_stiffness_n_per_m": 0.0,
    "tire.vertical_damping_ns_per_m": 0.0,
    "operating.camber_deg": 0.0,
}
TREAD = [3, 7, 8]  # x, x', z in axle4dof's state


@pytest.mark.parametrize("reference", ["running", "unloaded"])
def test_reduced_model_tread_equations_equal_tread1dof(reference):
    p4 = pack(**REDUCED, **{"axle.reference": reference})
    p1 = tread1dof.MODEL.pack(with_updates(Params(), {}))
    rng = np.random.default_rng(3)
    for V in (10.0, 30.0, 60.0):
        for _ in range(10):
            x = rng.normal(size=3) * [1e-3, 0.2, 2e-3]
            u = np.zeros(9)
            u[TREAD] = x
            np.testing.assert_allclose(MODEL.f(u, V, p4)[TREAD], tread1dof.MODEL.f(x, V, p1), rtol=1e-13, atol=1e-9)


def _tread_mode_growth(model, p, V_kmh):
    """Real part of the eigenvalue with the largest imaginary part (the tread mode)."""
    V = kmh_to_ms(V_kmh)
    vals = np.linalg.eigvals(model.jacobian(model.equilibrium(V, p), V, p))
    return vals[np.argmax(vals.imag)].real


def _hopf_speeds(growth, lo=20.0, hi=320.0, n=61):
    grid = np.linspace(lo, hi, n)
    s = np.array([growth(v) for v in grid])
    return [
        brentq(growth, grid[i], grid[i + 1], xtol=1e-12, rtol=1e-14)
        for i in range(n - 1)
        if np.sign(s[i]) != np.sign(s[i + 1])
    ]


def test_reduced_model_jacobian_is_block_triangular_and_tread_hopf_speeds_equal_tread1dof():
    """In the limit the axle rows get nothing from the tread states (friction passes
    through O, N acts at O), so the spectrum is the axle's plus tread1dof's exactly."""
    p4 = pack(**REDUCED)
    p1 = tread1dof.MODEL.pack(Params())
    V = kmh_to_ms(110.0)
    J = MODEL.jacobian(MODEL.equilibrium(V, p4), V, p4)
    axle_rows = [0, 1, 2, 4, 5, 6]
    assert np.abs(J[np.ix_(axle_rows, TREAD)]).max() == 0.0
    J1 = tread1dof.MODEL.jacobian(tread1dof.MODEL.equilibrium(V, p1), V, p1)
    np.testing.assert_allclose(J[np.ix_(TREAD, TREAD)], J1, rtol=1e-12, atol=1e-9)

    speeds4 = _hopf_speeds(lambda v: _tread_mode_growth(MODEL, p4, v))
    speeds1 = _hopf_speeds(lambda v: _tread_mode_growth(tread1dof.MODEL, p1, v))
    assert len(speeds1) == 2
    np.testing.assert_allclose(speeds4, speeds1, rtol=1e-8)


# -- (iii) energy conservation ------------------------------------------------------------

CONSERVATIVE = {
    "friction.sigma1_s_per_m": 0.0,
    "friction.sigma2_s_per_m": 0.0,
    "tread.lateral_damping_ns_per_m": 0.0,
    "axle.toe_damping_nms_per_rad": 0.0,
    "axle.camber_damping_nms_per_rad": 0.0,
    "axle.pitch_damping_nms_per_rad": 0.0,
    "tire.vertical_damping_ns_per_m": 0.0,
}


def _conservative_params(**updates):
    """No friction (F = N (sigma0 z + sigma1 z' + sigma2 v_r) = 0) and no damping; a
    test-only vector, as sigma0 = 0 is outside the validated range."""
    p = pack(**{**CONSERVATIVE, "axle.reference": "unloaded", **updates})
    p[slot("sigma0")] = 0.0
    return p


@pytest.mark.slow
@pytest.mark.parametrize("spin_inertia", [0.0, 1.5])
def test_energy_is_conserved_without_friction_and_damping(spin_inertia):
    p = _conservative_params(**{"axle.lateral_offset_m": 0.04, "axle.wheel_spin_inertia_kgm2": spin_inertia})
    V = kmh_to_ms(110.0)
    u0 = np.r_[0.02, -0.015, 0.01, 1e-3, 0.5, -0.8, 1.0, 0.1, 0.0]

    def energy(u):
        return kinetic_energy(u[:NQ], u[NQ : 2 * NQ], p) + potential_energy(u[:NQ], V, p)

    sol = solve_ivp(
        lambda t, u: MODEL.f(u, V, p), (0.0, 1.0), u0, method="DOP853", rtol=1e-11, atol=1e-13, dense_output=True
    )
    assert sol.success
    t = np.linspace(0.0, 1.0, 401)
    e = np.array([energy(u) for u in sol.sol(t).T])
    kinetic = np.array([kinetic_energy(u[:NQ], u[NQ : 2 * NQ], p) for u in sol.sol(t).T])
    assert kinetic.max() - kinetic.min() > 0.5 * kinetic.max()  # energy really moves around
    assert np.abs(e - e[0]).max() < 1e-9 * kinetic.max()
    assert MODEL.diagnostics(sol.y.T, V, p)[:, 3].max() == 0.0  # contact kept


def test_energy_check_detects_a_missing_damper_term():
    """The energy balance is sharp: a small damper shows up as the dissipated work."""
    p = _conservative_params(**{"axle.toe_damping_nms_per_rad": 0.5})
    V = kmh_to_ms(110.0)
    u0 = np.r_[0.02, -0.015, 0.01, 1e-3, 0.5, -0.8, 1.0, 0.1, 0.0]
    sol = solve_ivp(lambda t, u: MODEL.f(u, V, p), (0.0, 0.05), u0, method="DOP853", rtol=1e-11, atol=1e-13, dense_output=True)
    t = np.linspace(0.0, 0.05, 2001)
    u = sol.sol(t)
    e = np.array([kinetic_energy(x[:NQ], x[NQ : 2 * NQ], p) + potential_energy(x[:NQ], V, p) for x in u.T])
    dissipated = simpson(0.5 * u[4] ** 2, x=t)  # c_alpha * alpha'^2 integrated
    assert e[0] - e[-1] == pytest.approx(dissipated, rel=1e-4)


# -- (iv) analytic Jacobian and dfdv --------------------------------------------------------


def assert_rows_close(a, b, tol):
    """|a - b| <= tol * (|b| + max |b| of the row): relative, entries of a row share a scale."""
    scale = np.abs(b).max(axis=1, keepdims=True)
    assert np.all(np.abs(a - b) <= tol * (np.abs(b) + scale)), np.abs(a - b) / (np.abs(b) + scale)


def _complex_step_jacobian(u, V, p):
    h = 1e-30
    cols = []
    for k in range(u.size):
        du = np.zeros(u.size, dtype=complex)
        du[k] = 1j * h
        cols.append(MODEL.f(u + du, V, p).imag / h)
    return np.array(cols).T


def _central_jacobian(u, V, p):
    step = 1e-6 * np.maximum(np.abs(u), [1e-3, 1e-3, 1e-3, 1e-4, 1e-1, 1e-1, 1e-1, 1e-2, 1e-4])
    cols = [(MODEL.f(u + s, V, p) - MODEL.f(u - s, V, p)) / (2 * s[k]) for k, s in enumerate(np.diag(step))]
    return np.array(cols).T


@pytest.mark.parametrize("reference", ["running", "unloaded"])
@pytest.mark.parametrize("spin", [0.0, 1.2])
@settings(max_examples=8, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), kmh=st.floats(30.0, 250.0))
def test_jacobian_and_speed_derivative_match_complex_step_and_central_differences(reference, spin, seed, kmh):
    p = pack(**{"axle.reference": reference, "axle.wheel_spin_inertia_kgm2": spin, "axle.lateral_offset_m": 0.03})
    V = kmh_to_ms(kmh)
    u = random_state(np.random.default_rng(seed), p, V)
    J = MODEL.jacobian(u, V, p)
    assert_rows_close(J, _complex_step_jacobian(u, V, p), 1e-10)
    assert_rows_close(J, _central_jacobian(u, V, p), 1e-6)

    dv = MODEL.df_dspeed(u, V, p)
    np.testing.assert_allclose(dv, MODEL.f(u, V + 1e-30j, p).imag / 1e-30, rtol=1e-10, atol=1e-12 * np.abs(dv).max())
    # V ~ 10-70 m/s: a step of 1e-2 m/s keeps truncation (h^2) and rounding (eps |f| / h)
    # both far below the tolerance; 1e-4 m/s was in the rounding regime for small rows
    central = (MODEL.f(u, V + 1e-2, p) - MODEL.f(u, V - 1e-2, p)) / 2e-2
    np.testing.assert_allclose(dv, central, rtol=1e-5, atol=1e-6 * np.abs(dv).max())


def test_speed_derivative_includes_running_preload_and_wheel_spin():
    """df/dV carries the speed dependence of the running preloads and of the wheel-spin
    rate V/R_e (checked by complex step; the spin part is visible with a toe rate)."""
    p = pack(**{"axle.wheel_spin_inertia_kgm2": 1.2})
    V = kmh_to_ms(110.0)
    u = MODEL.equilibrium(V, p)
    u[4] = 0.7  # spin couples alpha' into the other rows
    cs = MODEL.f(u, V + 1e-30j, p).imag / 1e-30
    np.testing.assert_allclose(MODEL.df_dspeed(u, V, p), cs, rtol=1e-10, atol=1e-12 * np.abs(cs).max())
    p_no_spin = pack()
    assert np.abs(MODEL.df_dspeed(u, V, p) - MODEL.df_dspeed(u, V, p_no_spin))[4:8].max() > 1e-3


# -- (v) contact loss --------------------------------------------------------------------


def test_contact_loss_clamps_the_normal_load_and_stays_finite():
    p = pack()
    V = kmh_to_ms(110.0)
    u = MODEL.equilibrium(V, p)
    u[2] = -0.1  # pitch the arm up: C rises by about L * 0.1 = 45 mm > N0/k_z = 20 mm
    aux = MODEL.diagnostics(u, V, p)
    assert aux[2] == 0.0 and aux[3] == 1.0 and aux[1] == 0.0
    f = MODEL.f(u, V, p)
    J = MODEL.jacobian(u, V, p)
    assert np.all(np.isfinite(f)) and np.all(np.isfinite(J))
    assert_rows_close(J, _complex_step_jacobian(u, V, p), 1e-10)
    u[2] = 0.0
    assert MODEL.diagnostics(u, V, p)[3] == 0.0


# -- equilibria ---------------------------------------------------------------------------


@pytest.mark.parametrize("kmh", [20.0, 110.0, 240.0])
def test_running_reference_equilibrium_is_steady_with_zero_angles(kmh):
    p = pack(**{"axle.wheel_spin_inertia_kgm2": 1.0, "axle.lateral_offset_m": 0.05})
    V = kmh_to_ms(kmh)
    u = MODEL.equilibrium(V, p)
    assert np.all(u[:3] == 0.0) and np.all(u[4:8] == 0.0)
    f = MODEL.f(u, V, p)
    np.testing.assert_allclose(f, 0.0, atol=1e-12 * np.abs(MODEL.jacobian(u, V, p)).max())
    toe, camber = axle4dof.running_alignment(u, p)
    assert (toe, camber) == (p[slot("toe0")], p[slot("camber0")])


@pytest.mark.parametrize("kmh", [1.0, 18.3, 38.27, 110.0, 300.0])
def test_unloaded_reference_equilibrium_shows_compliance_steer(kmh):
    """The inboard tire force (toe-in, negative camber) acts behind and below O: the
    static moments give toe-out and camber top-outward of about L F/k_alpha and H F/k_beta."""
    p = pack(**{"axle.reference": "unloaded"})
    V = kmh_to_ms(kmh)
    u = MODEL.equilibrium(V, p)
    np.testing.assert_allclose(MODEL.f(u, V, p), 0.0, atol=1e-12 * np.abs(MODEL.jacobian(u, V, p)).max())
    force = MODEL.diagnostics(u, V, p)[1]
    assert force > 0.0
    alpha_static = -p[slot("L")] * force / p[slot("k_alpha")]
    beta_static = p[slot("H")] * force / p[slot("k_beta")]
    assert u[0] == pytest.approx(alpha_static, rel=0.05)
    assert u[1] == pytest.approx(beta_static, rel=0.05)
    toe, camber = axle4dof.running_alignment(u, p)
    assert toe < p[slot("toe0")] and camber > p[slot("camber0")]


# -- generated module ---------------------------------------------------------------------


def test_generated_module_header_matches_the_derivation_inputs():
    from polywear.models import axle4dof_derivation as derivation

    header = derivation.GENERATED_PATH.read_text().splitlines()[2]
    assert header.endswith(derivation._inputs_hash()), "regenerate: python -m polywear.models.axle4dof_derivation"


@pytest.mark.slow
def test_regenerating_gives_the_committed_file(tmp_path):
    from polywear.models import axle4dof_derivation as derivation

    written = derivation.write_generated(tmp_path / "generated.py")
    assert written.read_bytes() == derivation.GENERATED_PATH.read_bytes()


def test_rhs_python_equals_compiled_rhs():
    p = pack(**{"axle.wheel_spin_inertia_kgm2": 0.8, "axle.reference": "unloaded"})
    V = kmh_to_ms(90.0)
    u = random_state(np.random.default_rng(11), p, V)
    np.testing.assert_allclose(axle4dof.rhs_python(0.0, u, V, p), MODEL.f(u, V, p), rtol=1e-12, atol=1e-9)


def test_model_layout():
    assert MODEL.state_names == ("alpha", "beta", "gamma", "x", "alphadot", "betadot", "gammadot", "xdot", "z")
    assert MODEL.aux_names[:3] == tread1dof.MODEL.aux_names
    assert MODEL.aux_names[3] == "contact_lost"
    p = pack(**{"operating.toe_deg": 0.5, "axle.reference": "unloaded"})
    assert p[slot("toe0")] == pytest.approx(np.radians(0.5))
    assert p[slot("reference")] == 1.0 and pack()[slot("reference")] == 0.0


# -- docs/model.md section 7 --------------------------------------------------------------------


def _unstable_speeds(p, lo, hi, n):
    """Speeds [km/h] with an unstable equilibrium on a grid, and the unstable frequencies [Hz]."""
    out = []
    for kmh in np.linspace(lo, hi, n):
        V = kmh_to_ms(kmh)
        vals = np.linalg.eigvals(MODEL.jacobian(MODEL.equilibrium(V, p), V, p))
        out.append((kmh, sorted(v.imag / (2 * np.pi) for v in vals if v.real > 0 and v.imag > 0)))
    return out


def _max_growth(p, kmh, fmin=0.0, fmax=np.inf):
    V = kmh_to_ms(kmh)
    vals = np.linalg.eigvals(MODEL.jacobian(MODEL.equilibrium(V, p), V, p))
    band = vals[(vals.imag / (2 * np.pi) > fmin) & (vals.imag / (2 * np.pi) < fmax)]
    return band.real.max()


@pytest.mark.slow
def test_default_linear_band_and_tread_mode_match_model_md():
    """docs/model.md section 7: roughly 79 to 155 km/h, the tread mode (about 110-145 Hz)."""
    p = pack()
    tread = lambda kmh: _max_growth(p, kmh, fmin=80.0)  # noqa: E731
    lower = brentq(tread, 60.0, 100.0, xtol=1e-6)
    upper = brentq(tread, 130.0, 180.0, xtol=1e-6)
    assert 76.0 < lower < 82.0 and 150.0 < upper < 160.0
    for kmh, freqs in _unstable_speeds(p, 40.0, 200.0, 33):
        if lower < kmh < upper:
            assert len(freqs) == 1 and 105.0 < freqs[0] < 150.0
        else:
            assert freqs == []


@pytest.mark.slow
def test_bushing_damping_alone_lets_the_toe_mode_self_excite():
    """docs/model.md section 7: with toe/camber damping 144/83 the toe mode near 25 Hz goes
    unstable from about 40 km/h, besides the tread mode."""
    from polywear.dynamics.stability import mode_label

    p = pack(**{"axle.toe_damping_nms_per_rad": 144.0, "axle.camber_damping_nms_per_rad": 83.0})
    toe_mode = lambda kmh: _max_growth(p, kmh, fmin=10.0, fmax=40.0)  # noqa: E731
    onset = brentq(toe_mode, 20.0, 60.0, xtol=1e-6)
    assert 35.0 < onset < 45.0
    V = kmh_to_ms(onset + 5.0)
    vals, vecs = np.linalg.eig(MODEL.jacobian(MODEL.equilibrium(V, p), V, p))
    i = np.argmax(np.where((vals.imag > 0) & (vals.imag < 2 * np.pi * 40.0), vals.real, -np.inf))
    assert vals[i].real > 0 and 20.0 < vals[i].imag / (2 * np.pi) < 30.0
    assert mode_label(MODEL, p, vecs[:, i]) == "alpha"
    assert _max_growth(p, 110.0, fmin=80.0) > 0.0  # the tread mode is unstable too


def test_schematic_draws_into_given_axes(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    spec = importlib.util.spec_from_file_location("make_schematic", SCHEMATIC_SCRIPT)
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)

    fig, ax = plt.subplots()
    artists = script.plot_schematic(ax)
    texts = " ".join(a.get_text() for a in artists if hasattr(a, "get_text"))
    for label in ("O (bushing)", "C", r"\alpha", r"\beta", r"\gamma", "toe_0", "camber_0", "k_z", "X (forward)"):
        assert label in texts, label
    assert all(a.axes is ax for a in artists if hasattr(a, "axes") and a.axes is not None)
    fig.savefig(tmp_path / "schematic.png")
    plt.close(fig)


def test_schematic_script_runs(tmp_path):
    """The figure script outside the package writes its PNG when run as a script."""
    out = tmp_path / "axle4dof_schematic.png"
    subprocess.run([sys.executable, str(SCHEMATIC_SCRIPT), str(out)], check=True, capture_output=True)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_prepared_parameter_vector_caches_the_preloads_of_one_speed_only():
    """``prepare`` caches the running preloads of one speed: kernels give identical results
    at that speed and ignore the cache at any other speed (or for complex-step calls)."""
    from polywear.models.axle4dof import prepare

    p = pack()
    assert np.isnan(p[-4:]).all()  # a packed vector caches nothing
    V = kmh_to_ms(110.0)
    q = prepare(V, p)
    u = MODEL.equilibrium(V, p) + 1e-4
    np.testing.assert_array_equal(MODEL.f(u, V, q), MODEL.f(u, V, p))
    np.testing.assert_array_equal(MODEL.jacobian(u, V, q), MODEL.jacobian(u, V, p))
    other = kmh_to_ms(140.0)
    np.testing.assert_array_equal(MODEL.f(u, other, q), MODEL.f(u, other, p))
    np.testing.assert_array_equal(MODEL.df_dspeed(u, V, q), MODEL.df_dspeed(u, V, p))
    cs = MODEL.f(u, V + 1e-30j, q).imag / 1e-30  # complex V never matches the cached speed
    np.testing.assert_allclose(cs, MODEL.df_dspeed(u, V, p), rtol=1e-10, atol=1e-12 * np.abs(cs).max())
