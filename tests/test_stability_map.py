"""Stability maps against closed forms (tread1dof: V ~ 1/sin(toe)), the Routh-Hurwitz
condition, Lyapunov coefficients on either side of a Bautin point, and one-parameter
bifurcation diagrams at fixed parameter values; the ``polywear map`` command."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import xarray as xr

from polywear.dynamics.bifurcation import bifurcation
from polywear.dynamics.points import PointKind
from polywear.dynamics.sensitivity import perturbed
from polywear.dynamics.stability import stability
from polywear.dynamics.stability_map import stability_map
from polywear.models import get_model
from polywear.params import Params, with_updates

from .cli_runner import run_main
from .oracles import routh_hurwitz_hopf_speeds

TOE = "operating.toe_deg"
MU = "friction.mu_static"


@pytest.fixture(scope="module")
def toe_map():
    return stability_map(Params(), TOE, (0.1, 1.5), operating_range_kmh=(80.0, 130.0))


@pytest.fixture(scope="module")
def mu_map():
    return stability_map(Params(), MU, (0.55, 1.2))


@pytest.fixture(scope="module")
def nominal():
    return bifurcation(Params())


def _flat(intervals):
    return [v for iv in intervals for v in iv]


def test_toe_map_curves_follow_one_over_sin_toe(toe_map, nominal):
    """Speed enters tread1dof only through V sin(toe): every curve is V sin(toe) = const."""
    assert len(toe_map.hopf_curves) == 2 and len(toe_map.fold_curves) == 1
    assert toe_map.turning_points == [] and toe_map.bautin_points == []
    constants = sorted(h.speed_kmh * math.sin(math.radians(0.5)) for h in nominal.hopf_points)
    for curve in toe_map.hopf_curves:
        c = curve.speed_kmh * np.sin(np.radians(curve.value))
        k = int(np.argmin([abs(c[0] - x) for x in constants]))
        assert np.allclose(c, constants[k], rtol=1e-9)
        assert np.all(np.diff(np.sign(curve.first_lyapunov_coefficient)) == 0)  # criticality does not depend on toe
    fold = toe_map.fold_curves[0]
    c_fold = nominal.folds[0].speed_kmh * math.sin(math.radians(0.5))
    assert np.allclose(fold.speed_kmh * np.sin(np.radians(fold.value)), c_fold, rtol=1e-6)
    # exact dV/d(toe) at every fold point: -V cot(toe) per radian
    assert np.allclose(fold.derivative, -fold.speed_kmh / np.tan(np.radians(fold.value)) * math.pi / 180, rtol=1e-6)
    assert fold.value.min() < 0.3 and fold.value.max() == 1.5


@pytest.mark.parametrize("toe", [0.35, 0.8, 1.2])
def test_toe_map_bands_match_one_parameter_diagrams(toe_map, toe):
    diagram = bifurcation(perturbed(Params(), TOE, toe), extend=False)  # the map's window
    bands = toe_map.bands_at(toe)
    assert np.allclose(_flat(bands["linear"]), _flat(diagram.linear_band_kmh), rtol=1e-8)
    assert np.allclose(_flat(bands["sev"]), _flat(diagram.sev_band_kmh), rtol=1e-5)
    hard = _flat(bands["hard"])
    assert np.allclose(hard, _flat(diagram.hard_regions_kmh), rtol=1e-5)


def test_safe_toe_values_for_an_operating_range(toe_map, nominal):
    """No SEV in 80-130 km/h only where the first Hopf speed exceeds 130 km/h: sin(toe) < sin(0.5) V_H1 / 130."""
    h1 = nominal.hopf_points[0].speed_kmh
    limit = math.degrees(math.asin(math.sin(math.radians(0.5)) * h1 / 130.0))
    (safe,) = toe_map.safe_values()
    step = np.diff(toe_map.grid_values)[0]
    assert safe[0] == 0.1 and limit - step < safe[1] <= limit


def test_hopf_curve_points_are_hopf_points(mu_map):
    model = get_model("tread1dof")
    (curve,) = mu_map.hopf_curves
    for i in range(0, len(curve.value), 7):
        p = model.pack(perturbed(Params(), MU, curve.value[i]))
        speeds = np.array(routh_hurwitz_hopf_speeds(p, 5 / 3.6, 400 / 3.6)) * 3.6
        assert np.min(np.abs(speeds - curve.speed_kmh[i])) < 1e-8 * curve.speed_kmh[i]


def test_band_closure_of_the_mu_static_map(mu_map):
    """Below the turning point of the Hopf curve the linear band is closed (Routh-Hurwitz)."""
    (closure,) = mu_map.turning_points
    assert closure.kind is PointKind.HOPF_TURN
    value, speed = closure.value, closure.speed_kmh
    model = get_model("tread1dof")

    def hopf_speeds(v):
        p = model.pack(perturbed(Params(), MU, v))
        return np.array(routh_hurwitz_hopf_speeds(p, 20 / 3.6, 300 / 3.6, n=20000)) * 3.6

    above, below = hopf_speeds(value * (1 + 1e-5)), hopf_speeds(value * (1 - 1e-5))
    assert len(above) == 2 and above[0] < speed < above[1] and above[1] - above[0] < 2.0  # width ~ sqrt(distance)
    assert len(below) == 0
    assert mu_map.bands_at(0.58)["sev"] == []


def test_bautin_point_of_the_mu_static_map(mu_map, nominal):
    """l1 changes sign at the Bautin point, and the fold-of-cycles curve ends there."""
    (bautin,) = mu_map.bautin_points
    assert bautin.kind is PointKind.GH
    value, speed = bautin.value, bautin.speed_kmh
    l1 = {}
    for side in (-1, 1):
        stab = stability(perturbed(Params(), MU, value * (1 + side * 1e-3)), (20.0, 300.0))
        l1[side] = min(stab.hopf_points, key=lambda h: abs(h.speed_kmh - speed)).first_lyapunov_coefficient
    assert l1[-1] < 0 < l1[1]  # soft below, hard above (the default, 0.9, is hard)
    at = min(stability(perturbed(Params(), MU, value), (20.0, 300.0)).hopf_points,
             key=lambda h: abs(h.speed_kmh - speed))
    assert abs(at.first_lyapunov_coefficient) < 1e-3 * abs(nominal.hopf_points[1].first_lyapunov_coefficient)
    (fold,) = mu_map.fold_curves
    end = int(np.argmin(fold.value))
    assert fold.end_reasons[0].startswith("amplitude vanishing")
    assert abs(fold.value[end] - value) < 1e-3 * value and abs(fold.speed_kmh[end] - speed) < 0.5


@pytest.mark.parametrize("mu", [0.63, 0.75, 1.1])
def test_mu_static_map_bands_match_one_parameter_diagrams(mu_map, mu):
    diagram = bifurcation(perturbed(Params(), MU, mu), extend=False)  # the map's window
    bands = mu_map.bands_at(mu)
    assert np.allclose(_flat(bands["linear"]), _flat(diagram.linear_band_kmh), rtol=1e-8)
    assert np.allclose(_flat(bands["sev"]), _flat(diagram.sev_band_kmh), rtol=1e-5)


def test_save_and_plot(toe_map, tmp_path):
    toe_map.save(tmp_path / "m.nc")
    ds = xr.open_dataset(tmp_path / "m.nc", engine="h5netcdf")
    assert ds["state"].shape == (len(toe_map.grid_values), 561)
    assert set(np.unique(ds["state"].values)) == {0, 1, 2}
    assert np.array_equal(ds["fold_speed_kmh"].values, toe_map.fold_curves[0].speed_kmh)
    assert json.loads(ds.attrs["summary_json"])["param"] == TOE
    ds.close()
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    assert len(toe_map.plot(ax)) > 5
    plt.close(fig)


@pytest.mark.slow
def test_axle4dof_adhesion_map_matches_one_parameter_diagrams():
    params = with_updates(Params(), {"model": "axle4dof"})
    m = stability_map(params, "adhesion_scale", (0.8, 1.2))
    assert len(m.hopf_curves) == 2 and len(m.bautin_points) == 1
    for value in (0.9, 1.15):
        diagram = bifurcation(perturbed(params, "adhesion_scale", value))
        bands = m.bands_at(value)
        assert np.allclose(_flat(bands["linear"]), _flat(diagram.linear_band_kmh), rtol=1e-8)
        assert np.allclose(_flat(bands["sev"]), _flat(diagram.sev_band_kmh), rtol=1e-4)


# -- the command ---------------------------------------------------------------------------------
def test_cli_map_json_and_plot(tmp_path):
    plot = tmp_path / "map.png"
    code, out, err = run_main(["map", "--param", TOE, "--range", "0.3", "0.9", "--operating-range", "80", "130",
                               "--json", "-q", "--plot", str(plot)])
    assert code == 0, err
    data = json.loads(out)
    assert data["param"] == TOE and data["range"] == [0.3, 0.9] and len(data["hopf_curves"]) == 2
    assert data["at_nominal"]["sev"][0][0] == pytest.approx(58.0753, abs=1e-3)
    assert plot.read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize("args, fragment", [
    (["--param", "tread.mass"], "tread.mass"),
    (["--param", "operating.camber_deg", "--range", "-2", "0"], "does not enter"),
    (["--param", MU, "--range", "0.3", "1.0"], "friction.mu_coulomb"),
    (["--param", TOE, "--range", "1.0", "0.5"], "--range"),
])
def test_cli_bad_input(args, fragment):
    code, out, err = run_main(["map", "-q", *args])
    assert code == 2 and out == "" and err.count("\n") == 1 and fragment in err, err


def test_failed_rows_are_noted_grey_and_never_safe(monkeypatch):
    """Where the linear band cannot be computed (e.g. no equilibrium), the row is unknown, not stable."""
    import polywear.dynamics.stability as stab

    real = stab.fast_linear_band

    def failing(params, speed_range_kmh=(20.0, 300.0), **kw):
        if params.operating.toe_deg < 0.15:
            raise RuntimeError("no equilibrium (test)")
        return real(params, speed_range_kmh, **kw)

    monkeypatch.setattr(stab, "fast_linear_band", failing)
    m = stability_map(Params(), TOE, (0.1, 0.4), operating_range_kmh=(80.0, 130.0), folds=False)
    bad = m.grid_values < 0.15
    assert bad.any() and all("error" in b for b, flag in zip(m.grid_bands, bad) if flag)
    assert np.all(m.state_grid(np.linspace(20, 300, 50))[bad] == 3)
    assert all(lo >= 0.15 for lo, _ in m.safe_values())
    assert any("no equilibrium (test)" in note for note in m.notes)
