"""Keys and options hold to what a tire or a car can be (issue 24, section 2).

The bounds are read from the key registry and checked three ways: against the table of
docs/model.md section 6 (written by hand), at the bound itself (accepted) and just past
it (refused in one line naming the key), and through the CLI where an option stands for
a key (the same limit on both).
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import pytest

from polywear.keys import KEYS
from polywear.params import MAX_WEAR_KM, MAX_WEAR_ORDER, ParameterError, Params, with_updates

from .cli_runner import run_main

DOCS = Path(__file__).parent.parent / "docs" / "model.md"


def _documented_bounds() -> dict[str, tuple[str, str]]:
    """``key -> (lower, upper)`` as written in the bounds table of docs/model.md."""
    text = DOCS.read_text(encoding="utf-8")
    start = text.index("**Bounds.**")
    table = text[start:text.index("**Wear evolution**", start)]
    rows = re.findall(r"^\| `([a-z_.0-9]+)` \|([^|]*)\|[^|]*\|([^|]*)\|", table, re.M)  # key, lower, unit, upper
    return {key: (lower.strip(), upper.strip()) for key, lower, upper in rows}


def _written(value: float, inclusive: bool, lower: bool) -> str:
    if not math.isfinite(value):
        return ""
    sign = ("≥ " if inclusive else "> ") if lower else ("≤ " if inclusive else "< ")
    return f"{sign}{value:g}"


def test_docs_table_states_every_bound_of_the_registry():
    documented = _documented_bounds()
    stored = {k: i for k, i in KEYS.items() if i.kind == "stored"}
    assert set(documented) == set(stored)
    for key, info in stored.items():
        expected = (_written(info.lower, info.lower_inclusive, True), _written(info.upper, info.upper_inclusive, False))
        assert documented[key] == expected, key


PLAUSIBLE = {
    "operating.vertical_load_n": (500.0, 60_000.0),
    "operating.rolling_radius_m": (0.15, 0.8),
    "tire.contact_length_m": (0.01, 0.5),
    "tire.tread_width_m": (0.03, 0.6),
    "wear.energetic_rate_mm3_per_j": (1e-6, 0.1),
    "tread.mass_kg": (1e-4, 100.0),
    "tread.lateral_stiffness_n_per_m": (1e3, 1e9),
    "friction.sigma0_per_m": (10.0, 1e8),
    "friction.stribeck_velocity_m_per_s": (1e-4, 100.0),
}
"""The bounds the issue names (a wheel, a tire, a tread element, a rubber-road LuGre
parameter, a wear rate), written out independently."""


def test_friction_coefficients_are_those_of_a_tire_on_a_road():
    """mu_s and mu_c from wet ice (0.05) to soft rubber on a dry rough road (3); the rule
    mu_c <= mu_s on top."""
    for mu in (0.05, 3.0):
        assert with_updates(Params(), {"friction.mu_static": mu, "friction.mu_coulomb": mu}).friction.mu_coulomb == mu
    for key, value in (("friction.mu_static", 3.0 * (1 + 1e-9)), ("friction.mu_coulomb", 0.05 * (1 - 1e-9))):
        with pytest.raises(ParameterError, match=re.escape(key)):
            with_updates(Params(), {key: value})
    for key, value in (("friction.sigma1_s_per_m", 1e3 * (1 + 1e-9)), ("friction.sigma2_s_per_m", 1.0 + 1e-9),
                       ("tread.lateral_damping_ns_per_m", 1e5 * (1 + 1e-9))):
        with pytest.raises(ParameterError, match=re.escape(key)):
            with_updates(Params(), {key: value})


@pytest.mark.parametrize("key", sorted(PLAUSIBLE))
def test_bound_is_accepted_and_just_past_it_refused(key):
    low, high = PLAUSIBLE[key]
    assert (KEYS[key].lower, KEYS[key].upper) == (low, high)
    for value in (low, high):
        assert with_updates(Params(), {key: value}).model_dump()[key.split(".")[0]][key.split(".")[1]] == value
    for value in (low * (1 - 1e-9), high * (1 + 1e-9)):
        with pytest.raises(ParameterError, match=re.escape(key)):
            with_updates(Params(), {key: value})


@pytest.mark.parametrize("value", ["1.0", "1e30", "0"])
@pytest.mark.parametrize("json_flag", [[], ["--json"]])
def test_energetic_rate_out_of_bounds_is_one_line_exit_2(value, json_flag):
    code, out, err = run_main(["wear", "evolve", "--set", f"wear.energetic_rate_mm3_per_j={value}", *json_flag])
    assert code == 2 and out == ""
    assert err.strip().splitlines() == [err.strip()] and "wear.energetic_rate_mm3_per_j" in err


@pytest.mark.parametrize("args", [
    ["wear", "map", "--max-order", str(MAX_WEAR_ORDER + 1)],
    ["wear", "map", "--set", f"wear.max_order={MAX_WEAR_ORDER + 1}"],
])
def test_max_order_option_and_key_share_the_limit(args):
    code, _, err = run_main(args)
    assert code == 2 and str(MAX_WEAR_ORDER) in err


def test_profile_points_are_bounded():
    code, _, err = run_main(["wear", "map", "--set", "wear.profile_points=10000000"])
    assert code == 2 and "wear.profile_points" in err


@pytest.mark.parametrize("args", [
    ["wear", "evolve", "--distance-km", f"{1.5 * MAX_WEAR_KM:g}"],
    ["report", "--wear-km", f"{1.5 * MAX_WEAR_KM:g}"],
    ["report", "--set", f"wear.report_km={1.5 * MAX_WEAR_KM:g}"],
])
def test_wear_distances_share_the_limit(args, tmp_path):
    code, _, err = run_main([*args, *(["--out", str(tmp_path / "r")] if args[0] == "report" else [])])
    assert code == 2 and (f"{MAX_WEAR_KM:g}" in err or f"{MAX_WEAR_KM:.0f}" in err), err
    assert not (tmp_path / "r").exists()


def test_short_distance_runs_with_the_default_step():
    """500 km with no --step-km: the default 1000 km step clips to the distance."""
    code, out, err = run_main(["wear", "evolve", "--speed", "40", "--distance-km", "500", "--json", "-q"])
    assert code == 0, err
    assert json.loads(out)["distance_km"] == 500.0


def test_a_step_the_user_gives_is_still_checked():
    code, _, err = run_main(["wear", "evolve", "--speed", "40", "--distance-km", "500", "--step-km", "1000"])
    assert code == 2 and "--step-km" in err
