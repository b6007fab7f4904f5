"""The evolution's start state: from rest, or on the large stable cycle (hard self-excitation).

The hard car: toe 1.0 deg. Its diagram has a subcritical Hopf point at 103.9 km/h and the
fold of cycles at 127.4 km/h, so at 110 km/h steady rolling is stable and a stable cycle of
0.49 mm (147 Hz) coexists with it; the default car (toe 0.5 deg) vibrates there (soft)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from polywear.dynamics.bifurcation import bifurcation
from polywear.models import model_for
from polywear.params import Params, with_updates
from polywear.solvers.integrate import integrate
from polywear.units import kmh_to_ms
from polywear.wear.evolution import wear_evolution
from polywear.wear.start import cycle_start_states

HARD = {"operating.toe_deg": 1.0}


@pytest.fixture(scope="module")
def hard():
    params = with_updates(Params(), HARD)
    return params, bifurcation(params)


def test_the_hard_car_has_a_hard_region_at_110_kmh(hard):
    params, diagram = hard
    assert any(a < 110.0 < b for a, b in diagram.hard_regions_kmh)
    model = model_for(params)
    p = model.pack(params)
    V = kmh_to_ms(110.0)
    assert np.all(np.linalg.eigvals(model.jacobian(model.equilibrium(V, p), V, p)).real < 0.0)


def test_cycle_start_is_on_a_stable_cycle_a_simulation_stays_on(hard):
    """Independent of the collocation: a long simulation from the start state keeps the
    cycle's amplitude and period, far above the unstable cycle (the trigger)."""
    params, diagram = hard
    states = cycle_start_states(params, [50.0, 80.0, 110.0], diagram)
    assert set(states) == {110.0}  # 50 and 80 km/h: rolling unstable (soft), not hard
    cycles = diagram.cycles_at(110.0)
    big = [c for c in cycles if c.stable][-1]
    trigger = min(c.amplitude[0] for c in cycles if not c.stable)
    model = model_for(params)
    p = model.pack(params)
    V = kmh_to_ms(110.0)
    x_eq = model.equilibrium(V, p)[0]
    run = integrate(model, states[110.0], V, p, 200 * big.period, dt_out=big.period / 200)
    last = run.u[run.t > 150 * big.period, 0] - x_eq  # after 150 periods: what stays
    amplitude = 0.5 * (last.max() - last.min())
    assert amplitude == pytest.approx(big.amplitude[0], rel=0.01)
    assert amplitude > 2.0 * trigger
    crossings = np.flatnonzero(np.diff(np.sign(last - last.mean())) > 0)
    period = (crossings[-1] - crossings[0]) / (crossings.size - 1) * (big.period / 200)
    assert period == pytest.approx(big.period, rel=0.01)


def test_evolution_from_the_cycle_vibrates_where_the_one_from_rest_rolls(hard):
    params, _ = hard
    cycle = ((110.0, 1.0),)
    rest = wear_evolution(params, 20000.0, cycle, start="rest")
    kicked = wear_evolution(params, 20000.0, cycle, start="cycle")
    assert np.all(np.isnan(rest.vibration_order[:, 0]))  # steady rolling: the tread does not vibrate
    order = kicked.vibration_order[:, 0]
    assert np.all(np.isfinite(order))
    # the cycle's frequency order at 110 km/h: 147.1 Hz over the wheel's rotation frequency
    f_rot = kmh_to_ms(110.0) / (2.0 * math.pi * params.operating.rolling_radius_m)
    assert order[-1] == pytest.approx(147.1 / f_rot, rel=0.01)
    # the vibration adds sliding, and its writes make the dominant order 10 grow faster
    assert kicked.friction_energy_j[-1] > 1.02 * rest.friction_energy_j[-1]
    assert rest.dominant_order[-1] == kicked.dominant_order[-1] == 10
    assert abs(kicked.harmonics[-1, 9]) > 1.2 * abs(rest.harmonics[-1, 9])


def test_cycle_start_refused_where_no_stable_cycle_coexists_with_stable_rolling():
    soft = Params()  # toe 0.5 deg: at 110 km/h steady rolling is unstable, the vibration grows from rest
    with pytest.raises(ValueError, match="hard self-excitation"):
        wear_evolution(soft, 1000.0, ((110.0, 1.0),), start="cycle")
    with pytest.raises(ValueError, match="start = 'pothole'"):
        wear_evolution(soft, 1000.0, ((110.0, 1.0),), start="pothole")
