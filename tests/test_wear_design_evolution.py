"""Wear design for a car that vibrates (wear/design.py, judged by the nonlinear evolution):
the least change returned is checked by independent evolutions, at that change (no
visible polygon within the target) and at 3 % less of it (visible before the target)."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from polywear.dynamics.sensitivity import nominal_value, perturbed
from polywear.params import Params, with_updates
from polywear.wear.design import EVOLUTION_REFINE, SCREEN, Judge, WearDesignSettings, cycle_growth, wear_design
from polywear.wear.evolution import EvolutionSettings, StepBudgetError, wear_evolution

CYCLE = ((110.0, 1.0),)  # the default car vibrates at 110 km/h
TARGET = 4000.0
KEY = "tread.lateral_damping_ns_per_m"


def _car():
    """The default car with k_e = 0.01 mm^3/J: the default's polygon after a tenth of the distance."""
    return with_updates(Params(), {"wear.energetic_rate_mm3_per_j": 0.01})


@pytest.mark.slow
def test_least_change_for_a_vibrating_car_checked_by_evolution():
    params = _car()
    assert not cycle_growth(params, CYCLE)[2]  # rolling unstable at 110 km/h: the linear map does not apply
    messages = []
    result = wear_design(params, keys=(KEY,), target_km=TARGET, cycle=CYCLE,
                         progress=lambda done, total, message: messages.append(message))
    assert result.judge == "evolution"
    # progress after every evolution: the nominal car's, then each probe's, the least change among them
    assert messages[0] == f"nominal: visible after {result.nominal_evolution['visible_km']:,.0f} km"
    assert len(messages) >= 3 and all(m.startswith(f"{KEY} = ") for m in messages[1:])
    assert f"{KEY} = {result.options[0].value:.4g}: no visible polygon" in messages
    nominal = result.nominal_evolution
    assert nominal["visible_km"] is not None and nominal["visible_km"] < TARGET  # something must change
    (option,) = result.options
    assert option.evolution["visible_km"] is None
    factor = option.value / option.nominal
    # independent evolutions (the default settings, as the search's) at the change and at 3 % less of it
    at = wear_evolution(perturbed(params, KEY, option.value), TARGET, CYCLE)
    assert at.visible_km is None and at.depth_mm[-1] < params.wear.visible_depth_mm
    step = 1.5 * EVOLUTION_REFINE
    less = math.exp(math.log(factor) - math.copysign(step, math.log(factor)))
    before = wear_evolution(perturbed(params, KEY, option.nominal * less), TARGET, CYCLE)
    assert before.visible_km is not None and before.visible_km < TARGET


@pytest.mark.slow
def test_one_grid_level_unrefined_is_that_level_checked_by_evolution():
    """``max_levels=1, refine=False`` (the axle4dof report): the least change is the first grid
    level where a direction meets the criterion, not refined (two evolutions); where no
    direction meets it there, each says the search stopped there. Oracle: independent
    evolutions at the change (no polygon) and at the nominal car (visible)."""
    params = _car()
    step = 4.0 ** (1.0 / 8)  # max_factor 4 on EVOLUTION_GRID = 8 levels
    coarse = WearDesignSettings(judge=Judge.EVOLUTION, max_factor=4.0, max_levels=1, refine=False)
    result = wear_design(params, keys=(KEY,), target_km=TARGET, cycle=CYCLE, settings=coarse)
    (option,) = result.options
    assert option.value == pytest.approx(nominal_value(params, KEY) * step, rel=1e-12)
    assert option.below is None and result.evolutions == 2 and not result.summary()["refined"]
    at = wear_evolution(perturbed(params, KEY, option.value), TARGET, CYCLE)
    assert at.visible_km is None and option.evolution["depth_mm"] == pytest.approx(float(at.depth_mm[-1]), rel=1e-12)
    assert wear_evolution(params, TARGET, CYCLE).visible_km < TARGET
    # on two speeds, all in one thread (threads = 1) against probes side by side, each with its
    # windows in threads: the same, bit for bit
    two = ((110.0, 0.5), (120.0, 0.5))
    side_by_side = wear_design(params, keys=(KEY,), target_km=TARGET, cycle=two, settings=coarse)
    serial = wear_design(params, keys=(KEY,), target_km=TARGET, cycle=two, settings=replace(coarse, threads=1))
    assert serial.options == side_by_side.options and serial.not_found == side_by_side.not_found
    assert serial.nominal_evolution["visible_km"] < TARGET and side_by_side.evolutions == 2
    # a grid too fine for one level to reach the change: no option, and why
    fine = wear_design(params, keys=(KEY,), target_km=TARGET, cycle=CYCLE,
                       settings=WearDesignSettings(judge=Judge.EVOLUTION, max_factor=1.5, max_levels=1))
    assert not fine.options and fine.evolutions == 2
    (note,) = fine.not_found
    assert note == (f"{KEY}: more: +5 % does not meet the criterion; the search stopped there (1 grid level, "
                    "WearDesignSettings.max_levels); less: -5 % does not meet the criterion; the search stopped "
                    "there (1 grid level, WearDesignSettings.max_levels)")
    # both directions meet at the first level (mu_s -29 % and +41 % with max_factor 16): the
    # smaller relative change is the option, the other direction beside it, both judged with
    # the full settings where the screen judged first (independent evolutions)
    both = wear_design(params, keys=("friction.mu_static",), target_km=TARGET, cycle=CYCLE,
                       settings=replace(coarse, max_factor=16.0, screen=SCREEN))
    (option,) = both.options
    other = option.other_direction
    assert option.relative_change == pytest.approx(16.0 ** -0.125 - 1.0, rel=1e-12)
    assert other["relative_change"] == pytest.approx(16.0 ** 0.125 - 1.0, rel=1e-12)
    for value, evolved in ((option.value, option.evolution), (other["value"], other["evolution"])):
        again = wear_evolution(perturbed(params, "friction.mu_static", value), TARGET, CYCLE)
        assert again.visible_km is None and evolved["depth_mm"] == pytest.approx(float(again.depth_mm[-1]), rel=1e-12)
    with pytest.raises(ValueError, match="max_levels"):
        WearDesignSettings(max_levels=0)
    with pytest.raises(ValueError, match="refine_rounds"):
        WearDesignSettings(refine_rounds=0)
    with pytest.raises(ValueError, match="refine_rounds = 1 with refine = False: no rounds without the refinement"):
        WearDesignSettings(refine=False, refine_rounds=1)
    with pytest.raises(ValueError, match="refine = 1: must be True or False"):
        WearDesignSettings(refine=1)


def test_judge_is_checked():
    with pytest.raises(ValueError, match="needs a target"):
        wear_design(Params(), keys=(KEY,), settings=WearDesignSettings(judge=Judge.EVOLUTION), cycle=CYCLE)
    with pytest.raises(ValueError, match="WearDesignSettings: judge = 'nonsense': must be one of auto, map, evolution"):
        WearDesignSettings(judge="nonsense")


def test_a_probe_over_its_step_budget_is_undecided_and_reported():
    """With a step budget of one step beyond the fewest the distance takes, every probe
    whose tread vibrates stops at the budget: it is listed as undecided with the distance
    it reached (checked against an evolution with the same budget), never an option."""
    params = _car()
    tight = EvolutionSettings(max_steps=1)
    nominal = wear_evolution(params, TARGET, CYCLE)  # the search's nominal, with the default budget
    result = wear_design(params, keys=(KEY,), target_km=TARGET, cycle=CYCLE, nominal=nominal,
                         settings=WearDesignSettings(judge=Judge.EVOLUTION, evolution=tight, max_factor=1.5))
    assert result.undecided and result.evolutions >= len(result.undecided)
    assert all(u["key"] == KEY for u in result.undecided)
    assert {u["value"] for u in result.undecided}.isdisjoint(o.value for o in result.options)
    first = result.undecided[0]
    with pytest.raises(StepBudgetError) as stopped:
        wear_evolution(perturbed(params, KEY, first["value"]), TARGET, CYCLE, EvolutionSettings(max_steps=1))
    assert first["at_km"] == pytest.approx(stopped.value.done_km, rel=1e-12)
    assert first["relative_change"] == pytest.approx(first["value"] / nominal_value(params, KEY) - 1.0, rel=1e-12)
    assert result.summary()["undecided"] == result.undecided


def test_nominal_evolution_given_must_match_the_target_and_cycle():
    params = _car()
    short = wear_evolution(params, 500.0, CYCLE)
    with pytest.raises(ValueError, match="nominal evolution given ran 500 km"):
        wear_design(params, keys=(KEY,), target_km=TARGET, cycle=CYCLE, nominal=short,
                    settings=WearDesignSettings(judge=Judge.EVOLUTION))


@pytest.mark.slow
def test_one_round_probes_each_open_direction_of_a_key_once():
    """``refine_rounds=1`` where both directions of a key meet at the first grid level (mu_s
    -29 % and +41 % with max_factor 16): the round probes each direction once, at a third of
    its bracket (2 + 2 evolutions, not 2 + 4); the option is the least change found, at a third
    of the level or, where the third shows a polygon, at the level. Oracle: independent
    evolutions at the option (no polygon) and at its bracket's lower end (visible)."""
    params = _car()
    key = "friction.mu_static"
    one = WearDesignSettings(judge=Judge.EVOLUTION, max_factor=16.0, max_levels=1, refine_rounds=1)
    result = wear_design(params, keys=(key,), target_km=TARGET, cycle=CYCLE, settings=one)
    assert result.evolutions == 4 and result.summary()["refined"] and result.summary()["refine_rounds"] == 1
    (option,) = result.options
    thirds = 3.0 * abs(math.log(option.value / option.nominal)) / (math.log(16.0) / 8)
    assert min(abs(thirds - 1.0), abs(thirds - 3.0)) < 1e-9
    assert wear_evolution(perturbed(params, key, option.value), TARGET, CYCLE).visible_km is None
    lower = option.nominal if option.below is None else option.below["value"]
    assert wear_evolution(perturbed(params, key, lower), TARGET, CYCLE).visible_km < TARGET
    if abs(thirds - 3.0) < 1e-9:  # the third failed in both directions: the level is the answer
        assert option.below is not None
