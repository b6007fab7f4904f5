"""polywear: friction-induced lateral self-excited vibration of tire tread.

The entry points are reachable from the top level and imported on first use, so
``import polywear`` stays light (no numpy, scipy, numba or matplotlib)::

    import polywear as pw

    p = pw.load_params()                                  # the built-in defaults
    p = p.with_updates({"operating.toe_deg": 0.3})        # validated again
    stab = pw.stability(p)                                # Hopf speeds of steady rolling
    diagram = pw.bifurcation(p)                           # bifurcation diagram, SEV band

Entry points (each is the function or class named in brackets):

- ``Params``, ``load_params``, ``ParameterError`` [polywear.params]
- ``PolywearError`` [polywear.errors]: the root of polywear's errors (parameter, input and
  numerical errors sit under it)
- ``stability`` [dynamics.stability.stability]
- ``bifurcation`` [dynamics.bifurcation.bifurcation]
- ``simulate`` [dynamics.simulation.simulate]
- ``sensitivity`` [dynamics.sensitivity.sensitivity]
- ``stability_map`` [dynamics.stability_map.stability_map]
- ``study`` [studies.global_sensitivity.study], ``StudySpec``, ``load_study``
  [polywear.params]: the study specification (the ``[study]`` table), not a parameter
- ``design`` [dynamics.design.design]
- ``excitation`` [dynamics.excitation.excitation]
- ``report`` [report.report]
- ``wear_map`` [wear.map.wear_map]: linear wear stability over speed and order
- ``calibrate``, ``read_observations`` [measured.calibration]: fit parameters to observations
- ``read_tir`` [measured.tir_file], ``load_with_tir`` [measured.tir]: tyre property files (.tir) and parameters from them
- ``wear_evolution`` [wear.evolution.wear_evolution]: the worn profile over distance
- ``wear_design`` [wear.design.wear_design]: least parameter changes that keep polygonal wear
  from growing (or invisible up to a distance)
- ``fleet`` [studies.fleet], ``load_fleet_spec`` [studies.fleet_spec]: SEV risk over a fleet of cars
- ``campbell``, ``read_run`` [measured.campbell]: Campbell maps of measured run-ups
- ``read_profiles`` [measured.profile], ``calibrate_wear`` [measured.wear_calibration]:
  measured worn tires as polygon spectra, and the wear rate k_e they imply
- ``StabilitySettings``, ``ContinuationSettings``, ``SimulationSettings``, ``MapSettings``:
  validated frozen numerical settings of ``stability``, ``bifurcation``, ``simulate``,
  ``stability_map`` (a bad value raises ``ValueError`` naming the field)
- ``SpecialPoint``, ``PointKind`` [dynamics.points]: the special points of diagrams,
  stability maps and the AUTO-07p reference (Hopf, fold, period doubling, ...)
- ``friction`` (LuGre curves, loops and fits), ``models``, ``solvers``: modules.
"""

from __future__ import annotations

import sys

__version__ = "0.1.0"

# public name -> (module, attribute); attribute None: the module itself
_ENTRY_POINTS: dict[str, tuple[str, str | None]] = {
    "Params": ("polywear.params", "Params"),
    "load_params": ("polywear.params", "load_params"),
    "ParameterError": ("polywear.params", "ParameterError"),
    "PolywearError": ("polywear.errors", "PolywearError"),
    "stability": ("polywear.dynamics.stability", "stability"),
    "StabilitySettings": ("polywear.dynamics.stability", "StabilitySettings"),
    "ContinuationSettings": ("polywear.solvers.continuation", "ContinuationSettings"),
    "SimulationSettings": ("polywear.dynamics.simulation", "SimulationSettings"),
    "MapSettings": ("polywear.dynamics.stability_map", "MapSettings"),
    "bifurcation": ("polywear.dynamics.bifurcation", "bifurcation"),
    "simulate": ("polywear.dynamics.simulation", "simulate"),
    "sensitivity": ("polywear.dynamics.sensitivity", "sensitivity"),
    "stability_map": ("polywear.dynamics.stability_map", "stability_map"),
    "study": ("polywear.studies.global_sensitivity", "study"),
    "StudySpec": ("polywear.params", "StudySpec"),
    "load_study": ("polywear.params", "load_study"),
    "design": ("polywear.dynamics.design", "design"),
    "excitation": ("polywear.dynamics.excitation", "excitation"),
    "report": ("polywear.report", "report"),
    "wear_map": ("polywear.wear.map", "wear_map"),
    "calibrate": ("polywear.measured.calibration", "calibrate"),
    "read_observations": ("polywear.measured.calibration", "read_observations"),
    "read_tir": ("polywear.measured.tir_file", "read_tir"),
    "load_with_tir": ("polywear.measured.tir", "load_with_tir"),
    "wear_evolution": ("polywear.wear.evolution", "wear_evolution"),
    "wear_design": ("polywear.wear.design", "wear_design"),
    "fleet": ("polywear.studies.fleet", "fleet"),
    "load_fleet_spec": ("polywear.studies.fleet_spec", "load_fleet_spec"),
    "campbell": ("polywear.measured.campbell", "campbell"),
    "SpecialPoint": ("polywear.dynamics.points", "SpecialPoint"),
    "PointKind": ("polywear.dynamics.points", "PointKind"),
    "read_run": ("polywear.measured.run_file", "read_run"),
    "read_profiles": ("polywear.measured.profile", "read_profiles"),
    "calibrate_wear": ("polywear.measured.wear_calibration", "calibrate_wear"),
    "friction": ("polywear.friction", None),
    "models": ("polywear.models", None),
    "solvers": ("polywear.solvers", None),
}

__all__ = ["__version__", *_ENTRY_POINTS]


TYPE_CHECKING = False  # typing.TYPE_CHECKING, without importing typing (mypy knows the name)
if TYPE_CHECKING:
    from types import ModuleType as _ModuleType
else:
    _ModuleType = type(sys)  # types.ModuleType, without importing types


class _Package(_ModuleType):
    """The ``polywear`` module object: an entry point is never replaced by a submodule.

    Importing a submodule sets it as an attribute of its package; ``polywear.report``
    (the module) would then hide ``pw.report`` (the function). Such a submodule stays
    reachable through ``import polywear.report`` and ``sys.modules``.
    """

    def __setattr__(self, name: str, value: object) -> None:
        target = _ENTRY_POINTS.get(name)
        if target is not None and target[1] is not None and isinstance(value, _ModuleType):
            return
        super().__setattr__(name, value)


def __getattr__(name: str) -> object:
    """Import an entry point on first access (PEP 562) and keep it."""
    try:
        module_name, attribute = _ENTRY_POINTS[name]
    except KeyError:
        raise AttributeError(f"module 'polywear' has no attribute {name!r}") from None
    from importlib import import_module

    module = import_module(module_name)
    value = module if attribute is None else getattr(module, attribute)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)


sys.modules[__name__].__class__ = _Package
