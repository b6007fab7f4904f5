"""The wear section of the report: map always, evolution on request, verdict in words."""

from __future__ import annotations

import math

import pytest

from polywear.wear.evolution import EvolutionSettings
from polywear.params import Params, with_updates
from polywear.report.wear import _round_km, wear_headline, wear_html, wear_section, wear_sentences


def test_sentences_say_sides_distance_and_locking():
    section = {
        "energetic_rate_mm3_per_j": 1e-3,
        "map_rows": [{"speed_kmh": 110.0, "order": None, "frequency_hz": None, "growth_per_1000km": None,
                      "efold_km": None, "drift_deg_per_rev": None, "rolling_stable": False,
                      "note": "vibrating: see evolution"}],
        "evolutions": [{"label": "operating speed", "distance_km": 60000.0, "visible_km": 31234.0,
                        "visible_depth_mm": 0.1, "dominant_order": 18, "final_depth_mm": 0.4,
                        "cycle": [{"speed_kmh": 50.0, "share": 1.0, "vibration_order_end": 18.0, "locked_fraction": 0.6},
                                  {"speed_kmh": 110.0, "share": 1.0, "vibration_order_end": 9.37,
                                   "locked_fraction": 0.0}]}],
    }
    text = " ".join(wear_sentences(section))
    assert "18-sided polygon becomes visible (0.1 mm) after about 31,000 km" in text
    assert "at 110 km/h the tread vibrates at order 9.370, not locked to an integer order: its own pattern drifts" in text
    assert "at 50 km/h the tread vibrates at order 18.000, locked" in text
    assert "1/k_e" in text


def test_section_with_the_map_only(tmp_path):
    params = with_updates(Params(), {"operating.speed_kmh": 110.0})
    result = wear_section(params, (20.0, 300.0), lambda fig, name, caption: None, tmp_path)
    assert result.evolutions == [] and list(result.points.speeds_kmh) == [50.0, 80.0, 110.0, 120.0]
    section = result.summary()
    assert section["evolutions"] == [] and (tmp_path / "wear_map.nc").exists()
    speeds = [r["speed_kmh"] for r in section["map_rows"]]
    assert speeds == [50.0, 80.0, 110.0, 120.0]  # the cycle's speeds and the operating speed
    assert "vibrating" in " ".join(section["sentences"])
    assert "Evolution not run" in wear_html(section)


@pytest.mark.slow
def test_section_with_map_and_a_short_evolution(tmp_path):
    params = with_updates(Params(), {"operating.speed_kmh": 40.0, "wear.max_order": 30,
                                     "wear.cycle": [{"speed_kmh": 45.0, "share": 1.0}]})
    saved = {}

    def save(fig, name, caption):
        import matplotlib.pyplot as plt

        saved[name] = caption
        plt.close(fig)

    result = wear_section(params, (20.0, 120.0), save, tmp_path, evolution_km=2000.0, evolution=EvolutionSettings(step_km=2000.0))
    assert [label for label, _ in result.evolutions] == ["operating speed", "drive cycle"]
    section = result.summary()
    assert {"wear_map.png", "wear_evolution_operating.png", "wear_evolution_cycle_polar.png"} <= set(saved)
    assert (tmp_path / "wear_map.nc").exists() and (tmp_path / "wear_evolution_cycle.nc").exists()
    assert [r["speed_kmh"] for r in section["map_rows"]] == [40.0, 45.0]
    assert len(section["evolutions"]) == 2
    page = wear_html(section)
    assert "<h2>Polygonal wear</h2>" in page and "grows from small roughness" in page
    assert wear_html(None) == ""


def _speed(v, share, order=None, locked=False):
    return {"speed_kmh": v, "share": share, "vibration_order_end": order, "locked_fraction": float(locked),
            "locked_at_end": locked}


def _evolution(label, cycle, visible_km, order, efolds=5.4, distance_km=100_000.0):
    return {"label": label, "distance_km": distance_km, "visible_km": visible_km, "visible_depth_mm": 0.1,
            "dominant_order": order, "final_depth_mm": 0.3 if visible_km else 0.04,
            "growth_efolds": efolds if visible_km else None, "cycle": cycle}


def _section(*evolutions):
    return {"energetic_rate_mm3_per_j": 1e-3, "initial_roughness_um": 1.0, "map_rows": [],
            "evolutions": list(evolutions)}


DEFAULT_CYCLE = [_speed(50.0, 0.3), _speed(80.0, 0.4, 11.1), _speed(120.0, 0.3, 8.0, locked=True)]


def test_headline_gives_sides_and_km_on_the_cycle_and_alone_with_the_assumptions():
    section = _section(_evolution("operating speed", [_speed(110.0, 1.0, 8.52)], 29_600.0, 8),
                       _evolution("drive cycle", DEFAULT_CYCLE, 20_106.0, 8))
    lines = wear_headline(section)
    assert lines[0] == ("On the drive cycle (30 % at 50 km/h, 40 % at 80 km/h, 30 % at 120 km/h), an 8-sided polygon "
                        "becomes visible (0.1 mm) after about 20,000 km; at 110 km/h alone, after about 30,000 km.")
    text = " ".join(lines)
    assert "at 120 km/h the tread vibrates and locks to the tire at order 8" in text
    assert "At 80 km/h the tread vibrates at order 11.10 without locking to the tire" in text and "wears evenly" in text
    assert "scales as 1/k_e" in text and "factor of 10 either way" in text
    # ten times the roughness: ln(10) of the 5.4 e-folds of growth come for free
    expected = f"takes about {_round_km(20_106.0 * math.log(10.0) / 5.4)} km off"
    assert expected == "takes about 8,600 km off" and expected in text


def test_headline_without_a_visible_polygon_and_without_locking():
    section = _section(_evolution("operating speed", [_speed(110.0, 1.0, 8.52)], None, 9),
                       _evolution("drive cycle", [_speed(110.0, 1.0, 8.52)], None, 9))
    lines = wear_headline(section)
    assert lines[0].startswith("On the drive cycle (100 % at 110 km/h), no visible polygon within 100,000 km")
    assert "order 8.52 without locking" in lines[1] and "wears evenly" in lines[1]
    assert lines[1].endswith("the order that grows is the profile's own, 9.")
    assert "1 um" not in lines[-1]  # nothing grew to visible: no roughness statement
    assert wear_headline(_section()) == []


@pytest.mark.slow
def test_reported_distance_scales_as_one_over_k_e(tmp_path):
    """Independent of the evolution's own bookkeeping: the same car with k_e doubled, the
    same distance steps, reports the visible distance halved (to the step tolerance, 2 %), the
    same sides, and says so in the headline. (At 120 km/h alone the vibration locks at order 8.)"""
    sections = []
    for k_e in (1e-2, 2e-2):
        params = with_updates(Params(), {"operating.speed_kmh": 120.0, "wear.energetic_rate_mm3_per_j": k_e,
                                         "wear.max_order": 20, "wear.cycle": [{"speed_kmh": 120.0, "share": 1.0}]})
        sections.append(wear_section(params, (100.0, 140.0), lambda fig, name, caption: None, tmp_path, 1000.0,
                                     EvolutionSettings(step_km=100.0)).summary())
    (one, _), (two, _) = (s["evolutions"] for s in sections)
    assert one["visible_km"] is not None and two["visible_km"] == pytest.approx(one["visible_km"] / 2.0, rel=0.02)
    assert one["dominant_order"] == two["dominant_order"] == 8
    for s, ev in zip(sections, (one, two)):
        assert f"an 8-sided polygon becomes visible (0.1 mm) after about {_round_km(ev['visible_km'])} km" in s["headline"][0]


def test_headline_calls_a_locked_response_at_stable_rolling_forced():
    section = _section(_evolution("operating speed", [_speed(110.0, 1.0, 10.0, locked=True)], 28_000.0, 10),
                       _evolution("drive cycle", DEFAULT_CYCLE[:1], None, 9))
    section["map_rows"] = [{"speed_kmh": 50.0, "rolling_stable": True}, {"speed_kmh": 110.0, "rolling_stable": True}]
    lines = wear_headline(section)
    assert lines[0].endswith("at 110 km/h alone, a 10-sided polygon becomes visible (0.1 mm) after about 28,000 km.")
    assert lines[1] == "At 110 km/h the tread's forced response to the growing pattern locks to the tire at order 10."


def test_headline_gives_both_outcomes_where_a_pothole_starts_the_large_vibration():
    rest = _evolution("operating speed", [_speed(110.0, 1.0)], None, 10)
    kicked = dict(_evolution("operating speed, from the large vibration", [_speed(110.0, 1.0, 9.07)], 41_000.0, 9),
                  start="cycle")
    section = _section(dict(rest, start="rest"), kicked)
    section["cycle_start_kmh"] = [110.0]
    section["map_rows"] = [{"speed_kmh": 110.0, "rolling_stable": True}]
    lines = wear_headline(section)
    assert lines[0].startswith("From steady rolling: at 110 km/h alone, no visible polygon within 100,000 km")
    assert lines[1] == ("After a pothole starts the large vibration at 110 km/h (steady rolling is stable there, but a "
                        "large stable cycle coexists with it: hard self-excitation): at 110 km/h alone, a 9-sided "
                        "polygon becomes visible (0.1 mm) after about 41,000 km (at 110 km/h the tread keeps vibrating "
                        "at order 9.07, without locking to the tire).")
    # the assumptions and the rest of the headline are those of the evolution from rest
    assert "1 um" not in lines[-1]
    cycle = [_speed(50.0, 0.5, 18.4), _speed(110.0, 0.5, 9.07)]
    section["evolutions"].append(dict(_evolution("drive cycle, from the large vibration", cycle, None, 13),
                                      start="cycle"))
    assert "; on the drive cycle (50 % at 50 km/h, 50 % at 110 km/h), no visible polygon" in wear_headline(section)[1]
    assert wear_headline(_section(dict(rest, start="rest")))[0].startswith("At 110 km/h alone, no visible")


@pytest.mark.slow
def test_section_of_a_hard_car_evolves_from_rest_and_from_the_cycle(tmp_path):
    """Toe 1.0 deg: at 110 km/h steady rolling is stable beside a stable cycle (hard region
    103.9-127.4 km/h); the section runs the evolution from rest and, where the diagram shows
    the hard region, from the cycle, with the same fields plus its start."""
    from polywear.dynamics.bifurcation import bifurcation

    params = with_updates(Params(), {"operating.toe_deg": 1.0, "wear.cycle": [{"speed_kmh": 110.0, "share": 1.0}]})
    diagram = bifurcation(params)
    result = wear_section(params, (20.0, 300.0), lambda fig, name, caption: None, tmp_path, 5000.0, diagram=diagram)
    assert result.cycle_start_kmh == [110.0]
    section = result.summary()
    assert [ev["label"] for ev in section["evolutions"]] == [
        "operating speed", "drive cycle", "operating speed, from the large vibration",
        "drive cycle, from the large vibration"]  # the drive cycle is the operating speed alone
    rest, _, kicked, _ = section["evolutions"]
    assert (rest["label"], rest["start"]) == ("operating speed", "rest")
    assert (kicked["label"], kicked["start"]) == ("operating speed, from the large vibration", "cycle")
    assert set(rest) == set(kicked)
    assert rest["cycle"][0]["vibration_order_end"] is None and kicked["cycle"][0]["vibration_order_end"] > 9.0
    assert (tmp_path / "wear_evolution_operating_from_cycle.nc").exists()
    assert section["headline"][1].startswith("After a pothole starts the large vibration at 110 km/h")
    without = wear_section(params, (20.0, 300.0), lambda fig, name, caption: None, tmp_path, 5000.0)
    assert without.from_cycle == [] and without.summary()["evolutions"][0] == rest


def test_an_evolution_that_creeps_still_says_where_it_is():
    """Progress at every tenth of the distance, and every STEPS_BETWEEN_NOTES steps where the
    distance creeps (a car near locking: fleet car 187 took 208 steps for 28 km)."""
    from polywear.report.wear import STEPS_BETWEEN_NOTES, _tenths

    said = []
    forward = _tenths(lambda done, total, message: said.append(message))
    for step in range(1, 2 * STEPS_BETWEEN_NOTES + 11):
        forward(0.01 * step, 1000.0)  # creeping: 10 m per step
    assert said == [f"{0.01 * k:,.0f} of 1,000 km, {k} distance steps" for k in (STEPS_BETWEEN_NOTES, 2 * STEPS_BETWEEN_NOTES)]
    said.clear()
    forward = _tenths(lambda done, total, message: said.append(message))
    for km in (50.0, 100.0, 250.0, 1000.0):
        forward(km, 1000.0)
    assert said == ["100 of 1,000 km, 2 distance steps", "250 of 1,000 km, 3 distance steps",
                    "1,000 of 1,000 km, 4 distance steps"]
