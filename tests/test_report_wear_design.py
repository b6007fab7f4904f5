"""The report's design section for a car that vibrates on its drive cycle (issue 22 §4): by
default (tread1dof) the least change after which no polygon is visible within the report's
distance, checked by the nonlinear evolution. Oracles: independent evolutions at the
change found and at the bracket's other end; the report's own drive-cycle evolution."""

from __future__ import annotations

import json
import math
from html import escape as html_escape

import pytest

from polywear.dynamics.design import signed_percent
from polywear.dynamics.sensitivity import perturbed
from polywear.params import Params, with_updates
from polywear.wear.evolution import wear_evolution

from .cli_runner import run_main

KM = 4000.0


def _car():
    """The default car vibrating at 110 km/h, driven only there, with k_e = 0.01 mm^3/J: its
    polygon visible after about 3 000 km (a tenth of the default's distance)."""
    return with_updates(Params(), {"wear.energetic_rate_mm3_per_j": 0.01,
                                   "wear.cycle": [{"speed_kmh": 110.0, "share": 1.0}]})


@pytest.mark.slow
def test_report_gives_the_least_change_checked_by_evolution(tmp_path):
    from polywear.report.main import report

    params = _car()
    result = report(params, tmp_path, wear_evolution_km=KM)
    assert result.settings.wear_design_by_evolution  # the default for tread1dof
    found = result.wear_design
    assert found == json.loads((tmp_path / "summary.json").read_text())["wear_design"]
    assert found["judge"] == "evolution" and found["least_only"] and found["target_km"] == KM
    # the nominal car is the report's own drive-cycle evolution, not run again
    cycle = dict(result.wear.evolutions)["drive cycle"]
    assert found["nominal_evolution"]["visible_km"] == cycle.visible_km < KM
    option = found["options"][0]
    assert option["category"] != "road/compound"  # what an engineer sets, where one does it
    # independent evolutions: none visible with the change, visible at the bracket's other end
    cycle_shares = params.wear.cycle_shares()
    at = wear_evolution(perturbed(params, option["key"], option["value"]), KM, cycle_shares)
    assert at.visible_km is None and at.depth_mm[-1] < params.wear.visible_depth_mm
    below = option["below"]
    if below is not None and below["visible_km"] is not None:
        before = wear_evolution(perturbed(params, option["key"], below["value"]), KM, cycle_shares)
        assert before.visible_km == pytest.approx(below["visible_km"], rel=1e-9)
    # worded at the top and in the design section
    assert "What stops the polygon" in result.overall["lines"][-1]
    assert f"({signed_percent(option['relative_change'])})" in result.overall["lines"][-1]
    html = (tmp_path / "report.html").read_text()
    assert "What stops the polygon, judged by the nonlinear evolution" in html
    assert f"{found['evolutions']} evolutions" in html


@pytest.mark.slow
def test_report_searches_one_grid_level_where_the_refined_search_is_over_budget(tmp_path, monkeypatch):
    """A model outside WEAR_DESIGN_REFINED_BY_DEFAULT (axle4dof; here tread1dof taken out of
    it, to keep the test short): one grid level, screened, refined by one round, and said so;
    the change found and the largest below it checked by independent evolutions."""
    from polywear.report import main
    from polywear.report.verdict import search_accuracy_note

    monkeypatch.setattr(main, "WEAR_DESIGN_REFINED_BY_DEFAULT", ())
    params = _car()
    result = main.report(params, tmp_path, wear_evolution_km=KM)
    assert result.settings.wear_design_by_evolution and not result.settings.wear_design_refined
    found = result.wear_design
    assert found["refined"] and found["refine_rounds"] == 1 and found["least_only"]
    option = found["options"][0]
    thirds = 3.0 * abs(math.log(option["value"] / option["nominal"])) / (math.log(4.0) / 8)
    assert min(abs(thirds - k) for k in (1, 2, 3)) < 1e-9  # a third of the first grid level, two, or all of it
    cycle = params.wear.cycle_shares()
    at = wear_evolution(perturbed(params, option["key"], option["value"]), KM, cycle)
    assert at.visible_km is None and option["evolution"]["depth_mm"] == pytest.approx(float(at.depth_mm[-1]),
                                                                                    rel=1e-12)
    if option["below"] is not None:  # else the bracket's lower end is the car as it is
        assert wear_evolution(perturbed(params, option["key"], option["below"]["value"]), KM, cycle).visible_km < KM
    note = search_accuracy_note(found, option)
    lower = "the car as it is" if option["below"] is None else signed_percent(option["below"]["relative_change"])
    assert (f"refined by 1 round of the search, not to its 2 %: the least change lies between {lower} (a visible "
            f"polygon) and {signed_percent(option['relative_change'])}") in note
    assert note in result.overall["lines"][-1]
    assert html_escape(note) in (tmp_path / "report.html").read_text()
    assert main.report_search(refined=False).screen is not None  # screened where it is coarse
    assert search_accuracy_note(found | {"refine_rounds": None}, option) == ""  # refined to its accuracy
    assert "not refined" in search_accuracy_note(found | {"refined": False}, option)


def test_no_wear_design_turns_it_off(tmp_path):
    """``--no-wear-design``: the evolutions run, the search does not (``wear_design`` null,
    recorded as off); the command line has the flag pair."""
    from polywear.report.main import report

    off = report(_car(), tmp_path, wear_evolution_km=KM, wear_design_by_evolution=False)
    assert dict(off.wear.evolutions)["drive cycle"].visible_km < KM  # a search would have run
    assert off.wear_design is None and not off.settings.wear_design_by_evolution
    assert json.loads((tmp_path / "summary.json").read_text())["wear_design"] is None
    assert "What stops the polygon" not in " ".join(off.overall["lines"])
    code, out, _ = run_main(["report", "--help"])
    assert code == 0 and "--no-wear-design" in out


def test_the_other_direction_of_an_unrefined_change_is_worded_beside_it():
    """Where both directions of a key meet at the searched grid level (the axle4dof default
    car: tread stiffness -15.9 % and +18.9 %), the verdict and the design section give both."""
    from polywear.report.main import _wear_design_html
    from polywear.report.verdict import _stops

    found = {"target_km": 100000.0, "evolutions": 18, "refined": False, "refine_rounds": 0, "undecided": [],
             "not_found": [],
             "nominal_evolution": {"visible_km": 40506.0},
             "options": [{"key": "tread.lateral_stiffness_n_per_m", "label": "tread lateral stiffness",
                          "nominal": 1e6, "value": 8.409e5, "relative_change": -0.1591, "below": None,
                          "evolution": {"depth_mm": 0.0582, "visible_km": None},
                          "other_direction": {"value": 1.189e6, "relative_change": 0.1892,
                                              "evolution": {"depth_mm": 0.0123, "visible_km": None}}}]}
    line = _stops(found)
    assert "1e+06 N/m → 8.409e+05 N/m (−15.9 %) or → 1.189e+06 N/m (+18.9 %);" in line
    html = _wear_design_html(found)
    assert "8.409e+05 (−15.9 %)" in html and "1.189e+06 (+18.9 %) does it too (depth 0.012 mm, no visible polygon)" in html
    found["options"][0]["other_direction"] = None
    assert " or → " not in _stops(found) and "does it too" not in _wear_design_html(found)
