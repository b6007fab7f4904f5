"""Every settings object validates its fields on construction, is frozen, hashable and
picklable (settings travel to worker processes), and keeps its documented defaults."""

from __future__ import annotations

import dataclasses
import math
import pickle

import pytest

from polywear.measured.calibration import CalibrationSettings
from polywear.measured.campbell import CampbellSettings
from polywear.dynamics.design import DesignSettings
from polywear.dynamics.excitation import ExcitationSettings
from polywear.friction import LoopFitSettings, LoopSettings
from polywear.dynamics.sensitivity import SensitivitySettings
from polywear.dynamics.simulation import SimulationSettings
from polywear.dynamics.stability import StabilitySettings
from polywear.dynamics.stability_map import MapSettings
from polywear.dynamics.sweep import SweepSettings
from polywear.wear.evolution import EvolutionSettings
from polywear.solvers.continuation import ContinuationSettings
from polywear.validation.auto07p import AutoSettings

# (class, field, bad value): each must raise a ValueError naming the field
BAD = [
    (ContinuationSettings, "n_intervals", 0),
    (ContinuationSettings, "degree", 2.5),
    (ContinuationSettings, "ds_initial", -0.01),
    (ContinuationSettings, "ds_initial", 0.6),  # above ds_max
    (ContinuationSettings, "ds_min", 0.03),  # above ds_initial
    (ContinuationSettings, "ds_max", math.nan),
    (ContinuationSettings, "max_steps", 0),
    (ContinuationSettings, "newton_tol", 0.0),
    (ContinuationSettings, "max_newton", 0),
    (ContinuationSettings, "adapt_every", -1),
    (ContinuationSettings, "fold_tol", math.inf),
    (ContinuationSettings, "max_amplitude", 1e-4),  # below min_amplitude
    (ContinuationSettings, "multiplier_tol", -1e-5),
    (ContinuationSettings, "max_period_factor", 0.0),
    (MapSettings, "ds_initial", 0.05),  # above ds_max
    (MapSettings, "ds_min", 0.0),
    (MapSettings, "max_steps", 0),
    (MapSettings, "newton_tol", -1.0),
    (MapSettings, "max_turn", 4.0),
    (MapSettings, "n_seeds", 0),
    (MapSettings, "n_grid", 1),
    (MapSettings, "fold_step", 0.0),
    (MapSettings, "fold_min_step", 0.1),  # above fold_step
    (MapSettings, "fold_min_amplitude", 1.5),
    (MapSettings, "continuation", {"n_intervals": 40}),
    (StabilitySettings, "n_speeds", 2),
    (StabilitySettings, "n_speeds", 10.0),
    (StabilitySettings, "xtol_ms", 0.0),
    (SimulationSettings, "method", "euler"),
    (SimulationSettings, "rtol", 0.0),
    (SimulationSettings, "atol", math.inf),
    (SimulationSettings, "dt_out", -2e-5),
    (SimulationSettings, "min_cycles", 1),
    (SimulationSettings, "window_fraction", 0.0),
    (AutoSettings, "ncol", 8),
    (AutoSettings, "ntst", 1),
    (AutoSettings, "nmx", 0),
    (AutoSettings, "epsu", 0.0),
    (AutoSettings, "ds", 10.0),  # above dsmax
    (AutoSettings, "dsmax_cycles", 1e-3),  # below ds
    (SweepSettings, "small", 0.0),
    (SweepSettings, "large", math.nan),
    (SweepSettings, "chunk_s", -0.25),
    (SweepSettings, "max_duration_s", 0.1),  # shorter than one chunk
    (SweepSettings, "simulation", None),
    (CampbellSettings, "window_s", 0.0),
    (CampbellSettings, "overlap", 1.0),
    (CampbellSettings, "overlap", -0.1),
    (CampbellSettings, "f_range_hz", (50.0, 10.0)),
    (CampbellSettings, "peak_db", -3.0),
    (CampbellSettings, "sev_db", math.inf),
    (CampbellSettings, "disturbance_m", 0.0),
    (SensitivitySettings, "method", "backward"),
    (SensitivitySettings, "step", 0.0),
    (CalibrationSettings, "n_speeds", 2),
    (CalibrationSettings, "undetermined_above", 0.0),
    (DesignSettings, "margin_kmh", -1.0),
    (DesignSettings, "margin_kmh", math.inf),
    (DesignSettings, "search_factor", 1.0),
    (DesignSettings, "search_factor", math.nan),
    (ExcitationSettings, "duration_s", 0.0),
    (ExcitationSettings, "duration_s", math.inf),
    (ExcitationSettings, "settling_efoldings", -8.0),
    (ExcitationSettings, "settling_min_s", 0.0),
    (ExcitationSettings, "settling_max_s", 0.5),  # below settling_min_s
    (EvolutionSettings, "step_km", 0.0),
    (EvolutionSettings, "step_km", math.inf),
    (EvolutionSettings, "revolutions", 5),  # the CLI's least --revolutions
    (EvolutionSettings, "revolutions", 16.0),
    (LoopSettings, "points_per_period", 4),  # hysteresis_loops needs at least 8 samples per loop
    (LoopSettings, "rtol", 0.0),
    (LoopSettings, "atol", -1e-12),
    (LoopFitSettings, "harmonics", 0),
    (LoopFitSettings, "rtol", math.nan),
    (LoopFitSettings, "sigma0_range", (1e3, 10.0)),
    (LoopFitSettings, "sigma0_range", (0.0, 1e6)),
    (LoopFitSettings, "sigma0_range", (1.0, math.inf)),
]

CLASSES = [ContinuationSettings, MapSettings, StabilitySettings, SimulationSettings, AutoSettings, SweepSettings,
           CampbellSettings, SensitivitySettings, CalibrationSettings, DesignSettings, ExcitationSettings,
           EvolutionSettings, LoopSettings, LoopFitSettings]


@pytest.mark.parametrize(("cls", "name", "value"), BAD, ids=[f"{c.__name__}.{n}={v!r}" for c, n, v in BAD])
def test_bad_value_is_rejected_naming_the_field(cls, name, value):
    with pytest.raises(ValueError, match=rf"{cls.__name__}: .*\b{name}\b"):
        cls(**{name: value})


@pytest.mark.parametrize("cls", CLASSES, ids=lambda c: c.__name__)
def test_settings_are_frozen_hashable_and_picklable(cls):
    settings = cls()
    first = dataclasses.fields(cls)[0].name
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(settings, first, getattr(settings, first))
    assert pickle.loads(pickle.dumps(settings)) == settings
    assert hash(cls()) == hash(settings)
    changed = dataclasses.replace(settings)  # replace() validates again
    assert changed == settings


def test_defaults_are_unchanged():
    assert (StabilitySettings().n_speeds, StabilitySettings().xtol_ms) == (400, 1e-10)
    c = ContinuationSettings()
    assert (c.n_intervals, c.degree, c.ds_initial, c.ds_min, c.ds_max, c.max_steps) == (40, 4, 0.02, 1e-7, 0.5, 400)
    m = MapSettings()
    assert (m.ds_initial, m.ds_max, m.ds_min, m.n_seeds, m.n_grid, m.continuation) == (
        0.01, 0.03, 1e-7, 3, 81, ContinuationSettings())
    s = SweepSettings()
    assert (s.small, s.large, s.chunk_s, s.max_duration_s, s.simulation) == (1e-5, 1e-3, 0.25, 4.0, SimulationSettings())
    d = DesignSettings()
    assert (d.margin_kmh, d.search_factor) == (2.0, 3.0)
    e = ExcitationSettings()
    assert (e.duration_s, e.settling_efoldings, e.settling_min_s, e.settling_max_s) == (None, 8.0, 0.6, 8.0)
    assert DesignSettings(margin_kmh=0.0).margin_kmh == 0.0  # no margin is allowed
    assert (EvolutionSettings().step_km, EvolutionSettings().revolutions) == (1000.0, 16)
    assert (LoopSettings().points_per_period, LoopSettings().rtol, LoopSettings().atol) == (400, 1e-10, None)
    f = LoopFitSettings()
    assert (f.harmonics, f.sigma0_range, f.rtol) == (3, (1.0, 1e6), 1e-8)
    c = CampbellSettings()
    assert (c.window_s, c.overlap, c.f_range_hz, c.peak_db, c.sev_db, c.disturbance_m) == (0.5, 0.75, None, 15.0, 20.0,
                                                                                          1e-6)


def test_infinite_multiplier_tolerance_switches_the_check_off():
    assert ContinuationSettings(multiplier_tol=math.inf).multiplier_tol == math.inf
    assert ContinuationSettings(adapt_every=0).adapt_every == 0


def test_bifurcation_takes_its_stability_grid_as_settings():
    """bifurcation(stability_settings=...) is the grid of the Hopf bracketing (was n_speeds=);
    a widened range keeps the grid spacing (at most four times the points) and the other fields."""
    from polywear.dynamics.bifurcation import bifurcation
    from polywear.params import Params

    fixed = bifurcation(Params(), (20.0, 300.0), stability_settings=StabilitySettings(n_speeds=50), extend=False)
    assert fixed.stability.settings == {"n_speeds": 50, "xtol_ms": 1e-10}
    assert fixed.speed_range_kmh == (20.0, 300.0)
    grid = StabilitySettings(n_speeds=20, xtol_ms=1e-9)
    widened = bifurcation(Params(), (150.0, 200.0), stability_settings=grid)  # operating speed 110 km/h
    lo, hi = widened.speed_range_kmh
    assert lo < 110.0 < hi and (lo, hi) != (150.0, 200.0)
    n = widened.stability.settings["n_speeds"]
    assert n == min(max(20, math.ceil((hi - lo) / (50.0 / 19)) + 1), 80)
    assert widened.stability.settings["xtol_ms"] == 1e-9


def test_design_and_excitation_follow_their_settings():
    """DesignSettings.margin_kmh is the margin the design keeps and reports; the default
    simulated time of a portrait lies within ExcitationSettings' settling bounds."""
    from polywear.dynamics.bifurcation import bifurcation
    from polywear.dynamics.design import design
    from polywear.dynamics.excitation import settling_time
    from polywear.params import Params

    d = bifurcation(Params())
    (band_lo, _), *_ = d.sev_band_kmh
    below = (band_lo - 12.0, band_lo - 8.0)  # clear of the band by 8 km/h
    clear = design(Params(), below, diagram=d, settings=DesignSettings(margin_kmh=5.0))
    assert clear.margin_kmh == 5.0 and clear.options == [] and "5 km/h margin" in clear.reason
    blocked = design(Params(), below, keys=(), diagram=d, settings=DesignSettings(margin_kmh=10.0))
    assert blocked.margin_kmh == 10.0 and "outside the operating range" not in blocked.reason  # 10 km/h reach the band
    speed = 0.5 * sum(d.sev_band_kmh[0])
    cycles = d.cycles_at(speed)
    assert settling_time(d, speed, cycles, ExcitationSettings(settling_min_s=1.25, settling_max_s=1.25)) == 1.25
    free = settling_time(d, speed, cycles, ExcitationSettings(settling_max_s=1e3))
    assert 0.6 <= free and settling_time(d, speed, cycles) == min(max(free, 0.6), 8.0)


def test_study_spec_is_frozen_hashable_and_picklable():
    """The study specification (the [study] table, not part of Params) travels like a settings object."""
    import pydantic

    from polywear.params import Params, StudySpec

    study = StudySpec().with_updates({"n_base": 64, "parameters": [{"key": "operating.toe_deg", "low": 0.4, "high": 0.6}]})
    with pytest.raises(pydantic.ValidationError):
        study.n_base = 128
    assert pickle.loads(pickle.dumps(study)) == study and hash(study) == hash(pickle.loads(pickle.dumps(study)))
    assert study.with_updates({}) == study and StudySpec().n_base == 1024
    assert "study" not in Params.model_fields
