"""``polywear wear``: JSON format, files, and one-line errors for bad input."""

from __future__ import annotations

import json
import math

import pytest

from .cli_runner import run_main

ROW_KEYS = {"speed_kmh", "order", "frequency_hz", "growth_per_1000km", "efold_km", "drift_deg_per_rev",
            "rolling_stable", "note"}


def test_wear_map_json_one_row_per_speed():
    code, out, _ = run_main(["wear", "map", "--speeds", "40,110,210", "--json", "-q"])
    assert code == 0
    summary = json.loads(out)
    assert summary["model"] == "tread1dof" and len(summary["rows"]) == 3
    assert all(set(row) == ROW_KEYS for row in summary["rows"])
    slow, vibrating, fast = summary["rows"]
    assert slow["rolling_stable"] and slow["efold_km"] > 0 and 100 < slow["frequency_hz"] < 200
    assert not vibrating["rolling_stable"] and vibrating["note"] == "vibrating: see evolution"
    assert vibrating["efold_km"] is None and vibrating["order"] is None
    assert fast["order"] < slow["order"]
    lo, hi = summary["linear_band_kmh"][0]
    assert lo < 110 < hi


def test_wear_map_all_orders_and_files(tmp_path):
    nc, csv, png = tmp_path / "m.nc", tmp_path / "m.csv", tmp_path / "m.png"
    code, out, err = run_main(["wear", "map", "--speeds", "45,230", "--max-order", "30", "--all-orders", "--json",
                               "-o", str(nc), "--plot", str(png)])
    assert code == 0, err
    assert len(json.loads(out)["rows"]) == 60
    assert nc.stat().st_size > 0 and png.stat().st_size > 0
    code, _, err = run_main(["wear", "map", "--speeds", "45", "-o", str(csv), "-q"])
    assert code == 0, err
    assert csv.read_text().splitlines()[0].startswith("speed_kmh,order,")


@pytest.mark.parametrize("args, fragment", [
    (["--speeds", "40,abc"], "--speeds"),
    (["--speeds", "0,40"], "speed 0"),
    (["--speeds", ""], "no speed"),
    (["--max-order", "0"], "--max-order"),
    (["--out", "x.txt"], "--out"),
    (["--set", "wear.max_order=-3"], "wear.max_order"),
])
def test_wear_map_bad_input_is_one_line_exit_2(args, fragment):
    code, out, err = run_main(["wear", "map", *args])
    assert code == 2 and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and fragment in lines[0], err


def test_wear_evolve_json_and_files(tmp_path):
    nc, png = tmp_path / "e.nc", tmp_path / "polar.png"
    code, out, err = run_main(["wear", "evolve", "--speed", "40", "--distance-km", "2000", "--step-km", "1000",
                               "--json", "-q", "-o", str(nc), "--polar", str(png), "--polar-km", "0,2000"])
    assert code == 0, err
    summary = json.loads(out)
    assert summary["distance_km"] == 2000.0 and summary["distances_scale_as"] == "1/k_e"
    assert summary["cycle"] == [{"speed_kmh": 40.0, "share": 1.0, "vibration_order_end": None, "locked_fraction": 0.0}]
    assert summary["final_depth_mm"] > summary["initial_depth_mm"] > 0 and summary["visible_km"] is None
    import xarray as xr

    with xr.open_dataset(nc, engine="h5netcdf") as ds:
        assert ds["w"].dims == ("distance_km", "angle_deg") and ds.sizes["angle_deg"] == 720
    assert png.stat().st_size > 0


def test_wear_evolve_tolerance_reaches_the_steps(tmp_path):
    """--tolerance is the evolution's step tolerance (written with the result); a tighter one
    takes more distance steps (tread damping 60 N·s/m on the default cycle, docs/wear.md: 11
    steps at the default 0.01, 21 at 0.0025)."""
    import xarray as xr

    steps = []
    for tolerance in ("0.01", "0.0025"):
        nc = tmp_path / f"e{tolerance}.nc"
        code, out, err = run_main(["wear", "evolve", "-s", "tread.lateral_damping_ns_per_m=60", "--tolerance", tolerance,
                                   "-q", "-o", str(nc)])
        assert code == 0, err
        with xr.open_dataset(nc, engine="h5netcdf") as ds:
            assert float(ds.attrs["tolerance"]) == float(tolerance)
            steps.append(ds.sizes["distance_km"] - 1)
    assert steps[1] > steps[0]


def test_wear_evolve_workers_give_the_same_result():
    """--workers 2 simulates the cycle's two speeds in two threads: the same JSON as one."""
    args = ["wear", "evolve", "--cycle", "40:0.5,50:0.5", "--distance-km", "2000", "--step-km", "1000", "--json", "-q"]
    code, serial, err = run_main([*args, "--workers", "1"])
    assert code == 0, err
    code, parallel, err = run_main([*args, "--workers", "2"])
    assert code == 0, err
    assert json.loads(parallel) == json.loads(serial)


@pytest.mark.parametrize("args, fragment", [
    (["--cycle", "120:0.5,80:0.4"], "sum to 1"),
    (["--cycle", "120"], "speed:share"),
    (["--cycle", "120:0.5,120:0.5"], "more than once"),
    (["--cycle", "0:1"], "speed 0"),
    (["--speed", "50", "--cycle", "50:1"], "one of them"),
    (["--distance-km", "-5"], "--distance-km"),
    (["--step-km", "0"], "--step-km"),
    (["--revolutions", "2"], "--revolutions"),
    (["--polar", "x.gif"], "--polar"),
    (["--distance-km", "1000", "--polar-km", "500,2000"], "--polar-km"),
    (["--workers", "0"], "--workers"),
    (["--start", "pothole"], "--start"),
    (["--tolerance", "0"], "--tolerance"),
    (["--tolerance", "nan"], "--tolerance"),
    (["--tolerance", "0.6"], "--tolerance"),
    (["--speed", "110", "--start", "cycle"], "no hard self-excitation there"),  # the default car vibrates (soft)
])
def test_wear_evolve_bad_input(args, fragment):
    code, out, err = run_main(["wear", "evolve", *args])
    assert code == 2 and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and fragment in lines[0], err


def test_wear_design_json():
    code, out, err = run_main(["wear", "design", "--cycle", "40:0.5,50:0.5", "--target-km", "150000",
                               "-k", "tread.lateral_damping_ns_per_m", "--json", "-q"])
    assert code == 0, err
    summary = json.loads(out)
    assert summary["target_km"] == 150000.0 and summary["nominal_depth_at_target_mm"] > 0.1
    (option,) = summary["options"]
    assert option["key"] == "tread.lateral_damping_ns_per_m" and option["value"] > 80.0
    code, _, err = run_main(["wear", "design", "-k", "tread.mass", "-q"])
    assert code == 2 and "--key tread.mass" in err


@pytest.mark.slow
def test_wear_design_one_grid_level_from_the_command_line(monkeypatch):
    """``--levels 1 --no-refine`` (the quick look): the option is the first grid level
    (+18.9 % of the tread damping on the 110 km/h test car), worded with its evolution; the
    progress bar gets every evolution (the nominal car's, then each probe's)."""
    from contextlib import contextmanager

    from polywear.cli import common

    reports = []

    @contextmanager
    def recording(description, enabled=True):
        yield lambda done, total, message="": reports.append((description, done, message))

    monkeypatch.setattr(common, "progress", recording)
    args = ["wear", "design", "--judge", "evolution", "--target-km", "4000", "--cycle", "110:1",
            "-s", "wear.energetic_rate_mm3_per_j=0.01", "-k", "tread.lateral_damping_ns_per_m",
            "--levels", "1", "--no-refine"]
    code, out, err = run_main([*args, "--json", "-q"])
    assert [(d, n) for d, n, _ in reports] == [("wear design [evolutions]", 0), ("wear design [evolutions]", 1),
                                               ("wear design [evolutions]", 2)], reports
    assert reports[0][2].startswith("nominal: visible after") and reports[1][2].startswith("tread.lateral_damping")
    assert code == 0, err
    summary = json.loads(out)
    (option,) = summary["options"]
    assert option["relative_change"] == pytest.approx(4.0 ** 0.125 - 1.0, rel=1e-12) and not summary["refined"]
    assert summary["evolutions"] == 2 and option["evolution"]["visible_km"] is None
    code, out, err = run_main([*args, "-q"])
    assert code == 0 and "-> 95.14 (+18.9%), evolution over 4,000 km" in out, err
    code, _, err = run_main([*args[:-2], "--levels", "0", "-q"])
    assert code == 2 and "--levels" in err
    # one round of refinement (the axle4dof report's search): one direction open, so a
    # trisection of the first level (two probes more); the option at a third, two or three of it
    code, out, err = run_main([*args[:-1], "--rounds", "1", "--json", "-q"])
    assert code == 0, err
    summary = json.loads(out)
    (option,) = summary["options"]
    thirds = 3.0 * math.log1p(option["relative_change"]) / math.log(4.0 ** 0.125)
    assert min(abs(thirds - k) for k in (1, 2, 3)) < 1e-9 and summary["refine_rounds"] == 1
    assert summary["evolutions"] == 4 and option["evolution"]["visible_km"] is None
    code, _, err = run_main([*args[:-1], "--rounds", "0", "-q"])
    assert code == 2 and "--rounds" in err
    code, _, err = run_main([*args, "--rounds", "1", "-q"])  # with --no-refine
    assert code == 2 and "--rounds 1 with --no-refine: there is no refinement to bound" in err
