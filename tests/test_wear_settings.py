"""The wear map and the wear design take frozen validated settings (issue 21.3), recorded in
their results: a bad field fails on construction naming the class and the field; the
results say what they were computed with; the settings change what they say and nothing else."""

from __future__ import annotations

import dataclasses
import json
import math
import pickle

import numpy as np
import pytest

from polywear.params import MAX_WEAR_ORDER, Params
from polywear.wear.design import Judge, WearDesignSettings, wear_design
from polywear.wear.evolution import EvolutionSettings
from polywear.wear.map import WearMapSettings, wear_map

from .cli_runner import run_main

SPEEDS = [40.0, 110.0, 230.0]


@pytest.mark.parametrize("value", [0, -3, MAX_WEAR_ORDER + 1, 2.5, True, "30"])
def test_wear_map_settings_refuse_a_bad_order(value):
    with pytest.raises(ValueError, match=r"WearMapSettings: max_order = .*: must be an integer from 1 to 500"):
        WearMapSettings(max_order=value)


def test_wear_map_records_the_order_it_used_and_the_orders_do_not_depend_on_it():
    """Each order's multiplier is its own resolvent solve: the map to order 12 is the first
    12 columns of the map to the default order (60), bit for bit."""
    params = Params()
    full = wear_map(params, SPEEDS)
    assert full.settings == WearMapSettings(max_order=params.wear.max_order) and full.orders[-1] == 60
    part = wear_map(params, SPEEDS, WearMapSettings(max_order=12))
    assert part.settings.max_order == 12 and part.relative_change.shape == (3, 12)
    np.testing.assert_array_equal(part.relative_change, full.relative_change[:, :12])
    assert part.to_xarray().attrs["max_order"] == "12"
    assert "WearMapSettings(max_order=12)" in part.to_xarray().attrs["settings"]


def test_wear_map_refuses_the_old_positional_order():
    with pytest.raises(TypeError, match="WearMapSettings"):
        wear_map(Params(), SPEEDS, 30)


@pytest.mark.parametrize("field, value, need", [
    ("max_factor", 1.0, "above 1"),
    ("max_factor", 0.5, "above 1"),
    ("max_factor", math.inf, "positive and finite"),
    ("max_factor", math.nan, "positive and finite"),
    ("grid", 0, "integer >= 1"),
    ("grid", 2.5, "integer >= 1"),
    ("judge", "nonsense", "one of auto, map, evolution"),
    ("judge", None, "one of auto, map, evolution"),
    ("evolution", {"step_km": 500.0}, "EvolutionSettings"),
])
def test_wear_design_settings_refuse_bad_fields(field, value, need):
    with pytest.raises(ValueError, match=rf"WearDesignSettings: {field} = .*{need}"):
        WearDesignSettings(**{field: value})


def test_judge_text_becomes_the_member_and_settings_travel():
    settings = WearDesignSettings(judge="map", evolution=EvolutionSettings(step_km=500.0))
    assert settings.judge is Judge.MAP and settings == WearDesignSettings(judge=Judge.MAP,
                                                                          evolution=EvolutionSettings(step_km=500.0))
    assert pickle.loads(pickle.dumps(settings)) == settings and hash(settings) == hash(pickle.loads(pickle.dumps(settings)))
    assert dataclasses.replace(settings, grid=8).judge is Judge.MAP
    with pytest.raises(dataclasses.FrozenInstanceError):
        settings.grid = 3  # type: ignore[misc]


def test_wear_design_records_its_settings_and_the_judge_it_used(tmp_path):
    settings = WearDesignSettings(grid=6, max_factor=3.0)
    cycle = ((40.0, 1.0),)  # below the linear band: AUTO is the map there
    assert wear_map(Params(), [40.0]).rolling_stable.all()
    result = wear_design(Params(), keys=("operating.toe_deg",), target_km=60000.0, cycle=cycle, settings=settings)
    assert result.settings is settings and settings.judge is Judge.AUTO
    assert result.judge is Judge.MAP and result.nominal_rolling_stable and result.nominal_evolution is None
    saved = json.loads(result.save(tmp_path / "d.json").read_text())
    assert saved["settings"]["judge"] == "auto" and saved["settings"]["max_factor"] == 3.0 and saved["judge"] == result.judge
    (option,) = result.options  # toe +44 %: within the largest change searched
    assert 1.0 < option.value / option.nominal <= 3.0
    narrow = wear_design(Params(), keys=("operating.toe_deg",), target_km=60000.0, cycle=cycle,
                         settings=WearDesignSettings(grid=6, max_factor=1.3))
    assert narrow.options == [] and narrow.not_found == ["operating.toe_deg: no change within x1.3 meets the criterion"]


def test_cli_judge_choices_are_the_enum():
    code, out, err = run_main(["wear", "design", "--judge", "nonsense"])
    assert code == 2 and "--judge 'nonsense': one of auto, map, evolution" in err
    assert [j.value for j in Judge] == ["auto", "map", "evolution"]
