"""The statuses of results are enums in one style (``StrEnum``, like ``PointKind``): members
that equal, print and serialize as the strings they replaced, so JSON and text stay the same."""

from __future__ import annotations

import json
from enum import StrEnum

import pytest

from polywear.dynamics.attractor import Regime
from polywear.dynamics.design import DesignOutcome, _outcome
from polywear.dynamics.excitation import SelfExcitation
from polywear.dynamics.points import Criticality
from polywear.dynamics.simulation import SteadyOutcome, simulate
from polywear.dynamics.stability import stability
from polywear.params import Params
from polywear.wear.design import Judge

# the strings each status had before it was an enum
OLD_STRINGS = {
    Regime: {"period-multiplied SEV (stick-slip)", "SEV on a cycle off the continued branches",
             "quasi-periodic or chaotic SEV", "static divergence", "no SEV",
             "unstable rolling (soft SEV)", "hard SEV region"},  # the last two: the report's operating verdict
    SteadyOutcome: {"equilibrium", "cycle", "transient"},
    Criticality: {"soft", "hard"},
    DesignOutcome: {"", "the band vanishes", "the band moves above the range", "the band moves below the range",
                    "bands remain on both sides of the range"},
    SelfExcitation: {"soft self-excitation", "hard self-excitation", "no SEV"},
    Judge: {"auto", "map", "evolution"},
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


def test_excitation_regime_is_a_member_read_from_steady_rolling_and_the_cycles():
    """Each portrait's regime against an independent reading at its speed: the eigenvalues
    of steady rolling (unstable: soft) and the continued cycles there (a stable one with
    rolling stable: hard); the netCDF attribute is the plain text."""
    import numpy as np

    from polywear.dynamics.bifurcation import bifurcation
    from polywear.dynamics.excitation import ExcitationSettings, excitation
    from polywear.models import model_for
    from polywear.units import kmh_to_ms

    params = Params()
    diagram = bifurcation(params, (20.0, 300.0))
    (hard_lo, hard_hi), *_ = diagram.hard_regions_kmh
    speeds = [110.0, 0.5 * (hard_lo + hard_hi), 30.0]
    result = excitation(diagram, speeds, ExcitationSettings(duration_s=0.02))
    model = model_for(params)
    p = model.pack(params)
    expected = []
    for v in speeds:
        V = kmh_to_ms(v)
        unstable = np.linalg.eigvals(model.jacobian(model.equilibrium(V, p), V, p)).real.max() > 0.0
        stable_cycle = any(c.stable for c in diagram.cycles_at(v))
        expected.append(SelfExcitation.SOFT if unstable else SelfExcitation.HARD if stable_cycle
                        else SelfExcitation.NO_SEV)
    assert [portrait.regime for portrait in result] == expected == list(SelfExcitation)
    for portrait in result:
        assert type(portrait.regime) is SelfExcitation and portrait.settings is result.settings
        attr = portrait.to_xarray().attrs["regime"]
        assert type(attr) is str and attr == portrait.regime.value
