"""Renamed summary keys: the new name, and beside it the old one until the next release (CHANGELOG.md)."""

import math

import pytest

from polywear.results import with_deprecated_keys


def test_old_key_follows_the_new_one_with_the_same_value():
    out = with_deprecated_keys({"a": 1, "linear_band_kmh": [[1.0, 2.0]], "z": None},
                               {"linear_band_kmh": "unstable_intervals_kmh", "absent": "gone"})
    assert list(out) == ["a", "linear_band_kmh", "unstable_intervals_kmh", "z"]
    assert out["unstable_intervals_kmh"] == out["linear_band_kmh"]
    assert "gone" not in out


def test_old_key_of_a_unit_change_holds_the_old_unit():
    out = with_deprecated_keys({"amplitude_x_mm": 0.27, "range_x_mm": [0.0, None]},
                               {"amplitude_x_mm": ("amplitude_x_m", 1e-3), "range_x_mm": ("range_x_m", 1e-3)})
    assert out["amplitude_x_m"] == pytest.approx(0.27e-3, rel=1e-15)
    assert out["range_x_m"] == [0.0, None]


@pytest.mark.parametrize("old, new", [("first_bifurcation_kmh", "first_bifurcation_speed_kmh"),
                                      ("amplitude_mm", "amplitude_x_mm"), ("polygon_order", "frequency_order")])
def test_observation_files_with_an_old_quantity_name_still_read(tmp_path, old, new):
    from polywear.measured.calibration import read_observations

    path = tmp_path / "obs.toml"
    path.write_text(f'[[observation]]\nquantity = "{old}"\nvalue = 1.0\nsigma = 0.1\nat_speed_kmh = 110.0\n')
    with pytest.warns(FutureWarning, match=new):
        (obs,) = read_observations(path)
    assert obs.quantity == new


def test_default_speed_ranges_come_from_units_by_kind_of_analysis():
    """docs/cli.md 'Default speed ranges': linear analyses 5-300, cycles and wear 20-300, fleets 10-600 km/h."""
    import inspect

    from polywear import units
    from polywear.dynamics.bifurcation import bifurcation
    from polywear.dynamics.stability import stability
    from polywear.measured.calibration import calibrate
    from polywear.params import Params, StudySpec
    from polywear.studies.fleet import FleetSpec

    def default(fn):
        return inspect.signature(fn).parameters["speed_range_kmh"].default

    assert default(stability) == default(calibrate) == units.STABILITY_SPEED_RANGE_KMH == (5.0, 300.0)
    assert default(bifurcation) == StudySpec().speed_range_kmh == units.DEFAULT_SPEED_RANGE_KMH == (20.0, 300.0)
    assert FleetSpec.model_fields["speed_range_kmh"].default == units.FLEET_SPEED_RANGE_KMH == (10.0, 600.0)
    # the stated reason for 20 km/h: a 150 Hz tread mode is within the wear map's orders there, not at 5 km/h
    radius, orders = Params().operating.rolling_radius_m, Params().wear.max_order
    at_20 = units.frequency_order(150.0, units.kmh_to_ms(20.0), radius)
    assert at_20 == pytest.approx(150.0 * 2 * math.pi * radius * 3.6 / 20.0, rel=1e-12) and at_20 <= orders
    assert units.frequency_order(150.0, units.kmh_to_ms(5.0), radius) > orders
