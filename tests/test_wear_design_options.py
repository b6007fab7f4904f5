"""Wear design options (analysis/wear_design.py): criterion met, least change, verified by evolution."""

from __future__ import annotations

import math

import numpy as np
import pytest

from polywear.analysis.sensitivity import perturbed
from polywear.analysis.wear_design import allowed_growth, verify_option, wear_design
from polywear.analysis.wear_map import wear_map
from polywear.params import Params

CYCLE = ((40.0, 0.5), (50.0, 0.5))  # stable rolling: the linear criterion applies


def _weighted_growth(params):
    m = wear_map(params, [v for v, _ in CYCLE])
    assert m.rolling_stable.all()
    return float(np.max(np.array([s for _, s in CYCLE]) @ m.growth_per_1000km))


@pytest.fixture(scope="module")
def result():
    return wear_design(Params(), keys=("tread.lateral_damping_ns_per_m", "friction.mu_static", "operating.toe_deg"),
                       target_km=150000.0, cycle=CYCLE)


def test_options_meet_the_criterion_with_the_least_change(result):
    allowed = result.allowed_growth_per_1000km
    assert result.nominal_growth_per_1000km > allowed  # something must change
    keys = {o.key for o in result.options}
    assert {"tread.lateral_damping_ns_per_m", "friction.mu_static"} <= keys
    for option in result.options:
        changed = perturbed(Params(), option.key, option.value)
        assert _weighted_growth(changed) <= allowed  # recomputed independently of the search
        # 2 % less of the change does not meet it: the least change, to the search's accuracy
        less = option.nominal * (1.0 + option.relative_change) ** 0.98
        assert _weighted_growth(perturbed(Params(), option.key, less)) > allowed
    assert result.options[0].category == "tread"  # what an engineer sets comes first


def test_target_is_the_visible_depth_estimate():
    params = Params()
    start_um = 2 * params.wear.initial_roughness_um * math.sqrt(2 / params.wear.max_order)
    assert allowed_growth(params, 80000.0) == pytest.approx(math.log(100.0 / start_um) / 80.0)
    assert allowed_growth(params, None) == 0.0
    done = wear_design(params, keys=("tread.lateral_damping_ns_per_m",), target_km=60000.0, cycle=CYCLE)
    assert not done.options and "no change needed" in done.not_found[0]


@pytest.mark.slow
def test_best_option_is_verified_by_evolution(result):
    option = next(o for o in result.options if o.key == "friction.mu_static")
    check = verify_option(Params(), option, 150000.0, CYCLE, step_km=10000.0)
    assert check["visible_km"] is None and check["nominal_visible_km"] is not None
    assert check["depth_mm"] < Params().wear.visible_depth_mm < check["nominal_depth_mm"]
