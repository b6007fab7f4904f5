"""The edges-only continuation (polywear.studies.edges) against the full one, on cars with
four Hopf points at +-10 % (benchmarks/bench_fleet.py edges runs 200 of them)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from polywear.dynamics.bifurcation import bifurcation, branch_start
from polywear.dynamics.stability import stability
from polywear.models import model_for
from polywear.params import Params, with_updates
from polywear.solvers.continuation import BranchEnd, continue_from_hopf
from polywear.studies.edges import edges_diagram, oscillatory_intervals, pd_ns_edges_kmh
from polywear.studies.study_evaluator import StudyEvaluator
from polywear.units import kmh_to_ms, ms_to_kmh

KEYS = ("tread.lateral_stiffness_n_per_m", "tread.lateral_damping_ns_per_m", "operating.toe_deg",
        "operating.camber_deg", "friction.mu_static", "tread.mass_kg", "operating.vertical_load_n")

EXCURSION_AXLE = (1010691.8011842596, 84.91273195082226, 0.4965816174203995, -1.0240770867478863,
                  0.9574049953294085, 1.0356183272025927, 4113.462693365903)
"""Car 64 of ``bench_fleet.py edges --seed 7``: Hopf points 73.14, 80.49, 86.02, 159.69 km/h;
the branch from the first runs through the linear band, past the Hopf point at 80.49 km/h
into the gap above it, folds at 80.92 km/h (a band edge) and comes back."""
GAP_AXLE = (939704.2295985346, 77.81003120880563, 0.4679406027567147, -0.9692122878224957,
            0.9806623310539467, 1.0146665435222242, 3872.0544539366715)
"""Car 18: a window of stable cycles 71.83-74.62 km/h ended by a PD, a gap after it to 75.41 km/h."""
TWICE_AXLE = (985999.3723802326, 80.31223711804574, 0.5450938195581849, -0.9501998493329517,
              0.9550870465071797, 1.0352942399997187, 4173.6687234248975)
"""Car 21: the branch from the third Hopf point crosses the gap between the linear band's
two intervals twice."""
CROSSING_AXLE = (922638.3281564085, 87.67354768717308, 0.5441591302855918, -0.9461334364602205,
                 0.9845833632447908, 0.9415635334246808, 4005.1808129505043)
"""Car 53: the branch from the third Hopf point (85.23 km/h) crosses the gap below it, turns
2.5 km/h inside the first interval of the linear band (fold at 79.87 km/h) and comes back
across the gap stable: a hard region 82.41-85.23 km/h, lost when a branch stops 2 km/h
inside any interval rather than its own."""

WINDOW_AXLE = (1049738.7045055712, 78.68203757388277, 0.5206277594463431, -0.9446788926859567,
               0.9793248899556777, 0.9328097322971235, 4232.609023896524)
"""Car 682: the branch from the first Hopf point (63.74 km/h) has a PD at 60.72 km/h, runs 2 km/h
into the linear band, folds at 67.99 km/h and comes back to a window of stable cycles
63.6893-63.6895 km/h just below that Hopf point; stopped at its first deep point it missed it."""


def _car(values):
    return with_updates(Params(), {"model": "axle4dof", **dict(zip(KEYS, values))})


def _same_band(a, b, tol=1e-6):
    for name in ("sev_band_kmh", "hard_regions_kmh", "gaps_after_pd_ns_kmh"):
        x, y = getattr(a, name), getattr(b, name)
        assert len(x) == len(y), (name, x, y)
        if x:
            assert np.max(np.abs(np.subtract(x, y))) <= tol, (name, x, y)


def test_a_stopped_branch_is_the_full_branch_up_to_the_stop_and_not_failed():
    params = Params()
    model = model_for(params)
    p = model.pack(params)
    hopf = branch_start(stability(params, (20.0, 300.0)).hopf_points[0])
    bounds = (kmh_to_ms(20.0), kmh_to_ms(300.0))
    whole = continue_from_hopf(model, p, hopf, bounds)
    part = continue_from_hopf(model, p, hopf, bounds, stop=lambda branch: len(branch.points) >= 5)
    assert len(whole.points) > 5 and len(part.points) == 5
    assert part.end is BranchEnd.STOPPED and not part.failed
    for a, b in zip(part.points, whole.points):
        assert np.array_equal(a.orbit.nodes, b.orbit.nodes) and a.orbit.speed == b.orbit.speed


def test_an_edge_reached_from_inside_the_linear_band_is_kept_and_the_study_uses_it():
    params = _car(EXCURSION_AXLE)
    full = bifurcation(params, (20.0, 300.0))
    edges = edges_diagram(params, (20.0, 300.0))
    assert [round(h.speed_kmh, 2) for h in full.hopf_points] == [73.14, 80.49, 86.02, 159.69]
    _same_band(full, edges)
    assert any(abs(b - 80.9185) < 1e-3 for _, b in full.hard_regions_kmh)
    assert all(info["ended"] == "stopped" for info in edges.branch_info)
    assert sum(len(b.points) for b in edges.branches) < sum(len(b.points) for b in full.branches)
    # stopped on entering the linear band, the branch misses the fold above 80.49 km/h
    entry = edges_diagram(params, (20.0, 300.0), depth_kmh=0.0)
    assert len(entry.hard_regions_kmh) == len(full.hard_regions_kmh) - 1
    # the study's outputs from it: the speeds of the full diagram, no amplitude
    evaluator = StudyEvaluator(params, KEYS, "bifurcation", (20.0, 300.0), edges_only=True)
    values, outcome = evaluator(np.array(EXCURSION_AXLE))
    sev = full.sev_band_kmh
    assert values[:3] == pytest.approx((sev[0][0], sev[-1][1], sum(b - a for a, b in sev)), abs=1e-6)
    assert math.isnan(values[3]) and outcome.edges_only and outcome.status.value == "ok"


def test_oscillatory_intervals_leave_out_static_divergence():
    class Stab:
        linear_band_kmh = [(50.0, 60.0), (70.0, 90.0)]
        real_crossings_kmh = [75.0]

    assert oscillatory_intervals(Stab()) == [(50.0, 60.0)]


def test_a_band_bound_at_a_period_doubling_is_undecided():
    from types import SimpleNamespace as NS

    def point(kmh):
        return NS(orbit=NS(speed=kmh_to_ms(kmh)))

    branch = NS(special=[("PD", point(56.31), 3), ("LP", point(60.0), 5), ("NS", point(70.0), 8)])
    diagram = NS(sev_band_kmh=[(56.31, 58.0), (60.0, 90.0)], branches=[branch])
    assert pd_ns_edges_kmh(diagram) == [56.31]
    diagram.sev_band_kmh = [(60.0, 90.0)]
    assert pd_ns_edges_kmh(diagram) == []


@pytest.mark.slow
@pytest.mark.parametrize("values", [GAP_AXLE, TWICE_AXLE, CROSSING_AXLE], ids=["gap", "twice", "crossing"])
def test_edges_agree_with_the_full_continuation(values):
    params = _car(values)
    full = bifurcation(params, (20.0, 300.0))
    edges = edges_diagram(params, (20.0, 300.0))
    _same_band(full, edges)
    assert pd_ns_edges_kmh(full) == pd_ns_edges_kmh(edges) == []
    if values is CROSSING_AXLE:
        assert [(round(a, 2), round(b, 2)) for a, b in edges.hard_regions_kmh][2] == (82.41, 85.23)
    if values is GAP_AXLE:
        assert [(round(a, 2), round(b, 2)) for a, b in edges.gaps_after_pd_ns_kmh] == [(74.62, 75.41)]


@pytest.mark.slow
def test_a_cascade_branch_that_comes_back_below_its_hopf_point_keeps_the_window():
    """Both paths follow this branch from opposite ends, each with a mesh adapted along its own
    path, so they agree to the discretization error of its folds, not to rounding: the full
    continuation with 80 mesh intervals instead of 40 moves the fold at 62.862 km/h by
    1.1e-5 km/h; the two paths were 2.3e-6 km/h apart there with OpenBLAS's AVX-512 kernels
    and within 1e-6 with its AVX2 ones (docs/fleet.md)."""
    params = _car(WINDOW_AXLE)
    full = bifurcation(params, (20.0, 300.0))
    edges = edges_diagram(params, (20.0, 300.0))
    _same_band(full, edges, tol=2e-5)
    # followed through its fold at 67.99 km/h back to the fold at 63.689 km/h, where the window
    # of stable cycles (63.6893-63.6895 km/h, 2e-4 km/h wide) opens; whether 40 mesh intervals
    # resolve that window depends on the last bits (80 do, on this machine)
    folds = sorted(float(ms_to_kmh(bp.orbit.speed)) for branch in edges.branches
                   for label, bp, _ in branch.special if label == "LP")
    assert any(abs(v - 67.9929) < 1e-3 for v in folds) and any(abs(v - 63.6893) < 1e-3 for v in folds)
    assert all(info["ended"] == "stopped" for info in edges.branch_info)
    assert sum(len(b.points) for b in edges.branches) < sum(len(b.points) for b in full.branches)


def test_a_cascade_branch_is_stopped_only_deep_after_a_fold():
    from types import SimpleNamespace as NS

    from polywear.studies.edges import BranchStop

    class Stab:
        linear_band_kmh = [(60.0, 90.0)]
        real_crossings_kmh = []

    def branch(path, special=()):
        """Points at the speeds [km/h] of ``path``, moving as the path does."""
        dv = np.diff(path, append=path[-1] + (path[-1] - path[-2]))
        return NS(points=[NS(orbit=NS(speed=kmh_to_ms(v)), tangent_speed=float(np.sign(d)))
                          for v, d in zip(path, dv)], special=list(special))

    stop = BranchStop()(Stab())
    up = [60.0, 61.0, 61.8, 64.0]  # first 2 km/h deep at 64 km/h
    assert stop(branch(up))  # no PD/NS before: stopped at its first deep point
    cascade = [("PD", None, 1)]
    assert not stop(branch(up, cascade))
    assert not stop(branch(up + [68.0, 66.0], cascade))  # turned, but back towards 60 km/h
    assert not stop(branch(up + [68.0, 66.0, 61.0, 59.5, 61.0], cascade))  # out of the band and back
    assert stop(branch(up + [68.0, 66.0, 61.0, 59.5, 61.0, 63.0], cascade))  # deep again, moving away
