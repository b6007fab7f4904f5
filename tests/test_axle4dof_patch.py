"""axle4dof with the patch contact (models/axle4dof_patch*.py, docs/patch_contact.md section 6).

Oracles: complex-step derivatives (Jacobian, df/dV, and d/dp through the running preloads
against central differences); the point-contact axle4dof, which one element at the
centre of a patch with no transport is (the difference must vanish as 1/L); the
tread1dof patch, whose steady force the running reference must reproduce (the carrier at
rest); the flow map of a time integration without Jacobian, against exp(J T); with a
worn profile, the load at an independent sum of the harmonics, complex steps, and the
linear wear map against a brute-force time simulation.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm

from polywear.models import axle4dof, get_model, model_for
from polywear.models.axle4dof_patch import axle4dof_patch_model
from polywear.models.axle4dof_patch_kernels import LEN
from polywear.models.profile import coupled_model, profile_vector
from polywear.params import Params
from polywear.units import kmh_to_ms
from polywear.wear.map import wear_map

from .oracles import complex_step_jacobian, simulated_wear_change

AXLE_PATCH = {"model": "axle4dof", "friction.contact": "patch"}
GEOMETRY = {"axle.lateral_offset_m": 0.02, "axle.pivot_height_m": 0.05}
V = kmh_to_ms(110.0)


def _setup(elements=5, **updates):
    params = Params().with_updates({**AXLE_PATCH, "friction.patch_elements": max(elements, 2), **updates})
    model = axle4dof_patch_model(elements, params.friction.patch_pressure)
    return params, model, model.pack(params)


def _force(model, u, speed, p):
    return float(model.diagnostics(u, speed, p)[model.aux_names.index("friction_force")])


def test_model_for_dispatches_the_patch_on_axle4dof():
    params = Params().with_updates({**AXLE_PATCH, "friction.patch_elements": 7})
    model = model_for(params)
    assert model is axle4dof_patch_model(7, "parabolic")
    assert model.n == 3 * 7 + 6
    assert model.state_names[:6] == ("alpha", "beta", "gamma", "alphadot", "betadot", "gammadot")
    assert model.state_names[-3:] == ("x", "xdot", "z")


@pytest.mark.parametrize("reference", ["running", "unloaded"])
@pytest.mark.parametrize("pressure", ["parabolic", "uniform"])
def test_jacobian_and_speed_derivative_match_complex_steps(reference, pressure):
    _, model, p = _setup(5, **GEOMETRY, **{"axle.reference": reference, "friction.patch_pressure": pressure})
    u0 = model.equilibrium(V, p)
    rng = np.random.default_rng(3)
    for u in (u0, u0 + rng.normal(scale=1e-3, size=model.n) * np.maximum(np.abs(u0), 1e-3)):
        jac, dfdv = complex_step_jacobian(model, u, V, p)
        assert np.abs(model.jacobian(u, V, p) - jac).max() <= 1e-13 * np.abs(jac).max()
        assert np.abs(model.df_dspeed(u, V, p) - dfdv).max() <= 1e-12 * np.abs(dfdv).max()


def test_complex_steps_in_the_parameters_pass_through_the_running_preloads():
    """d f/d toe0 and d f/d N0 at a fixed state: the preloads hold the carrier's steady patch,
    which the kernels march in floats and carry to complex steps by one Newton step."""
    _, model, p = _setup(5, **GEOMETRY)
    u = model.equilibrium(V, p)
    for name, step in (("toe0", 1e-7), ("N0", 1e-3)):
        e = np.zeros(len(p))
        e[model.param_names.index(name)] = 1.0
        exact = model.f(u + 0j, V, p + 1e-30j * e).imag / 1e-30
        central = (model.f(u, V, p + step * e) - model.f(u, V, p - step * e)) / (2 * step)
        assert np.abs(exact).max() > 0
        assert np.abs(exact - central).max() <= 1e-6 * np.abs(exact).max()


@pytest.mark.parametrize("reference", ["running", "unloaded"])
def test_one_element_without_transport_is_the_point_contact(reference):
    """M = 1 at the centre of a patch of length L: the transport rate V cos(toe)/L -> 0 as L
    grows, and the model becomes the point contact; the difference falls as 1/L."""
    params, model, q = _setup(1, **GEOMETRY, **{"axle.reference": reference, "friction.patch_pressure": "uniform"})
    point = get_model("axle4dof")
    p = point.pack(params)
    u_point = point.equilibrium(V, p)
    eig_point = np.sort_complex(np.linalg.eigvals(point.jacobian(u_point, V, p)))
    order = [0, 1, 2, 6, 3, 4, 5, 7, 8]  # patch layout -> (alpha, beta, gamma, x, rates, z)
    errors = []
    for length in (1e9, 1e12):
        q[LEN] = length
        u = model.equilibrium(V, q)
        eig = np.sort_complex(np.linalg.eigvals(model.jacobian(u, V, q)))
        errors.append((np.abs(u[order] - u_point).max(), np.abs(eig - eig_point).max() / np.abs(eig_point).max()))
        assert np.abs(model.f(u, V, q)).max() < 1e-9
    assert errors[1][0] < 1e-12 and errors[1][1] < 1e-11
    assert errors[0][0] / errors[1][0] == pytest.approx(1e3, rel=0.05)
    assert _force(model, u, V, q) == pytest.approx(_force(point, u_point, V, p), rel=1e-10)


@pytest.mark.parametrize("toe", [0.05, 0.5, 2.0])
def test_running_reference_steady_force_is_the_tread1dof_patchs(toe):
    """The carrier held at rest in steady rolling (running reference, camber 0: the tread
    moves in the road plane): the patch is tread1dof's, force and states."""
    updates = {**GEOMETRY, "operating.toe_deg": toe, "operating.camber_deg": 0.0, "friction.patch_elements": 40}
    params, model, p = _setup(40, **updates)
    u = model.equilibrium(V, p)
    assert np.abs(u[:6]).max() == 0.0
    assert np.abs(model.f(u, V, p)).max() < 1e-9
    tread = params.with_updates({"model": "tread1dof"})
    tmodel = model_for(tread)
    tp = tmodel.pack(tread)
    tu = tmodel.equilibrium(V, tp)
    assert _force(model, u, V, p) == pytest.approx(_force(tmodel, tu, V, tp), rel=1e-12)
    np.testing.assert_allclose(u[6:], tu, rtol=1e-10, atol=1e-14)


def test_unloaded_reference_moves_the_equilibrium_and_the_force_follows_the_running_toe():
    """The unloaded axle yields to the steady force (toe and camber move); the patch force is
    then tread1dof's at the running toe, up to the tread's tilt (camber, pitch)."""
    updates = {**GEOMETRY, "axle.reference": "unloaded", "operating.camber_deg": 0.0}
    params, model, p = _setup(20, **updates)
    u = model.equilibrium(V, p)
    assert np.abs(model.f(u, V, p)).max() < 1e-8
    assert abs(u[0]) > 1e-5
    toe, _camber = axle4dof.running_alignment(u, p)
    tread = params.with_updates({"model": "tread1dof", "operating.toe_deg": np.degrees(toe)})
    tmodel = model_for(tread)
    tp = tmodel.pack(tread)
    assert _force(model, u, V, p) == pytest.approx(_force(tmodel, tmodel.equilibrium(V, tp), V, tp), rel=1e-3)


def test_flow_map_of_a_simulation_matches_the_linearization():
    """Central differences of the flow map over T (explicit integration, no Jacobian used)
    against exp(J T) (measured 1.7e-9 in the scaled max norm; a 0.1 % error in one
    body-element entry of J gives 5e-6), and the least damped eigenvalues from the flow
    map's (measured 1e-9 relative)."""
    _, model, p = _setup(3, **GEOMETRY, **{"axle.reference": "unloaded", "operating.speed_kmh": 80.0})
    speed = kmh_to_ms(80.0)
    u0 = model.equilibrium(speed, p)
    q = model.prepared(speed, p)
    T = 1e-3
    scale = np.array([1e-4] * 3 + [1e-2] * 3 + [1e-5, 1e-3, 1e-6] * 3)
    eps = 1e-4 * scale

    def flow(u):
        run = solve_ivp(lambda t, x: model.f(x, speed, q), (0, T), u, method="DOP853", rtol=1e-11, atol=1e-20)
        return run.y[:, -1]

    phi = np.column_stack([(flow(u0 + eps[k] * e) - flow(u0 - eps[k] * e)) / (2 * eps[k]) for k, e in enumerate(np.eye(model.n))])
    J = model.jacobian(u0, speed, p)
    exact = expm(J * T)
    scaled = (phi - exact) / scale[:, None] * scale[None, :]
    assert np.abs(scaled).max() < 1e-7 * np.abs(exact / scale[:, None] * scale[None, :]).max()
    lam = np.linalg.eigvals(J)
    mu = np.log(np.linalg.eigvals(phi).astype(complex)) / T
    for target in sorted(lam, key=lambda z: -z.real)[:4]:
        assert np.min(np.abs(mu - target)) < 1e-6 * abs(target)


# -- the worn profile (models/profile.py) ---------------------------------------------------


def _coupled(elements=6, V=30.0, **updates):
    params, model, p = _setup(elements, **GEOMETRY, **updates)
    return params, model, model.prepared(V, p), coupled_model(model), V


def test_zero_profile_is_the_model_bit_for_bit():
    params, model, q, coupled, V = _coupled()
    pz = profile_vector(model, params, V, np.zeros(4), np.zeros(4))
    u = model.equilibrium(V, q)
    for x in (u, u * 1.01 + 1e-6):
        uz = np.append(x, 0.7)
        assert np.array_equal(coupled.f(uz, V, pz)[:-1], model.f(x, V, q))
        assert np.array_equal(coupled.jacobian(uz, V, pz)[:-1, :-1], model.jacobian(x, V, q))
        assert np.array_equal(coupled.diagnostics(uz, V, pz), model.diagnostics(x, V, q))


def test_worn_profile_changes_the_load_and_its_derivatives_are_exact():
    """The coupled rhs is the model's at N0 - k_z w_c - c_z dw_c/dt (the preloads stay the
    nominal ones: the prepared vector); the Jacobian against complex steps. (The coupled
    df/dV is not exact for either axle4dof contact: models/profile.py differentiates the
    running preloads at the loaded N0, 2e-4 relative for the point contact, 6e-5 here; the
    wear analysis runs at fixed speeds and does not use it.)"""
    params, model, q, coupled, V = _coupled()
    R = params.operating.rolling_radius_m
    k_z, c_z = params.tire.vertical_stiffness_n_per_m, params.tire.vertical_damping_ns_per_m
    a, b = np.array([3e-5, -1e-5, 2e-5]), np.array([1e-5, 2e-5, -2e-5])
    pw = profile_vector(model, params, V, a, b)
    n = np.arange(1, 4)
    u = np.append(model.equilibrium(V, q) * 1.01, 1.1)
    w_c = np.sum(a * np.cos(n * 1.1) + b * np.sin(n * 1.1))
    dw_c = np.sum(n * (b * np.cos(n * 1.1) - a * np.sin(n * 1.1))) * V / R
    loaded = q.copy()
    loaded[model.param_names.index("N0")] -= k_z * w_c + c_z * dw_c
    np.testing.assert_allclose(coupled.f(u, V, pw)[:-1], model.f(u[:-1], V, loaded), rtol=1e-12, atol=1e-12)
    jac, _ = complex_step_jacobian(coupled, u, V, pw)
    assert np.abs(coupled.jacobian(u, V, pw) - jac).max() <= 1e-9 * np.abs(jac).max()
    assert np.any(jac[:-1, -1] != 0.0)


def test_wear_map_agrees_with_brute_force_simulation():
    """The map's per-revolution change of the fastest order at 40 km/h against a time
    simulation of the coupled model with a worn harmonic of 1 um (as tests/test_patch_wear.py
    does for tread1dof): the written harmonic over two revolutions after the transient."""
    params = Params().with_updates({**AXLE_PATCH, "friction.patch_elements": 6})
    m = wear_map(params, [40.0])
    k = int(m.most_unstable()[0])
    sim = simulated_wear_change(params, 40.0, int(m.orders[k]))
    change = m.relative_change[0, k]
    assert sim.real == pytest.approx(change.real, rel=1e-4)
    assert sim.imag == pytest.approx(change.imag, rel=1e-4)
    assert change.real > 0.0
