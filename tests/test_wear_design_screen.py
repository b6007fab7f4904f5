"""The evolution search screened by cheaper evolutions (wear/design.py, ``WearDesignSettings.screen``):
the same least change as the search with the full settings on every probe, and the option's
evolution and its bracket's other end are those of the full settings (checked against
independent evolutions)."""

from __future__ import annotations

import pytest

from polywear.dynamics.sensitivity import perturbed
from polywear.params import Params, with_updates
from polywear.wear.design import SCREEN, SCREEN_MARGIN, Judge, WearDesignSettings, _screen_clear, wear_design
from polywear.wear.evolution import EvolutionSettings, wear_evolution

CYCLE = ((110.0, 1.0),)  # the default car vibrates at 110 km/h
TARGET = 4000.0
KEY = "tread.lateral_damping_ns_per_m"


def _car():
    """The default car with k_e = 0.01 mm^3/J: the default's polygon after a tenth of the distance."""
    return with_updates(Params(), {"wear.energetic_rate_mm3_per_j": 0.01})


def test_screen_clear_judges_only_far_from_the_criterion():
    visible = 0.1
    evolved = {"distance_km": TARGET, "depth_mm": 0.01, "visible_km": None, "dominant_order": 9}
    assert _screen_clear(None, TARGET, visible)  # not evaluated: no evolution to repeat
    assert _screen_clear((False, 1.0, 9, None), TARGET, visible)  # decided by the map
    assert _screen_clear((True, 1.0, 9, evolved), TARGET, visible)
    assert not _screen_clear((True, 1.0, 9, evolved | {"depth_mm": (1 - SCREEN_MARGIN) * visible}), TARGET, visible)
    early = evolved | {"visible_km": (1 - SCREEN_MARGIN) * TARGET * 0.99, "depth_mm": visible}
    assert _screen_clear((False, 1.0, 9, early), TARGET, visible)
    assert not _screen_clear((False, 1.0, 9, early | {"visible_km": (1 - SCREEN_MARGIN) * TARGET}), TARGET, visible)
    assert not _screen_clear((False, 1.0, 9, evolved | {"undecided": True, "depth_mm": None}), TARGET, visible)


@pytest.mark.slow
def test_screened_search_gives_the_full_search_answer_checked_by_evolution():
    params = _car()
    nominal = wear_evolution(params, TARGET, CYCLE)
    kw = dict(keys=(KEY,), target_km=TARGET, cycle=CYCLE, nominal=nominal)
    full = wear_design(params, settings=WearDesignSettings(judge=Judge.EVOLUTION, max_factor=4.0), **kw)
    messages = []
    screened = wear_design(params, settings=WearDesignSettings(judge=Judge.EVOLUTION, max_factor=4.0, screen=SCREEN),
                           progress=lambda done, total, message: messages.append(message), **kw)
    assert any(m.endswith("(screened)") for m in messages)  # the screen judged some probes alone
    (a,), (b,) = full.options, screened.options
    assert b.value == a.value and b.evolution == a.evolution and b.below == a.below
    # the option's evolution is the full settings' (an independent evolution), not the screen's
    again = wear_evolution(perturbed(params, KEY, b.value), TARGET, CYCLE)
    assert again.visible_km is None and b.evolution["depth_mm"] == pytest.approx(float(again.depth_mm[-1]), rel=1e-12)
    if b.below is not None and b.below["visible_km"] is not None:
        before = wear_evolution(perturbed(params, KEY, b.below["value"]), TARGET, CYCLE)
        assert before.visible_km == pytest.approx(b.below["visible_km"], rel=1e-12)


def test_screen_must_be_evolution_settings():
    with pytest.raises(ValueError, match="screen = 0.1: must be an EvolutionSettings"):
        WearDesignSettings(screen=0.1)
    assert WearDesignSettings(screen=EvolutionSettings(tolerance=0.1)).screen.tolerance == 0.1
