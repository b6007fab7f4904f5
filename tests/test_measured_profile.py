"""Measured worn-tire profiles (measured/profile.py, `polywear measure profile`): spectra
against closed forms, outliers, noise floors, and one clear line for every bad file."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from polywear.measured.profile import FLOOR_SIGMAS, ProfileError, peak_to_valley_mm, read_profiles

from .cli_runner import run_main


def _write(path, header, rows):
    path.write_text(header + "\n" + "\n".join(",".join(f"{v}" for v in row) for row in rows) + "\n")
    return path


def _polygon(angle_deg, order, amplitude_mm, phase=0.3, depth_mm=7.0):
    return depth_mm - amplitude_mm * np.cos(np.radians(order * np.asarray(angle_deg)) + phase)


def test_a_sampled_pure_polygon_comes_back_exactly(tmp_path):
    angle = np.arange(72) * 5.0
    f = _write(tmp_path / "p.csv", "angle_deg,depth_mm", zip(angle, _polygon(angle, 9, 0.05)))
    (p,) = read_profiles([f]).profiles
    assert p.dominant_order == 9
    assert p.outliers_deg == () and not p.notes  # rounding is no stone in the groove (it dropped 7 of 72)
    assert p.amplitude_mm[8] == pytest.approx(0.05, rel=1e-12)
    others = np.delete(p.amplitude_mm, 8)
    assert others.max() < 1e-12
    assert p.peak_to_valley_mm == pytest.approx(0.1, rel=1e-5)  # 2 a for a pure harmonic


def test_uneven_sampling_and_a_30_degree_gap_stay_within_the_stated_error(tmp_path):
    rng = np.random.default_rng(5)
    angle = np.sort(rng.uniform(0.0, 360.0, 70))
    angle = angle[(angle < 200.0) | (angle > 230.0)]  # one gap of 30 degrees
    depth = _polygon(angle, 8, 0.06) + rng.normal(0.0, 0.01, angle.size)
    f = _write(tmp_path / "p.csv", "angle [deg],depth [mm]", [(f"{a:.4f}", f"{d:.4f}") for a, d in zip(angle, depth)])
    (p,) = read_profiles([f]).profiles
    assert p.dominant_order == 8
    assert abs(p.amplitude_mm[7] - 0.06) < 3.0 * p.std_error_mm[7]
    assert p.significant[7]  # the error is stated, and the polygon stands above it


def test_the_stated_error_is_the_scatter_of_the_amplitude_over_noise_draws(tmp_path):
    """The fit's covariance against a Monte Carlo of the same sampling: within 20 %."""
    angle = np.arange(36) * 10.0
    amps, stated = [], []
    rng = np.random.default_rng(11)
    for i in range(200):
        depth = _polygon(angle, 6, 0.05) + rng.normal(0.0, 0.02, 36)
        f = _write(tmp_path / f"p{i}.csv", "angle_deg,depth_mm", [(a, f"{d:.6f}") for a, d in zip(angle, depth)])
        (p,) = read_profiles([f]).profiles
        amps.append(p.amplitude_mm[5])
        stated.append(p.std_error_mm[5])
    assert np.std(amps) == pytest.approx(np.mean(stated), rel=0.2)
    assert np.mean(amps) == pytest.approx(0.05, abs=3 * np.std(amps) / math.sqrt(200))


def test_noise_alone_stays_below_the_floor(tmp_path):
    rng = np.random.default_rng(2)
    angle = np.arange(72) * 5.0
    hits = 0
    for i in range(40):
        f = _write(tmp_path / f"n{i}.csv", "angle_deg,depth_mm",
                   [(a, f"{7 + d:.5f}") for a, d in zip(angle, rng.normal(0, 0.02, 72))])
        (p,) = read_profiles([f]).profiles
        hits += int(p.significant.sum())
    # expected exp(-FLOOR^2/2) per order: 3e-4 x 26 orders x 40 files = 0.3
    assert hits <= 2
    assert FLOOR_SIGMAS >= 4


def test_a_stone_in_the_groove_is_named_and_left_out(tmp_path):
    angle = np.arange(36) * 10.0
    depth = _polygon(angle, 8, 0.08) + np.random.default_rng(1).normal(0, 0.01, 36)
    depth[5] -= 1.5  # a stone reads 1.5 mm shallower at 50 degrees
    f = _write(tmp_path / "s.csv", "angle_deg,depth_mm", [(a, f"{d:.3f}") for a, d in zip(angle, depth)])
    (p,) = read_profiles([f]).profiles
    assert p.outliers_deg == (50.0,)
    assert any("stone" in note for note in p.notes)
    assert p.dominant_order == 8 and abs(p.amplitude_mm[7] - 0.08) < 3 * p.std_error_mm[7]


def test_ribs_mileages_and_the_growth_between_them(tmp_path):
    angle = np.arange(48) * 7.5
    rows = [(rib, km, a, f"{d:.5f}") for rib in (1, 2) for km, amp in ((10000, 0.02), (20000, 0.04))
            for a, d in zip(angle, _polygon(angle, 10, amp))]
    f = _write(tmp_path / "g.csv", "rib,distance_km,angle_deg,depth_mm", rows)
    result = read_profiles([f])
    assert len(result.profiles) == 4 and result.dominant_order == 10
    growth = [g for g in result.growth() if g["order"] == 10]
    assert len(growth) == 2
    for g in growth:
        assert g["growth_per_1000km"] == pytest.approx(math.log(2.0) / 10.0, rel=1e-3)  # depths written to 1e-5 mm


def test_radius_in_metres_and_a_harmonics_table_give_the_same_polygon(tmp_path):
    angle = np.arange(60) * 6.0
    radius_m = 0.3 + _polygon(angle, 7, 0.03, depth_mm=0.0) * 1e-3
    f1 = _write(tmp_path / "r.csv", "angle_deg,radius_m", [(a, f"{r:.9f}") for a, r in zip(angle, radius_m)])
    f2 = _write(tmp_path / "h.csv", "order,amplitude_mm,phase_deg", [(7, 0.03, 17.2), (3, 0.001, 0.0)])
    a, b = read_profiles([f1, f2]).profiles
    assert a.dominant_order == b.dominant_order == 7
    assert a.amplitude_mm[6] == pytest.approx(0.03, rel=1e-5)
    assert b.amplitude_mm[6] == pytest.approx(0.03)
    assert peak_to_valley_mm(b.harmonics_mm) == pytest.approx(
        peak_to_valley_mm(np.where(np.arange(1, 8) == 7, b.harmonics_mm, 0)) , rel=0.1)


@pytest.mark.parametrize("header, rows, message", [
    ("angle_deg,depth_mm", [], "no readings"),
    ("angle_deg,depth_mm", [(0, 7.0)], "at least 6"),
    ("angle_deg,depth_mm", [(a, "nan" if a == 20 else 7.0) for a in range(0, 360, 10)], "not a finite number"),
    ("angle_deg,depth_mm", [(a * 11, 7.0) for a in range(36)], "outside 0..360"),
    ("angle_deg,depth_mm", [(350 - a * 10, 7.0) for a in range(36)], "not above the one before"),
    ("angle_deg,depth_mm", [(a * 10, 7000.0) for a in range(36)], "is not a tire's depth"),
    ("angle_deg,depth_mm", [(a * 10, 7.0) for a in range(36)] * 2, "two tires mixed"),
    ("angle_deg,depth", [(a * 10, 7.0) for a in range(36)], "has no unit"),
    ("angle_deg,width_mm", [(a * 10, 7.0) for a in range(36)], "neither a profile"),
])
def test_bad_files_get_one_clear_line(tmp_path, header, rows, message):
    f = _write(tmp_path / "bad.csv", header, rows)
    with pytest.raises(ProfileError, match=message):
        read_profiles([f])
    code, out, err = run_main(["measure", "profile", str(f)])
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and message.split()[0] in err


def test_cli_json_and_plot(tmp_path):
    angle = np.arange(36) * 10.0
    f = _write(tmp_path / "p.csv", "rib,angle_deg,depth_mm",
               [(r, a, f"{d:.3f}") for r in (1, 2) for a, d in zip(angle, _polygon(angle, 9, 0.07))])
    code, out, err = run_main(["measure", "profile", str(f), "--json", "--plot", str(tmp_path / "polar.png")])
    assert code == 0, err
    summary = json.loads(out)
    assert summary["dominant_order"] == 9
    assert summary["peak_to_valley_mm"] == pytest.approx(0.14, rel=0.02)
    assert (tmp_path / "polar.png").stat().st_size > 1000
    code, out, err = run_main(["measure", "profile", str(f), "--predict"])
    assert code == 2 and "go with --calibrate" in err
