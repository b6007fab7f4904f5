"""The first Hopf point's branch of a four-Hopf car continued from its first fold (the window
fold below that point, the band's lower end) found in the parameters, not from the Hopf
point (FastBand.window_fold, global_sensitivity.edges_band(window_fold=True),
solvers.continuation.continue_from_point), against the full continuation
(benchmarks/bench_fleet.py window-fold runs it on many cars)."""

from __future__ import annotations

import numpy as np
import pytest

from polywear.dynamics.bifurcation import bifurcation
from polywear.models import model_for
from polywear.solvers.continuation import continue_from_point
from polywear.studies.fast_band import (_FIXED_RANGE, Fallback, FallbackReason, FastBand, WindowFold,
                                        band_reference)
from polywear.studies.global_sensitivity import StudyEvaluator, edges_band
from polywear.units import kmh_to_ms, ms_to_kmh

from .test_gap_fold import PILOT_AXLE, _car
from .test_top_fold import GAP_AXLE, KEYS, RANGE


@pytest.fixture(scope="module")
def pilot():
    """Pilot 18 of seed 8: its first Hopf point's branch folds at 66.69 km/h, the band's lower end."""
    return band_reference(bifurcation(_car(PILOT_AXLE), RANGE, **_FIXED_RANGE))


@pytest.fixture(scope="module")
def full():
    """Car 18 of seed 7 by the full continuation: the branch from 75.41 km/h folds at 71.82 km/h
    and is stable up to a PD at 74.62 km/h (the window)."""
    return bifurcation(_car(GAP_AXLE), RANGE)


def _first_branch(diagram):
    """The branch from the first Hopf point and its special points (label, speed [km/h])."""
    b = min(diagram.branch_info, key=lambda i: abs(i["from_hopf_kmh"] - diagram.hopf_points[0].speed_kmh))["branch"]
    branch = diagram.branches[b]
    return branch, [(label, ms_to_kmh(pt.orbit.speed)) for label, pt, _ in branch.special]


def test_the_pilot_has_the_window_fold_as_the_bands_lower_end(pilot):
    j = pilot.window_fold
    assert j is not None and pilot.band.hopf_criticality[0] == "hard"
    fold = ms_to_kmh(pilot.folds[j].orbit.speed)
    assert fold < pilot.band.hopf_kmh[0]
    assert abs(pilot.band.sev_band_kmh[0][0] - fold) < 1e-9


def test_the_branch_from_a_fold_meets_the_branchs_next_points(full):
    """From the full branch's own fold, forward: the PD after it is the full branch's (same
    locator); backward: the first point is unstable (the side towards the Hopf point)."""
    branch, special = _first_branch(full)
    _, fold, k = branch.special[0]
    assert branch.special[0][0] == "LP" and special[1][0] == "PD"
    params = _car(GAP_AXLE)
    model = model_for(params)
    p = model.pack(params)
    from polywear.dynamics.bifurcation import branch_start

    hopf = branch_start(full.hopf_points[0])
    bounds = (kmh_to_ms(RANGE[0]), kmh_to_ms(RANGE[1]))
    sides = {}
    for reverse in (False, True):
        sides[reverse] = continue_from_point(model, p, fold, branch.scales, hopf, bounds, reverse=reverse,
                                             stop=lambda br: len(br.points) == 12)
    forward = next(s for s in sides.values() if s.points[0].stable)
    backward = next(s for s in sides.values() if s is not forward)
    assert not backward.points[0].stable
    pd = next(ms_to_kmh(pt.orbit.speed) for label, pt, _ in forward.special if label == "PD")
    assert abs(pd - special[1][1]) < 1e-6
    assert not any(label == "LP" for label, _, _ in forward.special)  # the start's fold is not found again


def test_the_band_of_a_four_hopf_car_is_the_full_continuations(pilot, full):
    params = _car(GAP_AXLE)
    fast = FastBand((pilot,), RANGE)
    out = edges_band(params, RANGE, fast, gap_fold=True, window_fold=True)
    window = out.window
    assert isinstance(window, WindowFold)
    _, special = _first_branch(full)
    assert abs(window.fold_kmh - special[0][1]) < 1e-6  # the fold found in the parameters is the branch's
    assert abs(window.pd_ns_kmh[0] - special[1][1]) < 1e-6
    assert window.stable_kmh[0] == pytest.approx((window.fold_kmh, window.pd_ns_kmh[0]), abs=1e-12)
    assert len(out.sev_band_kmh) == len(full.sev_band_kmh)
    assert np.max(np.abs(np.subtract(out.sev_band_kmh, full.sev_band_kmh))) < 1e-6
    assert np.ravel(out.gaps_after_pd_ns_kmh) == pytest.approx(np.ravel(full.gaps_after_pd_ns_kmh), abs=1e-6)
    # the branch from the first Hopf point was stopped at its first point
    assert min(out.diagram.branch_info, key=lambda i: abs(i["from_hopf_kmh"] - window.hopf_kmh))["n_points"] == 1


def test_a_soft_first_hopf_point_or_no_reference_falls_back(pilot):
    from dataclasses import replace

    from polywear.params import Params, with_updates

    nominal = with_updates(Params(), {"model": "axle4dof"})  # first Hopf point soft
    out = FastBand((pilot,), RANGE).window_fold(nominal)
    assert isinstance(out, Fallback) and out.reason is FallbackReason.HOPF_SIGNATURE
    out = FastBand((replace(pilot, window_fold=None),), RANGE).window_fold(_car(GAP_AXLE))
    assert isinstance(out, Fallback) and out.reason is FallbackReason.NO_REFERENCE


def test_the_study_evaluator_counts_the_window_fold(pilot):
    fast = FastBand((pilot,), RANGE)
    evaluate = lambda window: StudyEvaluator(_car(GAP_AXLE), KEYS, "bifurcation", RANGE, fast=fast, edges_only=True,
                                             top_fold=True, gap_fold=True, window_fold=window)(np.array(GAP_AXLE))
    (a, outcome_a), (b, outcome_b) = evaluate(True), evaluate(False)
    assert outcome_a.window_fold and not outcome_b.window_fold
    assert outcome_a.status == outcome_b.status
    assert np.allclose(a[:3], b[:3], rtol=0.0, atol=1e-6)
