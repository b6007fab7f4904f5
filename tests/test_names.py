"""Renamed summary keys: the new name, and beside it the old one until the next release (CHANGELOG.md)."""

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
