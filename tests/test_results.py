"""Every public result object has the interface of :class:`polywear.results.Result`:
summary() is JSON, to_xarray()/to_dataframe() work, save() round-trips .json/.nc/.csv and
refuses other suffixes, plot(ax) draws onto the given axes, figure() returns a Figure.

The results come from small, cheap cases (short simulations, coarse grids, one key)."""

from __future__ import annotations

import json

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import pytest  # noqa: E402
import xarray as xr  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from polywear import __version__  # noqa: E402
from polywear.params import Params, load_params  # noqa: E402
from polywear.results import Result  # noqa: E402

RANGE = (20.0, 300.0)


@pytest.fixture(scope="module")
def diagram():
    from polywear.dynamics.bifurcation import bifurcation

    return bifurcation(Params(), RANGE)


def _stability(d):
    return d.stability


def _bifurcation(d):
    return d


def _simulation(d):
    from polywear.dynamics.simulation import simulate

    return simulate(Params(), 120.0, 0.2)


def _simulation_set(d):
    from polywear.dynamics.simulation import simulate_disturbances

    return simulate_disturbances(Params(), [1e-5, 1e-3], speed_kmh=120.0, duration_s=0.2)


def _sweep(d):
    from polywear.dynamics.sweep import SweepSettings, sweep

    return sweep(Params(), [60.0, 120.0], settings=SweepSettings(max_duration_s=0.5))


def _sensitivity(d):
    from polywear.dynamics.sensitivity import sensitivity

    return sensitivity(Params(), keys=("operating.toe_deg",), diagram=d)


def _study(d):
    from polywear.studies.global_sensitivity import study

    from polywear.params import StudySpec

    spec = StudySpec().with_updates({"n_base": 8, "bootstrap": 10, "outputs": "hopf"})
    return study(Params(), spec, backend="serial")


def _design(d):
    from polywear.dynamics.design import design

    return design(Params(), (80.0, 130.0), speed_range_kmh=RANGE, keys=("operating.toe_deg",),
                  diagram=d)


def _excitation(d):
    from polywear.dynamics.excitation import ExcitationSettings, default_speeds, excitation

    return excitation(d, default_speeds(d, 120.0)[:1], ExcitationSettings(duration_s=0.2))[0]


def _excitation_result(d):
    from polywear.dynamics.excitation import ExcitationSettings, default_speeds, excitation

    return excitation(d, default_speeds(d, 120.0)[:1], ExcitationSettings(duration_s=0.2))


def _attractor(d):
    from polywear.dynamics.attractor import reached_attractors

    return reached_attractors(d, 120.0, duration_s=0.3)[0]


def _stability_map(d):
    from polywear.dynamics.stability_map import stability_map

    return stability_map(Params(), "operating.toe_deg", (0.1, 0.4), operating_range_kmh=(80.0, 130.0), folds=False)


def _wear_map(d):
    from polywear.wear.map import wear_map

    return wear_map(Params(), np.linspace(40.0, 200.0, 9))


def _wear_design(d):
    from polywear.wear.design import WearDesignSettings, wear_design

    return wear_design(Params(), keys=("operating.toe_deg",), settings=WearDesignSettings(grid=6))


def _wear_evolution(d):
    from polywear.wear.evolution import EvolutionSettings, wear_evolution

    return wear_evolution(Params(), 2000.0, cycle=((60.0, 1.0),), settings=EvolutionSettings(step_km=1000.0))


def _band(d):
    from polywear.studies.fast_band import band_from_diagram

    return band_from_diagram(d, (120.0,))


def _fleet(d, tmp_path_factory):
    from polywear.dynamics.bifurcation import bifurcation
    from polywear.studies.fast_band import _FIXED_RANGE, band_reference
    from polywear.studies.fleet import fleet, load_fleet_spec

    path = tmp_path_factory.mktemp("fleet") / "fleet.toml"
    path.write_text('[fleet]\nsamples = 3\nseed = 3\nspeed_range_kmh = [10.0, 600.0]\n'
                    '[[fleet.parameter]]\nkey = "operating.toe_deg"\ndistribution = "normal"\nmean = 0.5\nstd = 0.08\n'
                    '[[fleet.usage]]\nspeed_kmh = 110\nshare = 1.0\n')
    reference = band_reference(bifurcation(Params(), (10.0, 600.0), **_FIXED_RANGE))
    return fleet(Params(), load_fleet_spec(path, Params()), backend="serial", reference=reference)


def _campbell(d, tmp_path_factory):
    from polywear.measured.campbell import campbell
    from polywear.measured.run_file import read_run
    from polywear.units import order_frequency_hz

    fs, radius = 1000.0, Params().operating.rolling_radius_m
    t = np.arange(0.0, 4.0, 1.0 / fs)
    speed = 40.0 + 10.0 * t  # km/h
    rng = np.random.default_rng(1)
    signal = np.sin(2 * np.pi * np.cumsum(order_frequency_hz(8.0, speed, radius)) / fs) + 0.1 * rng.standard_normal(t.size)
    path = tmp_path_factory.mktemp("run") / "run.csv"
    np.savetxt(path, np.column_stack([t * 1000.0, speed / 3.6, signal]), delimiter=",",
               header="time [ms],speed [m/s],acc_y [m/s^2]", comments="")
    return campbell(read_run(path), Params(), predict=False, correct_ramp=False)


def _calibration(d):
    from polywear.measured.calibration import Observation, calibrate, predict

    obs = [Observation("first_hopf_kmh", 0.0, 1.0), Observation("hopf_frequency_hz", 0.0, 0.5)]
    values, _ = predict(Params(), obs, ["friction.mu_static"])
    obs = [Observation(o.quantity, float(v) * 1.01, o.sigma) for o, v in zip(obs, values)]
    return calibrate(Params(), obs, ["friction.mu_static"], profile=False)


def _tir(d):
    from pathlib import Path

    from polywear.measured.tir import load_with_tir

    return load_with_tir(Path(__file__).parent / "data" / "mf62_example.tir", sets=["tread.mass_kg=0.25"])


def _steady_curve(d):
    from polywear.friction import steady_curve

    return steady_curve(Params().friction, np.linspace(-1.0, 1.0, 41))


def _loops(d):
    from polywear.friction import LoopSettings, hysteresis_loops

    return hysteresis_loops(Params().friction, 0.3, 0.2, [1.0, 10.0], settings=LoopSettings(points_per_period=64))


def _friction_fit(d):
    from polywear.friction import fit_steady_curve, read_steady_csv, sample_path

    return fit_steady_curve(*read_steady_csv(sample_path("steady")))


def _loop_fit(d):
    from polywear.friction import fit_loops, read_loops_csv, sample_path

    return fit_loops(*read_loops_csv(sample_path("loops")))


def _measured_profiles(d):
    from pathlib import Path

    from polywear.measured.profile import read_profiles

    return read_profiles([Path(__file__).parents[1] / "examples" / "worn_tire.csv"])


def _wear_calibration(d):
    from polywear.measured.wear_calibration import calibrate_wear
    from polywear.wear.evolution import EvolutionSettings

    return calibrate_wear(_measured_profiles(d), Params(), roughness_known=True,
                          settings=EvolutionSettings(step_km=2000.0))


CASES = {
    "stability": _stability, "bifurcation": _bifurcation, "simulation": _simulation,
    "simulation_set": _simulation_set, "sweep": _sweep, "sensitivity": _sensitivity, "study": _study,
    "design": _design, "excitation": _excitation, "excitation_result": _excitation_result, "attractor": _attractor,
    "stability_map": _stability_map,
    "wear_map": _wear_map, "wear_design": _wear_design, "wear_evolution": _wear_evolution, "band": _band,
    "fleet": _fleet, "campbell": _campbell, "calibration": _calibration, "tir": _tir, "steady_curve": _steady_curve,
    "loops": _loops, "friction_fit": _friction_fit, "loop_fit": _loop_fit,
    "measured_profiles": _measured_profiles, "wear_calibration": _wear_calibration,
}
NEEDS_TMP = {"fleet", "campbell"}
WITHOUT_PARAMS = {"band", "campbell", "steady_curve", "loops", "friction_fit", "loop_fit", "measured_profiles"}
"""Results that do not come from a parameter set (a measured run, friction data, a band row)."""


@pytest.fixture(scope="module")
def results(diagram, tmp_path_factory):
    cache: dict[str, Result] = {}

    def get(name):
        if name not in cache:
            make = CASES[name]
            cache[name] = make(diagram, tmp_path_factory) if name in NEEDS_TMP else make(diagram)
        return cache[name]

    return get


def test_every_public_result_class_is_covered():
    """The public result classes of the analysis packages derive from Result, and each is a case here."""
    import importlib
    import pkgutil

    found = set()
    packages = ["polywear.dynamics", "polywear.wear", "polywear.studies", "polywear.measured", "polywear.friction"]
    names = [info.name for package in packages
             for info in pkgutil.walk_packages(importlib.import_module(package).__path__, package + ".")]
    for name in names:
        module = importlib.import_module(name)
        for obj in vars(module).values():
            if not (isinstance(obj, type) and obj.__module__ == name) or obj.__name__.startswith("_"):
                continue
            if hasattr(obj, "summary") and hasattr(obj, "plot"):  # what makes a result
                assert issubclass(obj, Result), obj
            if issubclass(obj, Result):
                found.add(obj.__name__)
    assert found >= {"StabilityResult", "BifurcationDiagram", "SimulationResult", "SimulationSet", "SweepResult",
                     "SensitivityResult", "GlobalSensitivityResult", "DesignResult", "ExcitationPortrait",
                     "Attractor", "StabilityMap", "WearMap", "WearDesignResult", "EvolutionResult", "Band",
                     "FleetResult", "CampbellResult", "CalibrationResult", "SteadyCurve", "HysteresisLoops",
                     "FrictionFit", "LoopFit", "ExcitationResult", "TirParameterSet", "MeasuredProfiles",
                     "WearCalibration"}
    assert len(found) == len(CASES)


def _save(result, path):
    """``result.save(path)``, which returns the path."""
    assert result.save(path) == path
    return path


@pytest.mark.parametrize("name", list(CASES))
def test_result_interface(name, results, tmp_path):
    result = results(name)
    assert isinstance(result, Result)
    summary = result.summary()
    assert json.loads(json.dumps(summary, allow_nan=False)) == summary  # JSON-serialisable as it is
    has_params = name not in WITHOUT_PARAMS
    assert (result.params is not None) == has_params
    assert result.polywear_version == __version__

    ds = result.to_xarray()
    assert isinstance(ds, xr.Dataset) and ds.attrs["polywear_version"] == __version__
    df = result.to_dataframe()
    assert isinstance(df, pd.DataFrame) and len(df.columns) > 0

    # .json: the summary, with the version (and parameters, settings where there are any)
    path = _save(result, tmp_path / "r.json")
    saved = json.loads(path.read_text())
    assert {k: saved[k] for k in summary} == json.loads(json.dumps(summary))
    assert saved["polywear_version"] == __version__
    if has_params:
        assert Params.model_validate(saved["params"]) == result.params

    # .nc: to_xarray with the parameters and version in its attributes
    path = _save(result, tmp_path / "r.nc")
    with xr.open_dataset(path, engine="h5netcdf") as back:
        assert back.attrs["polywear_version"] == __version__
        assert set(back.data_vars) == set(ds.data_vars)
        if has_params:
            (tmp_path / "p.toml").write_text(back.attrs["params_toml"])
            assert load_params(tmp_path / "p.toml") == result.params

    # .csv: the dataframe
    path = _save(result, tmp_path / "r.csv")
    back = pd.read_csv(path)
    assert list(back.columns) == [str(c) for c in df.columns] and len(back) == len(df)
    if name == "fleet":  # the per-car table
        assert len(back) == len(result.status)

    with pytest.raises(ValueError, match="cannot write"):
        result.save(tmp_path / "r.txt")
    assert not (tmp_path / "r.txt").exists()

    fig, ax = plt.subplots()
    result.plot(ax=ax)
    assert ax.has_data() or ax.patches or ax.texts  # drawn onto the given axes
    plt.close(fig)
    fig = result.figure()
    assert isinstance(fig, Figure) and fig.axes
    plt.close("all")


def test_save_is_atomic_and_leaves_no_partial_file(results, tmp_path):
    """A failing write leaves an existing file untouched and no temporary file behind."""
    result = results("stability")
    target = tmp_path / "s.json"
    target.write_text("old")

    class Broken(type(result)):
        def summary(self):
            raise RuntimeError("boom")

    broken = Broken(**{f: getattr(result, f) for f in result.__dataclass_fields__})
    with pytest.raises(RuntimeError):
        broken.save(target)
    assert target.read_text() == "old" and [p.name for p in tmp_path.iterdir()] == ["s.json"]


def test_report_holds_its_results(tmp_path):
    """The main job returns the result objects it computed; summary.json is derived from them."""
    from polywear.dynamics.diagram import BifurcationDiagram
    from polywear.dynamics.design import DesignResult
    from polywear.dynamics.sensitivity import SensitivityResult
    from polywear.dynamics.simulation import SimulationSet
    from polywear.wear.map import WearMap
    from polywear.report.main import report

    result = report(Params(), tmp_path, wear_evolution_km=2000.0)
    assert isinstance(result.diagram, BifurcationDiagram) and result.stability is result.diagram.stability
    assert isinstance(result.sensitivity, SensitivityResult) and isinstance(result.design, DesignResult)
    assert isinstance(result.disturbances, SimulationSet) and isinstance(result.wear_map, WearMap)
    assert all(isinstance(p, Result) for p in result.portraits)
    summary = result.summary()
    assert json.loads((tmp_path / "summary.json").read_text()) == json.loads(json.dumps(summary, default=float))
    assert summary["bifurcation"] == result.diagram.summary() and summary["design"] == result.design.summary()
    assert summary["wear"] == result.wear.summary() and summary["verdict"] == result.overall
    assert [label for label, _ in result.wear.evolutions] == ["operating speed", "drive cycle"]
    with xr.open_dataset(tmp_path / "bifurcation.nc", engine="h5netcdf") as saved:
        np.testing.assert_array_equal(saved["speed_kmh"].values, result.diagram.to_xarray()["speed_kmh"].values)
    # the report is a Result too: it records what it ran with (the defaults resolved), its
    # table is the diagram's cycles.csv, its JSON file the summary with the provenance
    from polywear.report.main import ReportSettings

    assert isinstance(result, Result)
    assert result.settings == ReportSettings((20.0, 300.0), (80.0, 130.0), 2000.0, True)
    assert result.save(tmp_path / "again.csv").read_bytes() == (tmp_path / "cycles.csv").read_bytes()
    saved = json.loads(result.save(tmp_path / "again.json").read_text())
    assert saved["settings"] == {"speed_range_kmh": [20.0, 300.0], "operating_range_kmh": [80.0, 130.0],
                                 "wear_evolution_km": 2000.0, "wear_design_by_evolution": True,
                                 "wear_design_refined": True}
    assert saved["verdict"] == json.loads(json.dumps(result.overall, default=float))
