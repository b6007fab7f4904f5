"""The key registry (polywear.keys) and the unit conversions (polywear.units).

Oracles: the hand-written ``[unit]`` of each field's description, the table of
docs/model.md section 6, the validation of a parameter set itself (pydantic), and the
definition of adhesion_scale (mu_s and mu_c times the factor, in closed form).
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from polywear import keys, units
from polywear.dynamics.sensitivity import nominal_value, parameter_direction, perturbed
from polywear.models import get_model
from polywear.params import ParameterError, Params, StudySpec, flat_items, with_updates
from polywear.studies.sampling import sample_params

DOCS = Path(__file__).resolve().parents[1] / "docs" / "model.md"
STORED = [k for k, i in keys.KEYS.items() if i.kind == "stored"]


def _numeric_flat_keys() -> set[str]:
    """Keys of the flat parameter listing whose value is a number (bools are none)."""
    return {k for k, v, _ in flat_items(Params())
            if isinstance(v, (int, float)) and not isinstance(v, bool)}


def test_every_numeric_key_and_the_derived_one_are_registered():
    assert set(STORED) == _numeric_flat_keys()
    assert [k for k, i in keys.KEYS.items() if i.kind == "derived"] == [keys.ADHESION_SCALE]
    for key in ("model", "axle.reference", "wear.cycle", "tread.mas_kg", "study.n_base"):
        with pytest.raises(ParameterError, match="unknown or non-numeric"):
            keys.key_info(key)


@pytest.mark.parametrize("key", list(keys.KEYS))
def test_every_key_has_a_unit_bounds_and_a_description(key):
    info = keys.key_info(key)
    assert info.key == key and info.unit and info.description
    assert info.lower < info.upper
    assert not (info.lower_inclusive and math.isinf(info.lower))
    assert not (info.upper_inclusive and math.isinf(info.upper))


@pytest.mark.parametrize("key", list(keys.KEYS))
def test_unit_from_the_name_is_the_one_written_in_the_description(key):
    written = re.findall(r"\[([^\]]*)\]", keys.KEYS[key].description)
    assert written and keys.KEYS[key].unit == written[-1], (key, written)


def _docs_units() -> dict[str, str]:
    """key -> unit column of the tables of docs/model.md section 6, in the descriptions' ASCII."""
    text = DOCS.read_text(encoding="utf-8")
    section = text.split("## 6. Configuration keys", 1)[1].split("\n## ", 1)[0]
    out = {}
    for key, unit in re.findall(r"^\| `([a-z_0-9.]+)` \| [^|]* \| ([^|]*) \|", section, flags=re.M):
        out[key] = (unit.strip().replace("·", " ").replace("²", "^2").replace("³", "^3").replace("µ", "u"))
    return out


def test_units_agree_with_the_docs_table():
    documented = _docs_units()
    missing = [k for k in STORED if k not in documented]
    assert not missing, f"not in docs/model.md section 6: {missing}"
    wrong = {k: (keys.KEYS[k].unit, documented[k]) for k in STORED if keys.KEYS[k].unit != documented[k]}
    assert not wrong


def test_unit_of_name_takes_the_longest_suffix():
    assert keys.unit_of_name("lateral_stiffness_n_per_m") == "N/m"
    assert keys.unit_of_name("sigma0_per_m") == "1/m"
    assert keys.unit_of_name("sigma1_s_per_m") == "s/m"
    assert keys.unit_of_name("stribeck_velocity_m_per_s") == "m/s"
    assert keys.unit_of_name("visible_depth_mm") == "mm"
    assert keys.unit_of_name("mu_static") == "-"


def _room(key: str, value: float) -> dict[str, float]:
    """Other keys moved so that only ``key``'s own rule can reject ``value``."""
    if key == "friction.mu_coulomb":
        return {"friction.mu_static": keys.KEYS["friction.mu_static"].upper}
    if key == "friction.mu_static":
        return {"friction.mu_coulomb": min(max(value, keys.KEYS["friction.mu_coulomb"].lower), 0.5)} if value > 0 else {}
    if key == "wear.profile_points":
        return {"wear.max_order": 1}
    if key == "wear.max_order" and value > 0:
        return {"wear.profile_points": max(720, 2 * int(value) + 1)}
    return {}


def _at(key: str, value: float) -> Params:
    value = int(value) if keys.KEYS[key].integer else float(value)
    return with_updates(Params(), {**_room(key, value), key: value})


@pytest.mark.parametrize("key", STORED)
def test_bounds_are_those_the_validation_applies(key):
    """At a finite bound the set is valid exactly when the bound is inclusive; just past it, never."""
    info = keys.KEYS[key]
    for bound, inclusive, outward in ((info.lower, info.lower_inclusive, -1.0), (info.upper, info.upper_inclusive, 1.0)):
        if math.isinf(bound):
            assert keys.get_value(_at(key, outward * 1e9), key) == outward * 1e9  # nothing rejects a large value
            continue
        beyond = bound + outward * (1.0 if info.integer else max(abs(bound), 1.0) * 1e-9)
        with pytest.raises(ParameterError, match=re.escape(key)):
            _at(key, beyond)
        if inclusive:
            assert keys.get_value(_at(key, bound), key) == bound
        else:
            with pytest.raises(ParameterError, match=re.escape(key)):
                _at(key, bound)


def test_a_derived_key_in_a_study_takes_its_registered_bounds():
    info = keys.KEYS[keys.ADHESION_SCALE]
    assert (info.lower, info.lower_inclusive, info.upper) == (0.0, False, math.inf)
    with pytest.raises(ParameterError, match="greater than 0"):
        StudySpec().with_updates({"parameters": [{"key": keys.ADHESION_SCALE, "low": 0.0, "high": 1.0}]})
    StudySpec().with_updates({"parameters": [{"key": keys.ADHESION_SCALE, "low": 1e-9, "high": 1.0}]})


def test_study_keys_are_the_float_keys_but_wear_and_the_derived_keys():
    expected = [k for k in STORED if not keys.KEYS[k].integer and not k.startswith("wear.")] + [keys.ADHESION_SCALE]
    assert list(keys.study_keys()) == expected


# -- adhesion_scale: read, write, derivative ------------------------------------------


def test_adhesion_scale_reads_one_and_writes_mu_s_and_mu_c():
    p = Params()
    assert keys.get_value(p, keys.ADHESION_SCALE) == 1.0 == nominal_value(p, keys.ADHESION_SCALE)
    s = 1.15
    q = keys.with_updates(p, {keys.ADHESION_SCALE: s})
    assert q.friction.mu_static == 0.9 * s and q.friction.mu_coulomb == 0.5 * s
    assert q.model_dump(exclude={"friction"}) == p.model_dump(exclude={"friction"})
    assert q.friction.sigma0_per_m == p.friction.sigma0_per_m
    back = keys.with_updates(q, {keys.ADHESION_SCALE: 1.0 / s})  # round trip
    assert back.friction.mu_static == pytest.approx(0.9, rel=1e-15)
    assert back.friction.mu_coulomb == pytest.approx(0.5, rel=1e-15)
    assert keys.with_updates(p, {keys.ADHESION_SCALE: 1.0}) == p


def test_adhesion_scale_applies_after_direct_settings_the_same_everywhere():
    p = Params()
    direct = {"friction.mu_static": 1.0, "tread.mass_kg": 2.0}
    q = keys.with_updates(p, {**direct, keys.ADHESION_SCALE: 1.1})
    assert q.friction.mu_static == 1.0 * 1.1 and q.friction.mu_coulomb == 0.5 * 1.1 and q.tread.mass_kg == 2.0
    assert sample_params(p, (*direct, keys.ADHESION_SCALE), (*direct.values(), 1.1)) == q
    assert perturbed(p, keys.ADHESION_SCALE, np.float64(0.8)) == keys.with_updates(p, {keys.ADHESION_SCALE: 0.8})
    with pytest.raises(ParameterError, match="friction.mu_static"):
        keys.with_updates(p, {keys.ADHESION_SCALE: 0.0})


@pytest.mark.parametrize("model_name", ["tread1dof", "axle4dof"])
def test_direction_of_adhesion_scale_is_its_closed_form_and_a_difference_quotient(model_name):
    model = get_model(model_name)
    p = Params(model=model_name)
    direction = parameter_direction(model, p, keys.ADHESION_SCALE)
    expected = np.zeros(len(model.slots))
    expected[model.param_names.index("mu_s")] = p.friction.mu_static
    expected[model.param_names.index("mu_c")] = p.friction.mu_coulomb
    assert np.array_equal(direction, expected)
    h = 1e-6  # pack is linear in mu_s, mu_c: the quotient is exact to rounding
    quotient = (model.pack(keys.with_updates(p, {keys.ADHESION_SCALE: 1.0 + h})) - model.pack(p)) / h
    keyed = [slot.key is not None for slot in model.slots]  # the others: flags and caches, no parameters
    assert np.allclose(quotient[keyed], direction[keyed], rtol=1e-8, atol=1e-12)
    assert not np.any(direction[np.logical_not(keyed)])
    toe = parameter_direction(model, p, "operating.toe_deg")
    toe_slot = {"tread1dof": "toe", "axle4dof": "toe0"}[model_name]
    assert toe[model.param_names.index(toe_slot)] == math.pi / 180.0 and np.count_nonzero(toe) == 1
    with pytest.raises(ParameterError):
        parameter_direction(model, p, "tread.mas_kg")


# -- unit conversions ---------------------------------------------------------------------


def test_speed_conversions():
    assert units.kmh_to_ms(36) == pytest.approx(10.0, rel=1e-15) and isinstance(units.kmh_to_ms(36), float)
    assert units.ms_to_kmh(10.0) == 36.0
    assert units.ms_to_kmh(units.kmh_to_ms(110.0)) == pytest.approx(110.0, rel=1e-15)
    speeds = np.array([20.0, 110.0, 300.0])
    assert np.array_equal(units.kmh_to_ms(speeds), speeds * (1.0 / 3.6))  # the product, bit for bit
    assert np.array_equal(units.kmh_to_ms(list(speeds)), units.kmh_to_ms(speeds))
    assert np.array_equal(units.ms_to_kmh(speeds), speeds * 3.6)
    assert isinstance(units.kmh_to_ms(np.float64(50.0)), float)


def test_wheel_circumference_and_rotation_frequency():
    assert units.wheel_circumference_m(0.3) == pytest.approx(1.884955592153876, rel=1e-15)
    v = units.kmh_to_ms(110.0)
    f = units.wheel_rotation_frequency_hz(v, 0.3)
    assert f * units.wheel_circumference_m(0.3) == pytest.approx(v, rel=1e-15)  # one circumference per turn
    assert units.frequency_order(150.0, v, 0.3) == pytest.approx(150.0 / f, rel=1e-15)
