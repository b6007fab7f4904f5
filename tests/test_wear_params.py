"""The [wear] table and [[wear.cycle]]: defaults, TOML round trip, one-line errors."""

from __future__ import annotations

import math
import tomllib

import pytest

from polywear.params import ParameterError, Params, default_toml, load_params, to_toml, with_updates


def test_default_cycle_is_a_three_speed_mix_summing_to_one():
    shares = Params().wear.cycle_shares()
    assert [v for v, _ in shares] == [50.0, 80.0, 120.0]
    assert math.fsum(s for _, s in shares) == 1.0


def test_params_init_text_has_the_wear_keys_commented():
    text = default_toml()
    data = tomllib.loads(text)
    assert data["wear"]["visible_depth_mm"] == 0.1 and len(data["wear"]["cycle"]) == 3
    assert data["tire"]["contact_length_m"] == 0.11 and data["tire"]["tread_width_m"] == 0.16
    for line in text.splitlines():
        if line.startswith(("energetic_rate_mm3_per_j", "visible_depth_mm", "contact_length_m")):
            assert "#" in line and "[" in line.split("#", 1)[1], line
    assert "# drive cycle" in text


def test_cycle_round_trip_and_normalisation(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text(
        "[[wear.cycle]]\nspeed_kmh = 130\nshare = 0.333\n"
        "[[wear.cycle]]\nspeed_kmh = 90\nshare = 0.333\n"
        "[[wear.cycle]]\nspeed_kmh = 40\nshare = 0.333\n"
    )
    params = load_params(path)
    shares = params.wear.cycle_shares()
    assert [v for v, _ in shares] == [130.0, 90.0, 40.0]
    assert all(s == pytest.approx(1.0 / 3.0, rel=1e-12) for _, s in shares)
    again = tmp_path / "again.toml"
    again.write_text(to_toml(params, comments=True))
    assert load_params(again) == params


@pytest.mark.parametrize("override, fragments", [
    ("wear.cycle=[{speed_kmh=50, share=0.5}]", ["wear.cycle", "0.5", "sum to 1"]),
    ("wear.cycle=[]", ["wear.cycle", "at least one"]),
    ("wear.cycle=[{speed_kmh=50, share=0.5}, {speed_kmh=50, share=0.5}]", ["wear.cycle", "50.0", "more than once"]),
    ("wear.cycle=[{speed_kmh=50, share=-1}]", ["wear.cycle.0.share", "-1", "greater than 0"]),
    ("wear.cycle=[{speed_kmh=0, share=1}]", ["wear.cycle.0.speed_kmh", "0", "greater than 0"]),
    ("wear.cycle=[{speed_kmh=50, share=1, mode=2}]", ["wear.cycle.0.mode", "unknown key"]),
    ("wear.cycle=[{speed_kmh=50}]", ["wear.cycle.0.share", "missing"]),
    ("wear.max_order=360", ["wear.max_order", "360", "wear.profile_points"]),
    ("wear.max_order=2.5", ["wear.max_order", "2.5", "integer"]),
    ("wear.seed=-1", ["wear.seed", "-1"]),
    ("wear.energetic_rate_mm3_per_j=0", ["wear.energetic_rate_mm3_per_j", "greater than or equal to 0.000001"]),
    ("wear.visible_depth_mm=-0.1", ["wear.visible_depth_mm", "-0.1", "greater than 0"]),
    ("tire.contact_length_m=0", ["tire.contact_length_m", "greater than or equal to 0.01"]),
])
def test_bad_wear_values_give_one_line(override, fragments):
    with pytest.raises(ParameterError) as exc:
        load_params(overrides=[override])
    message = str(exc.value)
    assert "\n" not in message
    for fragment in fragments:
        assert fragment in message, (fragment, message)


def test_wear_keys_are_not_study_keys():
    from polywear.params import study_keys

    assert not [k for k in study_keys() if k.startswith("wear.")]
    assert with_updates(Params(), {"wear.max_order": 30}).wear.max_order == 30
