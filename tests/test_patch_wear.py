"""The worn profile coupled to the patch contact (models/profile.py with models/patch.py):
the coupled kernels against the patch model at the load an independent quadrature of the
profile gives, the Jacobian against complex steps, the linear wear map against a brute-force
time simulation, the evolution's mean wear against the map's steady power (docs/patch_contact.md)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from polywear.models import model_for
from polywear.models.profile import coupled_model, patch_sinc, profile_vector
from polywear.params import Params
from polywear.wear.map import wear_map

from .cli_runner import run_main
from .oracles import complex_step_jacobian, simulated_wear_change

PATCH = {"friction.contact": "patch", "friction.patch_elements": 8}


def _setup(pressure="parabolic", V=30.0):
    params = Params().with_updates({**PATCH, "friction.patch_pressure": pressure})
    base = model_for(params)
    return params, base, base.pack(params), V


def _states(base, p, V, count):
    rng = np.random.default_rng(5)
    u_eq = base.equilibrium(V, p)
    scale = np.maximum(np.abs(u_eq), 1e-5)
    return [u_eq + 0.05 * scale * rng.standard_normal(base.n) for _ in range(count)]


def test_zero_profile_is_the_patch_bit_for_bit():
    params, base, p, V = _setup()
    coupled = coupled_model(base)
    pz = profile_vector(base, params, V, np.zeros(5), np.zeros(5))
    for u in _states(base, p, V, 3):
        uz = np.append(u, 0.7)
        assert np.array_equal(coupled.f(uz, V, pz)[:-1], base.f(u, V, p))
        assert np.array_equal(coupled.jacobian(uz, V, pz)[:-1, :-1], base.jacobian(u, V, p))
        assert np.array_equal(coupled.diagnostics(uz, V, pz), base.diagnostics(u, V, p))


def test_one_coupled_model_per_element_count():
    a = coupled_model(model_for(Params().with_updates({**PATCH, "friction.patch_elements": 4})))
    b = coupled_model(model_for(Params().with_updates({**PATCH, "friction.patch_elements": 5})))
    assert (a.n, b.n) == (13, 16)


@pytest.mark.parametrize("pressure", ["parabolic", "uniform"])
def test_worn_load_is_shared_by_the_pressure_distribution(pressure):
    """With a worn profile the coupled rhs is the patch's at the total load
    N0 - k_z w_c - c_z dw_c/dt, w_c by direct quadrature of the profile over the patch
    (independent of the sinc factors), shared by the elements as the pressure shares N0."""
    params, base, p, V = _setup(pressure)
    coupled = coupled_model(base)
    R, a = params.operating.rolling_radius_m, 0.5 * params.tire.contact_length_m
    k_z, c_z = params.tire.vertical_stiffness_n_per_m, params.tire.vertical_damping_ns_per_m
    orders = np.arange(1, 7)
    rng = np.random.default_rng(2)
    amp_c, amp_s = 4e-5 * rng.standard_normal(6), 4e-5 * rng.standard_normal(6)
    sinc = patch_sinc(orders, params.tire.contact_length_m, R)
    pw = profile_vector(base, params, V, sinc * amp_c, sinc * amp_s)
    s = np.linspace(-a, a, 4001)

    def w_c(phi):
        angle = (phi + s / R)[:, None] * orders
        return np.trapezoid((amp_c * np.cos(angle) + amp_s * np.sin(angle)).sum(-1), s) / (2 * a)

    i_n = base.param_names.index("N")
    for u in _states(base, p, V, 2):
        for phi_c in (0.4, 3.1):
            wc_dot = (w_c(phi_c + 1e-4) - w_c(phi_c - 1e-4)) / 2e-4 * V / R
            q = p.copy()
            q[i_n] = p[i_n] - k_z * w_c(phi_c) - c_z * wc_dot
            assert abs(q[i_n] - p[i_n]) > 1.0  # the profile does change the load
            got = coupled.f(np.append(u, phi_c), V, pw)[:-1]
            np.testing.assert_allclose(got, base.f(u, V, q), rtol=1e-7, atol=1e-7 * np.abs(got).max())
            aux = coupled.diagnostics(np.append(u, phi_c), V, pw)
            assert aux[base.aux_names.index("normal_load")] == pytest.approx(q[i_n], rel=1e-9)


def test_jacobian_and_speed_derivative_against_complex_steps():
    params, base, p, V = _setup()
    coupled = coupled_model(base)
    rng = np.random.default_rng(4)
    pw = profile_vector(base, params, V, 2e-5 * rng.standard_normal(9), 2e-5 * rng.standard_normal(9))
    for u in _states(base, p, V, 2):
        uw = np.append(u, 1.3)
        jac = coupled.jacobian(uw, V, pw)
        ref, ref_v = complex_step_jacobian(coupled, uw, V, pw)
        np.testing.assert_allclose(jac, ref, rtol=1e-9, atol=1e-12 * np.abs(ref).max())
        assert np.any(jac[:-1, -1] != 0.0)  # the profile drives every element through the angle
        np.testing.assert_allclose(coupled.df_dspeed(uw, V, pw), ref_v, rtol=1e-9, atol=1e-12 * np.abs(ref_v).max())


def test_worn_load_below_zero_is_clamped():
    params, base, p, V = _setup()
    coupled = coupled_model(base)
    pw = profile_vector(base, params, V, [0.05], [0.0])  # 5 cm: lifts the tire off
    u = np.append(base.equilibrium(V, p), 0.0)
    assert coupled.diagnostics(u, V, pw)[base.aux_names.index("normal_load")] == 0.0
    assert coupled.diagnostics(u, V, pw)[base.aux_names.index("friction_force")] == 0.0


@pytest.mark.parametrize("toe", [0.5, 2.0])
def test_patch_wear_map_agrees_with_brute_force_simulation(toe):
    """The map's dw_n/w_n per revolution (transfer function of the linearization) against a
    time simulation of the coupled patch with a worn harmonic of 1 um: the written harmonic
    over two revolutions after the transient (no linear algebra). Both real (growth) and
    imaginary (drift) parts; they are small (e-folding 1e6-1e8 km) but resolved."""
    params = Params().with_updates({"friction.contact": "patch", "operating.toe_deg": toe})
    m = wear_map(params, [40.0])
    k = int(m.most_unstable()[0])
    sim = simulated_wear_change(params, 40.0, int(m.orders[k]))
    change = m.relative_change[0, k]
    assert sim.real == pytest.approx(change.real, rel=1e-4)
    assert sim.imag == pytest.approx(change.imag, rel=1e-4)
    assert change.real > 0.0  # a growing order: not a comparison of two zeros


def test_patch_evolution_runs_and_wears_what_the_map_says():
    """`polywear wear evolve --set friction.contact=patch` runs; its mean wear (the power of
    simulated windows) equals the map's steady power times the distance; nothing grows."""
    params = Params().with_updates({"friction.contact": "patch"})
    code, out, err = run_main(["wear", "evolve", "--set", "friction.contact=patch", "--speed", "110",
                               "--distance-km", "2000", "--json", "-q"])
    assert code == 0, err
    summary = json.loads(out)
    m = wear_map(params, [110.0])
    assert summary["mean_wear_mm"] == pytest.approx(2.0 * m.mean_wear_mm_per_1000km[0], rel=1e-3)
    assert summary["final_depth_mm"] == pytest.approx(summary["initial_depth_mm"], rel=1e-3)
    assert summary["visible_km"] is None
