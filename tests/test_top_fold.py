"""The top of the SEV band of the studies' edges-only cars from the fold followed in the
parameters (FastBand.top_fold, study_evaluator.edges_band) against the full continuation
(benchmarks/bench_fleet.py sobol-edges runs it on many four-Hopf cars)."""

from __future__ import annotations

import numpy as np
import pytest

from polywear.dynamics.bifurcation import bifurcation
from polywear.params import Params, with_updates
from polywear.studies.fast_band import _FIXED_RANGE, Fallback, FallbackReason, FastBand, TopFold, band_reference
from polywear.studies.study_evaluator import edges_band

KEYS = ("tread.lateral_stiffness_n_per_m", "tread.lateral_damping_ns_per_m", "operating.toe_deg",
        "operating.camber_deg", "friction.mu_static", "tread.mass_kg", "operating.vertical_load_n")
GAP_AXLE = (939704.2295985346, 77.81003120880563, 0.4679406027567147, -0.9692122878224957,
            0.9806623310539467, 1.0146665435222242, 3872.0544539366715)
"""Car 18 of ``bench_fleet.py edges --seed 7``: Hopf points 75.41, 86.97, 92.88 and 173.23 km/h
(hard), the band's top a fold at 187.66 km/h, a window 71.82-74.62 km/h ended by a PD."""
RANGE = (20.0, 300.0)


@pytest.fixture(scope="module")
def nominal():
    """The nominal axle4dof car's reference: two Hopf points, soft-hard, a fold above the second."""
    return band_reference(bifurcation(with_updates(Params(), {"model": "axle4dof"}), RANGE, **_FIXED_RANGE))


def test_the_nominal_reference_has_a_top_fold(nominal):
    j = nominal.top_fold
    assert j is not None
    assert nominal.band.hopf_criticality[-1] == "hard"
    assert nominal.band.sev_band_kmh[-1][1] == nominal.band.folds_kmh[j]
    assert nominal.band.hard_regions_kmh[-1] == (nominal.band.hopf_kmh[-1], nominal.band.folds_kmh[j])


def test_the_top_fold_of_a_four_hopf_car_is_the_full_continuations(nominal):
    params = with_updates(Params(), {"model": "axle4dof", **dict(zip(KEYS, GAP_AXLE))})
    sev, gaps, diagram, top, _ = edges_band(params, RANGE, FastBand((nominal,), RANGE))
    assert isinstance(top, TopFold)
    full = bifurcation(params, RANGE)
    # the fold the continuation located on the branch (secants in the arclength) is the one
    # the fast path solved directly, from a reference with two Hopf points only
    assert abs(top.fold_kmh - max(f.speed_kmh for f in full.folds)) < 1e-6
    assert abs(top.hopf_kmh - full.hopf_points[-1].speed_kmh) < 1e-6
    assert len(sev) == len(full.sev_band_kmh)
    assert np.max(np.abs(np.subtract(sev, full.sev_band_kmh))) < 1e-6
    assert np.ravel(gaps) == pytest.approx(np.ravel(full.gaps_after_pd_ns_kmh), abs=1e-6)
    # the branch from the last Hopf point was stopped at its first point; the others were followed
    top_branch = min(diagram.branch_info, key=lambda i: abs(i["from_hopf_kmh"] - top.hopf_kmh))
    assert top_branch["n_points"] == 1
    assert sum(i["n_points"] for i in diagram.branch_info) > 40


def test_without_a_reference_with_a_top_fold_the_edges_path_is_kept(nominal):
    from dataclasses import replace

    params = with_updates(Params(), {"model": "axle4dof", **dict(zip(KEYS, GAP_AXLE))})
    fast = FastBand((replace(nominal, top_fold=None),), RANGE)
    out = fast.top_fold(params)
    assert isinstance(out, Fallback) and out.reason is FallbackReason.NO_REFERENCE
    sev, gaps, diagram, top, _ = edges_band(params, RANGE, fast)
    assert top is None and sev == diagram.sev_band_kmh and gaps == diagram.gaps_after_pd_ns_kmh


def test_a_soft_last_hopf_point_has_no_top_fold(nominal):
    """On a range that ends between the nominal car's two Hopf points the last Hopf point in
    it is the first, a soft one: no top fold."""
    params = with_updates(Params(), {"model": "axle4dof"})
    cut = (20.0, 0.5 * (nominal.band.hopf_kmh[0] + nominal.band.hopf_kmh[-1]))
    out = FastBand((nominal,), cut).top_fold(params)
    assert isinstance(out, Fallback) and out.reason is FallbackReason.HOPF_SIGNATURE


def test_the_study_evaluator_uses_the_top_fold_and_gives_the_edges_paths_outputs(nominal):
    from polywear.studies.study_evaluator import StudyEvaluator

    base, fast = with_updates(Params(), {"model": "axle4dof"}), FastBand((nominal,), RANGE)
    with_top = StudyEvaluator(base, KEYS, "bifurcation", RANGE, fast=fast, edges_only=True, top_fold=True)
    without = StudyEvaluator(base, KEYS, "bifurcation", RANGE, fast=fast, edges_only=True, top_fold=False)
    values = np.array(GAP_AXLE)
    (a, outcome_a), (b, outcome_b) = with_top(values), without(values)
    assert outcome_a.top_fold and not outcome_b.top_fold
    assert outcome_a.edges_only and outcome_a.status == outcome_b.status
    assert np.allclose(a[:3], b[:3], rtol=0.0, atol=1e-6) and np.isnan(a[3]) and np.isnan(b[3])
