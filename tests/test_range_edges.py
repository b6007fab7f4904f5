"""A band below the analysed range is found, and a range edge is never an onset (issue 24, section 3).

With ``operating.toe_deg = 6`` the SEV band lies at 4.85-21.27 km/h, mostly below the
default range 20-300 km/h. The widened diagram is checked against two other methods: the
linear stability on a range chosen to hold the band (the Hopf speed), and a simulation
with a large disturbance inside the band (a cycle) and just above its fold (decay).
"""

from __future__ import annotations

import json

import pytest

from polywear.dynamics.bifurcation import SPEED_FLOOR_KMH, bifurcation
from polywear.dynamics.stability import stability
from polywear.params import Params

from .cli_runner import run_main

TOE6 = Params().with_updates({"operating.toe_deg": 6.0})


@pytest.fixture(scope="module")
def diagram():
    return bifurcation(TOE6)


def test_band_below_the_range_is_found(diagram):
    summary = diagram.summary()
    assert summary["requested_speed_range_kmh"] == [20.0, 300.0]
    assert summary["speed_range_kmh"][0] == SPEED_FLOOR_KMH
    assert any("below 20 km/h" in note for note in summary["range_notes"])
    onset = stability(TOE6, (2.0, 30.0)).hopf_points[0].speed_kmh  # a range that holds the band
    assert summary["first_bifurcation_speed_kmh"] == pytest.approx(onset, abs=1e-3)
    assert summary["first_bifurcation_speed_kmh"] == pytest.approx(4.85, abs=0.01)
    assert summary["second_bifurcation_speed_kmh"] == pytest.approx(21.27, abs=0.01)


@pytest.mark.parametrize("speed, outcome", [(20.5, "cycle"), (22.0, "equilibrium")])
def test_simulation_agrees_with_the_fold(speed, outcome):
    """Inside the hard part of the band a 0.6 mm disturbance grows into a cycle; above the fold it decays."""
    code, out, err = run_main(["simulate", "--set", "operating.toe_deg=6", "--speed", str(speed),
                               "--disturbance", "0.0006", "--json", "-q"])
    assert code == 0, err
    assert json.loads(out)["outcome"] == outcome


def test_default_range_is_not_widened_without_a_band_below():
    """The defaults are stable from walking pace to 20 km/h: their diagram keeps its range."""
    assert stability(Params(), (SPEED_FLOOR_KMH, 20.0)).hopf_points == []
    summary = bifurcation(Params()).summary()
    assert summary["speed_range_kmh"] == summary["requested_speed_range_kmh"] == [20.0, 300.0]


@pytest.mark.parametrize("speed_range, ends, onset_word", [
    (("5", "300"), ["lower"], "the onset lies below the analysed range"),
    (("100", "120"), ["lower", "upper"], "over the whole analysed range"),
    (("100", "400"), ["lower"], "the onset lies below the analysed range"),
    (("30", "150"), ["upper"], "to beyond the analysed range"),
])
def test_stability_never_prints_a_range_edge_as_an_onset(speed_range, ends, onset_word):
    toe = ["--set", "operating.toe_deg=6"] if speed_range[0] == "5" else []
    args = ["stability", *toe, "--speed-range", *speed_range, "-q"]
    code, out, _ = run_main(args)
    assert code == 0 and onset_word in out
    assert f"from {float(speed_range[0]):.3f}" not in out
    code, out, _ = run_main([*args, "--json"])
    assert json.loads(out)["linear_band_open_ends"] == ends


def test_stability_prints_a_band_inside_the_range_as_before():
    code, out, _ = run_main(["stability", "-q"])
    assert code == 0 and "steady rolling unstable from 58.075 to 207.750 km/h" in out
    code, out, _ = run_main(["stability", "-q", "--json"])
    assert json.loads(out)["linear_band_open_ends"] == []
