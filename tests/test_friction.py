"""LuGre physics (property tests), static curve, hysteresis loops, fitting, friction CLI."""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from polywear.friction import (
    STEADY_PARAMETERS,
    FrictionDataError,
    bristle_response,
    LOOP_COLUMNS,
    LoopSettings,
    falling_branch,
    fit_loops,
    fit_steady_curve,
    hysteresis_loops,
    read_loops_csv,
    read_steady_csv,
    sample_path,
    steady_curve,
    steady_friction_jacobian,
    synthetic_steady_data,
)
from polywear.params import Friction, load_params
from polywear.physics.lugre import (
    bristle_decay_rate,
    bristle_rate,
    bristle_rate_partials,
    friction_coefficient,
    real_abs,
    real_sign,
    steady_deflection,
    steady_friction,
    steady_friction_slope,
    stribeck,
    stribeck_dv,
)

from .cli_runner import run_main

ROOT = Path(__file__).resolve().parents[1]
FAST = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
SLOWISH = settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@st.composite
def frictions(draw) -> Friction:
    """Valid friction sets over wide, physically sensible ranges."""
    mu_s = draw(st.floats(0.05, 2.0))
    return Friction(
        sigma0_per_m=draw(st.floats(10.0, 1e4)),
        sigma1_s_per_m=draw(st.floats(0.0, 0.2)),
        sigma2_s_per_m=draw(st.floats(0.0, 0.02)),
        mu_static=mu_s,
        mu_coulomb=draw(st.floats(0.05, mu_s)),  # from the bound of friction.mu_coulomb to mu_s
        stribeck_velocity_m_per_s=draw(st.floats(0.01, 2.0)),
        stribeck_exponent=draw(st.floats(1.0, 4.0)),
    )


def g_of(f: Friction, v):
    return stribeck(v, f.mu_static, f.mu_coulomb, f.stribeck_velocity_m_per_s, f.stribeck_exponent)


def steady_args(f: Friction):
    return (f.sigma2_s_per_m, f.mu_static, f.mu_coulomb, f.stribeck_velocity_m_per_s, f.stribeck_exponent)


speeds = st.floats(1e-3, 20.0).flatmap(lambda x: st.sampled_from([x, -x]))


# -- the scalar kernels -----------------------------------------------------------------------


@FAST
@given(x=st.floats(-1e6, 1e6), y=st.floats(-1e6, 1e6))
def test_real_abs_and_sign_act_on_the_real_part(x, y):
    z = complex(x, y)
    a, s = real_abs(z), real_sign(z)
    assert a.real == abs(x)
    assert s == (np.sign(x) if x != 0.0 else 0.0)
    if x != 0.0:
        assert a == s * z  # analytic continuation of |x| = sgn(x) x off the real axis
    assert real_abs(x) == abs(x) and real_sign(x) == np.sign(x)


@FAST
@given(x=st.floats(-1e3, 1e3).filter(lambda x: abs(x) > 1e-9))
def test_real_abs_complex_step_gives_the_sign(x):
    h = 1e-30
    assert real_abs(complex(x, h)).imag / h == np.sign(x)


@FAST
@given(f=frictions(), v=speeds)
def test_stribeck_dv_against_complex_step_and_central_differences(f, v):
    args = (f.mu_static, f.mu_coulomb, f.stribeck_velocity_m_per_s, f.stribeck_exponent)
    exact = stribeck_dv(v, *args)
    scale = (f.mu_static - f.mu_coulomb) / f.stribeck_velocity_m_per_s  # |dG/dv| <~ this
    cs = stribeck(complex(v, 1e-30), *args).imag / 1e-30
    assert abs(cs - exact) <= 1e-12 * scale + 1e-12 * abs(exact)
    h = 1e-6 * min(abs(v), f.stribeck_velocity_m_per_s)
    fd = (stribeck(v + h, *args) - stribeck(v - h, *args)) / (2.0 * h)
    roundoff = 1e-15 * f.mu_static / h
    assert abs(fd - exact) <= 1e-6 * scale + roundoff


@FAST
@given(f=frictions().filter(lambda f: f.stribeck_exponent > 1.0))
def test_stribeck_is_flat_at_zero_for_exponent_above_one(f):
    args = (f.mu_static, f.mu_coulomb, f.stribeck_velocity_m_per_s, f.stribeck_exponent)
    assert stribeck_dv(0.0, *args) == 0.0
    assert stribeck(0.0, *args) == pytest.approx(f.mu_static, rel=1e-15)


@FAST
@given(f=frictions(), v=speeds)
def test_steady_state_is_a_fixed_point_and_gives_steady_friction(f, v):
    z_ss = float(steady_deflection(v, f.sigma0_per_m, *steady_args(f)[1:]))
    g = g_of(f, v)
    assert z_ss == pytest.approx(math.copysign(g, v) / f.sigma0_per_m, rel=1e-14)
    zdot = bristle_rate(v, z_ss, f.sigma0_per_m, g)
    assert abs(zdot) <= 1e-14 * abs(v)
    mu = friction_coefficient(v, z_ss, zdot, f.sigma0_per_m, f.sigma1_s_per_m, f.sigma2_s_per_m)
    assert mu == pytest.approx(float(steady_friction(v, *steady_args(f))), rel=1e-13, abs=1e-15)


@FAST
@given(f=frictions(), v=speeds)
def test_steady_friction_slope(f, v):
    """Slope against central differences and against stribeck_dv + sigma2."""
    slope = float(steady_friction_slope(v, *steady_args(f)))
    assert slope == pytest.approx(stribeck_dv(v, *steady_args(f)[1:]) * np.sign(v) + f.sigma2_s_per_m,
                                  rel=1e-12, abs=1e-15)
    h = 1e-6 * min(abs(v), f.stribeck_velocity_m_per_s)
    mu = lambda x: float(steady_friction(x, *steady_args(f)))  # noqa: E731
    scale = (f.mu_static - f.mu_coulomb) / f.stribeck_velocity_m_per_s + f.sigma2_s_per_m
    roundoff = 1e-15 * abs(mu(v)) / h
    assert abs((mu(v + h) - mu(v - h)) / (2 * h) - slope) <= 1e-6 * scale + roundoff


@FAST
@given(f=frictions(), v=speeds, start=st.floats(-3.0, 3.0))
def test_bristle_rate_partials_against_complex_step(f, v, start):
    """d(dz/dt)/dv (through G(v) too) and d(dz/dt)/dz, as the models' Jacobians use them."""
    args = (f.mu_static, f.mu_coulomb, f.stribeck_velocity_m_per_s, f.stribeck_exponent)
    z = start * f.mu_static / f.sigma0_per_m
    h = 1e-30
    rate = lambda v_, z_: bristle_rate(v_, z_, f.sigma0_per_m, stribeck(v_, *args))  # noqa: E731
    d_dv, d_dz = bristle_rate_partials(v, z, f.sigma0_per_m, stribeck(v, *args), stribeck_dv(v, *args))
    assert d_dv == pytest.approx(rate(complex(v, h), complex(z)).imag / h, rel=1e-12, abs=1e-12)
    assert d_dz == pytest.approx(rate(complex(v), complex(z, h)).imag / h, rel=1e-12)
    assert d_dz == -bristle_decay_rate(v, f.sigma0_per_m, stribeck(v, *args))


# -- bristle dynamics ---------------------------------------------------------------------------


@SLOWISH
@given(f=frictions(), v=speeds, start=st.floats(-10.0, 10.0))
def test_bristle_reaches_steady_state_from_any_start(f, v, start):
    """At constant v the ODE is linear: z(t) = z_ss + (z0 - z_ss) exp(-a t), a = sigma0 |v| / G."""
    g = g_of(f, v)
    a = bristle_decay_rate(v, f.sigma0_per_m, g)
    z_ss = math.copysign(g, v) / f.sigma0_per_m
    z0 = start * f.mu_static / f.sigma0_per_m
    t = np.linspace(0.0, 30.0 / a, 61)
    r = bristle_response(f, lambda time: v + 0.0 * np.asarray(time), t, z0)
    closed = z_ss + (z0 - z_ss) * np.exp(-a * t)
    scale = f.mu_static / f.sigma0_per_m * max(1.0, abs(start))
    assert np.max(np.abs(r.deflection - closed)) <= 1e-7 * scale
    assert np.allclose(r.memory, np.exp(-a * t), rtol=1e-7, atol=1e-12)
    assert r.deflection[-1] == pytest.approx(z_ss, rel=1e-8, abs=1e-9 * scale)
    assert r.mu[-1] == pytest.approx(float(steady_friction(v, *steady_args(f))), rel=1e-6, abs=1e-9)


@st.composite
def bounded_velocities(draw):
    """v(t) = c + sum of three sinusoids [m/s]; |v| <= 3 m/s, up to 10 Hz."""
    c = draw(st.floats(-1.0, 1.0))
    amps = draw(st.lists(st.floats(0.0, 0.7), min_size=3, max_size=3))
    freqs = draw(st.lists(st.floats(0.2, 10.0), min_size=3, max_size=3))
    phases = draw(st.lists(st.floats(0.0, 2 * np.pi), min_size=3, max_size=3))

    def v(t):
        t = np.asarray(t, dtype=float)
        return c + sum(A * np.sin(2 * np.pi * w * t + p) for A, w, p in zip(amps, freqs, phases))

    return v


@SLOWISH
@given(f=frictions(), v=bounded_velocities(), start=st.floats(-1.0, 1.0))
def test_bristle_stays_bounded_when_it_starts_inside(f, v, start):
    """|z0| <= mu_s/sigma0 implies |z(t)| <= mu_s/sigma0 (G <= mu_s; Canudas de Wit et al. 1995)."""
    bound = f.mu_static / f.sigma0_per_m
    t = np.linspace(0.0, 0.6, 1201)
    r = bristle_response(f, v, t, start * bound, rtol=1e-8, max_step=5e-3)
    assert np.max(np.abs(r.deflection)) <= bound * (1.0 + 1e-6)


@SLOWISH
@given(f=frictions(), v=bounded_velocities(), start=st.floats(1.5, 20.0).flatmap(lambda x: st.sampled_from([x, -x])))
def test_bristle_outside_the_bound_never_grows(f, v, start):
    """While |z| > mu_s/sigma0, d|z|/dt < 0: the largest |z| is the initial one."""
    bound = f.mu_static / f.sigma0_per_m
    t = np.linspace(0.0, 0.5, 1001)
    r = bristle_response(f, v, t, start * bound, rtol=1e-8, max_step=5e-3)
    outside = np.abs(r.deflection) > bound
    assert np.all(np.diff(np.abs(r.deflection))[outside[:-1] & outside[1:]] <= 1e-7 * bound)


# -- static curve -----------------------------------------------------------------------------


def test_steady_curve_is_odd_and_matches_the_closed_form():
    f = Friction()
    v = np.linspace(-2.0, 2.0, 101)
    c = steady_curve(f, v)
    g = f.mu_coulomb + (f.mu_static - f.mu_coulomb) * np.exp(-np.abs(v / f.stribeck_velocity_m_per_s) ** 2)
    assert np.allclose(c.mu, np.sign(v) * g + f.sigma2_s_per_m * v, rtol=1e-14, atol=1e-15)
    assert np.allclose(c.mu, -c.mu[::-1], atol=1e-15)


@FAST
@given(f=frictions())
def test_falling_branch_bounds_the_negative_slope(f):
    branch = falling_branch(f)
    v = np.geomspace(1e-6, 1e3, 4000) * f.stribeck_velocity_m_per_s
    slope = steady_friction_slope(v, *steady_args(f))
    if branch is None:
        assert np.all(slope >= -1e-12 * np.abs(slope).max())
        return
    lo, hi = branch
    inside = (v > lo * (1 + 1e-9)) & (v < hi * (1 - 1e-9))
    resolved = (v / f.stribeck_velocity_m_per_s) ** f.stribeck_exponent < 700.0  # exp(-x) > 0 in floats
    assert np.all(slope[inside & resolved] < 0.0) and np.all(slope[inside] <= 0.0)
    assert np.all(slope[v < lo * (1 - 1e-9)] >= 0.0)
    if math.isfinite(hi):
        assert np.all(slope[v > hi * (1 + 1e-9)] >= 0.0)
        assert steady_friction_slope(hi, *steady_args(f)) == pytest.approx(0.0, abs=1e-9 * f.mu_static / f.stribeck_velocity_m_per_s)
    else:
        assert f.sigma2_s_per_m == 0.0


def test_falling_branch_default_contains_the_operating_sliding_velocity():
    # default: V sin(toe) = 110/3.6 * sin(0.5 deg) = 0.2666 m/s (docs/model.md sections 3 and 6)
    lo, hi = falling_branch(Friction())
    assert lo < 110 / 3.6 * math.sin(math.radians(0.5)) < hi


# -- hysteresis loops ------------------------------------------------------------------------


def first_order_deviation(f: Friction, loops, i):
    """Quasi-static expansion: mu - mu_ss = (sigma1 - G/|v|) (G'/sigma0) dv/dt + O(f^2)."""
    v = loops.velocity[i]
    vdot = loops.v_amplitude * 2 * np.pi * loops.frequencies_hz[i] * np.cos(loops.phase)
    args = (f.mu_static, f.mu_coulomb, f.stribeck_velocity_m_per_s, f.stribeck_exponent)
    g = np.array([stribeck(x, *args) for x in v])
    dg = np.array([stribeck_dv(x, *args) for x in v])
    return (f.sigma1_s_per_m - g / np.abs(v)) * dg / f.sigma0_per_m * vdot


def test_loops_collapse_onto_the_static_curve_at_low_frequency():
    f = Friction()
    loops = hysteresis_loops(f, 0.4, 0.25, [0.5, 0.05, 0.005], settings=LoopSettings(points_per_period=120))
    dev = loops.max_deviation
    assert dev[0] > 1e-3  # visibly open at 0.5 Hz ...
    assert np.all(np.diff(dev) < 0) and dev[2] < 1e-4  # ... and closing as f -> 0
    assert dev[0] / dev[1] == pytest.approx(10.0, rel=0.02)  # deviation proportional to f
    for i in range(3):
        pred = first_order_deviation(f, loops, i)
        err = np.max(np.abs(loops.mu[i] - loops.steady_mu[i] - pred))
        assert err <= 0.2 * (loops.frequencies_hz[i] / 0.5) * np.abs(pred).max()  # O(f^2)
    assert np.all(loops.periodicity_error < 1e-9)


@SLOWISH
@given(f=frictions(), v_mean=st.floats(0.05, 3.0), ratio=st.floats(0.1, 0.8))
def test_loops_follow_the_quasi_static_expansion(f, v_mean, ratio):
    """For any friction set, a slow loop (f << sigma0 |v| / G / 2 pi) hugs the static curve."""
    v_amp = ratio * v_mean
    v_min = v_mean - v_amp
    slowest_rate = f.sigma0_per_m * v_min / f.mu_static  # smallest decay rate a [1/s]
    # the expansion is in (d/dt of ln of the lag) / a; v(t) sweeps G's features (scale v_s,
    # and v_min for the a^(delta-1) terms) at speed v_amp omega
    stretch = 1.0 + v_amp * f.stribeck_exponent * (1.0 / f.stribeck_velocity_m_per_s + 1.0 / v_min)
    freq = 1e-3 * slowest_rate / (2 * np.pi * stretch)
    loops = hysteresis_loops(f, v_mean, v_amp, [freq], settings=LoopSettings(points_per_period=64))
    pred = first_order_deviation(f, loops, 0)
    err = np.max(np.abs(loops.mu[0] - loops.steady_mu[0] - pred))
    # the loop is integrated to 1e-9 mu_s in mu (LoopSettings.atol): a deviation below 20 times
    # that (a flat curve, mu_s ~ mu_c) cannot show a 5 % error of the expansion
    assume(np.abs(pred).max() > 20e-9 * f.mu_static)
    assert err <= 0.05 * np.abs(pred).max()


def test_loops_approach_the_frozen_bristle_limit_at_high_frequency():
    """f -> inf: z freezes at zbar = <v>/<a> (zero mean rate) and mu = sigma0 zbar + sigma1 (v - a zbar) + sigma2 v."""
    f = Friction()
    v_mean, v_amp = 0.3, 0.2
    errors = []
    for freq in (1e3, 1e4):
        loops = hysteresis_loops(f, v_mean, v_amp, [freq], settings=LoopSettings(points_per_period=256))
        v = loops.velocity[0]
        a = np.array([bristle_decay_rate(x, f.sigma0_per_m, g_of(f, x)) for x in v])
        zbar = np.mean(v) / np.mean(a)
        limit = f.sigma0_per_m * zbar + f.sigma1_s_per_m * (v - a * zbar) + f.sigma2_s_per_m * v
        errors.append(np.max(np.abs(loops.mu[0] - limit)))
    assert errors[1] < 0.15 * errors[0] and errors[1] < 2e-3  # O(1/f)


def plain_lugre_rhs(f: Friction, velocity):
    """An independent NumPy transcription of docs/model.md section 2 (no polywear kernels)."""

    def rhs(t, z):
        v = velocity(t)
        g = f.mu_coulomb + (f.mu_static - f.mu_coulomb) * np.exp(-np.abs(v / f.stribeck_velocity_m_per_s) ** f.stribeck_exponent)
        return v - f.sigma0_per_m * np.abs(v) * z / g

    return rhs


@pytest.mark.parametrize("v_mean, v_amp, freq", [(0.267, 0.2, 50.0), (0.0, 0.5, 20.0), (0.1, 0.3, 200.0)])
def test_periodic_loop_equals_brute_force_transient_integration(v_mean, v_amp, freq):
    """Second method: run DOP853 on an independent rhs from z = 0 until the transient is gone."""
    f = Friction()
    loops = hysteresis_loops(f, v_mean, v_amp, [freq], settings=LoopSettings(points_per_period=100))
    velocity = lambda t: v_mean + v_amp * np.sin(2 * np.pi * freq * t)  # noqa: E731
    period = 1.0 / freq
    n = 60  # periods: the memory exp(-int a dt) is < 1e-12 by then for these cases
    assert loops.periodicity_error[0] < 1e-9
    t_last = (n - 1) * period + loops.phase / (2 * np.pi * freq)
    sol = solve_ivp(plain_lugre_rhs(f, velocity), (0.0, n * period), [0.0], method="DOP853",
                    t_eval=t_last, rtol=1e-12, atol=1e-15)
    scale = f.mu_static / f.sigma0_per_m
    assert np.max(np.abs(sol.y[0] - loops.deflection[0])) <= 1e-7 * scale
    if v_mean == 0.0:  # the stick-through-zero case: v_r changes sign on the loop
        assert loops.velocity[0].min() < 0.0 < loops.velocity[0].max()


def test_zero_crossing_loop_is_odd_symmetric():
    """v_mean = 0: half a period later v -> -v, so mu -> -mu (the model is odd)."""
    loops = hysteresis_loops(Friction(), 0.0, 0.5, [5.0], settings=LoopSettings(points_per_period=200))
    assert np.any(loops.velocity[0] < 0) and np.any(loops.velocity[0] > 0)
    mu = loops.mu[0]
    assert np.allclose(mu[100:], -mu[:100], atol=1e-9)


def test_loops_open_with_frequency_and_close_again_when_the_bristle_freezes():
    loops = hysteresis_loops(Friction(), 0.267, 0.2, [0.5, 5.0, 50.0, 1000.0],
                             settings=LoopSettings(points_per_period=200))
    assert np.all(np.diff(loops.max_deviation) > 0)
    assert loops.area[0] < 0.2 * loops.area[1]
    assert loops.area[3] < 0.2 * loops.area[2]  # fast limit: a curve without area


@pytest.mark.parametrize("kwargs", [
    {"frequencies_hz": []}, {"frequencies_hz": [0.0]}, {"frequencies_hz": [np.nan]},
    {"v_amplitude": 0.0}, {"v_amplitude": -1.0}, {"v_mean": np.inf},
])
def test_loops_reject_bad_input(kwargs):
    args = {"v_mean": 0.3, "v_amplitude": 0.1, "frequencies_hz": [1.0], **kwargs}
    with pytest.raises(ValueError):
        hysteresis_loops(Friction(), **args)


def test_loop_result_saves_and_plots(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import xarray as xr

    loops = hysteresis_loops(Friction(), 0.267, 0.2, [0.5, 50.0], settings=LoopSettings(points_per_period=50))
    path = loops.save(tmp_path / "loops.nc")
    ds = xr.open_dataset(path, engine="h5netcdf")
    assert np.array_equal(ds["mu"].values, loops.mu)
    assert "sigma0_per_m = 400.0" in ds.attrs["friction_toml"]
    ds.close()
    artists = loops.plot()
    assert len(artists) == 3  # static curve + two loops
    json.dumps(loops.summary(), allow_nan=False)


# -- fitting ----------------------------------------------------------------------------------

TRUE = Friction(mu_static=1.0, mu_coulomb=0.6, stribeck_velocity_m_per_s=0.3, stribeck_exponent=1.5,
                sigma2_s_per_m=0.004)
V_DATA = np.concatenate([np.geomspace(0.01, 5.0, 40), -np.geomspace(0.02, 3.0, 15)])


@FAST
@given(f=frictions(), v=st.floats(0.01, 5.0))
def test_steady_friction_jacobian_against_central_differences(f, v):
    jac = steady_friction_jacobian(np.array([v, -v]), f)
    for j, name in enumerate(STEADY_PARAMETERS):
        x = getattr(f, name)
        h = 1e-6 * max(abs(x), 1e-3)
        up = Friction.model_construct(**{**f.model_dump(), name: x + h})
        down = Friction.model_construct(**{**f.model_dump(), name: x - h})
        fd = (steady_friction(v, *steady_args(up)) - steady_friction(v, *steady_args(down))) / (2 * h)
        assert jac[0, j] == pytest.approx(fd, rel=1e-5, abs=1e-8)
        assert jac[1, j] == -jac[0, j]


def test_fit_recovers_exact_parameters_from_noise_free_data():
    fit = fit_steady_curve(V_DATA, steady_friction(V_DATA, *steady_args(TRUE)))
    assert fit.converged
    for name in STEADY_PARAMETERS:
        assert fit.value(name) == pytest.approx(getattr(TRUE, name), rel=1e-7)
    assert fit.rms < 1e-9


def test_fit_recovers_parameters_within_reported_intervals():
    mu = synthetic_steady_data(TRUE, V_DATA, noise_sd=0.01, seed=7)
    fit = fit_steady_curve(V_DATA, mu, confidence=0.999)
    assert fit.converged and fit.fitted == STEADY_PARAMETERS
    for name in STEADY_PARAMETERS:
        lo, hi = fit.interval(name)
        assert lo <= getattr(TRUE, name) <= hi, name
        assert 0 < fit.standard_errors[name] < 0.2 * max(getattr(TRUE, name), 0.01)
    assert fit.rms == pytest.approx(0.01, rel=0.25)  # residuals carry the noise, no more
    assert fit.r_squared > 0.99


@pytest.mark.slow
def test_fit_confidence_intervals_have_their_nominal_coverage():
    """Over 200 seeded data sets the 95% intervals contain the truth 95% of the time."""
    n = 200
    hits = np.zeros(len(STEADY_PARAMETERS))
    for seed in range(n):
        fit = fit_steady_curve(V_DATA, synthetic_steady_data(TRUE, V_DATA, 0.01, seed=1000 + seed))
        for j, name in enumerate(STEADY_PARAMETERS):
            lo, hi = fit.interval(name)
            hits[j] += lo <= getattr(TRUE, name) <= hi
    coverage = hits / n
    # binomial(200, 0.95): mean 190, s.d. 3.1; allow -3.2 s.d. / +2.6 s.d.
    assert np.all(coverage >= 0.90) and np.all(coverage <= 0.99), dict(zip(STEADY_PARAMETERS, coverage))


def test_fit_accepts_magnitudes_at_negative_velocity():
    mu = synthetic_steady_data(TRUE, V_DATA, noise_sd=0.01, seed=3)
    signed = fit_steady_curve(V_DATA, mu)
    magnitudes = fit_steady_curve(V_DATA, np.abs(mu))
    assert not signed.magnitudes and magnitudes.magnitudes
    for name in STEADY_PARAMETERS:
        assert magnitudes.value(name) == pytest.approx(signed.value(name), rel=1e-8)


def test_fit_with_fixed_parameters_keeps_them():
    base = Friction(stribeck_exponent=TRUE.stribeck_exponent, sigma2_s_per_m=TRUE.sigma2_s_per_m)
    mu = steady_friction(V_DATA, *steady_args(TRUE))
    fit = fit_steady_curve(V_DATA, mu, base, fit=("mu_static", "mu_coulomb", "stribeck_velocity_m_per_s"))
    assert fit.fitted == ("mu_static", "mu_coulomb", "stribeck_velocity_m_per_s")
    assert fit.value("stribeck_exponent") == TRUE.stribeck_exponent
    assert fit.friction.sigma0_per_m == base.sigma0_per_m
    for name in fit.fitted:
        assert fit.value(name) == pytest.approx(getattr(TRUE, name), rel=1e-7)


def test_fit_of_rising_data_respects_mu_c_below_mu_s_and_flags_unidentifiable():
    v = np.geomspace(0.01, 3.0, 30)
    mu = 0.5 + 0.05 * v  # no Stribeck drop at all
    fit = fit_steady_curve(v, mu)
    assert fit.friction.mu_coulomb <= fit.friction.mu_static
    assert fit.value("sigma2_s_per_m") == pytest.approx(0.05, rel=1e-6)
    json.dumps(fit.summary(), allow_nan=False)  # non-finite errors become null


@FAST
@given(seed=st.integers(0, 2**32 - 1), noise=st.floats(0.0, 0.3))
def test_fit_result_always_satisfies_the_parameter_rules(seed, noise):
    rng = np.random.default_rng(seed)
    v = rng.uniform(0.01, 4.0, 20) * rng.choice([-1, 1], 20)
    mu = synthetic_steady_data(TRUE, v, noise, seed)
    if np.any((v > 0.0) & (mu <= 0.0)):  # noise drove a point against the sliding direction: refused
        with pytest.raises(FrictionDataError, match="mu > 0 where v > 0"):
            fit_steady_curve(v, mu)
        return
    try:
        fit = fit_steady_curve(v, mu)
    except FrictionDataError as exc:  # allowed only for a value driven onto a bound of 0
        assert "valid parameter range" in str(exc)
        return
    Friction.model_validate(fit.friction.model_dump())
    assert 0 < fit.friction.mu_coulomb <= fit.friction.mu_static <= 5.0
    assert 1.0 <= fit.friction.stribeck_exponent <= 10.0


def test_fit_toml_snippet_pastes_into_a_parameter_file(tmp_path):
    fit = fit_steady_curve(V_DATA, synthetic_steady_data(TRUE, V_DATA, 0.01, seed=5))
    path = tmp_path / "p.toml"
    path.write_text('model = "tread1dof"\n\n' + fit.to_toml())
    assert load_params(path).friction == fit.friction


def test_fit_rejects_bad_arrays():
    with pytest.raises(FrictionDataError, match="NaN"):
        fit_steady_curve([0.1, 0.2, np.nan, 0.4, 0.5, 0.6], np.ones(6))
    with pytest.raises(FrictionDataError, match="v = 0"):
        fit_steady_curve([0.0, 0.2, 0.3, 0.4, 0.5, 0.6], np.ones(6))
    with pytest.raises(FrictionDataError, match="points cannot determine"):
        fit_steady_curve([0.1, 0.2, 0.3, 0.4, 0.5], np.ones(5))
    with pytest.raises(ValueError, match="choose from"):
        fit_steady_curve(V_DATA, np.ones(V_DATA.size), fit=("sigma0_per_m",))


# -- fitting loops ----------------------------------------------------------------------------


def independent_loops(f: Friction, v_mean, v_amp, freqs, points, n_periods=40):
    """Measured-like loops from the independent NumPy rhs (DOP853, transient waited out)."""
    rows = []
    for freq in freqs:
        velocity = lambda t, w=2 * np.pi * freq: v_mean + v_amp * np.sin(w * t)  # noqa: E731
        t_last = (n_periods - 1 + np.arange(points) / points) / freq
        rhs = plain_lugre_rhs(f, velocity)
        sol = solve_ivp(rhs, (0.0, n_periods / freq), [0.0], method="DOP853", t_eval=t_last, rtol=1e-12, atol=1e-15)
        v, z = velocity(t_last), sol.y[0]
        zdot = np.array([rhs(t, zz) for t, zz in zip(t_last, z)])
        mu = f.sigma0_per_m * z + f.sigma1_s_per_m * zdot + f.sigma2_s_per_m * v
        rows.append((np.full(points, freq), t_last, v, mu))
    return [np.concatenate(col) for col in zip(*rows)]


@pytest.mark.slow
def test_loop_fit_recovers_sigma0_and_sigma1_from_independent_loops():
    """Noise-free loops from the independent integration: the fit must land on the truth."""
    true = Friction(sigma0_per_m=150.0, sigma1_s_per_m=0.06)
    freq, t, v, mu = independent_loops(true, 0.3, 0.2, [3.0, 40.0], points=40)
    fit = fit_loops(freq, t, v, mu, Friction())  # static keys are the defaults, as in `true`
    assert fit.converged
    assert fit.value("sigma0_per_m") == pytest.approx(150.0, rel=1e-5)
    assert fit.value("sigma1_s_per_m") == pytest.approx(0.06, rel=1e-4)
    assert fit.rms < 1e-6


def test_fourier_velocity_reproduces_a_trigonometric_polynomial():
    from polywear.friction.fits import _fourier_velocity

    t = np.linspace(0.0, 0.5, 37, endpoint=False)
    v = lambda t: 0.3 + 0.2 * np.sin(4 * np.pi * t) - 0.05 * np.cos(12 * np.pi * t + 0.4)  # noqa: E731
    fitted = _fourier_velocity(t, v(t), 2.0, harmonics=3)
    probe = np.linspace(0.0, 1.0, 101)
    assert np.allclose(fitted(probe), v(probe), atol=1e-13)
    assert np.isscalar(float(fitted(0.1)))


@pytest.mark.parametrize("case, fragment", [
    ("too_few", "need at least"),
    ("half_period", "uncovered"),
    ("nan", "NaN"),
])
def test_loop_fit_rejects_unusable_loops(case, fragment):
    freq, t, v, mu = independent_loops(Friction(), 0.3, 0.2, [5.0], points=40, n_periods=5)
    if case == "too_few":
        freq, t, v, mu = freq[::4], t[::4], v[::4], mu[::4]
    elif case == "half_period":
        freq, t, v, mu = freq[:20], t[:20], v[:20], mu[:20]
    else:
        mu[3] = np.nan
    with pytest.raises(FrictionDataError, match=fragment):
        fit_loops(freq, t, v, mu)


def test_loops_csv_errors_through_the_cli(tmp_path):
    path = tmp_path / "loops.csv"
    path.write_text("frequency_hz,time_s,friction_coefficient\n1,0,0.5\n")
    code, out, err = run_main(["friction", "fit-loops", str(path)])
    assert code == 2 and out == "" and err.count("\n") == 1 and "sliding_velocity_m_per_s" in err
    path.write_text(",".join(LOOP_COLUMNS) + "\n0,0,0.3,0.5\n")
    with pytest.raises(FrictionDataError, match="must be > 0"):
        read_loops_csv(path)


# -- data files -------------------------------------------------------------------------------


@pytest.mark.parametrize("kind, name, reader", [("steady", "friction_sample.csv", read_steady_csv),
                                                ("loops", "friction_loops_sample.csv", read_loops_csv)])
def test_sample_files_are_what_the_docs_recipes_make(kind, name, reader, tmp_path, monkeypatch):
    """docs/friction.md holds the recipe of each shipped sample; run it and compare."""
    doc = (ROOT / "docs" / "friction.md").read_text()
    blocks = [b for b in re.findall(r"```python\n(.*?)```", doc, re.S) if f'open("{name}"' in b]
    assert len(blocks) == 1
    monkeypatch.chdir(tmp_path)
    exec(compile(blocks[0], "docs/friction.md", "exec"), {})
    for new, old in zip(reader(tmp_path / name), reader(sample_path(kind))):
        assert np.array_equal(new, old)


def recipe_truth(name: str) -> Friction:
    """The ``true = Friction(...)`` of the docs recipe that writes ``name``."""
    doc = (ROOT / "docs" / "friction.md").read_text()
    block = next(b for b in re.findall(r"```python\n(.*?)```", doc, re.S) if f'open("{name}"' in b)
    made = re.search(r"true = Friction\((.*?)\)\n", block, re.S).group(1)
    return eval(f"Friction({made})", {"Friction": Friction})


def test_fit_of_the_sample_brackets_the_parameters_it_was_made_from():
    true = recipe_truth("friction_sample.csv")
    v, mu = read_steady_csv(sample_path())
    fit = fit_steady_curve(v, mu, confidence=0.999)
    for name in STEADY_PARAMETERS:
        lo, hi = fit.interval(name)
        assert lo <= getattr(true, name) <= hi, name


@pytest.mark.slow
def test_loop_fit_of_the_loops_sample_brackets_sigma0_and_sigma1(tmp_path):
    true = recipe_truth("friction_loops_sample.csv")
    out = tmp_path / "fitted.toml"
    code, stdout, err = run_main(["friction", "fit-loops", "--sample", "--confidence", "0.999", "--json",
                                  "--out", str(out)])
    assert code == 0, err
    summary = json.loads(stdout)
    assert summary["converged"]
    for name in ("sigma0_per_m", "sigma1_s_per_m"):
        row = summary["parameters"][name]
        lo, hi = row["interval"]
        assert lo <= getattr(true, name) <= hi, name
        assert getattr(load_params(out).friction, name) == row["value"]


BAD_CSV = {
    "missing_column": ("sliding_velocity_m_per_s,mu\n0.1,0.9\n", "missing column"),
    "non_numeric": ("sliding_velocity_m_per_s,friction_coefficient\n0.1,0.9\n0.2,abc\n", "line 3"),
    "nan": ("sliding_velocity_m_per_s,friction_coefficient\n0.1,0.9\n0.2,nan\n", "not finite"),
    "zero_velocity": ("sliding_velocity_m_per_s,friction_coefficient\n0.0,0.9\n", "= 0"),
    "ragged": ("sliding_velocity_m_per_s,friction_coefficient\n0.1,0.9,7\n", "3 fields"),
    "empty": ("# nothing\n", "empty"),
    "too_few": ("sliding_velocity_m_per_s,friction_coefficient\n0.1,0.9\n0.2,0.8\n0.3,0.7\n", "points cannot"),
}


@pytest.mark.parametrize("case", sorted(BAD_CSV))
def test_bad_csv_is_one_line_error_exit_2(case, tmp_path):
    text, fragment = BAD_CSV[case]
    path = tmp_path / f"{case}.csv"
    path.write_text(text)
    code, out, err = run_main(["friction", "fit", str(path)])
    assert code == 2
    assert out == ""
    assert err.startswith("error: ") and err.count("\n") == 1 and fragment in err, err
    if case != "too_few":
        with pytest.raises(FrictionDataError):
            read_steady_csv(path)


def test_csv_extra_columns_comments_and_column_order(tmp_path):
    path = tmp_path / "d.csv"
    path.write_text("# rig 3\ntemperature_c,friction_coefficient,sliding_velocity_m_per_s\n20,0.9,0.1\n21,-0.8,-0.2\n")
    v, mu = read_steady_csv(path)
    assert v.tolist() == [0.1, -0.2] and mu.tolist() == [0.9, -0.8]


# -- CLI --------------------------------------------------------------------------------------


def test_cli_curve_json():
    code, out, _ = run_main(["friction", "curve", "--json", "-s", "operating.toe_deg=1.0"])
    assert code == 0
    summary = json.loads(out)
    v_op = 110 / 3.6 * math.sin(math.radians(1.0))
    assert summary["operating_sliding_velocity_m_per_s"] == pytest.approx(v_op, rel=1e-12)
    assert summary["operating_slope_s_per_m"] == pytest.approx(
        float(steady_friction_slope(v_op, *steady_args(Friction()))), rel=1e-12)
    assert summary["falling_branch_m_per_s"] == pytest.approx(list(falling_branch(Friction())))


def test_cli_loops_plot_out_json(tmp_path):
    code, out, err = run_main(["friction", "loops", "--frequencies", "1,100", "--v-mean", "0.3",
                              "--points", "40", "--plot", str(tmp_path / "l.png"), "--out", str(tmp_path / "l.nc"),
                              "--json"])
    assert code == 0, err
    summary = json.loads(out)
    assert [row["frequency_hz"] for row in summary["loops"]] == [1.0, 100.0]
    assert (tmp_path / "l.png").stat().st_size > 0 and (tmp_path / "l.nc").stat().st_size > 0


def test_cli_fit_sample_writes_a_loadable_parameter_file(tmp_path):
    out_file = tmp_path / "fitted.toml"
    code, out, err = run_main(["friction", "fit", "--sample", "-s", "tread.mass_kg=2", "--out", str(out_file),
                              "--json"])
    assert code == 0, err
    summary = json.loads(out)
    params = load_params(out_file)
    assert params.tread.mass_kg == 2.0  # the rest of the configuration is kept
    for name, row in summary["parameters"].items():
        assert getattr(params.friction, name) == row["value"]
    assert summary["converged"] and summary["n_points"] == 60


def test_cli_fit_fix_and_text_output():
    code, out, _ = run_main(["friction", "fit", "--sample", "--fix", "stribeck_exponent", "-s",
                            "friction.stribeck_exponent=1.6"])
    assert code == 0
    assert re.search(r"stribeck_exponent\s+1\.6\s+\(fixed\)", out)
    assert "[friction]" in out and "rms residual" in out


@pytest.mark.parametrize("args, fragment", [
    (["friction", "fit"], "either a CSV FILE or --sample"),
    (["friction", "fit", "--sample", "--fix", "sigma0_per_m"], "not a fitted key"),
    (["friction", "fit", "--sample", "--out", "x.txt"], ".toml"),
    (["friction", "fit", "/nonexistent/data.csv"], "cannot read"),
    (["friction", "loops", "--frequencies", "5,-1"], "frequencies"),
    (["friction", "curve", "-s", "friction.mu_coulomb=2"], "friction.mu_coulomb"),
])
def test_cli_user_errors(args, fragment):
    code, out, err = run_main(args)
    assert code == 2 and out == ""
    assert err.startswith("error: ") and err.count("\n") == 1 and fragment in err, err


def test_cli_bad_csv_end_to_end_without_traceback(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("v,mu\n1,2\n")
    exe = Path(sys.executable).parent / "polywear"
    proc = subprocess.run([str(exe), "friction", "fit", str(path)], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert proc.stderr.startswith("error: ") and proc.stderr.count("\n") == 1
    assert "Traceback" not in proc.stderr and proc.stdout == ""


@pytest.mark.parametrize(("v", "mu", "fragment"), [
    (-1e9, 0.8, "|v| at most 1000 m/s"),
    (2000.0, 0.8, "|v| at most 1000 m/s"),
    (0.3, 5.0, "0 < |mu| <= 3"),
    (0.3, -3.0, "mu > 0 where v > 0"),
    (0.3, 0.0, "0 < |mu| <= 3"),
])
def test_fit_refuses_points_no_tire_gives(v, mu, fragment, tmp_path):
    velocity = np.append(V_DATA, v)
    values = np.append(synthetic_steady_data(TRUE, V_DATA, 0.0, seed=1), mu)
    with pytest.raises(FrictionDataError, match=re.escape(fragment)):
        fit_steady_curve(velocity, values)
    path = tmp_path / "d.csv"
    path.write_text("sliding_velocity_m_per_s,friction_coefficient\n"
                    + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(velocity, values)))
    code, out, err = run_main(["friction", "fit", str(path)])
    assert code == 2 and out == "" and err.count("\n") == 1 and fragment in err


def test_fit_pinned_at_a_bound_warns():
    """Falling data whose Stribeck exponent would lie above 10: delta stops at its bound 10, with a warning."""
    steep = Friction(mu_static=0.9, mu_coulomb=0.5, stribeck_velocity_m_per_s=0.25, stribeck_exponent=10.0)
    v = np.geomspace(0.01, 2.0, 40)
    mu = synthetic_steady_data(steep, v, 0.0, seed=1)
    mu = np.where(v > 0.25, 0.5 + steep.sigma2_s_per_m * v, mu)  # a step: steeper than any delta
    fit = fit_steady_curve(v, mu)
    assert "stribeck_exponent" in fit.at_bound
    [warning] = [w for w in fit.warnings() if w.startswith("stribeck_exponent")]
    assert "at the bound of the fit" in warning
    assert fit.summary()["warnings"] == fit.warnings()
    clean = fit_steady_curve(V_DATA, synthetic_steady_data(TRUE, V_DATA, 0.0, seed=1))
    assert clean.at_bound == () and clean.warnings() == []


def test_fit_box_is_the_keys_plausibility_bounds():
    """Data from mu_s = 4 seen only beyond the Stribeck velocity (every value <= 1.4, so the
    data check passes): the fit stops at friction.mu_static's bound 3 with a warning, not at
    a box of its own (it used to reach 4 and then fail the key's validation)."""
    from polywear.keys import KEYS

    v = np.geomspace(0.3, 2.0, 40)
    mu = 0.5 + 3.5 * np.exp(-((v / 0.25) ** 2)) + 0.002 * v
    assert mu.max() < 1.4
    fit = fit_steady_curve(v, mu, fit=("mu_static",))
    assert fit.at_bound == ("mu_static",) and fit.friction.mu_static == pytest.approx(KEYS["friction.mu_static"].upper)
    assert fit.warnings()[0].startswith("mu_static = 3 is at the bound of the fit")


@pytest.mark.parametrize("frequencies", ["1e12", "0.5,2e4", "0", "-1"])
def test_loop_frequencies_beyond_a_tire_are_refused(frequencies):
    code, out, err = run_main(["friction", "loops", "--frequencies", frequencies])
    assert code == 2 and out == "" and "(0, 10000] Hz" in err
    with pytest.raises(ValueError, match=r"\(0, 10000\] Hz"):
        hysteresis_loops(Friction(), 0.3, 0.2, [float(f) for f in frequencies.split(",")])
