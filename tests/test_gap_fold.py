"""The band in the gap between the two intervals of the linear band of a four-Hopf car
(hard, soft, hard, hard) from the first fold of the third Hopf point's branch followed in the
parameters (FastBand.gap_fold, study_evaluator.edges_band(gap_fold=True)) against the full
continuation (benchmarks/bench_fleet.py gap-fold runs it on many cars)."""

from __future__ import annotations

import numpy as np
import pytest

from polywear.dynamics.bifurcation import bifurcation
from polywear.params import Params, with_updates
from polywear.studies.fast_band import (_FIXED_RANGE, GAP_FOLD_CRITICALITY, Fallback, FallbackReason, FastBand,
                                        GapFold, band_reference)
from polywear.studies.study_evaluator import StudyEvaluator, edges_band

from .test_top_fold import GAP_AXLE, KEYS, RANGE

PILOT_AXLE = (987100.0119213299, 72.31558762731393, 0.5178550792685728, -1.0448179168612337,
              0.9782577914070933, 1.0485791125296053, 3941.3756502067276)
"""Pilot 18 of ``bench_fleet.py gap-fold --seed 7`` (seed 8): Hopf points 68.90, 79.09, 81.92
and 158.03 km/h (hard, soft, hard, hard); the third's branch folds at 79.40 km/h, the lower
end of the band's interval through the gap."""

PD_GAP_AXLE = (970518.2285072784, 76.52663821152005, 0.49506841428004555, -0.9207675324752159,
               0.9691515682385714, 1.095914297779049, 4258.598876389745)
"""Car 222 of ``bench_fleet.py gap-fold --seed 11``: hard, soft, hard, hard; without the third
Hopf point's branch its diagram has a gap after a PD/NS point from the second Hopf point
(92.45 km/h) to 92.97 km/h, which the gap fold's piece (its fold at 88.09 km/h) closes."""


def _car(values):
    return with_updates(Params(), {"model": "axle4dof", **dict(zip(KEYS, values))})


@pytest.fixture(scope="module")
def pilot():
    return band_reference(bifurcation(_car(PILOT_AXLE), RANGE, **_FIXED_RANGE))


def test_the_pilot_has_the_gap_fold_as_a_band_edge(pilot):
    j = pilot.gap_fold
    assert pilot.band.hopf_criticality == GAP_FOLD_CRITICALITY and j is not None
    fold = pilot.folds[j].orbit.speed * 3.6
    second, third = pilot.band.hopf_kmh[1], pilot.band.hopf_kmh[2]
    assert second < fold < third
    assert any(abs(a - fold) < 1e-9 and b >= third for a, b in pilot.band.sev_band_kmh)


def test_the_gap_of_a_four_hopf_car_is_the_full_continuations(pilot):
    params = _car(GAP_AXLE)
    fast = FastBand((pilot,), RANGE)
    sev, gaps, diagram, top, gap = edges_band(params, RANGE, fast, gap_fold=True)
    assert isinstance(gap, GapFold) and top is not None
    full = bifurcation(params, RANGE)
    # the fold solved directly in the parameters is the one the continuation met on the branch
    branch = min(full.branch_info, key=lambda i: abs(i["from_hopf_kmh"] - gap.hopf_kmh))["branch"]
    first = next(pt for label, pt, _ in full.branches[branch].special if label == "LP").orbit.speed * 3.6
    assert abs(gap.fold_kmh - first) < 1e-6
    assert gap.second_hopf_kmh < gap.fold_kmh  # above the second Hopf point: an edge of the band
    assert any(abs(a - first) < 1e-6 for a, _ in full.sev_band_kmh)
    assert len(sev) == len(full.sev_band_kmh)
    assert np.max(np.abs(np.subtract(sev, full.sev_band_kmh))) < 1e-6
    assert np.ravel(gaps) == pytest.approx(np.ravel(full.gaps_after_pd_ns_kmh), abs=1e-6)
    # the branches from the third and fourth Hopf points were stopped at their first points
    for v in (gap.hopf_kmh, top.hopf_kmh):
        assert min(diagram.branch_info, key=lambda i: abs(i["from_hopf_kmh"] - v))["n_points"] == 1


def test_the_piece_closes_a_gap_after_a_pd_that_the_skipped_branch_covered(pilot):
    params = _car(PD_GAP_AXLE)
    sev, gaps, diagram, _, gap = edges_band(params, RANGE, FastBand((pilot,), RANGE), gap_fold=True)
    assert isinstance(gap, GapFold) and gap.fold_kmh < gap.second_hopf_kmh
    full = bifurcation(params, RANGE)
    assert len(diagram.gaps_after_pd_ns_kmh) == len(full.gaps_after_pd_ns_kmh) + 1  # the diagram's own: one more
    assert len(gaps) == len(full.gaps_after_pd_ns_kmh)
    assert np.ravel(gaps) == pytest.approx(np.ravel(full.gaps_after_pd_ns_kmh), abs=1e-6)
    assert len(sev) == len(full.sev_band_kmh)
    assert np.max(np.abs(np.subtract(sev, full.sev_band_kmh))) < 1e-6


def test_other_hopf_points_or_no_reference_fall_back(pilot):
    from dataclasses import replace

    nominal = with_updates(Params(), {"model": "axle4dof"})  # two Hopf points
    out = FastBand((pilot,), RANGE).gap_fold(nominal)
    assert isinstance(out, Fallback) and out.reason is FallbackReason.HOPF_SIGNATURE
    out = FastBand((replace(pilot, gap_fold=None),), RANGE).gap_fold(_car(GAP_AXLE))
    assert isinstance(out, Fallback) and out.reason is FallbackReason.NO_REFERENCE


def test_the_study_evaluator_counts_the_gap_fold(pilot):
    fast = FastBand((pilot,), RANGE)
    evaluate = lambda gap: StudyEvaluator(_car(GAP_AXLE), KEYS, "bifurcation", RANGE, fast=fast, edges_only=True,
                                          top_fold=True, gap_fold=gap)(np.array(GAP_AXLE))
    (a, outcome_a), (b, outcome_b) = evaluate(True), evaluate(False)
    assert outcome_a.gap_fold and outcome_a.top_fold and not outcome_b.gap_fold
    assert outcome_a.status == outcome_b.status
    assert np.allclose(a[:3], b[:3], rtol=0.0, atol=1e-6)
