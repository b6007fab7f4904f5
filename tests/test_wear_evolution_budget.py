"""Wear evolution: the vibration's third line is fitted where it sits near an integer order,
and an evolution that would need too many distance steps stops with a clear message."""

from __future__ import annotations

import time

import numpy as np
import pytest

from polywear.errors import NumericalError
from polywear.params import Params, with_updates
from polywear.wear.evolution import EvolutionSettings, wear_evolution
from polywear.wear.windows import FITTED_LINES, NEAR_SPAN, SIDEBANDS, _fitted_beyond, _per_revolution, _split


def _tones(nu, third, per_rev=512, revolutions=16, T=0.05):
    """Per-revolution writes (M, 40) of a power with a line at order nu (amplitude 50), its
    third harmonic (``third``), and a locked component at order 25 (amplitude 1)."""
    t = np.arange(revolutions * per_rev + 1) * (T / per_rev)
    angle = 2 * np.pi * t / T
    locked = 1.0 * np.cos(2 * np.pi * 25 * t / T + 1.0)
    power = (400 + 50 * np.cos(2 * np.pi * nu * t / T + 0.2) + third * np.cos(2 * np.pi * 3 * nu * t / T + 0.4)
             + locked)
    D, _ = _per_revolution(t, power, angle, per_rev, revolutions, Params(), 40)
    alone, _ = _per_revolution(t, locked, angle, per_rev, revolutions, Params(), 40)
    return D, alone[0]


def test_third_line_near_an_integer_order_is_fitted_not_counted_as_coherent():
    """axle4dof at 110 km/h vibrates at order 8.344: its third line, at 25.03, turns by half a
    period over a 16-revolution window. Synthetic writes with a known locked part at order 25:
    with the third line fitted (on orders 23-27), S_25 is the locked part but for the leak of
    the line's mirror at order -25.03 (about 8 sin(0.03 pi)/(50 pi), 6e-3; measured 5e-3);
    counted as coherent, the line's write (8 times the locked part's) lands in S_25."""
    nu, M = 8.34375, 16
    D, truth = _tones(nu, third=8.0)
    eps = [abs(j * nu - round(j * nu)) for j in range(1, SIDEBANDS + 1)]
    beyond = _fitted_beyond(nu, eps, M)
    assert FITTED_LINES == 3 and beyond == [pytest.approx(0.03125)]
    fitted, drifting, ratios = _split(D, nu, eps + beyond, M)
    plain = _split(D, nu, eps, M)[0]
    assert abs(fitted[24] - truth[24]) < 1e-2 * abs(truth[24])
    assert abs(plain[24] - truth[24]) > 3.0 * abs(truth[24])
    span = np.arange(25 - NEAR_SPAN, 25 + NEAR_SPAN + 1) - 1
    np.testing.assert_allclose(fitted[span], truth[span], rtol=0, atol=1e-2 * abs(truth[24]))
    rest = np.setdiff1d(np.arange(40), span)
    np.testing.assert_array_equal(fitted[rest], plain[rest])  # elsewhere the split is as before
    # the split still predicts what the window wrote
    predicted = M * fitted + sum(c * (1 - r ** M) / (1 - r) for c, r in zip(drifting, ratios))
    np.testing.assert_allclose(predicted[span], D.sum(axis=0)[span], rtol=0, atol=1e-3 * np.abs(D).max() * M)


def test_third_line_is_not_fitted_where_the_window_cannot_resolve_it_or_the_vibration_locks():
    assert _fitted_beyond(8.34375, [0.34375, 0.3125], 4) == [0.0]  # eps M = 0.125 < RESOLVABLE
    assert _fitted_beyond(9.0, [0.0, 0.0], 16) == []  # locked
    assert _fitted_beyond(float("nan"), [], 16) == []  # no vibration


def test_step_budget_stops_an_evolution_that_would_take_too_many_steps():
    """k_e 100 times the default (the upper bound of the key) over 60 000 km wears the polygon
    ever deeper; with a budget of 5 steps (+ 8 for the distance at the longest step) it stops
    within seconds, naming the key."""
    params = with_updates(Params(), {"wear.energetic_rate_mm3_per_j": 0.1})
    start = time.process_time()
    with pytest.raises(NumericalError, match=r"budget of 13 distance steps.*wear\.energetic_rate_mm3_per_j = 0\.1"):
        wear_evolution(params, 60000.0, cycle=((120.0, 1.0),), settings=EvolutionSettings(max_steps=5))
    assert time.process_time() - start < 30.0


def test_step_budget_at_the_default_k_e_points_to_the_steps_not_to_k_e():
    """At the default k_e the key is not what to lower: the message says so and names the
    settings that let the evolution go on."""
    with pytest.raises(NumericalError, match=r"budget of 2 distance steps.*not above its default.*max_steps"):
        wear_evolution(Params(), 8000.0, cycle=((120.0, 1.0),), settings=EvolutionSettings(max_steps=1))


def test_step_budget_must_be_a_positive_integer():
    with pytest.raises(ValueError, match="max_steps"):
        EvolutionSettings(max_steps=0)


@pytest.mark.slow
def test_reused_steady_rolling_window_is_simulated_again_as_the_profile_grows():
    """Toe 0.35 deg at 80 km/h: rolling is stable, but the response to order 11 turns
    nonlinear (the window vibrating, locked at 11) from a few um, far below the linear
    regime's load bound (about 20 um here), and order 11's growth per revolution falls
    tenfold between 5 and 20 um. Reusing the first window's rates while the load stays below
    that bound grew order 11 past the saturation; simulated again at every doubling of the
    largest harmonic, the evolution follows the one that simulates every window
    (LINEAR_LOAD = 0)."""
    import polywear.wear.evolution as we

    params = with_updates(Params(), {"operating.toe_deg": 0.35})
    cycle = ((80.0, 1.0),)
    reused = wear_evolution(params, 10000.0, cycle=cycle)
    default = we.LINEAR_LOAD
    try:
        we.LINEAR_LOAD = 0.0
        simulated = wear_evolution(params, 10000.0, cycle=cycle)
    finally:
        we.LINEAR_LOAD = default
    assert abs(simulated.harmonics[-1, 10]) > 10.0 * abs(simulated.harmonics[0, 10])  # order 11 grew
    assert abs(reused.harmonics[-1, 10]) == pytest.approx(abs(simulated.harmonics[-1, 10]), rel=0.02)
    assert reused.depth_mm[-1] == pytest.approx(simulated.depth_mm[-1], rel=0.02)


def test_until_visible_stops_at_the_first_visible_step_with_the_whole_evolutions_steps():
    """Stopped once visible, the evolution has the whole evolution's steps up to the first
    step at or past the visible depth, and the same visible distance, bit for bit."""
    params = with_updates(Params(), {"wear.energetic_rate_mm3_per_j": 0.05})
    cycle = ((110.0, 1.0),)
    full = wear_evolution(params, 3000.0, cycle)
    short = wear_evolution(params, 3000.0, cycle, settings=EvolutionSettings(until_visible=True))
    first = int(np.flatnonzero(full.depth_mm >= params.wear.visible_depth_mm)[0])
    assert 0 < first < full.distance_km.size - 1  # visible before the end: there is something to stop
    assert short.distance_km.size == first + 1
    np.testing.assert_array_equal(short.distance_km, full.distance_km[:first + 1])
    np.testing.assert_array_equal(short.harmonics, full.harmonics[:first + 1])
    assert short.visible_km == full.visible_km and short.settings["until_visible"]
