"""Parameter sets: the docs/model.md section 6 table, TOML round trips, validation messages."""

from __future__ import annotations

import math
import tomllib
import typing

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from polywear.keys import KEYS
from polywear.params import (
    ParameterError,
    Params,
    StudySpec,
    default_toml,
    flat_items,
    get_value,
    load_params,
    load_study,
    parse_override,
    to_toml,
    with_updates,
)

# docs/model.md section 6, typed in by hand: the oracle for keys and defaults.
SPEC_DEFAULTS = {
    "model": "tread1dof",
    "operating.speed_kmh": 110.0,
    "operating.toe_deg": 0.5,
    "operating.camber_deg": -1.0,
    "operating.vertical_load_n": 4000.0,
    "operating.rolling_radius_m": 0.30,
    "tread.mass_kg": 1.0,
    "tread.lateral_stiffness_n_per_m": 1.0e6,
    "tread.lateral_damping_ns_per_m": 80.0,
    "friction.sigma0_per_m": 400.0,
    "friction.sigma1_s_per_m": 0.05,
    "friction.sigma2_s_per_m": 0.002,
    "friction.mu_static": 0.9,
    "friction.mu_coulomb": 0.5,
    "friction.stribeck_velocity_m_per_s": 0.25,
    "friction.stribeck_exponent": 2.0,
    "friction.contact": "point",
    "friction.patch_elements": 40,
    "friction.patch_pressure": "parabolic",
    "axle.inertia_x_kgm2": 2.0,
    "axle.inertia_y_kgm2": 8.0,
    "axle.inertia_z_kgm2": 8.0,
    "axle.toe_stiffness_nm_per_rad": 2.58e5,
    "axle.toe_damping_nms_per_rad": 1440.0,
    "axle.camber_stiffness_nm_per_rad": 3.44e5,
    "axle.camber_damping_nms_per_rad": 830.0,
    "axle.pitch_stiffness_nm_per_rad": 5.06e3,
    "axle.pitch_damping_nms_per_rad": 304.0,
    "axle.arm_length_m": 0.45,
    "axle.lateral_offset_m": 0.0,
    "axle.pivot_height_m": 0.30,
    "axle.camber_thrust_factor": 0.1,
    "axle.wheel_spin_inertia_kgm2": 0.0,
    "axle.reference": "running",
    "tire.vertical_stiffness_n_per_m": 2.0e5,
    "tire.vertical_damping_ns_per_m": 100.0,
    # docs/model.md section 9 (wear): the contact patch
    "tire.contact_length_m": 0.11,
    "tire.tread_width_m": 0.16,
}
# The [study] table: settings of `polywear study` (docs/sensitivity.md), not model parameters
# (params.StudySpec, not a field of Params).
STUDY_DEFAULTS = {
    "study.method": "sobol",
    "study.outputs": "hopf",
    "study.n_base": 1024,
    "study.second_order": True,
    "study.morris_levels": 4,
    "study.seed": 12345,
    "study.bootstrap": 1000,
    "study.confidence": 0.95,
    "study.speed_range_kmh": (20.0, 300.0),
    "study.operating_range_kmh": (80.0, 130.0),
    "study.parameters": (),
}
# The [wear] table (docs/model.md section 9; tests/test_wear_params.py checks its validation).
WEAR_DEFAULTS = {
    "wear.energetic_rate_mm3_per_j": 1.0e-3,
    "wear.initial_roughness_um": 1.0,
    "wear.max_order": 60,
    "wear.profile_points": 720,
    "wear.seed": 0,
    "wear.visible_depth_mm": 0.1,
    "wear.report_km": 100_000.0,
}
CHOICES = {"model": ("tread1dof", "axle4dof"), "axle.reference": ("running", "unloaded")}
NUMERIC_KEYS = [k for k, v in SPEC_DEFAULTS.items() if isinstance(v, float)]


@pytest.mark.parametrize("key", sorted(SPEC_DEFAULTS))
def test_every_spec_key_exists_with_its_default(key):
    value = get_value(Params(), key)
    assert value == SPEC_DEFAULTS[key] and type(value) is type(SPEC_DEFAULTS[key])


def test_no_key_outside_the_spec_table():
    """A key that docs/model.md section 6 does not list must be added there (and here) first."""
    items = {key: value for key, value, _ in flat_items(Params())}
    assert len(items) == len(flat_items(Params()))
    expected = set(SPEC_DEFAULTS) | set(WEAR_DEFAULTS) | {"wear.cycle"}
    assert set(items) == expected, set(items) ^ expected
    with_study = {key: value for key, value, _ in flat_items(Params(), StudySpec())}
    assert set(with_study) == expected | set(STUDY_DEFAULTS), set(with_study) ^ (expected | set(STUDY_DEFAULTS))
    assert {k: with_study[k] for k in STUDY_DEFAULTS} == STUDY_DEFAULTS
    assert {k: items[k] for k in WEAR_DEFAULTS} == WEAR_DEFAULTS


def test_every_key_has_a_description_with_a_unit_or_choice():
    for key, _, description in flat_items(Params(), StudySpec()):
        assert description, key
        if key in NUMERIC_KEYS:
            assert "[" in description and "]" in description, f"{key}: no [unit] in {description!r}"


def test_choices_are_accepted():
    for key, options in CHOICES.items():
        for option in options:
            assert get_value(with_updates(Params(), {key: option}), key) == option


# -- random valid parameter sets -------------------------------------------------------------


def _bounds(key: str) -> dict[str, float | bool]:
    """Hypothesis float bounds from the key's registered bounds (polywear.keys)."""
    info = KEYS[key]
    out: dict[str, float | bool] = {"allow_nan": False, "allow_infinity": False,
                                    "min_value": -1e12, "max_value": 1e12}
    if math.isfinite(info.lower):
        out.update(min_value=info.lower, exclude_min=not info.lower_inclusive)
    if math.isfinite(info.upper):
        out.update(max_value=info.upper, exclude_max=not info.upper_inclusive)
    return out


@st.composite
def valid_updates(draw) -> dict[str, typing.Any]:
    """A full, valid set of {key: value} (mu_coulomb drawn below mu_static)."""
    updates: dict[str, typing.Any] = {key: draw(st.sampled_from(options)) for key, options in CHOICES.items()}
    for key in NUMERIC_KEYS:
        if key != "friction.mu_coulomb":
            updates[key] = draw(st.floats(**_bounds(key)))
    mu_s = updates["friction.mu_static"]
    updates["friction.mu_coulomb"] = draw(st.floats(KEYS["friction.mu_coulomb"].lower, mu_s))
    return updates


@settings(max_examples=150, deadline=None)
@given(updates=valid_updates(), comments=st.booleans())
def test_toml_round_trip_is_the_identity(updates, comments, tmp_path_factory):
    params = with_updates(Params(), updates)
    for key, value in updates.items():
        assert get_value(params, key) == value
    path = tmp_path_factory.mktemp("rt") / "p.toml"
    path.write_text(to_toml(params, comments=comments))
    assert load_params(path) == params


def test_default_file_loads_to_the_defaults(tmp_path):
    path = tmp_path / "d.toml"
    path.write_text(default_toml())
    assert load_params(path) == Params()
    assert load_study(path) == StudySpec()  # the default file holds the [study] table too
    assert tomllib.loads(default_toml())["friction"]["mu_static"] == 0.9


def test_file_then_overrides_in_that_order(tmp_path):
    path = tmp_path / "p.toml"
    path.write_text("[tread]\nmass_kg = 2\n[friction]\nmu_static = 1.2\n")
    params = load_params(path, ["tread.mass_kg=3.5", "model=axle4dof"])
    assert params.tread.mass_kg == 3.5 and params.friction.mu_static == 1.2 and params.model == "axle4dof"
    assert params.tread.lateral_stiffness_n_per_m == SPEC_DEFAULTS["tread.lateral_stiffness_n_per_m"]
    assert isinstance(load_params(path).tread.mass_kg, float)  # TOML integers become floats


def test_params_are_immutable():
    params = Params()
    with pytest.raises(Exception):
        params.tread.mass_kg = 2.0  # type: ignore[misc]
    with_updates(params, {"tread.mass_kg": 2.0})
    assert params.tread.mass_kg == 1.0


# -- validation errors: one line naming key, value and rule ------------------------------------


def check_message(exc: pytest.ExceptionInfo, *fragments: str) -> None:
    message = str(exc.value)
    assert "\n" not in message, message
    for fragment in fragments:
        assert fragment in message, f"{fragment!r} not in {message!r}"


BAD_VALUES = [
    # key, value, fragments the message must contain (key, value, rule)
    ("tread.mass_kg", -1.0, ["tread.mass_kg", "-1.0", "greater than or equal to 0.0001"]),
    ("tread.mass_kg", 0.0, ["tread.mass_kg", "0.0", "greater than or equal to 0.0001"]),
    ("friction.stribeck_velocity_m_per_s", 0.0, ["friction.stribeck_velocity_m_per_s", "0.0", "greater than or equal to 0.0001"]),
    ("friction.stribeck_velocity_m_per_s", -0.1, ["friction.stribeck_velocity_m_per_s", "-0.1", "greater than or equal to 0.0001"]),
    ("friction.mu_coulomb", 1.0, ["friction.mu_coulomb", "1.0", "must not exceed", "friction.mu_static", "0.9"]),
    ("friction.stribeck_exponent", 0.5, ["friction.stribeck_exponent", "0.5", "greater than or equal to 1"]),
    ("tread.lateral_damping_ns_per_m", -5.0, ["tread.lateral_damping_ns_per_m", "-5.0", "greater than or equal to 0"]),
    ("operating.toe_deg", 25.0, ["operating.toe_deg", "25.0", "less than 20"]),
    ("tread.mass_kg", "heavy", ["tread.mass_kg", "'heavy'", "must be a number"]),
    ("tread.mass_kg", True, ["tread.mass_kg", "True", "must be a number"]),
    ("axle.reference", True, ["axle.reference", "True", "'running' or 'unloaded'"]),
    ("tread.mass_kg", [1.0], ["tread.mass_kg", "[1.0]", "must be a number"]),
    ("model", "axle2dof", ["model", "'axle2dof'", "'tread1dof' or 'axle4dof'"]),
    ("tread.mass_kg", math.nan, ["tread.mass_kg", "nan", "finite"]),
    ("tread.mass_kg", math.inf, ["tread.mass_kg", "inf", "finite"]),
    ("operating.speed_kmh", -math.inf, ["operating.speed_kmh", "-inf", "finite"]),
]


@pytest.mark.parametrize("key, value, fragments", BAD_VALUES, ids=[f"{k}={v!r}" for k, v, _ in BAD_VALUES])
def test_bad_value_in_with_updates(key, value, fragments):
    with pytest.raises(ParameterError) as exc:
        with_updates(Params(), {key: value})
    check_message(exc, *fragments)


def toml_literal(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, float) and not math.isfinite(value):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf")
    return repr(value)


@pytest.mark.parametrize("key, value, fragments", BAD_VALUES, ids=[f"{k}={v!r}" for k, v, _ in BAD_VALUES])
def test_bad_value_in_a_toml_file(key, value, fragments, tmp_path):
    table, _, name = key.rpartition(".")
    line = f"{name} = {toml_literal(value)}\n"
    path = tmp_path / "bad.toml"
    path.write_text(f"[{table}]\n{line}" if table else line)
    with pytest.raises(ParameterError) as exc:
        load_params(path)
    check_message(exc, *fragments)


@settings(max_examples=60, deadline=None)
@given(key=st.sampled_from(NUMERIC_KEYS), value=st.sampled_from([math.nan, math.inf, -math.inf, True, False, "1.0"]))
def test_every_numeric_key_rejects_non_numbers_and_non_finite(key, value):
    with pytest.raises(ParameterError) as exc:
        with_updates(Params(), {key: value})
    rule = "finite" if isinstance(value, float) else "must be a number"
    check_message(exc, key, repr(value) if not isinstance(value, float) else str(value), rule)


@settings(max_examples=60, deadline=None)
@given(key=st.sampled_from(NUMERIC_KEYS), data=st.data())
def test_every_numeric_key_rejects_values_beyond_its_bounds(key, data):
    bounds = _bounds(key)
    outside = []
    if bounds["min_value"] > -1e12:
        lo = bounds["min_value"]
        outside.append(st.floats(lo - 1e6, lo, exclude_max=not bounds.get("exclude_min", False)))
    if bounds["max_value"] < 1e12:
        hi = bounds["max_value"]
        outside.append(st.floats(hi, hi + 1e6, exclude_min=not bounds.get("exclude_max", False)))
    if not outside:
        return  # unbounded key (e.g. lateral offset): any finite number is valid
    value = data.draw(st.one_of(outside))
    with pytest.raises(ParameterError) as exc:
        with_updates(Params(), {key: value})
    check_message(exc, key, repr(value))


@pytest.mark.parametrize("update, fragments", [
    ({"tread.mass": 1.0}, ["tread.mass", "unknown key", "mass_kg"]),
    ({"frcition.mu_static": 1.0}, ["frcition", "unknown key", "friction"]),
    ({"speed_kmh": 80.0}, ["speed_kmh", "unknown key", "operating"]),
    ({"tread.mass_kg.x": 1.0}, ["tread.mass_kg.x", "table.key"]),
    ({"tread": 1.0}, ["tread", "1.0", "dictionary"]),
])
def test_unknown_or_misplaced_keys(update, fragments):
    with pytest.raises(ParameterError) as exc:
        with_updates(Params(), update)
    check_message(exc, *fragments)


def test_unknown_key_in_a_file_is_an_error_not_a_default(tmp_path):
    path = tmp_path / "typo.toml"
    path.write_text("[tread]\nmass_kg = 2.0\nlateral_stifness_n_per_m = 5e5\n")
    with pytest.raises(ParameterError) as exc:
        load_params(path)
    check_message(exc, "tread.lateral_stifness_n_per_m", "unknown key")
    path.write_text("[tyre]\nvertical_stiffness_n_per_m = 1e5\n")
    with pytest.raises(ParameterError) as exc:
        load_params(path)
    check_message(exc, "tyre", "unknown key")


def test_file_problems(tmp_path):
    with pytest.raises(ParameterError) as exc:
        load_params(tmp_path / "missing.toml")
    check_message(exc, "missing.toml", "cannot read")
    path = tmp_path / "broken.toml"
    path.write_text("[tread\nmass_kg = 1\n")
    with pytest.raises(ParameterError) as exc:
        load_params(path)
    check_message(exc, "broken.toml", "not valid TOML")


@pytest.mark.parametrize("text, fragment", [
    ("tread.mass_kg", "expected table.key=value"),
    ("=3", "expected table.key=value"),
    ("tread.mass_kg=", "expected table.key=value"),
    ("tread.mass_kg=nan", "finite"),
    ("tread.mass_kg=-inf", "finite"),
])
def test_parse_override_errors(text, fragment):
    with pytest.raises(ParameterError) as exc:
        parse_override(text)
    check_message(exc, fragment)


def test_parse_override_values():
    assert parse_override("tread.mass_kg=2") == ("tread.mass_kg", 2)
    assert parse_override(" friction.mu_static = 1.5e0 ") == ("friction.mu_static", 1.5)
    assert parse_override("model=axle4dof") == ("model", "axle4dof")
    assert parse_override('axle.reference="unloaded"') == ("axle.reference", "unloaded")


@settings(max_examples=50, deadline=None)
@given(updates=valid_updates(), key=st.sampled_from(NUMERIC_KEYS))
def test_with_updates_validates_again(updates, key):
    """Starting from any valid set, an update that breaks a rule raises; the set is unchanged."""
    params = with_updates(Params(), updates)
    with pytest.raises(ParameterError):
        with_updates(params, {key: math.nan})
    with pytest.raises(ParameterError):
        with_updates(params, {"friction.mu_coulomb": params.friction.mu_static * 1.5 + 1e-9})
    assert with_updates(params, {}) == params
