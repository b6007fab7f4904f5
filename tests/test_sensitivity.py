"""Local sensitivity of the bifurcation speeds: exact derivatives against differences,
closed forms and invariants (tread1dof), axle4dof, and the ``polywear sensitivity`` command."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from polywear.dynamics.bifurcation import bifurcation
from polywear.dynamics.sensitivity import (ADHESION_SCALE, PAPER_PARAMETERS, SensitivitySettings, sensitivity,
                                           perturbed)
from polywear.params import ADHESION_SCALE as STUDY_ADHESION_SCALE
from polywear.params import Params, with_updates

from .cli_runner import run_main

QUANTITIES = ("hopf_1", "hopf_2", "fold_1", "first_bifurcation", "second_bifurcation")
SCALING_KEYS = (
    "tread.mass_kg",
    "tread.lateral_stiffness_n_per_m",
    "tread.lateral_damping_ns_per_m",
    "operating.vertical_load_n",
)


@pytest.fixture(scope="module")
def nominal():
    """The default tread1dof diagram (Hopf 58.1 soft, 207.8 hard, fold 254.7 km/h)."""
    return bifurcation(Params())


def _by_quantity(result, field="derivative") -> dict:
    return {(r["quantity"], r["param"]): r[field] for r in result.rows}


def _relative_error(a: float, b: float) -> float:
    return abs(a - b) / abs(b) if b != 0.0 else abs(a)


def test_adhesion_key_is_the_same_name_in_params_and_sensitivity():
    assert ADHESION_SCALE == STUDY_ADHESION_SCALE


def test_rows_cover_every_quantity_and_parameter(nominal):
    result = sensitivity(Params(), diagram=nominal)
    assert {r["quantity"] for r in result.rows} == set(QUANTITIES)
    assert {r["param"] for r in result.rows} == set(PAPER_PARAMETERS)
    assert len(result.rows) == len(QUANTITIES) * len(PAPER_PARAMETERS)
    for r in result.rows:
        assert set(r) == {"quantity", "param", "nominal", "speed_kmh", "derivative", "normalized"}
        if r["normalized"] is not None:
            assert math.isclose(r["normalized"], r["nominal"] / r["speed_kmh"] * r["derivative"], rel_tol=1e-12,
                                abs_tol=1e-15)
    # first/second bifurcation speeds are the first Hopf speed and the fold (hard upper end)
    d = _by_quantity(result)
    for key in PAPER_PARAMETERS:
        assert d[("first_bifurcation", key)] == d[("hopf_1", key)]
        assert d[("second_bifurcation", key)] == d[("fold_1", key)]


def test_toe_sensitivity_is_minus_theta_cot_theta(nominal):
    """V_H, V_fold ~ 1/sin(toe) (speed enters only through V sin(toe)), so S = -theta cot(theta).

    At the default 0.5 deg this is -1 + 2.54e-5: "exactly -1" holds only to O(theta^2).
    """
    theta = math.radians(0.5)
    expected = -theta / math.tan(theta)
    assert abs(expected + 1.0 - theta**2 / 3) < 1e-9  # -1 + theta^2/3 + O(theta^4)
    result = sensitivity(Params(), ["operating.toe_deg"], diagram=nominal)
    S = _by_quantity(result, "normalized")
    for q in ("hopf_1", "hopf_2"):
        assert S[(q, "operating.toe_deg")] == pytest.approx(expected, rel=1e-9)
    assert S[("fold_1", "operating.toe_deg")] == pytest.approx(expected, rel=1e-7)
    assert abs(S[("hopf_1", "operating.toe_deg")] + 1.0) > 2e-5  # not -1 exactly


@settings(max_examples=4, deadline=None)
@given(toe=st.floats(0.2, 2.0))
def test_toe_closed_form_at_other_toe_angles(toe):
    factor = math.sin(math.radians(0.5)) / math.sin(math.radians(toe))
    params = with_updates(Params(), {"operating.toe_deg": toe})
    result = sensitivity(params, ["operating.toe_deg"], speed_range_kmh=(20.0 * factor, 300.0 * factor))
    theta = math.radians(toe)
    for r in result.rows:
        assert r["normalized"] == pytest.approx(-theta / math.tan(theta), rel=1e-7), r


def test_scaling_invariance_of_m_k_c_n(nominal):
    """Scaling m, k, c and N by one factor leaves every bifurcation speed unchanged: sum S = 0."""
    result = sensitivity(Params(), SCALING_KEYS, diagram=nominal)
    S = _by_quantity(result, "normalized")
    for q in QUANTITIES:
        values = [S[(q, key)] for key in SCALING_KEYS]
        assert abs(sum(values)) < 1e-7 * max(abs(v) for v in values), (q, values)


@settings(max_examples=3, deadline=None)
@given(damping=st.floats(40.0, 120.0), mu_s=st.floats(0.75, 1.1), mass=st.floats(0.5, 2.0))
def test_scaling_invariance_holds_away_from_the_defaults(damping, mu_s, mass):
    params = with_updates(Params(), {"tread.lateral_damping_ns_per_m": damping, "friction.mu_static": mu_s,
                                     "tread.mass_kg": mass})
    result = sensitivity(params, SCALING_KEYS)
    assume(result.rows)
    S = _by_quantity(result, "normalized")
    for q in {r["quantity"] for r in result.rows}:
        values = [S[(q, key)] for key in SCALING_KEYS]
        assert abs(sum(values)) < 1e-6 * max(abs(v) for v in values), (q, values)


def test_camber_does_not_enter_tread1dof(nominal):
    result = sensitivity(Params(), ["operating.camber_deg"], diagram=nominal)
    assert all(r["derivative"] == 0.0 and r["normalized"] == 0.0 for r in result.rows)


@pytest.mark.slow
def test_exact_matches_central_differences_for_all_seven_parameters(nominal):
    """Central differences re-run the whole continuation (Hopf points and fold) at p +- dp."""
    exact = _by_quantity(sensitivity(Params(), diagram=nominal))
    central = _by_quantity(sensitivity(Params(), settings=SensitivitySettings("central", 1e-4), diagram=nominal))
    for key, value in exact.items():
        assert central[key] is not None, key
        scale = max(abs(value), 1e-12)
        assert abs(central[key] - value) <= 1e-4 * scale, (key, value, central[key])


@pytest.mark.slow
def test_step_study_truncation_then_rounding(nominal):
    """Central differences: error ~ h^2 (x100 per decade) down to an optimum, then rounding grows.

    Forward differences (the paper's eq. 3): error ~ h (x10 per decade).
    """
    key = "tread.lateral_damping_ns_per_m"
    exact = _by_quantity(sensitivity(Params(), [key], diagram=nominal))
    steps = (1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-7, 1e-9)

    def errors(method, step_list):
        out = {}
        for h in step_list:
            d = _by_quantity(sensitivity(Params(), [key], SensitivitySettings(method, h), diagram=nominal))
            out[h] = {q: _relative_error(d[(q, key)], exact[(q, key)]) for q in ("hopf_1", "hopf_2", "fold_1")}
        return out

    central = errors("central", steps)
    forward = errors("forward", steps[:3])
    for q in ("hopf_1", "hopf_2", "fold_1"):
        for a, b in ((1e-1, 1e-2), (1e-2, 1e-3)):
            assert 50 < central[a][q] / central[b][q] < 200, (q, central)
            assert 5 < forward[a][q] / forward[b][q] < 20, (q, forward)
        best = min(central[h][q] for h in steps)
        assert best < 1e-7, (q, central)
        assert central[1e-4][q] < 1e-4
        assert central[1e-9][q] > 10 * best, (q, central)  # rounding regime


@pytest.mark.slow
def test_fold_sensitivity_against_a_rerun_continuation(nominal):
    """dV_fold/dp from the left null vector against the fold of re-run diagrams at p +- 1e-3 p."""
    for key in (ADHESION_SCALE, "operating.vertical_load_n"):
        exact = _by_quantity(sensitivity(Params(), [key], diagram=nominal))[("fold_1", key)]
        p0 = 1.0 if key == ADHESION_SCALE else Params().operating.vertical_load_n
        h = 1e-3 * p0
        folds = [bifurcation(perturbed(Params(), key, p0 + s * h)).folds[0].speed_kmh for s in (1, -1)]
        assert (folds[0] - folds[1]) / (2 * h) == pytest.approx(exact, rel=1e-4)


@pytest.mark.slow
def test_axle4dof_exact_matches_central_differences():
    params = with_updates(Params(), {"model": "axle4dof"})
    diagram = bifurcation(params)
    keys = ("operating.toe_deg", "operating.camber_deg", ADHESION_SCALE)
    exact = _by_quantity(sensitivity(params, keys, diagram=diagram))
    central = _by_quantity(sensitivity(params, keys, SensitivitySettings("central", 1e-4), diagram=diagram))
    assert {q for q, _ in exact} >= {"hopf_1", "hopf_2", "first_bifurcation", "second_bifurcation"}
    for key, value in exact.items():
        assert abs(central[key] - value) <= 1e-4 * abs(value), (key, value, central[key])
    # camber enters axle4dof (camber thrust), unlike tread1dof
    assert abs(exact[("hopf_1", "operating.camber_deg")]) > 1.0


# -- the command ---------------------------------------------------------------------------------
def test_cli_json_rows(tmp_path):
    plot, out = tmp_path / "fig9.png", tmp_path / "rows.csv"
    code, stdout, err = run_main(["sensitivity", "--json", "-q", "-p", "operating.toe_deg", "-p", ADHESION_SCALE,
                                  "--plot", str(plot), "--out", str(out)])
    assert code == 0, err
    data = json.loads(stdout)
    assert set(data) >= {"model", "method", "rows"} and data["model"] == "tread1dof" and data["method"] == "exact"
    assert {r["param"] for r in data["rows"]} == {"operating.toe_deg", ADHESION_SCALE}
    assert {r["quantity"] for r in data["rows"]} == set(QUANTITIES)
    for r in data["rows"]:
        assert list(r) == ["quantity", "param", "nominal", "speed_kmh", "derivative", "normalized"]
    # derivative in km/h per degree of toe: dV/dtoe = -V theta cot(theta) / toe_deg
    toe = next(r for r in data["rows"] if r["quantity"] == "hopf_1" and r["param"] == "operating.toe_deg")
    theta = math.radians(0.5)
    assert toe["derivative"] == pytest.approx(-toe["speed_kmh"] * theta / math.tan(theta) / 0.5, rel=1e-9)
    assert plot.stat().st_size > 10_000 and plot.read_bytes()[:4] == b"\x89PNG"
    with open(out) as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == len(data["rows"])


def test_cli_forward_difference_is_the_papers_eq3():
    code, stdout, err = run_main(["sensitivity", "--json", "-q", "--method", "forward", "--step", "1e-3",
                                  "-p", "tread.lateral_stiffness_n_per_m"])
    assert code == 0, err
    forward = {r["quantity"]: r["derivative"] for r in json.loads(stdout)["rows"]}
    _, stdout, _ = run_main(["sensitivity", "--json", "-q", "-p", "tread.lateral_stiffness_n_per_m"])
    exact = {r["quantity"]: r["derivative"] for r in json.loads(stdout)["rows"]}
    for q in QUANTITIES:  # first order: relative error ~ step
        assert forward[q] == pytest.approx(exact[q], rel=1e-2)
        assert forward[q] != exact[q]


@pytest.mark.parametrize("args, fragment", [
    (["-p", "tread.mass"], "tread.mass"),
    (["-p", "axle.reference"], "axle.reference"),
    (["--step", "-1"], "--step"),
    (["--speed-range", "100", "50"], "--speed-range"),
    (["-s", "tread.mass_kg=-1"], "tread.mass_kg"),
])
def test_cli_bad_input_is_one_line_exit_2(args, fragment):
    code, stdout, err = run_main(["sensitivity", "-q", *args])
    assert code == 2 and stdout == ""
    assert err.startswith("error: ") and err.count("\n") == 1 and fragment in err, err


@pytest.mark.slow
def test_cli_axle4dof_defaults():
    code, stdout, err = run_main(["sensitivity", "--json", "-q", "--set", "model=axle4dof"])
    assert code == 0, err
    data = json.loads(stdout)
    assert data["model"] == "axle4dof"
    rows = {(r["quantity"], r["param"]): r for r in data["rows"]}
    assert {p for _, p in rows} == set(PAPER_PARAMETERS)
    assert all(r["derivative"] is not None and np.isfinite(r["derivative"]) for r in data["rows"])
    # docs/model.md section 7: linear band roughly 79 to 155 km/h
    assert rows[("hopf_1", "operating.toe_deg")]["speed_kmh"] == pytest.approx(79.4, abs=1.0)
    assert rows[("hopf_2", "operating.toe_deg")]["speed_kmh"] == pytest.approx(155.2, abs=1.0)
