"""Linear stability of tread1dof against the closed forms of docs/model.md section 3."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from polywear.dynamics.bifurcation import branch_start
from polywear.dynamics.stability import StabilitySettings, stability
from polywear.models import get_model
from polywear.params import Params, with_updates
from polywear.solvers.continuation import continue_from_hopf

from .oracles import characteristic_polynomial, routh_hurwitz_hopf_speeds

MODEL = get_model("tread1dof")


def test_jacobian_eigenvalues_are_the_roots_of_the_cubic():
    p = MODEL.pack(Params())
    for V_kmh in (10.0, 58.0, 110.0, 207.0, 290.0):
        V = V_kmh / 3.6
        J = MODEL.jacobian(MODEL.equilibrium(V, p), V, p)
        eig = np.sort_complex(np.linalg.eigvals(J))
        roots = np.sort_complex(np.roots(characteristic_polynomial(V, p)))
        assert np.allclose(eig, roots, rtol=1e-9, atol=1e-9 * np.abs(roots).max())


def test_default_hopf_speeds_match_routh_hurwitz_and_model_md():
    result = stability(Params(), (5.0, 300.0))
    p = MODEL.pack(Params())
    oracle = routh_hurwitz_hopf_speeds(p, 5 / 3.6, 300 / 3.6)
    speeds = [h.speed_ms for h in result.hopf_points]
    assert len(speeds) == 2
    assert np.allclose(speeds, oracle, rtol=1e-9)
    # docs/model.md section 7: ~58.1 km/h (soft, ~127 Hz) and ~207.8 km/h (hard, ~147 Hz)
    (h1, h2) = result.hopf_points
    assert abs(h1.speed_kmh - 58.1) < 0.1 and abs(h2.speed_kmh - 207.8) < 0.1
    assert abs(h1.frequency_hz - 127) < 1 and abs(h2.frequency_hz - 147) < 1
    assert (h1.criticality, h2.criticality) == ("soft", "hard")
    # at a Hopf point of a cubic the frequency is sqrt(a1/a3)
    for h in result.hopf_points:
        a3, a2, a1, a0 = characteristic_polynomial(h.speed_ms, p)
        assert math.isclose(h.omega, math.sqrt(a1 / a3), rel_tol=1e-8)
    assert result.linear_band_kmh == [(h1.speed_kmh, h2.speed_kmh)]


@settings(max_examples=8, deadline=None)
@given(toe=st.floats(0.2, 2.0))
def test_hopf_speeds_scale_exactly_as_one_over_sin_toe(toe):
    base = stability(Params(), (5.0, 300.0))
    # widen the range so that the scaled Hopf speeds stay inside it
    factor = math.sin(math.radians(0.5)) / math.sin(math.radians(toe))
    moved = stability(
        with_updates(Params(), {"operating.toe_deg": toe}), (5.0 * factor, 300.0 * factor)
    )
    expected = [h.speed_ms * factor for h in base.hopf_points]
    assert np.allclose([h.speed_ms for h in moved.hopf_points], expected, rtol=1e-9)


@settings(max_examples=8, deadline=None)
@given(scale=st.floats(0.125, 10.0))  # the load stays a wheel load: 500 N to 40 kN
def test_hopf_speeds_invariant_when_m_k_c_n_scale_together(scale):
    base = Params()
    scaled = with_updates(
        base,
        {
            "tread.mass_kg": base.tread.mass_kg * scale,
            "tread.lateral_stiffness_n_per_m": base.tread.lateral_stiffness_n_per_m * scale,
            "tread.lateral_damping_ns_per_m": base.tread.lateral_damping_ns_per_m * scale,
            "operating.vertical_load_n": base.operating.vertical_load_n * scale,
        },
    )
    a = stability(base, (5.0, 300.0))
    b = stability(scaled, (5.0, 300.0))
    assert np.allclose([h.speed_ms for h in a.hopf_points], [h.speed_ms for h in b.hopf_points], rtol=1e-9)
    assert np.allclose([h.omega for h in a.hopf_points], [h.omega for h in b.hopf_points], rtol=1e-9)


@pytest.mark.parametrize("index", [0, 1])
def test_first_lyapunov_coefficient_predicts_the_emerging_cycle(index):
    """Near a Hopf point the cycle amplitude is 2 |q_x| sqrt(-mu / (omega l1)) (normal form),
    with mu = dRe(lambda)/dV (V - V_H); a second method (continuation) must agree, and the
    branch must leave to the side and with the stability that the sign of l1 implies."""
    params = Params()
    p = MODEL.pack(params)
    hopf = stability(params, (5.0, 300.0)).hopf_points[index]
    branch = continue_from_hopf(MODEL, p, branch_start(hopf), (20 / 3.6, 300 / 3.6))
    first = branch.points[0]
    mu = hopf.dre_dspeed * (first.orbit.speed - hopf.speed_ms)
    predicted = 2 * abs(hopf.q[0]) * math.sqrt(-mu / (hopf.omega * hopf.first_lyapunov_coefficient))
    assert first.orbit.amplitude()[0] == pytest.approx(predicted, rel=1e-3)
    # soft: cycles on the unstable side of the equilibrium, stable; hard: the opposite
    unstable_side = np.sign(hopf.dre_dspeed) * (first.orbit.speed - hopf.speed_ms) > 0
    assert unstable_side == (hopf.first_lyapunov_coefficient < 0)
    assert first.stable == (hopf.first_lyapunov_coefficient < 0)


def test_bad_speed_range_is_rejected():
    with pytest.raises(ValueError, match="speed range"):
        stability(Params(), (300.0, 5.0))


class _RealCrossing:
    """Eigenvalues V - 1 (real) and -1 +- 3i: a static divergence at V = 1, no Hopf point."""

    n = 3

    @staticmethod
    def equilibrium(V, p):
        return np.zeros(3)

    @staticmethod
    def jacobian(u, V, p):
        return np.array([[V - 1.0, 0.0, 0.0], [0.0, -1.0, 3.0], [0.0, -3.0, -1.0]])


def test_real_eigenvalue_crossing_is_located_not_a_hopf_point():
    from polywear.dynamics.stability import _hopf_in_bracket, equilibrium_eigenvalues

    model = _RealCrossing()
    _, eig = equilibrium_eigenvalues(model, None, [0.5, 1.7])
    hopfs, reals = _hopf_in_bracket(model, None, 0.5, 1.7, eig[0], eig[1], 1e-12)
    assert hopfs == [] and reals == [pytest.approx(1.0, abs=1e-11)]


def test_unloaded_axle_equilibrium_follows_the_sliding_branch():
    """With little toe the unloaded axle also has a sticking equilibrium (v_r = 0); the
    homotopy from the running state must stay on the sliding one at every speed, so the
    running toe and the sliding velocity vary smoothly with speed."""
    params = with_updates(Params(), {"model": "axle4dof", "axle.reference": "unloaded", "operating.toe_deg": 0.3})
    model = get_model("axle4dof")
    p = model.pack(params)
    speeds = np.linspace(5.0, 300.0, 60) / 3.6
    v_r = np.array([model.diagnostics(model.equilibrium(V, p), V, p)[0] for V in speeds])
    assert np.all(v_r > 1e-4)
    assert np.all(np.diff(v_r) > 0)  # the sliding velocity grows with speed on this branch
    result = stability(params, (5.0, 300.0))
    assert result.summary()["running_alignment"]["toe_deg"] < 0.0  # compliance steer to toe-out


@pytest.mark.parametrize("n_speeds", [5, 12, 40])
def test_a_band_narrower_than_the_grid_is_not_missed(n_speeds):
    """At c = 448.78 N s/m (just below the damping where the linear band closes) steady
    rolling is unstable in a band about 0.2 km/h wide near 120 km/h. A grid of 5 to 40
    speeds over 20-300 km/h (spacing 7-70 km/h) must still find both Hopf points: the
    grid refines itself where a sorted eigenvalue real part peaks near zero. Oracle: the
    Routh-Hurwitz condition on a 2000-point grid around the band."""
    params = with_updates(Params(), {"tread.lateral_damping_ns_per_m": 448.78})
    result = stability(params, (20.0, 300.0), StabilitySettings(n_speeds=n_speeds))
    oracle = routh_hurwitz_hopf_speeds(MODEL.pack(params), 110 / 3.6, 130 / 3.6)
    assert len(oracle) == 2 and 0.0 < (oracle[1] - oracle[0]) * 3.6 < 0.5
    assert np.allclose([h.speed_ms for h in result.hopf_points], oracle, rtol=1e-9)
    assert len(result.linear_band_kmh) == 1
