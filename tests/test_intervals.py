"""Speed-interval helpers (dynamics.intervals) on cases worked by hand."""

from polywear.dynamics.intervals import runs_of, subtract, union


def test_runs_of_consecutive_flags_including_the_ends():
    speeds = [10.0, 20.0, 30.0, 40.0, 50.0, 60.0]
    assert runs_of(speeds, [True, True, False, True, False, True]) == [(10.0, 20.0), (40.0, 40.0), (60.0, 60.0)]
    assert runs_of(speeds, [False] * 6) == []


def test_union_joins_overlapping_and_touching_and_within_the_gap():
    assert union([(50.0, 60.0), (10.0, 20.0), (15.0, 30.0), (30.0, 40.0)]) == [(10.0, 40.0), (50.0, 60.0)]
    assert union([(10.0, 20.0), (20.0 + 1e-10, 25.0)]) == [(10.0, 20.0), (20.0 + 1e-10, 25.0)]
    assert union([(10.0, 20.0), (20.0 + 1e-10, 25.0)], gap=1e-9) == [(10.0, 25.0)]


def test_subtract_cuts_holes_and_drops_slivers():
    assert subtract([(10.0, 100.0)], [(20.0, 30.0), (90.0, 120.0)]) == [(10.0, 20.0), (30.0, 90.0)]
    assert subtract([(10.0, 20.0)], [(0.0, 10.0), (20.0, 30.0)]) == [(10.0, 20.0)]
    assert subtract([(10.0, 20.0)], [(10.0 + 1e-10, 20.0)]) == []
    assert subtract([(10.0, 20.0)], []) == [(10.0, 20.0)]
