"""End-to-end CLI: stability, bifurcation (both methods), design, report; bad input."""

import json

import pytest

from .cli_runner import run_main


def test_stability_json_matches_model_md():
    code, out, err = run_main(["stability", "--speed-range", "5", "300", "--json"])
    assert code == 0, err
    s = json.loads(out)
    assert set(s) >= {"model", "hopf_speeds_kmh", "hopf_frequencies_hz", "linear_band_kmh", "unstable_intervals_kmh"}
    assert s["unstable_intervals_kmh"] == s["linear_band_kmh"]  # the old name, until the next release
    assert s["model"] == "tread1dof"
    assert [round(v, 1) for v in s["hopf_speeds_kmh"]] == [58.1, 207.8]
    assert [round(v) for v in s["hopf_frequencies_hz"]] == [127, 147]


def test_stability_axle4dof_finds_the_second_unstable_mode():
    code, out, err = run_main(["stability", "--json", "-s", "model=axle4dof",
                               "-s", "axle.toe_damping_nms_per_rad=144", "-s", "axle.camber_damping_nms_per_rad=83"])
    assert code == 0, err
    modes = {h["mode"]: h for h in json.loads(out)["hopf_points"] if h["crossing"] == "destabilizing"}
    assert "alpha" in modes and 35.0 < modes["alpha"]["speed_kmh"] < 45.0  # toe mode from about 40 km/h
    assert 20.0 < modes["alpha"]["frequency_hz"] < 30.0


def test_bifurcation_json_and_files(tmp_path):
    code, out, err = run_main(["bifurcation", "--json", "-q", "--out", str(tmp_path / "b.nc"),
                               "--csv", str(tmp_path / "b.csv"), "--plot", str(tmp_path / "b.png")])
    assert code == 0, err
    s = json.loads(out)
    for key in ("hopf_points", "folds", "linear_band_kmh", "sev_band_kmh", "first_bifurcation_speed_kmh",
                "second_bifurcation_speed_kmh", "trigger_amplitude"):
        assert key in s
    assert s["folds"][0]["speed_kmh"] == pytest.approx(254.74, abs=0.05)
    assert all((tmp_path / f).stat().st_size > 0 for f in ("b.nc", "b.csv", "b.png"))


@pytest.mark.slow
def test_sweep_method_brackets_the_continuation_bands():
    code, out, err = run_main(["bifurcation", "--method", "sweep", "--n-speeds", "15", "--speed-range",
                               "40", "280", "--json", "-q"])
    assert code == 0, err
    s = json.loads(out)
    spacing = s["grid_spacing_kmh"]
    # continuation: SEV 58.08-254.74 km/h, linear band 58.08-207.75 km/h
    assert 58.08 <= s["first_bifurcation_speed_kmh"] < 58.08 + spacing
    assert 254.74 - spacing < s["second_bifurcation_speed_kmh"] <= 254.74
    lo, hi = s["linear_band_kmh"][0]
    assert 58.08 <= lo < 58.08 + spacing and 207.75 - spacing < hi <= 207.75


@pytest.mark.parametrize(
    "args, message",
    [
        (["bifurcation", "--speed-range", "100", "50"], "--speed-range"),
        (["bifurcation", "-s", "tread.mass_kg=-1"], "tread.mass_kg"),
        (["stability", "-s", "operating.toe_deg=nan"], "operating.toe_deg"),
        (["design", "--param", "tread.nonsense"], "tread.nonsense"),
        (["report", "--operating-range", "130", "80"], "--operating-range"),
    ],
)
def test_bad_input_is_one_line_and_exit_code_2(args, message):
    code, out, err = run_main(args)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and message in lines[0]
    assert "Traceback" not in err


EVOLUTION_FIELDS = {"label", "distance_km", "cycle", "final_depth_mm", "dominant_order", "visible_depth_mm",
                    "visible_km", "mean_wear_mm", "energetic_rate_mm3_per_j", "distances_scale_as"}


@pytest.mark.slow
def test_report_writes_everything(tmp_path):
    """The defaults, with the evolutions by default (wear.report_km, here shortened by the key)."""
    code, out, err = run_main(["report", "--out", str(tmp_path), "--json", "-q", "--set", "wear.report_km=30000"])
    assert code == 0, err
    s = json.loads(out)
    assert s["operating"]["regime"] == "unstable rolling (soft SEV)"
    assert s["operating"]["sev_amplitude_x_mm"] == pytest.approx(0.27, rel=0.05)
    assert s["operating"]["sev_amplitude_x_m"] == pytest.approx(1e-3 * s["operating"]["sev_amplitude_x_mm"], rel=1e-15)
    for name in ("report.html", "bifurcation.png", "phase_portraits.png", "sensitivity.png", "summary.json",
                 "bifurcation.nc", "cycles.csv", "params.toml", "wear_map.png", "wear_evolution_cycle.png",
                 "wear_evolution_cycle_polar.png", "wear_evolution_cycle_waterfall.png",
                 "wear_evolution_operating.png", "wear_evolution_operating.nc"):
        assert (tmp_path / name).stat().st_size > 0
    page = (tmp_path / "report.html").read_text()
    assert "self-excited vibration" in page
    operating, cycle = s["wear"]["evolutions"]
    assert (operating["label"], cycle["label"]) == ("operating speed", "drive cycle")
    assert EVOLUTION_FIELDS <= set(operating) and EVOLUTION_FIELDS <= set(cycle)
    assert operating["distance_km"] == cycle["distance_km"] == 30000.0
    # the default car wears into an 8-sided polygon after about 20 000 km on the default cycle (docs/wear.md)
    verdict = s["verdict"]
    assert verdict["vibrates"] and verdict["polygon_visible"] and verdict["dominant_order"] == cycle["dominant_order"] == 8
    assert "8-sided polygon becomes visible (0.1 mm) after about" in verdict["lines"][1]
    assert page.index(verdict["lines"][1][:40]) < page.index("<h2>Speed bands</h2>")  # at the top of the page


def test_report_wear_km_0_turns_the_evolution_off(tmp_path):
    """--wear-km 0: the dynamics and the wear map only; the verdict does not call the wear safe.
    (An operating range below the band keeps the design step short.)"""
    code, out, err = run_main(["report", "--out", str(tmp_path), "--json", "-q", "--wear-km", "0",
                               "--operating-range", "20", "30"])
    assert code == 0, err
    s = json.loads(out)
    assert s["wear"]["evolutions"] == [] and s["wear"]["headline"] == [] and s["wear"]["map_rows"]
    assert s["verdict"]["polygon_visible"] is None and "Wear evolution not run" in s["verdict"]["lines"][1]
    assert not list(tmp_path.glob("wear_evolution*"))
    assert "Evolution not run" in (tmp_path / "report.html").read_text()
    code, _, err = run_main(["report", "--out", str(tmp_path), "--wear-km", "-1"])
    assert code == 2 and "--wear-km" in err


def test_excitation_soft_and_hard_regions_end_on_the_right_attractor():
    code, out, err = run_main(["excitation", "--json"])
    assert code == 0, err
    soft, hard = json.loads(out)["portraits"]
    assert soft["regime"].startswith("soft") and hard["regime"].startswith("hard")
    (stable,) = soft["cycles"]
    assert all(r["outcome"] == "cycle" for r in soft["runs"])
    assert all(r["final_amplitude_x_mm"] == pytest.approx(stable["amplitude_x_mm"], rel=1e-5) for r in soft["runs"])
    unstable, stable = hard["cycles"]
    assert not unstable["stable"] and stable["stable"]
    outcome = {r["start"]: r for r in hard["runs"]}
    assert outcome["near steady rolling"]["outcome"] == outcome["inside cycle 1"]["outcome"] == "equilibrium"
    for start in ("outside cycle 1", "inside cycle 2", "outside cycle 2"):
        assert outcome[start]["final_amplitude_x_mm"] == pytest.approx(stable["amplitude_x_mm"], rel=1e-5)
