"""The public Python API: ``import polywear as pw`` (lazy entry points, the quick start)."""

from __future__ import annotations

import inspect
import json
import subprocess
import sys
import types
from enum import Enum
from importlib import import_module

import numpy as np
import pytest
from pydantic import BaseModel

import polywear as pw
from polywear.params import ParameterError

from .cli_runner import run_main

# public name -> where it lives; written out here, independently of polywear._ENTRY_POINTS
EXPECTED = {
    "Params": "polywear.params:Params",
    "load_params": "polywear.params:load_params",
    "ParameterError": "polywear.params:ParameterError",
    "PolywearError": "polywear.errors:PolywearError",
    "stability": "polywear.dynamics.stability:stability",
    "StabilitySettings": "polywear.dynamics.stability:StabilitySettings",
    "ContinuationSettings": "polywear.solvers.continuation:ContinuationSettings",
    "SimulationSettings": "polywear.dynamics.simulation:SimulationSettings",
    "MapSettings": "polywear.dynamics.stability_map:MapSettings",
    "bifurcation": "polywear.dynamics.bifurcation:bifurcation",
    "simulate": "polywear.dynamics.simulation:simulate",
    "sensitivity": "polywear.dynamics.sensitivity:sensitivity",
    "stability_map": "polywear.dynamics.stability_map:stability_map",
    "study": "polywear.studies.global_sensitivity:study",
    "StudySpec": "polywear.params:StudySpec",
    "load_study": "polywear.params:load_study",
    "design": "polywear.dynamics.design:design",
    "excitation": "polywear.dynamics.excitation:excitation",
    "report": "polywear.report.main:report",
    "wear_map": "polywear.wear.map:wear_map",
    "calibrate": "polywear.measured.calibration:calibrate",
    "read_observations": "polywear.measured.calibration:read_observations",
    "read_tir": "polywear.measured.tir_file:read_tir",
    "load_with_tir": "polywear.measured.tir:load_with_tir",
    "wear_evolution": "polywear.wear.evolution:wear_evolution",
    "wear_design": "polywear.wear.design:wear_design",
    "fleet": "polywear.studies.fleet:fleet",
    "load_fleet_spec": "polywear.studies.fleet_spec:load_fleet_spec",
    "campbell": "polywear.measured.campbell:campbell",
    "read_profiles": "polywear.measured.profile:read_profiles",
    "calibrate_wear": "polywear.measured.wear_calibration:calibrate_wear",
    "SpecialPoint": "polywear.dynamics.points:SpecialPoint",
    "PointKind": "polywear.dynamics.points:PointKind",
    "read_run": "polywear.measured.run_file:read_run",
    "friction": "polywear.friction",
    "models": "polywear.models",
    "solvers": "polywear.solvers",
}


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_entry_point_is_the_library_object(name):
    module_name, _, attribute = EXPECTED[name].partition(":")
    module = import_module(module_name)
    assert getattr(pw, name) is (getattr(module, attribute) if attribute else module)
    assert name in pw.__all__ and name in dir(pw)


def _own_signature(obj):
    """The signature polywear writes for an entry point: a function's, or the constructor of a
    class whose ``__init__`` is polywear's (a dataclass's generated one counts); None for a
    class whose constructor pydantic, Enum or Exception write (and type) themselves."""
    if inspect.isfunction(obj):
        return inspect.signature(obj)
    init = obj.__init__
    if inspect.isfunction(init) and init.__module__.startswith("polywear"):
        return inspect.signature(init)
    assert issubclass(obj, (BaseModel, Enum, Exception)), f"{obj!r}: constructor written outside polywear"
    return None


@pytest.mark.parametrize("name", sorted(n for n in EXPECTED if callable(getattr(pw, n))))
def test_entry_point_has_type_hints(name):
    signature = _own_signature(getattr(pw, name))
    if signature is None:
        return
    unannotated = [p.name for p in signature.parameters.values()
                   if p.name != "self" and p.annotation is inspect.Parameter.empty]
    assert not unannotated, f"{name}: parameters without a type hint: {unannotated}"
    assert signature.return_annotation is not inspect.Signature.empty, f"{name}: no return type hint"


def test_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no attribute 'no_such_thing'"):
        pw.no_such_thing  # noqa: B018


def test_report_function_survives_import_of_the_report_module():
    import polywear.report.main  # noqa: F401  (the submodule of the same name)

    assert callable(pw.report) and not isinstance(pw.report, types.ModuleType)
    assert sys.modules["polywear.report.main"].report is pw.report


def test_import_is_lazy_and_dir_imports_nothing():
    code = (
        "import sys, polywear as pw; names = dir(pw); "
        "heavy = ('numpy', 'scipy', 'numba', 'matplotlib', 'pydantic', 'xarray', 'typer', 'rich'); "
        "print(sorted(m for m in heavy if m in sys.modules), 'stability' in names)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["[]", "True"]


def test_with_updates_method_validates_again():
    p = pw.load_params()
    q = p.with_updates({"operating.toe_deg": 0.3, "tread.mass_kg": 2})
    assert (q.operating.toe_deg, q.tread.mass_kg, p.operating.toe_deg) == (0.3, 2.0, 0.5)
    with pytest.raises(ParameterError, match="operating.toe_deg"):
        p.with_updates({"operating.toe_deg": 45.0})
    with pytest.raises(ParameterError, match="unknown key"):
        p.with_updates({"tread.mass": 1.0})


def _round_trip(summary: dict) -> dict:
    """The summary as the CLI prints it: through JSON (numpy values as lists and floats)."""
    return json.loads(json.dumps(summary, default=lambda o: o.tolist() if isinstance(o, np.ndarray) else o.item()))


def test_quick_start_stability_equals_cli_json():
    code, out, err = run_main(["stability", "--json", "--set", "operating.toe_deg=0.4"])
    assert code == 0, err
    result = pw.stability(pw.load_params().with_updates({"operating.toe_deg": 0.4}))
    assert _round_trip(result.summary()) == json.loads(out)
    assert len(result.hopf_points) == 2


@pytest.mark.slow
def test_quick_start_bifurcation_equals_cli_json():
    code, out, err = run_main(["bifurcation", "--json", "-q"])
    assert code == 0, err
    diagram = pw.bifurcation(pw.load_params())
    assert _round_trip(diagram.summary()) == json.loads(out)
    assert diagram.summary()["second_bifurcation_speed_kmh"] > diagram.summary()["first_bifurcation_speed_kmh"]


def test_lower_layers_reachable_as_attributes():
    code = (
        "import polywear as pw; "
        "print(pw.solvers.integrate.integrate.__name__, pw.solvers.continuation.ContinuationSettings.__name__, "
        "pw.models.tread1dof.MODEL.name, pw.models.base.Model.__name__, 'integrate' in dir(pw.solvers))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["integrate", "ContinuationSettings", "tread1dof", "Model", "True"]
    with pytest.raises(AttributeError):
        pw.solvers.no_such_solver  # noqa: B018
