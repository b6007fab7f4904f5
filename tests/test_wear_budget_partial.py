"""An evolution stopped at its step budget is not lost: the evolution up to there comes with
the error (``StepBudgetError.partial``), the report keeps it and says how far the wear is
judged, and ``polywear wear evolve`` writes it before its one-line error.

Oracle: the partial evolution is the first part of the same evolution run without a budget,
step for step (the steps are deterministic, so the prefix must agree bit for bit)."""

from __future__ import annotations

import numpy as np
import pytest

import polywear.wear.evolution as evolution
from polywear.params import Params, with_updates
from polywear.wear.evolution import EvolutionSettings, StepBudgetError, wear_evolution

from .cli_runner import run_main

STEADY = {"operating.speed_kmh": 40.0, "wear.max_order": 30, "wear.cycle": [{"speed_kmh": 45.0, "share": 1.0}]}
"""A car that rolls steadily at its speeds: windows of 3 revolutions, steps that grow (cheap)."""


def test_a_budget_stop_keeps_the_evolution_up_to_there():
    """The default car at 120 km/h (it vibrates) with a budget of 4 steps over 8 000 km."""
    whole = wear_evolution(Params(), 8000.0, cycle=((120.0, 1.0),), workers=1)
    with pytest.raises(StepBudgetError) as stop:
        wear_evolution(Params(), 8000.0, cycle=((120.0, 1.0),), settings=EvolutionSettings(max_steps=3), workers=1)
    part = stop.value.partial
    assert whole.complete and not part.complete
    n = part.distance_km.size
    assert 1 < n < whole.distance_km.size and part.distance_km[-1] == stop.value.done_km
    np.testing.assert_array_equal(part.distance_km, whole.distance_km[:n])
    np.testing.assert_array_equal(part.harmonics, whole.harmonics[:n])
    np.testing.assert_array_equal(part.vibration_order, whole.vibration_order[: n - 1])
    summary = part.summary()
    assert summary["complete"] is False and summary["requested_km"] == 8000.0
    assert summary["distance_km"] == stop.value.done_km
    assert whole.summary()["complete"] is True


def test_a_work_budget_stops_the_evolution_where_its_windows_add_up_past_it():
    """The same car with a budget of simulated revolutions: it stops at the first step after
    its windows passed the budget, keeps the same prefix, and says which budget it was."""
    whole = wear_evolution(Params(), 8000.0, cycle=((120.0, 1.0),), workers=1)
    budget = whole.settings["simulated_revolutions"] // 2
    with pytest.raises(StepBudgetError, match="simulated revolutions") as stop:
        wear_evolution(Params(), 8000.0, cycle=((120.0, 1.0),), settings=EvolutionSettings(max_revolutions=budget),
                       workers=1)
    part = stop.value.partial
    n = part.distance_km.size
    assert not part.complete and 1 < n < whole.distance_km.size
    np.testing.assert_array_equal(part.harmonics, whole.harmonics[:n])
    assert part.settings["simulated_revolutions"] > budget
    with pytest.raises(ValueError, match="max_revolutions"):
        EvolutionSettings(max_revolutions=0)


@pytest.fixture
def budget_of_three(monkeypatch):
    monkeypatch.setattr(evolution, "step_budget", lambda distance_km, settings: 3)


def test_the_report_keeps_a_stopped_evolution_and_says_how_far_the_wear_is_judged(tmp_path, budget_of_three):
    import matplotlib.pyplot as plt

    from polywear.report.verdict import glance
    from polywear.report.wear import wear_html, wear_section

    def save(fig, name, caption):
        plt.close(fig)

    result = wear_section(with_updates(Params(), STEADY), (20.0, 120.0), save, tmp_path, evolution_km=20000.0)
    section = result.summary()
    for ev in section["evolutions"]:
        assert ev["complete"] is False and ev["requested_km"] == 20000.0 and 0.0 < ev["distance_km"] < 20000.0
    assert (tmp_path / "wear_evolution_cycle.nc").exists()
    reached = section["evolutions"][0]["distance_km"]
    assert f"no visible polygon within {reached:,.0f} km" in " ".join(section["sentences"])
    assert "stopped there, at its step budget, short of the 20,000 km asked" in " ".join(section["sentences"])
    assert "(stopped at its step budget)" in wear_html(section)
    summary = {"operating": {"speed_kmh": 40.0}, "design": {"operating_range_kmh": [80.0, 130.0], "options": [],
                                                             "reason": "r"}}
    judged = {"vibrates": False, "visible_km": {"drive cycle": None}, "polygon_visible": False,
              "wear_stopped_km": reached, "dominant_order": None, "design_options": [], "point_contact": None,
              "patch": None}
    lines = glance(summary, judged, Params())
    assert lines[0].startswith("At risk: not from vibration") and f"within {reached:,.0f} km, beyond not judged" in lines[0]
    assert "nothing wears into a polygon" not in lines[1]


def test_wear_evolve_writes_the_stopped_evolution_then_says_why(tmp_path, budget_of_three):
    out = tmp_path / "worn.nc"
    args = ["wear", "evolve", "--distance-km", "20000", "--speed", "45", "-o", str(out), "-q"]
    code, stdout, err = run_main([*args, *[a for k, v in STEADY.items() if k != "wear.cycle"
                                           for a in ("-s", f"{k}={v}")]])
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2 and len(lines) == 1 and "budget of 3 distance steps" in lines[0]
    assert "is written" in lines[0] and out.exists()
    import xarray as xr

    with xr.open_dataset(out) as ds:
        assert ds.attrs["complete"] == "False" and 0.0 < float(ds.distance_km[-1]) < 20000.0


@pytest.mark.slow
def test_a_whole_report_with_a_stopped_evolution_says_so_at_the_top(tmp_path, budget_of_three):
    """Toe 0.05 deg (no SEV band in 20-300 km/h): its evolutions stop at a budget of 3 steps;
    the report is written whole, its summary says how far, and its verdict does not say "no"."""
    import json

    from polywear.report.main import report

    report(with_updates(Params(), {"operating.toe_deg": 0.05}), tmp_path, wear_evolution_km=60000.0)
    summary = json.loads((tmp_path / "summary.json").read_text())
    evolutions = summary["wear"]["evolutions"]
    assert evolutions and all(ev["complete"] is False and ev["distance_km"] < 60000.0 for ev in evolutions)
    reached = min(ev["distance_km"] for ev in evolutions if ev.get("start", "rest") == "rest")
    glance, lines = summary["verdict"]["glance"], summary["verdict"]["lines"]
    assert all(ev["visible_km"] is None for ev in evolutions)  # three steps are far short of ~26 000 km
    assert glance[0].startswith("At risk: not from vibration") and "beyond not judged" in glance[0]
    assert any(f"does not wear into a visible polygon within {reached:,.0f} km" in line for line in lines)
    assert summary["verdict"]["wear_stopped_km"] == reached
    assert (tmp_path / "report.html").exists()
