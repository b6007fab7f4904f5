"""A design verdict speaks of the band over all speeds, not of the range analysed (issue 24, section 3).

With ``--speed-range 20 100`` the toe option 0.5 -> 0.22 deg pushes the band out of the
analysed range; it does not make it vanish. The band it leaves is checked against the
tread model's closed form: every speed scales as ``1 / sin(toe)`` (docs/model.md).
"""

from __future__ import annotations

import math

import pytest

from polywear.dynamics.bifurcation import SPEED_CEILING_KMH, SPEED_FLOOR_KMH, bifurcation
from polywear.dynamics.design import DesignOption, DesignOutcome, _band_over_all_speeds, design
from polywear.params import Params


@pytest.fixture(scope="module")
def toe_option():
    result = design(Params(), (80.0, 130.0), keys=("operating.toe_deg",), speed_range_kmh=(20.0, 100.0))
    return result.options[0]


def test_toe_option_moves_the_band_above_instead_of_vanishing(toe_option):
    assert toe_option.achieved
    assert toe_option.outcome is DesignOutcome.ABOVE
    assert "vanish" not in toe_option.text()
    (low, high), = toe_option.sev_band_kmh
    assert (low, high) == pytest.approx((132.0, 579.0), abs=0.1)


def test_band_left_by_the_toe_option_is_the_closed_form_scaling(toe_option):
    nominal = bifurcation(Params()).sev_band_kmh
    factor = math.sin(math.radians(0.5)) / math.sin(math.radians(toe_option.values[0]))
    (low, high), = toe_option.sev_band_kmh
    assert low == pytest.approx(nominal[0][0] * factor, rel=1e-3)
    assert high == pytest.approx(nominal[-1][1] * factor, rel=1e-3)


def test_a_band_that_is_gone_at_every_speed_still_vanishes():
    """A tread damped to 2000 N s/m is stable from walking pace to the ceiling: nothing replaces "vanishes"."""
    key = "tread.lateral_damping_ns_per_m"
    option = DesignOption((key,), (80.0,), (2000.0,), True, [], outcome=DesignOutcome.VANISHES)
    _band_over_all_speeds(Params(), option, 78.0, 132.0)
    assert option.outcome is DesignOutcome.VANISHES and option.sev_band_kmh == []
    damped = Params().with_updates({key: 2000.0})
    assert bifurcation(damped, (SPEED_FLOOR_KMH, SPEED_CEILING_KMH), extend=False).sev_band_kmh == []
