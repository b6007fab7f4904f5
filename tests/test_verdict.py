"""The verdict in every regime: the safe car, bands cut by the analysed range, attractors
other than the continued period-1 cycle (period doubling, static divergence), and the
trigger amplitude up to the fold.

Oracles: for tread1dof the speed enters only through V sin(toe), so every bifurcation
speed scales exactly as 1 / sin(toe) (the diagram at the default toe 0.5 deg is the
reference); AUTO-07p's fold amplitudes (docs/validation_auto07p.md); det J changing
sign at a real eigenvalue crossing; a second simulation from another start.
"""

import json
import math

import numpy as np
import pytest

from polywear.dynamics.attractor import Regime, reached_attractors
from polywear.dynamics.bifurcation import SPEED_CEILING_KMH, bifurcation
from polywear.dynamics.diagram import statically_divergent
from polywear.dynamics.design import design
from polywear.dynamics.sensitivity import sensitivity
from polywear.dynamics.simulation import simulate
from polywear.models import get_model
from polywear.params import Params, with_updates
from polywear.report.main import _sentence, operating_verdict

from .cli_runner import run_main

SIN_NOMINAL = math.sin(math.radians(0.5))


def _toe(toe_deg, **more):
    return with_updates(Params(), {"operating.toe_deg": toe_deg, **more})


@pytest.fixture(scope="module")
def nominal():
    """Hopf and fold speeds [km/h] of the defaults (toe 0.5 deg), the scaling reference."""
    d = bifurcation(Params(), (20.0, 300.0))
    return [h.speed_kmh for h in d.hopf_points], [f.speed_kmh for f in d.folds]


def _scaled(speed_kmh, toe_deg):
    return speed_kmh * SIN_NOMINAL / math.sin(math.radians(toe_deg))


# -- the safe car: no Hopf point, no cycle ----------------------------------------------
def test_safe_car_verdict_sensitivity_and_design_are_answers():
    params = _toe(0.05)  # Hopf speeds scale to 581 and 2078 km/h: nothing in 20-300 km/h
    diagram = bifurcation(params, (20.0, 300.0))
    assert diagram.hopf_points == [] and diagram.sev_band_kmh == [] and diagram.open_edges == []
    s = diagram.summary()
    assert s["first_bifurcation_speed_kmh"] is None and s["second_bifurcation_speed_kmh"] is None
    assert s["open_at"] is None and s["warnings"] == []
    verdict = operating_verdict(diagram, params, 110.0)
    assert verdict["regime"] == "no SEV" and verdict["steady_rolling_stable"]
    assert "no self-excited vibration" in _sentence(verdict)
    sens = sensitivity(params, diagram=diagram)
    assert sens.rows == [] and "no Hopf point" in sens.summary()["notes"][0]
    options = design(params, (80.0, 130.0), diagram=diagram)
    assert options.options == []


def test_safe_car_bifurcation_text_exit_0():
    code, out, err = run_main(["bifurcation", "-q", "-s", "operating.toe_deg=0.05"])
    assert code == 0, err
    assert "no self-excited vibration in the speed range" in out


# -- the analysed range does not decide the answer ---------------------------------------
def test_band_cut_at_the_upper_end_is_extended_to_its_fold(nominal):
    """toe 0.3 deg: the band used to end at 300 km/h; its fold is at 254.7 / sin ratio."""
    hopfs, folds = nominal
    diagram = bifurcation(_toe(0.3), (20.0, 300.0))
    s = diagram.summary()
    assert s["open_at"] is None and s["range_notes"]
    assert s["second_bifurcation_speed_kmh"] == pytest.approx(_scaled(folds[0], 0.3), rel=1e-7)
    assert s["first_bifurcation_speed_kmh"] == pytest.approx(_scaled(hopfs[0], 0.3), rel=1e-9)
    assert s["requested_speed_range_kmh"] == [20.0, 300.0]


def test_band_cut_at_the_lower_end_is_extended_to_its_hopf_point(nominal):
    hopfs, folds = nominal
    s = bifurcation(_toe(5.0), (20.0, 300.0)).summary()
    assert s["first_bifurcation_speed_kmh"] == pytest.approx(_scaled(hopfs[0], 5.0), rel=1e-9)  # 5.81 km/h
    assert s["second_bifurcation_speed_kmh"] == pytest.approx(_scaled(folds[0], 5.0), rel=1e-7)


def test_band_open_beyond_the_ceiling_is_null_with_open_at(nominal):
    """toe 0.1 deg: the second Hopf point scales to 1039 km/h, above the ceiling: the upper
    edge is reported as null, never as the range limit, and has no sensitivity."""
    hopfs, _ = nominal
    assert _scaled(hopfs[1], 0.1) > SPEED_CEILING_KMH
    params = _toe(0.1)
    diagram = bifurcation(params, (20.0, 300.0))
    s = diagram.summary()
    assert diagram.speed_range_kmh[1] == SPEED_CEILING_KMH
    assert s["open_at"] == "upper" and "upper end" in s["warnings"][0]
    assert s["second_bifurcation_speed_kmh"] is None and s["sev_band_kmh"][-1][1] is None
    assert s["first_bifurcation_speed_kmh"] == pytest.approx(_scaled(hopfs[0], 0.1), rel=1e-9)
    json.dumps(s)  # null, not NaN or a number
    sens = sensitivity(params, keys=("operating.toe_deg",), diagram=diagram)
    assert {r["quantity"] for r in sens.rows} == {"hopf_1", "first_bifurcation"}
    assert any(n.startswith("second_bifurcation") for n in sens.notes)
    # the first bifurcation speed's exact toe sensitivity against the 1/sin(toe) law
    (row,) = [r for r in sens.rows if r["quantity"] == "first_bifurcation"]
    toe = math.radians(0.1)
    assert row["normalized"] == pytest.approx(-toe / math.tan(toe), rel=1e-6)
    verdict = operating_verdict(diagram, params, 300.0)  # in the band: soft SEV, margin to an open edge
    assert verdict["regime"] == "unstable rolling (soft SEV)"
    assert verdict["margin_to_second_bifurcation_kmh"] is None
    assert verdict["margin_to_first_bifurcation_kmh"] == pytest.approx(row["speed_kmh"] - 300.0)


def test_operating_speed_outside_the_requested_range_is_analysed():
    """--speed-range 20 100 at 110 km/h: the range widens to hold 110 km/h, and the verdict is
    the one on the full range (0.269 mm soft SEV), not "no SEV"."""
    params = Params()
    narrow = bifurcation(params, (20.0, 100.0))
    full = bifurcation(params, (20.0, 300.0))
    assert narrow.speed_range_kmh[1] >= 110.0 and narrow.range_notes
    v_narrow, v_full = operating_verdict(narrow, params, 110.0), operating_verdict(full, params, 110.0)
    assert v_narrow["regime"] == v_full["regime"] == "unstable rolling (soft SEV)"
    assert v_narrow["sev_amplitude_x_mm"] == pytest.approx(v_full["sev_amplitude_x_mm"], rel=1e-8)
    assert narrow.summary()["second_bifurcation_speed_kmh"] == pytest.approx(
        full.summary()["second_bifurcation_speed_kmh"], rel=1e-8)


# -- other attractors -----------------------------------------------------------------------
def test_stick_slip_past_period_doubling_is_named_with_amplitude_and_frequency():
    """mu_c = 0.05 at 110 km/h lies between two period doublings of the period-1 branch
    (54.4 and 116.5 km/h); without a stable continued cycle at hand the run starts from
    steady rolling and ends on a cycle with several maxima per period. Checks: the run
    continued from its own end state stays on it (an attractor, settled), and the dominant
    frequency of the spectrum is a whole multiple of 1/period (two methods)."""
    params = with_updates(Params(), {"friction.mu_coulomb": 0.05})
    diagram = bifurcation(params, (100.0, 120.0), extend=False)  # no Hopf point: no continuation
    assert diagram.hopf_points == [] and diagram.linear_band_kmh == [(100.0, 120.0)]
    (found,) = reached_attractors(diagram, 110.0)
    st = found.run.steady
    assert found.regime == Regime.PERIOD_MULTIPLIED and st.maxima_per_period >= 2
    ratio = found.dominant_frequency_hz * st.period
    assert ratio == pytest.approx(round(ratio), abs=0.02) and round(ratio) >= 1
    again = simulate(params, 110.0, 1.0, initial=found.run.u[-1])
    assert again.steady.outcome == "cycle" and again.steady.maxima_per_period == st.maxima_per_period
    assert again.steady.amplitude[0] == pytest.approx(found.amplitude[0], rel=1e-3)
    assert again.steady.period == pytest.approx(st.period, rel=1e-4)
    verdict = operating_verdict(diagram, params, 110.0)
    assert verdict["regime"] == Regime.PERIOD_MULTIPLIED and verdict["sev_amplitude_x_mm"] == 1e3 * found.amplitude[0]
    assert verdict["frequency_hz"] == found.dominant_frequency_hz
    assert Regime.PERIOD_MULTIPLIED in _sentence(verdict)


@pytest.fixture(scope="module")
def divergent_axle():
    """axle4dof with a soft toe bushing: a real eigenvalue crosses zero near 35.7 km/h, below
    the tread's Hopf point (78.5 km/h): compliance steer, a static divergence."""
    return with_updates(Params(), {"model": "axle4dof", "axle.toe_stiffness_nm_per_rad": 2e4,
                                   "operating.speed_kmh": 50.0})


def test_static_divergence_is_not_sev(divergent_axle):
    params = divergent_axle
    diagram = bifurcation(params, (30.0, 70.0), extend=False)
    (v_div,) = diagram.stability.real_crossings_kmh
    model = get_model("axle4dof")
    p = model.pack(params)

    def det(v_kmh):
        V = v_kmh / 3.6
        return np.linalg.det(model.jacobian(model.equilibrium(V, p), V, p))

    assert np.sign(det(v_div - 0.01)) != np.sign(det(v_div + 0.01))  # a real eigenvalue through 0
    assert diagram.divergence_kmh == [(v_div, 70.0)]
    assert diagram.sev_band_kmh == []  # unstable rolling, but nothing vibrates
    s = diagram.summary()
    assert s["real_eigenvalue_crossings_kmh"] == [v_div] and s["divergence_kmh"] == [[v_div, None]]
    verdict = operating_verdict(diagram, params, 50.0)
    assert verdict["regime"] == "static divergence" and verdict["divergence"]
    assert not verdict["steady_rolling_stable"] and "sev_amplitude_x_mm" not in verdict and "sev_amplitude_x_m" not in verdict
    assert "not SEV" in _sentence(verdict)


def test_a_hopf_pair_split_into_two_real_eigenvalues_is_not_divergence():
    assert statically_divergent(np.array([2.0, -1.0 + 3j, -1.0 - 3j]))
    assert not statically_divergent(np.array([2.0, 5.0, -1.0]))  # an even count: a split oscillatory pair
    assert not statically_divergent(np.array([2.0, 1.0 + 3j, 1.0 - 3j]))
    assert not statically_divergent(np.array([-2.0, -1.0 + 3j, -1.0 - 3j]))


# -- trigger amplitude -----------------------------------------------------------------------
@pytest.mark.parametrize("model, auto_fold_mm", [("tread1dof", 0.4707251313), ("axle4dof", 0.24766178)])
def test_trigger_amplitude_runs_from_zero_to_the_fold(model, auto_fold_mm):
    """The hard region's trigger amplitude runs from 0 at the subcritical Hopf point to the
    fold amplitude (AUTO-07p's value, docs/validation_auto07p.md), not to the largest stored point."""
    diagram = bifurcation(with_updates(Params(), {"model": model}), (20.0, 300.0))
    (trigger,) = diagram.trigger_amplitude("x")
    (fold,) = diagram.folds
    assert trigger["min_x_mm"] == 0.0
    assert trigger["max_x_mm"] == 1e3 * fold.amplitude[diagram.state_names.index("x")]
    assert trigger["max_x_mm"] == pytest.approx(auto_fold_mm, rel=2e-6)
    assert trigger["speed_range_kmh"][1] == pytest.approx(fold.speed_kmh)


@pytest.mark.slow
def test_period_doublings_listed_in_text_and_the_verdict_is_not_blank(capsys):
    """Stick-slip (mu_c = 0.3): two period doublings of the period-1 branch near 81 and
    102 km/h; at 90 km/h no continued cycle is stable and the verdict names the motion
    reached from the last stable cycle, with its amplitude and frequency."""
    from polywear.cli.bifurcation_cmd import _print_summary

    params = with_updates(Params(), {"friction.mu_coulomb": 0.3, "operating.speed_kmh": 90.0})
    diagram = bifurcation(params, (20.0, 150.0), extend=False)
    s = diagram.summary()
    assert len(s["period_doublings"]) == 2 and s["period_doublings"][0] < 90.0 < s["period_doublings"][1]
    _print_summary(s)
    out = capsys.readouterr().out
    assert sum(line.strip().startswith("PD") for line in out.splitlines()) == 2
    assert not any(c.stable for c in diagram.cycles_at(90.0))
    verdict = operating_verdict(diagram, params, 90.0)
    a = verdict["attractor"]
    assert a["start"].startswith("the stable cycle") and a["regime"] != "no SEV"
    assert verdict["sev_amplitude_x_mm"] > 0.0 and verdict["frequency_hz"] > 0.0


def test_divergence_listed_in_bifurcation_text(divergent_axle, capsys):
    from polywear.cli.bifurcation_cmd import _print_summary

    _print_summary(bifurcation(divergent_axle, (30.0, 70.0), extend=False).summary())
    out = capsys.readouterr().out
    assert any(line.strip().startswith("DIV") for line in out.splitlines())
    assert "no self-excited vibration in the speed range" in out


def test_failed_extension_keeps_the_edge_open(monkeypatch):
    """If the wider diagram cannot be computed (e.g. no equilibrium at the new low speeds),
    the last diagram is kept and its cut end is reported open, never as a bifurcation speed."""
    import polywear.dynamics.bifurcation as bif

    real = bif.stability

    def failing_below_20(params, speed_range_kmh, **kw):
        if speed_range_kmh[0] < 20.0:
            raise RuntimeError("no equilibrium below 20 km/h (test)")
        return real(params, speed_range_kmh, **kw)

    monkeypatch.setattr(bif, "stability", failing_below_20)
    diagram = bifurcation(_toe(5.0), (20.0, 300.0))
    s = diagram.summary()
    assert s["speed_range_kmh"] == [20.0, 300.0] and s["open_at"] == "lower"
    assert s["first_bifurcation_speed_kmh"] is None and s["sev_band_kmh"][0][0] is None
    assert "range not widened to 1-300 km/h: no equilibrium below 20 km/h" in s["range_notes"][-1]


def test_sweep_band_reaching_the_grid_end_is_open():
    """The brute-force sweep: a band that reaches the last grid speed has no second
    bifurcation speed (null, open_at "upper"), one inside the grid keeps both."""
    from types import SimpleNamespace

    from polywear.dynamics.sweep import sweep_bands

    speeds = [20.0, 40.0, 60.0, 80.0]

    def result(flags):
        runs = [SimpleNamespace(outcome="cycle" if f else "equilibrium", steady=True) for f in flags]
        return SimpleNamespace(speeds_kmh=speeds, params=Params(),
                               runs={k: runs for k in ("small", "large", "up", "down")})

    s = sweep_bands(result([False, True, True, True]))
    assert s["open_at"] == "upper" and s["second_bifurcation_speed_kmh"] is None
    assert s["first_bifurcation_speed_kmh"] == 40.0 and s["warnings"] and s["sev_band_kmh"] == [[40.0, None]]
    s = sweep_bands(result([False, True, True, False]))
    assert s["open_at"] is None and (s["first_bifurcation_speed_kmh"], s["second_bifurcation_speed_kmh"]) == (40.0, 60.0)


def test_hard_region_cut_at_the_ceiling_has_an_open_trigger_range(nominal, capsys):
    """toe 0.115 deg: the subcritical Hopf point scales to 903 km/h, its fold to 1107 km/h,
    above the ceiling: the hard region and its trigger range are open at the upper end."""
    from polywear.cli.bifurcation_cmd import _print_summary

    hopfs, folds = nominal
    assert _scaled(hopfs[1], 0.115) < SPEED_CEILING_KMH < _scaled(folds[0], 0.115)
    s = bifurcation(_toe(0.115), (20.0, 300.0)).summary()
    assert s["open_at"] == "upper" and s["folds"] == []
    (region,) = s["hard_regions_kmh"]
    assert region[0] == pytest.approx(_scaled(hopfs[1], 0.115), rel=1e-9) and region[1] is None
    (trigger,) = s["trigger_amplitude"]
    assert trigger["speed_range_kmh"] == region and trigger["min_x_mm"] == 0.0 == trigger["min_x"]
    _print_summary(s)
    assert "hard excitation" in capsys.readouterr().out


@pytest.mark.slow
def test_sustained_irregular_oscillation_is_quasi_periodic_or_chaotic():
    """Stick-slip (mu_c = 0.3) at 90 km/h, between the period doublings at 81 and 102 km/h,
    from a small disturbance: the oscillation never settles on a cycle (no repetition within
    20 maxima) but its swing is sustained. Check: an independent 5 s run from a 1 mm
    disturbance has, in its last second, the same peak-to-peak of x (2 %)."""
    params = with_updates(Params(), {"friction.mu_coulomb": 0.3})
    diagram = bifurcation(params, (85.0, 95.0), extend=False)  # unstable rolling, no continuation
    (found,) = reached_attractors(diagram, 90.0)
    assert found.regime == Regime.QUASI_PERIODIC and found.run.steady.outcome == "transient"
    assert 100.0 < found.dominant_frequency_hz < 160.0
    other = simulate(params, 90.0, 5.0, disturbance=1e-3)
    last = other.t >= 4.0
    assert 2.0 * found.amplitude[0] == pytest.approx(np.ptp(other.u[last, 0]), rel=0.02)
    verdict = operating_verdict(diagram, params, 90.0)
    assert verdict["regime"] == Regime.QUASI_PERIODIC and verdict["sev_amplitude_x_mm"] == 1e3 * found.amplitude[0]


# an axle4dof car with four Hopf points (+-10 % around the defaults): its period-1 cycles
# double their period and bifurcate to tori between 56 and 80 km/h; the SEV band has a gap
# from the period doubling at 56.55 km/h to the first Hopf point at 59.75 km/h
CASCADE_AXLE = {"model": "axle4dof", "tread.lateral_stiffness_n_per_m": 948930.934576492,
                "tread.lateral_damping_ns_per_m": 81.8398969900876, "operating.toe_deg": 0.5467546658405247,
                "operating.camber_deg": -0.9620696553401403, "friction.mu_static": 0.9827781893606673,
                "tread.mass_kg": 0.9305625684486208, "operating.vertical_load_n": 4073.967469208907}


@pytest.fixture(scope="module")
def cascade_axle():
    params = with_updates(Params(), CASCADE_AXLE)
    return params, bifurcation(params, (10.0, 600.0), extend=False)


@pytest.mark.slow
def test_gap_of_the_band_after_a_period_doubling_is_decided_by_simulation(cascade_axle):
    """At 58 km/h steady rolling is stable (eigenvalues: closed check) and no period-1 cycle
    is stable, so the band has a gap there; started from the stable cycle of the window
    below the period doubling, the tread ends in chaotic SEV of ~0.56 mm, which the verdict
    now reports instead of "no SEV". Check: an independent 6 s run from the same start still
    swings by more than 0.5 mm peak-to-peak in its last second, and from 0.1 mm the tread
    returns to rest (coexisting attractors: hard excitation)."""
    params, diagram = cascade_axle
    sev = diagram.sev_band_kmh
    assert any(b < 58.0 < c for (_, b), (c, _) in zip(sev[:-1], sev[1:]))  # a gap of the band
    assert any(s.kind.value == "PD" and 56.0 < s.speed_kmh < 57.0 for s in diagram.special)
    model = get_model("axle4dof")
    p = model.pack(params)
    V = 58.0 / 3.6
    assert np.linalg.eigvals(model.jacobian(model.equilibrium(V, p), V, p)).real.max() < 0.0
    verdict = operating_verdict(diagram, params, 58.0)
    assert verdict["steady_rolling_stable"] and not verdict["in_sev_band"] and verdict["in_band_gap_after_pd_ns"]
    assert verdict["regime"] == Regime.QUASI_PERIODIC and 0.4 < verdict["sev_amplitude_x_mm"] < 0.8
    assert [a["regime"] for a in verdict["other_attractors"]] == ["no SEV"]
    x = model.index("x")
    start = np.array(min((c for c in diagram.cycles if c.stable), key=lambda c: abs(c.speed_kmh - 58.0)).orbit.nodes[0])
    run = simulate(params, 58.0, 6.0, initial=start)
    assert np.ptp(run.u[run.t >= 5.0, x]) > 0.5e-3
    assert "quasi-periodic or chaotic SEV" in _sentence(verdict) and "steady rolling is stable" in _sentence(verdict)


def test_gap_after_a_period_doubling_is_listed_in_json_and_text(cascade_axle, capsys):
    from polywear.cli.bifurcation_cmd import _print_summary

    _, diagram = cascade_axle
    s = diagram.summary()
    gap = next(g for g in s["gaps_after_pd_ns_kmh"] if g[0] < 58.0 < g[1])
    assert gap == pytest.approx([56.548, 59.755], abs=1e-3) and gap in [list(g) for g in diagram.gaps_after_pd_ns_kmh]
    _print_summary(s)
    assert "gap after PD/NS (period-1)      56.548 ..    59.755 km/h" in capsys.readouterr().out


@pytest.mark.slow
def test_a_motion_decayed_to_rounding_noise_is_no_sev(cascade_axle):
    """At 57 km/h the same start decays (by ~1e-3 per 1.5 s piece): later pieces see only the
    integrator's noise (x swinging by ~1e-13 m), which was classified as a sustained chaotic
    motion; judged against the largest deviation of the whole simulation it is rest. Both
    starts then give the same attractor (steady rolling), reported once."""
    params, diagram = cascade_axle
    found = reached_attractors(diagram, 57.0)
    assert [a.regime for a in found] == ["no SEV"]
    verdict = operating_verdict(diagram, params, 57.0)
    assert verdict["regime"] == "no SEV" and verdict["other_attractors"] == []


# -- one verdict: vibration and wear together (report/verdict.py) ---------------------------
def _wear_summary(*evolutions):
    from polywear.report.wear import wear_headline

    section = {"energetic_rate_mm3_per_j": 1e-3, "initial_roughness_um": 1.0, "map_rows": [], "sentences": [],
               "evolutions": list(evolutions)}
    section["headline"] = wear_headline(section)
    return section


def _alone(speed_kmh, visible_km, order, vibration_order=None, locked=False):
    """An evolution at one speed as summary.json holds it."""
    return {"label": "operating speed", "distance_km": 100_000.0, "visible_km": visible_km, "visible_depth_mm": 0.1,
            "dominant_order": order, "final_depth_mm": 0.4 if visible_km else 0.02,
            "growth_efolds": 5.0 if visible_km else None,
            "cycle": [{"speed_kmh": speed_kmh, "share": 1.0, "vibration_order_end": vibration_order,
                       "locked_fraction": float(locked), "locked_at_end": locked}]}


NO_BAND = {"operating_range_kmh": [80.0, 130.0], "options": [],
           "reason": "No SEV band in 20-300 km/h: steady rolling is stable and no stable cycle exists, so there is "
                     "nothing to move."}
STABLE_ROLLING = {"speed_kmh": 110.0, "steady_rolling_stable": True, "in_sev_band": False, "regime": "no SEV"}


def test_stable_rolling_car_with_a_visible_polygon_gets_a_wear_warning_not_safe():
    """The issue's toe 0.05 deg car: no SEV, but a 10-sided polygon from a forced resonance of
    the tread at 110 km/h. The verdict names it, with its frequency (10 f_rot, closed form)."""
    from polywear.report.verdict import verdict

    params = _toe(0.05)
    ev = _alone(110.0, 26_000.0, 10)
    summary = {"operating": STABLE_ROLLING, "wear": _wear_summary(ev, {**ev, "label": "drive cycle"}),
               "design": NO_BAND}
    v = verdict(summary, params, _sentence(STABLE_ROLLING))
    text = " ".join(v["lines"])
    assert v["polygon_visible"] and v["dominant_order"] == 10 == v["sides"] and v["source"] == "forced resonance" and not v["vibrates"]
    f_rot = 110.0 / 3.6 / (2.0 * math.pi * params.operating.rolling_radius_m)
    assert f"forced resonance of the tread at order 10 ({10 * f_rot:.0f} Hz at 110 km/h)" in text
    assert "a 10-sided polygon becomes visible (0.1 mm) after about 26,000 km" in text
    assert "Nothing to change" not in text and "nothing to move" not in text.replace(NO_BAND["reason"], "")
    assert "the wear itself must change" in v["lines"][-1] and "keeps the polygon invisible for 100,000 km" in v["lines"][-1]
    assert v["wear_design_option"]["key"] in v["lines"][-1] or v["wear_design_option"]["label"] in v["lines"][-1]
    assert v["glance"][2] == v["lines"][-1]  # at a glance too: the wear change, not "no option clears the band"
    # the same car without a visible polygon: safe
    quiet = _alone(110.0, None, 10)
    v = verdict({**summary, "wear": _wear_summary(quiet, {**quiet, "label": "drive cycle"})}, params,
                _sentence(STABLE_ROLLING))
    assert v["polygon_visible"] is False and v["lines"][-1].startswith("Nothing to change")


def test_wear_not_evolved_is_not_called_safe():
    from polywear.report.verdict import verdict

    summary = {"operating": STABLE_ROLLING, "wear": _wear_summary(), "design": NO_BAND}
    v = verdict(summary, _toe(0.05), _sentence(STABLE_ROLLING))
    assert v["polygon_visible"] is None and "not evolved" in v["lines"][-1] and "Nothing to change:" not in v["lines"][-1]


def test_point_contact_force_against_c_alpha_alpha():
    """tread1dof: at steady rolling the tread does not move, so the slip angle is the toe angle
    (closed form); the LuGre force lies between mu_c N and mu_s N plus the viscous sigma2 v_r."""
    from polywear.report.verdict import C_ALPHA_N_PER_RAD, point_contact

    for toe in (0.05, 0.5, 5.0):
        params = _toe(toe)
        pc = point_contact(params, 110.0)
        f = params.friction
        N = params.operating.vertical_load_n
        v_r = 110.0 / 3.6 * math.sin(math.radians(toe))
        assert pc["slip_angle_deg"] == pytest.approx(toe, rel=1e-9)
        assert f.mu_coulomb * N <= pc["lateral_force_n"] <= f.mu_static * N + f.sigma2_s_per_m * N * v_r + 1e-9
        assert pc["c_alpha_alpha_n"] == pytest.approx(C_ALPHA_N_PER_RAD * math.radians(toe), rel=1e-9)
        assert pc["overstated"] == (pc["lateral_force_n"] > 2.0 * pc["c_alpha_alpha_n"])
    assert point_contact(_toe(0.05), 110.0)["overstated"] and not point_contact(_toe(5.0), 110.0)["overstated"]


def test_the_point_contact_note_is_beside_the_wear_judgement_only_for_the_point_contact():
    from polywear.report.verdict import verdict

    ev = _alone(110.0, 26_000.0, 10)
    summary = {"operating": STABLE_ROLLING, "wear": _wear_summary(ev, {**ev, "label": "drive cycle"}),
               "design": NO_BAND}
    point = verdict(summary, _toe(0.05), _sentence(STABLE_ROLLING))
    assert point["point_contact"]["overstated"] and any("slides under the whole load" in x for x in point["lines"])
    patch = verdict(summary, with_updates(_toe(0.05), {"friction.contact": "patch"}), _sentence(STABLE_ROLLING))
    assert patch["point_contact"] is None and not any("slides under the whole load" in x for x in patch["lines"])


def test_option_that_clears_the_band_but_brings_the_polygon_sooner_is_shown_as_such():
    """Toe 0.5 -> 0.05 deg clears the band; against a car with no visible polygon within
    100 000 km it brings one. Its distance (linear map) checked against the linear depth of
    wear.design, computed independently: visible at that distance, not 2 km before."""
    from polywear.report.verdict import verdict
    from polywear.wear.design import linear_depth_mm

    params = Params()
    option = {"params": ["operating.toe_deg"], "nominal": [0.5], "values": [0.05], "achieved": True,
              "change": "toe angle 0.5° → 0.05° (−90.0 %)"}
    design = {"operating_range_kmh": [80.0, 130.0], "options": [option], "reason": ""}
    vibrating = {"speed_kmh": 110.0, "steady_rolling_stable": False, "regime": "unstable rolling (soft SEV)",
                 "sev_amplitude_x_mm": 0.27}
    quiet = _alone(110.0, None, 9, vibration_order=8.52)
    summary = {"operating": vibrating, "wear": _wear_summary(quiet, {**quiet, "label": "drive cycle"}),
               "design": design}
    v = verdict(summary, params, "At 110 km/h: self-excited vibration.")
    (judged,) = v["design_options"]
    km = judged["cycle"]["visible_km"]
    assert judged["sooner"] and judged["text"].startswith("brings the polygon sooner")
    assert "on the drive cycle" in judged["text"] and "(now none within 100,000 km)" in judged["text"]
    changed = _toe(0.05)
    visible = changed.wear.visible_depth_mm
    assert linear_depth_mm(changed, km) >= visible > linear_depth_mm(changed, km - 2.0)
    assert "clears the SEV band" in v["lines"][-1] and "brings the polygon sooner" in v["lines"][-1]
    assert "No option that clears the band keeps the polygon from coming sooner" in v["lines"][-1]


def test_hard_region_says_the_evolution_starts_from_steady_rolling_and_names_the_cycle():
    from polywear.report.verdict import verdict

    hard = {"speed_kmh": 230.0, "steady_rolling_stable": True, "regime": "hard SEV region",
            "sev_amplitude_x_mm": 0.4, "trigger_amplitude_x_mm": 0.2, "wear": {"frequency_order": 4.31, "frequency_hz": 153.0}}
    ev = _alone(230.0, None, 5)
    summary = {"operating": hard, "wear": _wear_summary(ev, {**ev, "label": "drive cycle"}), "design": NO_BAND}
    v = verdict(summary, with_updates(Params(), {"operating.speed_kmh": 230.0}), "At 230 km/h: hard excitation.")
    assert v["vibrates"]
    (line,) = [x for x in v["lines"] if x.startswith("Steady rolling is stable at 230 km/h")]
    assert "above 0.200 mm" in line and "order 4.31 (153 Hz)" in line
