"""Fleet wear risk (``fleet(..., wear_km=D)``, ``polywear fleet --wear-km``) against a closed
form: with only k_e varied (lognormal), every car's visible distance is the nominal car's
times k_nom / k_e (the wear per revolution scales with k_e, the dynamics do not see it), so
the risk P(visible < D) is P(k_e > k*), k* = k_nom visible_nom / D, a normal probability in
ln k_e. The nominal distance comes from an independent evolution; the run is interrupted
after its first checkpoint and resumed."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy import stats

from polywear.dynamics.bifurcation import bifurcation
from polywear.params import Params, with_updates
from polywear.studies.fast_band import _FIXED_RANGE, band_reference
from polywear.studies.fleet import OUTPUTS, fleet, load_fleet_spec
from polywear.wear.evolution import EvolutionSettings, StepBudgetError, wear_evolution

from .cli_runner import run_main

K_NOM, K_STD = 1.0e-2, 3.0e-3
"""Mean and std of k_e [mm^3/J] over the fleet (ten times the default: the same polygon
after a tenth of the distance, so each evolution is short)."""
D_KM = 3000.0
SPEC = """
[fleet]
samples = {samples}
seed = 5
checkpoint_every = {every}
speed_range_kmh = [10.0, 600.0]
[[fleet.parameter]]
key = "wear.energetic_rate_mm3_per_j"
distribution = "lognormal"
mean = {mean}
std = {std}
[[fleet.usage]]
speed_kmh = 110
share = 1.0
"""


def _spec(tmp_path, samples, every):
    path = tmp_path / "fleet.toml"
    path.write_text(SPEC.format(samples=samples, every=every, mean=K_NOM, std=K_STD))
    return load_fleet_spec(path, Params())


@pytest.mark.slow
def test_wear_risk_against_the_lognormal_closed_form(tmp_path):
    nominal = wear_evolution(with_updates(Params(), {"wear.energetic_rate_mm3_per_j": K_NOM}), D_KM, ((110.0, 1.0),))
    visible_nom = nominal.visible_km
    assert visible_nom is not None and 0.5 * D_KM < visible_nom < 1.5 * D_KM  # the threshold inside the fleet
    at = int(np.flatnonzero(nominal.depth_mm >= 0.1)[0])
    order_nom = int(nominal.dominant_order[at])

    spec = _spec(tmp_path, samples=24, every=12)
    reference = band_reference(bifurcation(Params(), (10.0, 600.0), **_FIXED_RANGE))

    def interrupt(done, total, message=""):
        if done > 12:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        fleet(Params(), spec, backend="processes", workers=2, batch_size=2, reference=reference, pilot=False,
              checkpoint_dir=tmp_path, progress=interrupt, wear_km=D_KM)
    assert int(np.load(tmp_path / "fleet_checkpoint.npz")["done"]) == 12
    result = fleet(Params(), spec, backend="processes", workers=2, reference=reference, pilot=False,
                   checkpoint_dir=tmp_path, resume=True, wear_km=D_KM)
    assert result.ok.all()
    k_e = result.samples[:, 0]
    visible = result.values[:, OUTPUTS.index("wear_visible_km")]
    seen = np.isfinite(visible)
    # the scaling, car by car: visible * k_e / k_nom is the nominal distance (up to the distance step)
    np.testing.assert_allclose(visible[seen] * k_e[seen] / K_NOM, visible_nom, rtol=0.01)
    k_star = K_NOM * visible_nom / D_KM
    clear = np.abs(np.log(k_e / k_star)) > 0.01  # cars not at the threshold within the 1 % of the steps
    np.testing.assert_array_equal(seen[clear], (k_e > k_star)[clear])
    assert np.all(result.values[seen, OUTPUTS.index("wear_order")] == order_nom)

    s = result.summary()
    s2 = math.log1p((K_STD / K_NOM) ** 2)
    closed = stats.norm.sf((math.log(k_star) - (math.log(K_NOM) - 0.5 * s2)) / math.sqrt(s2))
    assert s["wear_risk_probability"] == pytest.approx(np.mean(visible < D_KM), abs=1e-12)
    lo, hi = s["wear_risk_ci"]
    assert lo <= closed <= hi
    assert lo <= s["wear_risk_probability"] <= hi
    assert s["wear_most_dangerous_order"] == order_nom
    assert s["wear_orders"] == {str(order_nom): int(seen.sum())}
    assert s["risk_probability"] == 1.0  # every car vibrates at 110 km/h: counted in the wear risk all the same


@pytest.mark.slow
def test_cli_wear_risk_json(tmp_path):
    """``--wear-km`` adds the wear risk, its interval, the order and the drivers to --json;
    without it the keys are null."""
    path = tmp_path / "fleet.toml"
    path.write_text(SPEC.format(samples=2, every=2, mean=K_NOM, std=K_STD))
    code, out, err = run_main(["fleet", "--spec", str(path), "--backend", "serial", "--json", "-q",
                               "--wear-km", f"{D_KM:g}"])
    assert code == 0, err
    s = json.loads(out)
    assert 0.0 <= s["wear_risk_probability"] <= 1.0 and len(s["wear_risk_ci"]) == 2
    assert set(s["wear_drivers_main_effect"]) == {"wear.energetic_rate_mm3_per_j"}
    assert s["wear_km"] == D_KM and s["wear_cycle"] == [{"speed_kmh": 110.0, "share": 1.0}]
    code, out, err = run_main(["fleet", "--spec", str(path), "--wear-km", "-5"])
    assert code != 0 and "--wear-km" in err


def test_a_car_over_the_step_budget_stops_there():
    """The evaluator stops a car's evolution at its step budget, at the distance an
    unstopped evolution of the same car has after that many steps, and says so; with the
    default budget the same car ends with the evolution's own visible distance and order
    (its evolution stopped once visible: the same steps up to there)."""
    from polywear.studies.fleet import FleetEvaluator, wear_step_budget

    params = with_updates(Params(), {"wear.energetic_rate_mm3_per_j": K_NOM})
    cycle = ((110.0, 1.0),)
    full = wear_evolution(params, D_KM, cycle)
    budget = wear_step_budget(D_KM, 1)
    assert budget == 2 and full.distance_km.size - 1 > budget  # ceil(3000 / 8000) + 1: fewer than it takes
    with pytest.raises(StepBudgetError) as stop:
        wear_evolution(params, D_KM, cycle, EvolutionSettings(max_steps=1))
    # the budget's 2 attempts (a rejected step counts) end on one of the unstopped run's first 2 steps
    assert stop.value.done_km in full.distance_km[1 : budget + 1]
    stopped = FleetEvaluator(params, (), None, (110.0,), wear_km=D_KM, wear_max_steps=1, usage_cycle=cycle)._wear(params)
    assert np.isnan(stopped[0]) and np.isnan(stopped[1])
    assert stopped[2] == f"over the budget of 2 distance steps at {stop.value.done_km:,.0f} of {D_KM:,.0f} km"
    ended = FleetEvaluator(params, (), None, (110.0,), wear_km=D_KM, usage_cycle=cycle)._wear(params)
    seen = np.flatnonzero(full.depth_mm >= params.wear.visible_depth_mm)
    assert ended[0] == full.visible_km and ended[1] == full.dominant_order[seen[0]] and ended[2] == ""


def test_a_car_over_the_work_budget_stops_there_and_says_which_budget():
    """The same car with a work budget of half the simulated revolutions its evolution takes:
    stopped at the same distance as the evolution with that budget, said in revolutions."""
    from polywear.studies.fleet import FleetEvaluator, FleetSpec

    params = with_updates(Params(), {"wear.energetic_rate_mm3_per_j": K_NOM})
    cycle = ((110.0, 1.0),)
    full = wear_evolution(params, D_KM, cycle, EvolutionSettings(until_visible=True))
    half = full.settings["simulated_revolutions"] // 2
    with pytest.raises(StepBudgetError) as stop:
        wear_evolution(params, D_KM, cycle, EvolutionSettings(until_visible=True, max_revolutions=half))
    assert stop.value.unit == "simulated revolutions" and stop.value.budget == half
    stopped = FleetEvaluator(params, (), None, (110.0,), wear_km=D_KM, wear_max_revolutions=half,
                             usage_cycle=cycle)._wear(params)
    assert np.isnan(stopped[0]) and np.isnan(stopped[1])
    assert stopped[2] == f"over the budget of {half:,} simulated revolutions at {stop.value.done_km:,.0f} of {D_KM:,.0f} km"
    with pytest.raises(ValueError, match="wear_max_revolutions"):
        FleetSpec(samples=10, wear_km=D_KM, wear_max_revolutions=0,
                  parameter=[{"key": "operating.toe_deg", "distribution": "uniform", "low": 0.4, "high": 0.6}])


def test_cars_over_the_budget_are_listed_and_kept_out_of_the_wear_risk():
    """Summary of 10 cars (values set by hand): 2 over the wear budget, 1 failed. The wear
    risk counts the 7 others (3 visible within D: 3/7, its exact interval from scipy), the
    band risk the 9 evaluated; the 2 are counted and listed with their parameters."""
    from scipy.stats import binomtest

    from polywear.studies.fleet import WEAR_MAX_STEPS, CarOutcome, FleetResult, FleetSpec

    spec = FleetSpec(samples=10, wear_km=D_KM, parameter=[{"key": "operating.toe_deg", "distribution": "uniform",
                                                            "low": 0.4, "high": 0.6}],
                     usage=[{"speed_kmh": 110.0, "share": 1.0}])
    X = np.linspace(0.41, 0.59, 10)[:, None]
    values = np.full((10, len(OUTPUTS)), np.nan)
    values[:, 2] = [1, 1, 0, 0, 1, 0, 1, 1, 0, 1]  # at risk (band)
    values[:, OUTPUTS.index("wear_visible_km")] = [1000, 2000, np.inf, np.inf, np.nan, np.inf, np.nan, 2500, np.inf, np.nan]
    values[:, OUTPUTS.index("wear_order")] = [8, 8, 9, 9, np.nan, 9, np.nan, 7, 9, np.nan]
    over = f"over the budget of {WEAR_MAX_STEPS + 1} distance steps at 1,234 of 3,000 km"
    outcomes = [CarOutcome(path="fast")] * 10
    outcomes[4] = outcomes[6] = CarOutcome(path="fast", wear=over)
    outcomes[9] = CarOutcome(failure="ValueError", detail="bad")
    s = FleetResult(Params(), spec, X, values, outcomes).summary()
    assert s["risk_probability"] == pytest.approx(5 / 9)  # the over-budget cars' bands count
    assert s["wear_n_evaluated"] == 7 and s["wear_risk_probability"] == pytest.approx(3 / 7)
    ci = binomtest(3, 7).proportion_ci(0.95, method="exact")
    assert s["wear_risk_ci"] == pytest.approx([ci.low, ci.high])
    assert s["wear_over_budget"] == 2 and s["wear_max_steps"] == WEAR_MAX_STEPS + 1  # + ceil(3 000 / 8 000)
    assert s["wear_over_budget_cars"] == [{"car": i, "reason": over, "parameters": {"operating.toe_deg": X[i, 0]}}
                                          for i in (4, 6)]
    assert s["wear_most_dangerous_order"] == 8 and s["wear_orders"] == {"7": 1, "8": 2}
