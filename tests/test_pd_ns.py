"""Location of period doublings (PD) and torus bifurcations (NS) on cycle branches.

The located point lies on the crossing: a multiplier at -1 (PD) or a complex pair on the
unit circle (NS), to ``crossing_tol``; cycles solved at fixed speeds just below and above it
have that multiplier on either side. Multipliers outside the circle that only meet and turn
from a real pair into a complex one (or back) are no bifurcation and are not reported.
"""

from __future__ import annotations

import numpy as np
import pytest

from polywear.dynamics.bifurcation import bifurcation
from polywear.studies.global_sensitivity import DEFAULT_KEYS
from polywear.studies.sampling import sample_params
from polywear.models import get_model
from polywear.params import Params, get_value, with_updates
from polywear.solvers.continuation import (BranchPoint, ContinuationSettings, same_special_point, solve_at_speed,
                                           stability_decided)
from polywear.solvers.continuation.events import _collisions_only, _ns_pair, _pd_test

SETTINGS = ContinuationSettings()
DELTA_KMH = 1e-4
"""Speed offset [km/h] of the independent bracket: a tenth of the accuracy of the bisection
on counts this locator replaced (1e-3 of a step of 0.1-2 km/h, the first point past the
crossing), above the located points' speed error (crossing_tol / |dmu/dV| < 2e-5 km/h here)."""


def _axle_sample(index: int) -> Params:
    """Sample ``index`` of the fleet benchmark's axle4dof draw (seed 0, every parameter of the
    sensitivity study within +-10 % of its default): four Hopf points, many PD/NS points."""
    base = with_updates(Params(), {"model": "axle4dof"})
    nominal = np.array([get_value(base, k) for k in DEFAULT_KEYS])
    rng = np.random.default_rng(0)
    for _ in range(index + 1):
        values = nominal * (1.0 + 0.1 * (2.0 * rng.random(len(nominal)) - 1.0))
    return sample_params(base, DEFAULT_KEYS, values)


@pytest.fixture(scope="module")
def complex_diagram():
    return bifurcation(_axle_sample(13), extend=False)


def _nontrivial(mu: np.ndarray) -> np.ndarray:
    return np.delete(mu, int(np.argmin(np.abs(mu - 1.0))))


def _located(diagram, label: str) -> list[BranchPoint]:
    return [pt for branch in diagram.branches for lab, pt, _ in branch.special if lab == label]




def _nearest(mu: np.ndarray, near: complex) -> complex:
    """The non-trivial multiplier nearest ``near``."""
    mu = _nontrivial(mu)
    return mu[np.argmin(np.abs(mu - near))]


def test_located_points_lie_on_the_crossing(complex_diagram):
    pds, nss = _located(complex_diagram, "PD"), _located(complex_diagram, "NS")
    assert len(pds) >= 3 and len(nss) >= 1
    for pt in pds:
        d = _nearest(pt.multipliers, -1.0) + 1.0
        assert abs(d) <= SETTINGS.crossing_tol and d.imag == 0.0  # a real multiplier at -1
    for pt in nss:
        mu = _nontrivial(pt.multipliers)
        pair = mu[np.abs(mu.imag) > 1e-3]
        assert np.min(np.abs(np.abs(pair) - 1.0)) <= SETTINGS.crossing_tol


def test_cycles_just_below_and_above_have_the_multiplier_on_either_side(complex_diagram):
    model = get_model("axle4dof")
    p = model.pack(complex_diagram.params)
    fold_kmh = [f.speed_kmh for f in complex_diagram.folds]
    checked = 0
    for label in ("PD", "NS"):
        for pt in _located(complex_diagram, label):
            v = pt.orbit.speed * 3.6
            if min(abs(v - f) for f in fold_kmh) < 10 * DELTA_KMH:
                continue  # the speed is not a coordinate of the branch there
            mu = _nontrivial(pt.multipliers)
            if label == "NS":
                mu = mu[np.abs(mu.imag) > 1e-3]  # the pair on the circle
            mu0 = mu[np.argmin(np.abs(mu + 1.0) if label == "PD" else np.abs(np.abs(mu) - 1.0))]
            sides = []
            for dv in (-DELTA_KMH, DELTA_KMH):
                cycle = solve_at_speed(model, p, pt.orbit, (v + dv) / 3.6, SETTINGS)
                assert cycle is not None and stability_decided(cycle.multipliers, SETTINGS.multiplier_tol)
                sides.append(abs(_nearest(cycle.multipliers, mu0)) - 1.0)
            assert sides[0] * sides[1] < 0.0, (label, v, sides)
            checked += 1
    assert checked >= 4


def test_stable_runs_end_at_the_located_points(complex_diagram):
    located = [pt.orbit.speed * 3.6 for label in ("PD", "NS") for pt in _located(complex_diagram, label)]
    edges = [v for iv in complex_diagram.stable_cycle_intervals_kmh() for v in iv]
    at_crossings = [v for v in edges if any(abs(v - w) <= 1e-12 * w for w in located)]
    assert len(at_crossings) >= 3


def test_a_located_point_is_the_same_point_on_another_mesh(complex_diagram):
    """Branches meet one special point on different meshes: the same orbit on a mesh with every
    interval halved (exact) is the same special point, although its mesh nodes miss the peaks
    by more than the tolerance."""
    located = [pt.orbit for label in ("PD", "NS") for pt in _located(complex_diagram, label)]
    node_differences = []
    for orbit in located:
        mesh = np.sort(np.concatenate([orbit.mesh, 0.5 * (orbit.mesh[:-1] + orbit.mesh[1:])]))
        other = orbit.with_mesh(mesh)
        assert same_special_point(orbit, other) and same_special_point(other, orbit)
        span = np.ptp(orbit.nodes, axis=0)
        node_differences.append(np.max(np.abs(span - np.ptp(other.nodes, axis=0))) / span.max())
    assert max(node_differences) > 1e-4  # comparing nodes would find two points
    assert not any(same_special_point(a, b) for k, a in enumerate(located) for b in located[k + 1:])


def _point(*mu: complex) -> BranchPoint:
    multipliers = np.array([1.0, *mu], dtype=complex)
    return BranchPoint(None, multipliers, np.zeros(1), 0)


def test_pd_test_function_changes_sign_only_where_a_real_multiplier_crosses_minus_one():
    conj = lambda z: (z, np.conj(z))
    # a complex pair outside meets on the negative axis: two real multipliers below -1
    assert _pd_test(np.array([1.0, *conj(-2.63 + 1.21j)])) > 0 < _pd_test(np.array([1.0, -4.53, -1.66]))
    # one of them then crosses -1
    assert _pd_test(np.array([1.0, -4.53, -0.99])) < 0
    assert _pd_test(np.array([1.0, -0.83, 0.5])) > 0 > _pd_test(np.array([1.0, -1.25, 0.5]))


def test_collisions_outside_the_circle_are_no_bifurcation():
    # two real multipliers outside become a complex pair outside (after one crossed +1, a fold)
    a, b = _point(5.241, 0.6935, -0.39 + 0.06j, -0.39 - 0.06j), _point(2.15 + 0.547j, 2.15 - 0.547j,
                                                                    -0.399 + 0.051j, -0.399 - 0.051j)
    assert _ns_pair(a.multipliers, b.multipliers) is None and _collisions_only(a, b)
    # a complex pair outside meets on the negative axis, and one of the two crosses -1 (a PD)
    a, b = _point(-1.85 + 1.04j, -1.85 - 1.04j, 0.05), _point(-3.805, -0.9877, 0.05)
    assert _ns_pair(a.multipliers, b.multipliers) is None and _collisions_only(a, b)
    # a torus bifurcation: the pair itself crosses the circle
    a, b = _point(0.373 + 0.948j, 0.373 - 0.948j, 0.5), _point(0.397 + 0.917j, 0.397 - 0.917j, 0.5)
    assert _ns_pair(a.multipliers, b.multipliers) == (0.373 + 0.948j, 0.397 + 0.917j)
    # two real multipliers cross -1 in one step: no sign change, not a collision (bisection)
    a, b = _point(-0.9, -0.8, 0.1), _point(-1.1, -1.2, 0.1)
    assert _pd_test(a.multipliers) * _pd_test(b.multipliers) > 0 and not _collisions_only(a, b)
