"""A locked vibration keeps its phase to the profile's harmonic at its order (wear/step.py
``step_rates``/``pinned_step``, wear/windows.py ``continued``): its write there turns with that
harmonic, so a pattern worn across it travels around the tire; the update integrates that
exactly, and the next window starts at the vibration's phase to the turned harmonic."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from polywear.models import model_for
from polywear.models.profile import coupled_model, profile_vector
from polywear.params import Params
from polywear.units import kmh_to_ms
from polywear.wear.evolution import initial_roughness
from polywear.wear.step import pinned_step, update_profile
from polywear.wear.windows import _settle_times, continued, window_wear


@pytest.mark.parametrize("W, x, c", [(1 + 0.5j, 0.3 - 0.8j, 0.4 + 1.2j), (2j, -0.5 + 0.1j, -0.6 - 0.3j),
                                     (1.0 + 0j, 0j, 0.5j), (1.0 + 0j, 2.5 + 0j, -0.2 + 3j)])
def test_pinned_step_against_an_ode_solver(W, x, c):
    """dW/ds = x W + c W/|W| over s in [0, 1]: the closed-form radius and the quadrature of the
    turn against scipy's RK45 at 1e-12."""
    def rhs(_, y):
        w = y[0] + 1j * y[1]
        d = x * w + c * w / abs(w)
        return [d.real, d.imag]

    ref = solve_ivp(rhs, (0.0, 1.0), [W.real, W.imag], rtol=1e-12, atol=1e-14).y[:, -1]
    assert pinned_step(W, x, c)[0] == pytest.approx(ref[0] + 1j * ref[1], abs=1e-10)


def test_pinned_write_that_erases_the_harmonic_is_added_instead():
    """A write against W larger than W itself has no polar solution over the step: added."""
    assert pinned_step(1.0 + 0j, 0j, -2.0 + 0j) is None
    W = np.array([1.0 + 0j, 0.5 + 0j])
    out, added = update_profile(W, np.zeros(2, dtype=complex), np.zeros(2, dtype=complex), np.array([-2.0, 0.0j]))
    assert out[0] == pytest.approx(-1.0) and added[0] == pytest.approx(-2.0) and out[1] == W[1]


@pytest.fixture(scope="module")
def locked_at_120():
    """The default car at 120 km/h with order 8 of the profile at 60 um: the vibration locks
    at order 8 (checked below); three windows settle it on the profile."""
    params = Params()
    base = model_for(params)
    V = float(kmh_to_ms(120.0))
    W = initial_roughness(params)
    W[7] = 60e-6 * np.exp(0.3j)
    u0 = coupled_model(base).equilibrium(V, profile_vector(base, params, V))
    u0[base.index("x")] += 1e-5
    first, nxt, _ = _settle_times(base, params, V)
    win = window_wear(params, V, W, u0, first, 16)
    for _ in range(3):
        win = window_wear(params, V, W, win.end_state, nxt, 16)
    return params, V, W, win, nxt


def test_locked_write_turns_with_the_harmonic_it_locks_to(locked_at_120):
    """Turn W_8 by 1 rad: the window's write at order 8 relative to W_8 stays the same (to 1e-3
    rad and 1e-3 of its size), while relative to the tire it turns by the 1 rad."""
    params, V, W, win, nxt = locked_at_120
    assert win.locked and round(win.order) == 8
    turned = W.copy()
    turned[7] *= np.exp(1j)
    after = window_wear(params, V, turned, continued(win.end_state, win, turned), nxt, 16)
    assert after.locked
    before_rel, after_rel = win.coherent[7] / W[7], after.coherent[7] / turned[7]
    assert abs(np.angle(after_rel / before_rel)) < 1e-3
    assert abs(after_rel) == pytest.approx(abs(before_rel), rel=1e-3)
    assert np.angle(after.coherent[7] / win.coherent[7]) == pytest.approx(1.0, abs=1e-3)


def test_continued_start_moves_the_vibration_with_the_turned_harmonic(locked_at_120):
    """After W_8 turns by 1 rad, the contact angle turned back by 1/8 rad starts the vibration
    at its locked phase to the new W_8: after a quarter of the settling time the window writes
    at order 8 as it writes once settled (measured 2e-5 of the write), while the unshifted
    start is still catching up (18 %)."""
    params, V, W, win, nxt = locked_at_120
    turned = W.copy()
    turned[7] *= np.exp(1j)
    shifted = continued(win.end_state, win, turned)
    assert shifted[-1] == pytest.approx(win.end_state[-1] - 1.0 / 8.0)
    short = 0.25 * nxt  # a quarter of the settling time: what remains of the restart's transient

    def departure(state):
        w = window_wear(params, V, turned, state, short, 16)
        settled = window_wear(params, V, turned, w.end_state, nxt, 16)
        return abs(w.coherent[7] - settled.coherent[7]) / abs(settled.coherent[7])

    at_phase, unshifted = departure(shifted), departure(win.end_state)
    assert at_phase < 1e-3
    assert unshifted > 0.05


def test_continued_leaves_an_unlocked_window_alone(locked_at_120):
    params, _, W, win, nxt = locked_at_120
    steady = window_wear(params, float(kmh_to_ms(50.0)), W, win.end_state, nxt, 3)
    assert not math.isfinite(steady.order)
    assert np.array_equal(continued(win.end_state, steady, 2.0 * W), win.end_state)


@pytest.mark.parametrize("x_n", [-0.2 + 0.5j, 0j, 1.5 - 0.3j])
def test_write_at_a_multiple_of_the_locking_order_turns_with_the_locked_harmonic(x_n):
    """A vibration locked at order m moves with the phase of W_m, so its write at order 2m
    turns twice as fast as W_m: dW_2m/ds = x W_2m + t (W_m/|W_m|)^2. Where W_m turns
    uniformly (its pinned write across it), the update is exact: against scipy's RK45."""
    W = np.array([0.3 + 0.1j, 1.0 + 0.4j, 0.2 - 0.1j, 0.05 + 0.02j])  # orders 1..4, locked at 2
    x = np.array([0.1j, 0j, -0.1 + 0j, x_n])
    pinned = np.array([0j, 0.8j, 0j, 0j])  # across W_2: W_2 turns by 0.8/|W_2| rad, its size kept
    turning = np.array([0j, 0j, 0j, 0.03 - 0.02j])
    forcing = np.array([0.01 + 0j, 0j, 0j, 0.004j])

    def rhs(_, y):
        w = y[:4] + 1j * y[4:]
        d = x * w + forcing
        d[1] += pinned[1] * w[1] / abs(w[1])
        d[3] += turning[3] * (w[1] / abs(w[1])) ** 2
        return np.concatenate([d.real, d.imag])

    ref = solve_ivp(rhs, (0.0, 1.0), np.concatenate([W.real, W.imag]), rtol=1e-12, atol=1e-14).y[:, -1]
    out, _ = update_profile(W, x, forcing, pinned, turning)
    np.testing.assert_allclose(out, ref[:4] + 1j * ref[4:], rtol=0, atol=1e-10)
