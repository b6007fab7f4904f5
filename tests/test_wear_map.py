"""Linear wear-stability map (wear/map.py) against independent checks:
brute-force time simulation of the coupled model at small amplitude, the mean wear
rate by hand, the k_e scaling and Sueoka's two findings."""

from __future__ import annotations

import math

import numpy as np
import pytest

from polywear.wear.law import friction_power, written_harmonics
from polywear.wear.map import VIBRATING_NOTE, load_to_power, wear_map
from polywear.models import get_model
from polywear.models.profile import coupled_model, patch_sinc, profile_vector
from polywear.params import Params, with_updates
from polywear.solvers.integrate import integrate


def _simulated_change(params, speed_kmh, order, amplitude_m=1e-6, revolutions=4):
    """dw_n/w_n per revolution from a time simulation of the coupled model with a worn
    harmonic of 1 um, after the transient has died out (brute force, no linear algebra)."""
    base = get_model(params.model)
    coupled = coupled_model(base)
    V = speed_kmh / 3.6
    R = params.operating.rolling_radius_m
    u0, A, *_ = load_to_power(base, base.pack(params), V)
    decay = -np.max(np.linalg.eigvals(A).real)
    cos_coef = np.zeros(order)
    cos_coef[-1] = patch_sinc([order], params.tire.contact_length_m, R)[0] * amplitude_m
    p = profile_vector(base, params, V, cos_coef, np.zeros(order))
    T = 2 * math.pi * R / V
    settle = math.ceil(14.0 / decay / T) * T  # transient down by e^-14
    run = integrate(coupled, np.append(u0, 0.0), V, p, settle + revolutions * T, rtol=1e-9, atol=1e-13,
                    dense_from=settle)
    dt = T / (64 * order)
    t = settle + np.arange(round(revolutions * T / dt) + 1) * dt
    u = run.dense(t)
    dW, _ = written_harmonics(t, friction_power(coupled, u, V, p), u[:, -1], [order], params)
    return dW[0] / revolutions / amplitude_m  # W_n = amplitude (cosine harmonic)


@pytest.mark.parametrize("model", ["tread1dof", pytest.param("axle4dof", marks=pytest.mark.slow)])
def test_map_agrees_with_brute_force_simulation(model):
    params = with_updates(Params(), {"model": model})
    m = wear_map(params, [40.0])
    k = int(m.most_unstable()[0])
    order = int(m.orders[k])
    sim = _simulated_change(params, 40.0, order)
    lam = 1.0 + sim
    revs_per_km = m.revolutions_per_km
    efold_sim = 1.0 / (math.log(abs(lam)) * revs_per_km)
    drift_sim = -math.degrees(math.atan2(lam.imag, lam.real)) / order
    assert m.efold_km[0, k] == pytest.approx(efold_sim, rel=0.02)
    assert m.drift_deg_per_rev[0, k] == pytest.approx(drift_sim, rel=0.02)
    assert m.efold_km[0, k] < 1e5  # a growing order: the comparison is not between two zeros


def test_mean_wear_is_k_e_times_steady_power():
    """0.07 mm per 1000 km at 110 km/h for the defaults, by hand from F0 v_r0."""
    params = Params()
    m = wear_map(params, [110.0])
    V = 110 / 3.6
    v_r0 = V * math.sin(math.radians(0.5))
    f = params.friction
    g0 = f.mu_coulomb + (f.mu_static - f.mu_coulomb) * math.exp(-(v_r0 / f.stribeck_velocity_m_per_s) ** 2)
    power = params.operating.vertical_load_n * (g0 + f.sigma2_s_per_m * v_r0) * v_r0
    per_rev = 1e-12 * power / (V * 0.16)
    expected = per_rev * 1e6 / (2 * math.pi * 0.3) * 1e3
    assert m.mean_wear_mm_per_1000km[0] == pytest.approx(expected, rel=1e-9)
    assert 0.05 < expected < 0.09


def test_linear_band_is_flagged_not_numbered():
    m = wear_map(Params(), [40.0, 110.0, 230.0])
    assert m.rolling_stable.tolist() == [True, False, True]
    rows = m.summary()["rows"]
    assert rows[1]["note"] == VIBRATING_NOTE and rows[1]["efold_km"] is None and rows[1]["order"] is None
    assert rows[0]["order"] > rows[2]["order"]  # fewer sides at higher speed
    assert len(m.rows(all_orders=True)) == 2 * 60 + 1


def test_distances_scale_as_one_over_k_e():
    params = Params()
    m1 = wear_map(params, [35.0, 45.0])
    m3 = wear_map(with_updates(params, {"wear.energetic_rate_mm3_per_j": 3e-3}), [35.0, 45.0])
    grow = m1.growth_per_rev > 0
    # exact to first order in dw/w (~1e-7 per revolution): ln|1 + d| differs from Re d by O(|d|^2)
    np.testing.assert_allclose(m3.efold_km[grow] * 3.0, m1.efold_km[grow], rtol=1e-5)
    assert np.array_equal(m3.growth_per_rev > 0, grow)


def test_constant_frequency_law():
    """Sueoka: across speeds the most unstable order changes while its frequency stays
    near the tread mode. Exceptions: speeds where the mode's order sits on a zero of the
    patch filter sinc_n (n a/R = pi, here n ~ 17); at most one in five speeds."""
    speeds = np.linspace(20.0, 56.0, 19)
    m = wear_map(Params(), speeds)
    best = m.most_unstable()
    orders = m.orders[best]
    freq = m.frequency_hz[np.arange(len(speeds)), best]
    near = np.abs(freq / m.mode_frequency_hz - 1.0) < 0.1
    assert orders.max() >= 2 * orders.min()
    assert near.mean() >= 0.8, list(zip(speeds, orders, freq, m.mode_frequency_hz))


def test_damping_moves_the_unstable_orders_k_e_only_the_growth():
    """Sueoka's second finding: damping changes which orders grow; k_e only how fast."""
    params = Params()

    def unstable(p):
        m = wear_map(p, [40.0])
        return set(m.orders[m.growth_per_rev[0] > 0].tolist()), m.relative_change[0]

    lowest = []
    for c in (40.0, 80.0, 160.0, 320.0):
        orders, _ = unstable(with_updates(params, {"tread.lateral_damping_ns_per_m": c}))
        lowest.append(min(orders))
    assert lowest == sorted(lowest, reverse=True) and lowest[0] > lowest[-1]  # more damping, wider range
    ref_orders, ref_growth = unstable(params)
    k_orders, k_growth = unstable(with_updates(params, {"wear.energetic_rate_mm3_per_j": 5e-3}))
    assert k_orders == ref_orders
    np.testing.assert_allclose(k_growth, 5.0 * ref_growth, rtol=1e-12)  # dw/w is linear in k_e
