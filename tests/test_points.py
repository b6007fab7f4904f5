"""Units in the result types (no m/s field called ``speed``) and one special-point type
shared by the bifurcation diagram, the stability map and the AUTO-07p adaptor."""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import pkgutil
from types import SimpleNamespace

import numpy as np
import pytest

import polywear.dynamics
import polywear.friction
import polywear.measured
import polywear.studies
import polywear.validation
import polywear.wear
from polywear.dynamics.bifurcation import bifurcation
from polywear.dynamics.points import PointKind, SpecialPoint
from polywear.dynamics.stability_map import MapSettings, stability_map
from polywear.params import Params, with_updates
from polywear.validation.auto07p import AUTO_KINDS, point_kind, special_points

UNIT_SUFFIXES = ("_kmh", "_ms", "_m_per_s")
"""A speed field names its unit: km/h at the interface, m/s only where it says so."""
NOT_SPEEDS = {
    ("HopfPoint", "dre_dspeed"): "d Re(lambda)/dV [1/m], a derivative",
}
"""Fields with "speed" in the name that are not speeds (besides counts, ``n_...``)."""


def _public_dataclasses():
    """Every public dataclass defined in the analysis packages, polywear.validation and the report."""
    names = ["polywear.report.main", "polywear.report.wear"]
    for package in (polywear.dynamics, polywear.wear, polywear.studies, polywear.measured, polywear.friction,
                    polywear.validation):
        names += [f"{package.__name__}.{m.name}" for m in pkgutil.walk_packages(package.__path__)]
    found = []
    for name in names:
        module = importlib.import_module(name)
        found += [obj for key, obj in vars(module).items()
                  if inspect.isclass(obj) and dataclasses.is_dataclass(obj) and obj.__module__ == name
                  and not key.startswith("_")]
    return found


def test_no_public_result_field_is_a_speed_without_its_unit():
    classes = _public_dataclasses()
    names = {c.__name__ for c in classes}
    assert {"HopfPoint", "CyclePoint", "SpecialPoint", "BifurcationDiagram", "StabilityMap"} <= names
    for cls in classes:
        assert not hasattr(cls, "speed"), cls
        for f in dataclasses.fields(cls):
            if "speed" in f.name and not f.name.startswith("n_") and (cls.__name__, f.name) not in NOT_SPEEDS:
                assert f.name.endswith(UNIT_SUFFIXES), (cls.__name__, f.name)


@pytest.fixture(scope="module")
def diagram():
    return bifurcation(Params())


def test_hopf_and_cycle_points_carry_both_units(diagram):
    h = diagram.hopf_points[0]
    assert h.speed_kmh == pytest.approx(3.6 * h.speed_ms, rel=1e-15)
    cycle = diagram.cycles[5]
    assert cycle.speed_kmh == pytest.approx(3.6 * cycle.speed_ms, rel=1e-15)


def test_the_diagram_holds_special_points(diagram):
    """Defaults (docs/model.md section 7): H1 soft, H2 hard, the fold of cycles above H2."""
    points = diagram.special_points
    assert all(isinstance(p, SpecialPoint) for p in [*points, *diagram.special, *diagram.folds])
    assert [p.kind for p in points] == [PointKind.HOPF, PointKind.HOPF, PointKind.LP]
    assert [p.criticality for p in points[:2]] == ["soft", "hard"]
    assert [p.speed_kmh for p in points[:2]] == [h.speed_kmh for h in diagram.hopf_points]
    (fold,) = diagram.folds
    assert fold is points[2] and fold.label == "LP" and fold.branch == 0
    summary = diagram.summary()["folds"][0]
    assert summary == {"speed_kmh": fold.speed_kmh, "amplitude_x_mm": 1e3 * fold.amplitude[0], "frequency_hz": fold.frequency_hz,
                       "amplitude_x_m": 1e3 * fold.amplitude[0] * 1e-3}  # the old key, until the next release
    assert fold.frequency_hz == pytest.approx(1.0 / fold.orbit.period, rel=1e-15)
    low, high = fold.orbit.extrema()
    np.testing.assert_array_equal(fold.amplitude, 0.5 * (high - low))


def test_a_real_eigenvalue_crossing_is_a_divergence_point():
    """axle4dof with a soft toe bushing (tests/test_verdict.py): static divergence near 35.7 km/h."""
    params = with_updates(Params(), {"model": "axle4dof", "axle.toe_stiffness_nm_per_rad": 2e4,
                                     "operating.speed_kmh": 50.0})
    diagram = bifurcation(params, (30.0, 70.0), extend=False)
    (div,) = diagram.special_points
    assert div.kind is PointKind.DIV and 35.0 < div.speed_kmh < 36.5
    assert [div.speed_kmh] == list(diagram.stability.real_crossings_kmh)


def test_map_points_are_special_points():
    """The mu_s map's Hopf curve turns back (the linear band closes) and has a Bautin point."""
    m = stability_map(Params(), "friction.mu_static", (0.55, 1.2), folds=False, settings=MapSettings(n_grid=3))
    (closure,) = m.turning_points
    (bautin,) = m.bautin_points
    assert closure.kind is PointKind.HOPF_TURN and bautin.kind is PointKind.GH
    assert 0.55 < closure.value < bautin.value < 1.2
    summary = m.summary()
    assert summary["band_closures"] == [{"value": closure.value, "speed_kmh": closure.speed_kmh}]
    assert summary["bautin_points"] == [{"value": bautin.value, "speed_kmh": bautin.speed_kmh}]


def test_auto07p_labels_and_results_as_special_points():
    assert point_kind(SimpleNamespace(point_type=SimpleNamespace(name="FOLD"))) is PointKind.LP
    assert point_kind(SimpleNamespace(point_type=SimpleNamespace(name="REGULAR"))) is None
    assert AUTO_KINDS["HOPF_BIFURCATION"] is PointKind.HOPF and AUTO_KINDS["TORUS"] is PointKind.NS
    result = {  # the shape of a model_diagram result (numbers made up)
        "model": "tread1dof",
        "hopf": [{"speed_kmh": 200.0, "frequency_hz": 140.0}, {"speed_kmh": 60.0, "frequency_hz": 120.0}],
        "folds": [{"speed_kmh": 250.0, "amplitude_x_m": 4e-4, "period_s": 0.008,
                   "amplitude": {"x": 4e-4, "xdot": 0.3, "z": 1e-5}}],
    }
    h1, h2, fold = special_points(result)
    assert (h1.kind, h1.speed_kmh, h1.frequency_hz) == (PointKind.HOPF, 60.0, 120.0)
    assert h2.speed_kmh == 200.0
    assert fold.kind is PointKind.LP and fold.frequency_hz == 125.0
    np.testing.assert_array_equal(fold.amplitude, [4e-4, 0.3, 1e-5])


def test_point_kinds_serialise_to_their_labels():
    assert [str(k) for k in (PointKind.HOPF, PointKind.LP, PointKind.PD, PointKind.NS)] == ["HB", "LP", "PD", "NS"]
    assert PointKind("LP") is PointKind.LP
