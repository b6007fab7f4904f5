"""Profile -> load coupling (models/profile.py): zero profile = base model bit for bit,
the load law against an independent patch quadrature, Jacobian against complex steps."""

from __future__ import annotations

import numpy as np
import pytest

from polywear.models import get_model
from polywear.models.profile import coupled_model, harmonics_of, patch_sinc, profile_vector
from polywear.params import Params, with_updates
from polywear.solvers.integrate import integrate

from .oracles import complex_step_jacobian

MODELS = ("tread1dof", "axle4dof")


def _setup(name, speed_ms=30.0):
    params = with_updates(Params(), {"model": name})
    base = get_model(name)
    return params, base, base.pack(params), speed_ms


def _states(base, p, V, count=4):
    rng = np.random.default_rng(7)
    u_eq = base.equilibrium(V, p)
    scale = np.maximum(np.abs(u_eq), 1e-4)
    return [u_eq + 0.05 * scale * rng.standard_normal(base.n) for _ in range(count)]


@pytest.mark.parametrize("name", MODELS)
def test_zero_profile_reproduces_the_base_model_bit_for_bit(name):
    params, base, p, V = _setup(name)
    coupled = coupled_model(base)
    for k in (0, 7):
        pz = profile_vector(base, params, V, np.zeros(k), np.zeros(k))
        for u in _states(base, p, V):
            for angle in (0.0, 2.1):
                uz = np.append(u, angle)
                assert np.array_equal(coupled.f(uz, V, pz)[:-1], base.f(u, V, p))
                assert np.array_equal(coupled.jacobian(uz, V, pz)[:-1, :-1], base.jacobian(u, V, p))
                assert np.array_equal(coupled.diagnostics(uz, V, pz), base.diagnostics(u, V, p))


@pytest.mark.parametrize("name", MODELS)
def test_jacobian_matches_complex_steps_with_a_worn_profile(name):
    params, base, p, V = _setup(name)
    coupled = coupled_model(base)
    rng = np.random.default_rng(3)
    pw = profile_vector(base, params, V, 2e-5 * rng.standard_normal(9), 2e-5 * rng.standard_normal(9))
    for u in _states(base, p, V, 2):
        uw = np.append(u, 1.3)
        jac = coupled.jacobian(uw, V, pw)
        ref, _ = complex_step_jacobian(coupled, uw, V, pw)
        np.testing.assert_allclose(jac, ref, rtol=1e-9, atol=1e-9 * np.abs(ref).max())
        assert np.any(jac[:-1, -1] != 0.0)  # the profile drives the model through the angle


def test_tread1dof_speed_derivative_matches_complex_step():
    params, base, p, V = _setup("tread1dof")
    coupled = coupled_model(base)
    pw = profile_vector(base, params, V, [1e-5, -2e-5, 3e-6], [4e-6, 1e-5, -7e-6])
    uw = np.append(_states(base, p, V, 1)[0], 0.4)
    ref = coupled.f(uw + 0j, V + 1e-30j, pw.astype(complex)).imag / 1e-30
    np.testing.assert_allclose(coupled.df_dspeed(uw, V, pw), ref, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("name", MODELS)
def test_load_is_the_patch_average_law(name):
    """N = N0 - k_z (w_c - w_mean) - c_z dw_c/dt with w_c by direct quadrature over the patch
    of a sampled profile (independent of the sinc factors and of the kernel's harmonics)."""
    params, base, p, V = _setup(name)
    coupled = coupled_model(base)
    R = params.operating.rolling_radius_m
    a = 0.5 * params.tire.contact_length_m
    k_z, c_z = params.tire.vertical_stiffness_n_per_m, params.tire.vertical_damping_ns_per_m
    rng = np.random.default_rng(11)
    orders = np.arange(1, 13)
    amp_c, amp_s = 3e-5 * rng.standard_normal(12), 3e-5 * rng.standard_normal(12)
    mean_depth = 4e-4  # uniform wear: must change nothing

    def w(phi):
        phi = np.asarray(phi)[..., None]
        return mean_depth + (amp_c * np.cos(orders * phi) + amp_s * np.sin(orders * phi)).sum(-1)

    samples = w(2 * np.pi * np.arange(720) / 720)
    A, B = harmonics_of(samples, 12)
    np.testing.assert_allclose(A, amp_c, atol=1e-15)
    np.testing.assert_allclose(B, amp_s, atol=1e-15)
    sinc = patch_sinc(orders, params.tire.contact_length_m, R)
    pw = profile_vector(base, params, V, sinc * A, sinc * B)
    s = np.linspace(-a, a, 4001)
    u_eq = base.equilibrium(V, p)
    i_load = base.aux_names.index("normal_load")
    n0_eff = base.diagnostics(u_eq, V, p)[i_load]  # N0 (minus nothing: axle at rest)
    for phi_c in (0.3, 2.0, 4.4):
        def w_c(phi):
            return np.trapezoid(w(phi + s / R), s) / (2 * a)
        dphi = 1e-4
        wc_dot = (w_c(phi_c + dphi) - w_c(phi_c - dphi)) / (2 * dphi) * V / R
        expected = n0_eff - k_z * (w_c(phi_c) - mean_depth) - c_z * wc_dot
        got = coupled.diagnostics(np.append(u_eq, phi_c), V, pw)[i_load]
        assert got == pytest.approx(expected, rel=1e-8)
        assert abs(got - n0_eff) > 1.0  # the profile does change the load


def test_tread1dof_load_is_clamped_at_zero():
    params, base, p, V = _setup("tread1dof")
    coupled = coupled_model(base)
    pw = profile_vector(base, params, V, [0.05], [0.0])  # 5 cm: lifts the tire off
    u = np.append(base.equilibrium(V, p), 0.0)
    assert coupled.diagnostics(u, V, pw)[base.aux_names.index("normal_load")] == 0.0
    k, c, m = (params.tread.lateral_stiffness_n_per_m, params.tread.lateral_damping_ns_per_m,
               params.tread.mass_kg)
    assert coupled.f(u, V, pw)[1] == pytest.approx((-c * u[1] - k * u[0]) / m)  # no friction left


@pytest.mark.parametrize("name", MODELS)
def test_zero_profile_trajectory_equals_the_base_one(name):
    """The added angle state changes only the step-size control's norm: same solution."""
    params, base, p, V = _setup(name)
    coupled = coupled_model(base)
    u0 = _states(base, p, V, 1)[0]
    ref = integrate(base, u0, V, p, 0.05, dt_out=1e-3, rtol=1e-9, atol=1e-12)
    got = integrate(coupled, np.append(u0, 0.0), V, profile_vector(base, params, V), 0.05, dt_out=1e-3,
                    rtol=1e-9, atol=1e-12)
    scale = np.abs(ref.u).max(axis=0)
    assert np.all(np.abs(got.u[:, :-1] - ref.u) <= 1e-6 * scale)
    np.testing.assert_allclose(got.u[:, -1], ref.t * V / params.operating.rolling_radius_m, rtol=1e-12)
