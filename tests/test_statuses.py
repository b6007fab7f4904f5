"""The statuses of results are enums in one style (``StrEnum``, like ``PointKind``): members
that equal, print and serialize as the strings they replaced, so JSON and text stay the same."""

from __future__ import annotations

import json
from enum import StrEnum

import pytest

from polywear.dynamics.attractor import Regime
from polywear.dynamics.design import DesignOutcome, _outcome
from polywear.dynamics.points import Criticality
from polywear.dynamics.simulation import SteadyOutcome, simulate
from polywear.dynamics.stability import stability
from polywear.params import Params

# the strings each status had before it was an enum
OLD_STRINGS = {
    Regime: {"period-multiplied SEV (stick-slip)", "SEV on a cycle off the continued branches",
             "quasi-periodic or chaotic SEV", "static divergence", "no SEV"},
    SteadyOutcome: {"equilibrium", "cycle", "transient"},
    Criticality: {"soft", "hard"},
    DesignOutcome: {"", "the band vanishes", "the band moves above the range", "the band moves below the range",
                    "bands remain on both sides of the range"},
}


@pytest.mark.parametrize("enum", list(OLD_STRINGS), ids=lambda e: e.__name__)
def test_members_are_the_old_strings_in_json_text_and_comparisons(enum):
    assert issubclass(enum, StrEnum) and {m.value for m in enum} == OLD_STRINGS[enum]
    for member in enum:
        assert member == member.value and f"{member}" == member.value and f"{member:>40s}" == f"{member.value:>40s}"
        assert json.dumps({"status": member}) == json.dumps({"status": member.value})
        assert enum(member.value) is member


def test_hopf_criticality_follows_the_sign_of_the_lyapunov_coefficient():
    hopfs = stability(Params(), (20.0, 300.0)).hopf_points
    assert len(hopfs) == 2
    for h in hopfs:
        assert h.criticality is (Criticality.SOFT if h.first_lyapunov_coefficient < 0 else Criticality.HARD)
        assert h.special_point().criticality is h.criticality
        assert h.summary()["criticality"] == h.criticality.value


def test_a_run_outcome_is_a_member_and_its_file_attribute_a_plain_string():
    run = simulate(Params(), 30.0, 0.5)  # below the first Hopf speed: back to rest
    assert run.steady.outcome is SteadyOutcome.EQUILIBRIUM and run.steady.steady
    attr = run.to_dataset().attrs["outcome"]
    assert type(attr) is str and attr == "equilibrium"


@pytest.mark.parametrize("band, expected", [
    ([], DesignOutcome.VANISHES),
    ([(150.0, 200.0)], DesignOutcome.ABOVE),
    ([(20.0, 70.0)], DesignOutcome.BELOW),
    ([(20.0, 70.0), (150.0, 200.0)], DesignOutcome.BOTH_SIDES),
])
def test_design_outcome_names_where_the_band_went(band, expected):
    assert _outcome(band, 80.0, 130.0) is expected
