"""AUTO-07p as a reference: the equations it is given, and its own results checked
against independent methods (eigenvalues of the kernel Jacobian, long Radau runs).

The tests that run AUTO are marked ``auto07p`` and ``slow`` and are skipped, with the
install command as reason, where bifpy or gfortran is missing
(``scripts/ensure-auto07p.sh .venv`` installs both).
"""

from __future__ import annotations

import json
import math
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from polywear.units import kmh_to_ms, ms_to_kmh
from polywear.models.tread1dof import MODEL
from polywear.params import Params, with_updates
from polywear.validation import auto07p as A

AVAILABLE, MISSING_REASON = A.auto07p_available()


def needs_auto(test):
    """Marks: runs AUTO-07p (slow), skipped with the install command if unavailable."""
    test = pytest.mark.skipif(not AVAILABLE, reason=MISSING_REASON)(test)
    return pytest.mark.auto07p(pytest.mark.slow(test))


UNIT = np.asarray(A.STATE_UNIT)
RATE = A.TIME_UNIT_S / UNIT  # d(scaled state)/d(scaled time) per SI rate
DAMPED = {"tread.lateral_damping_ns_per_m": 40.0}  # cycles whose sliding velocity reverses
PARAM_SETS = [Params(), with_updates(Params(), {**DAMPED, "friction.stribeck_exponent": 1.5})]


# -- the equations handed to AUTO (no AUTO needed) -------------------------------------
states = st.tuples(
    st.floats(-3.0, 3.0),  # x - x_eq [mm]
    st.floats(-0.6, 0.6),  # x' [m/s]
    st.floats(-3.0, 3.0),  # z - z_eq [mm]
)


@settings(max_examples=60, deadline=None)
@given(which=st.sampled_from([0, 1]), speed_kmh=st.floats(20.0, 300.0), offset=states)
def test_auto_equations_equal_the_kernel(which, speed_kmh, offset):
    params = PARAM_SETS[which]
    p = MODEL.pack(params)
    V = kmh_to_ms(speed_kmh)
    u = MODEL.equilibrium(V, p) + np.asarray(offset) * UNIT
    slide = V * math.sin(p[MODEL.param_names.index("toe")]) - u[1]
    scaled = u / UNIT

    # in AUTO's units every term is O(1) (or larger): compare to 1e-12 of that
    rhs = np.array(A.auto_rhs(p)(scaled, [V]))
    np.testing.assert_allclose(rhs, RATE * MODEL.f(u, V, p), rtol=1e-12, atol=1e-12)

    if abs(slide) < 1e-9:  # not differentiable at v_r = 0
        return
    d_state, d_par = A.auto_jacobian(p, [A.SPEED_INDEX, 11])(scaled, [V])
    expected = RATE[:, None] * MODEL.jacobian(u, V, p) * UNIT[None, :]
    np.testing.assert_allclose(np.array(d_state), expected, rtol=1e-12, atol=1e-12 * np.abs(expected).max())
    d_par = np.array(d_par)
    np.testing.assert_allclose(d_par[:, 0], RATE * MODEL.df_dspeed(u, V, p), rtol=1e-12, atol=1e-14)
    assert np.all(d_par[:, 1] == 0.0)  # the period is AUTO's own unknown


@pytest.mark.parametrize("which", [0, 1])
@pytest.mark.parametrize("slide_sign", [1.0, -1.0])
def test_auto_jacobian_matches_finite_differences_of_auto_rhs(which, slide_sign):
    p = MODEL.pack(PARAM_SETS[which])
    V = kmh_to_ms(110.0)
    drive = V * math.sin(p[MODEL.param_names.index("toe")])
    scaled = np.array([0.4, drive - slide_sign * 0.1, 1.1])  # v_r = slide_sign * 0.1 m/s
    func, jac = A.auto_rhs(p), A.auto_jacobian(p, [A.SPEED_INDEX])
    d_state, d_par = (np.array(m) for m in jac(scaled, [V]))
    h = 1e-6
    for j in range(3):
        step = np.zeros(3)
        step[j] = h
        central = (np.array(func(scaled + step, [V])) - np.array(func(scaled - step, [V]))) / (2 * h)
        np.testing.assert_allclose(d_state[:, j], central, rtol=1e-6, atol=1e-6 * np.abs(d_state).max())
    central = (np.array(func(scaled, [V + h])) - np.array(func(scaled, [V - h]))) / (2 * h)
    np.testing.assert_allclose(d_par[:, 0], central, rtol=1e-6, atol=1e-9)


def _stored_orbit(f, ntst, ncol, mesh):
    """An orbit stored as AUTO does: ncol + 1 equispaced values per mesh interval."""
    t = np.concatenate([np.linspace(a, b, ncol + 1)[:-1] for a, b in zip(mesh[:-1], mesh[1:])] + [[1.0]])
    return f(t)


def test_orbit_extremes_are_exact_for_the_collocation_polynomial():
    rng = np.random.default_rng(7)
    mesh = np.sort(np.concatenate([[0.0, 1.0], rng.uniform(0, 1, 7)]))
    ncol = 4
    coeffs = rng.normal(size=ncol + 1)

    def quartic(t):  # degree ncol: reproduced exactly by every interval's polynomial
        return np.polyval(coeffs, t)[:, None]

    low, high = A.orbit_extremes(_stored_orbit(quartic, len(mesh) - 1, ncol, mesh), ncol)
    fine = quartic(np.linspace(0, 1, 2_000_001))
    np.testing.assert_allclose([low[0], high[0]], [fine.min(), fine.max()], rtol=1e-10)


def test_orbit_extremes_find_peaks_between_stored_points():
    ncol, ntst = 4, 20
    mesh = np.linspace(0, 1, ntst + 1)

    def wave(t):
        return np.stack([np.sin(2 * np.pi * t + 0.3), 2 * np.cos(2 * np.pi * t + 0.1)], axis=1)

    stored = _stored_orbit(wave, ntst, ncol, mesh)
    low, high = A.orbit_extremes(stored, ncol)
    # what is left is the interpolation error of degree-4 pieces of width 0.05
    np.testing.assert_allclose(high, [1.0, 2.0], rtol=1e-6)
    np.testing.assert_allclose(low, [-1.0, -2.0], rtol=1e-6)
    assert stored[:, 0].max() < 1.0 - 1e-5  # the stored points alone miss the peak
    with pytest.raises(ValueError, match="ntst"):
        A.orbit_extremes(stored[:-1], ncol)


def test_scratch_directory_is_removed_even_after_an_error():
    before = tempfile.tempdir
    with pytest.raises(RuntimeError):
        with A._scratch_directory() as scratch:
            assert tempfile.gettempdir() == scratch
            Path(tempfile.mkdtemp(prefix="bifpy-"), "fort.7").write_text("x")
            raise RuntimeError("AUTO failed")
    assert not Path(scratch).exists()
    assert tempfile.tempdir == before


def test_settings_are_validated():
    with pytest.raises(ValueError, match="ncol"):
        A.AutoSettings(ncol=8)
    with pytest.raises(ValueError, match="dsmin"):
        A.AutoSettings(ds=10.0)
    fine = A.AutoSettings().refined()
    assert fine.ntst == 2 * A.AutoSettings().ntst and fine.epsu < A.AutoSettings().epsu


# -- independent references ------------------------------------------------------------
def eigen_hopf_speeds(params, speed_range_kmh=(20.0, 300.0), samples=400):
    """Hopf speeds [km/h] and frequencies [Hz]: Brent's method on the largest real part
    of the eigenvalues of the kernel Jacobian at the closed-form equilibrium."""
    p = MODEL.pack(params)

    def leading(V):
        eig = np.linalg.eigvals(MODEL.jacobian(MODEL.equilibrium(V, p), V, p))
        pair = eig[np.abs(eig.imag) > 1e-9]
        return pair[np.argmax(pair.real)]

    grid = np.linspace(*kmh_to_ms(np.asarray(speed_range_kmh)), samples)
    growth = np.array([leading(V).real for V in grid])
    out = []
    for a, b, ga, gb in zip(grid[:-1], grid[1:], growth[:-1], growth[1:]):
        if ga * gb < 0:
            V = brentq(lambda v: leading(v).real, a, b, xtol=1e-13, rtol=1e-15)
            out.append((ms_to_kmh(V), abs(leading(V).imag) / (2 * np.pi)))
    return out


def radau_amplitude(params, periods=25, measured=5, rtol=1e-10):
    """Half peak-to-peak of x on the attractor reached from the equilibrium kicked by
    x' = 0.2 m/s, at the operating speed: scipy Radau, the last ``measured`` periods."""
    p = MODEL.pack(params)
    V = kmh_to_ms(params.operating.speed_kmh)
    start = MODEL.equilibrium(V, p) + np.array([0.0, 0.2, 0.0])
    guess = 1.0 / 140.0  # a rough period [s], only to size the run
    solution = solve_ivp(
        lambda t, u: MODEL.f(u, V, p), (0.0, periods * guess), start, method="Radau",
        rtol=rtol, atol=[1e-15, 1e-12, 1e-15], jac=lambda t, u: MODEL.jacobian(u, V, p),
        dense_output=True,
    )  # fmt: skip
    assert solution.status == 0
    x = solution.sol(np.linspace((periods - measured) * guess, periods * guess, 100_001))[0]
    return 0.5 * (x.max() - x.min())


# -- AUTO-07p's own results ------------------------------------------------------------
@pytest.fixture(scope="module")
def default_diagram():
    return A.tread1dof_diagram(Params(), (20.0, 300.0))


@needs_auto
def test_hopf_speeds_equal_the_eigenvalue_crossings(default_diagram):
    reference = eigen_hopf_speeds(Params())
    assert len(default_diagram["hopf"]) == len(reference) == 2
    for hopf, (speed, frequency) in zip(default_diagram["hopf"], reference):
        assert hopf["speed_kmh"] == pytest.approx(speed, rel=1e-6)
        assert hopf["frequency_hz"] == pytest.approx(frequency, rel=1e-6)


@needs_auto
def test_equilibrium_stability_agrees_with_eigenvalues(default_diagram):
    p = MODEL.pack(Params())
    hopf = [h["speed_kmh"] for h in default_diagram["hopf"]]
    eq = default_diagram["equilibrium"]
    checked = 0
    for speed, stable in zip(eq["speed_kmh"], eq["stable"]):
        if min(abs(speed - h) for h in hopf) < 1e-3 * speed:
            continue  # at a Hopf point the answer is a matter of rounding
        V = kmh_to_ms(speed)
        growth = np.linalg.eigvals(MODEL.jacobian(MODEL.equilibrium(V, p), V, p)).real.max()
        assert stable == (growth < 0), speed
        checked += 1
    assert checked > 20


@needs_auto
def test_cycle_amplitude_at_operating_speed_equals_long_time_integration(default_diagram):
    cycles = default_diagram["operating_point"]["cycles"]
    assert default_diagram["operating_point"]["speed_kmh"] == 110.0
    assert len(cycles) == 1 and cycles[0]["stable"]
    assert cycles[0]["min_sliding_velocity_m_per_s"] > 0  # v_r keeps its sign here
    assert cycles[0]["amplitude"]["x"] == pytest.approx(radau_amplitude(Params()), rel=1e-3)


@needs_auto
def test_a_fold_of_cycles_lies_above_the_upper_hopf_speed(default_diagram):
    upper = max(h["speed_kmh"] for h in default_diagram["hopf"])
    folds = [f for f in default_diagram["folds"] if f["speed_kmh"] > upper]
    assert len(folds) == 1
    fold = folds[0]
    assert upper < fold["speed_kmh"] < 300.0
    assert fold["amplitude_x_m"] > 0 and fold["period_s"] > 0
    # stable and unstable cycles meet there: stability changes across the fold
    branch = default_diagram["cycles"][0]
    speed = np.array(branch["speed_kmh"])
    turn = int(np.argmax(speed))
    assert speed[turn] == pytest.approx(fold["speed_kmh"], rel=1e-3)
    assert all(branch["stable"][turn - 5 : turn - 1]) and not any(branch["stable"][turn + 2 : turn + 6])


@needs_auto
def test_cycle_branch_joins_the_two_hopf_points(default_diagram):
    assert len(default_diagram["cycles"]) == 1  # the branch from the lower Hopf point reached the upper
    branch = default_diagram["cycles"][0]
    low, high = (h["speed_kmh"] for h in default_diagram["hopf"])
    assert branch["from_hopf_kmh"] == low and branch["ended"] == "hopf"
    assert branch["end_speed_kmh"] == pytest.approx(high, rel=1e-5)
    assert min(branch["min_sliding_velocity_m_per_s"]) > 0  # v_r > 0 on the default branch
    json.dumps(default_diagram, allow_nan=False)


@needs_auto
def test_refinement_moves_the_numbers_far_less_than_1e_4(default_diagram):
    base = A.headline_numbers(default_diagram)
    fine = A.headline_numbers(A.tread1dof_diagram(Params(), (20.0, 300.0), A.AutoSettings().refined()))
    assert base.keys() == fine.keys() and len(base) == 9
    for key in base:
        assert base[key] == pytest.approx(fine[key], rel=1e-5), key


@needs_auto
def test_auto_copes_with_sliding_velocity_reversal():
    params = with_updates(Params(), DAMPED)
    diagram = A.tread1dof_diagram(params, (20.0, 150.0))
    (cycle,) = diagram["operating_point"]["cycles"]
    assert cycle["min_sliding_velocity_m_per_s"] < -0.01  # v_r changes sign twice a period
    assert diagram["cycles"][0]["ended"] == "speed_range"
    assert cycle["amplitude"]["x"] == pytest.approx(radau_amplitude(params, rtol=1e-9), rel=1e-4)
