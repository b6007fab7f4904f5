"""The least-change search (dynamics/least_change.py) on criteria whose least change is known in closed form."""

import math

import pytest

from polywear.dynamics.least_change import least_factor


def threshold(up: float | None = None, down: float | None = None, calls: list | None = None):
    """Criterion met for f >= up or f <= down; returns f itself where met."""
    def meets(f):
        if calls is not None:
            calls.append(f)
        return f if (up is not None and f >= up) or (down is not None and f <= down) else None
    return meets


@pytest.mark.parametrize("up", [1.0001, 1.37, 2.9, 3.999])
def test_least_factor_brackets_the_threshold_to_the_bisection_accuracy(up):
    factor, payload = least_factor(threshold(up=up), max_factor=4.0)
    assert payload == factor  # what the criterion returned at the factor reported
    assert up <= factor and math.log(factor / up) <= 0.01


def test_the_smaller_change_of_the_two_directions_wins():
    factor, _ = least_factor(threshold(up=1.6, down=1 / 1.3), max_factor=4.0)
    assert 1 / 1.3 >= factor >= 1 / 1.3 * math.exp(-0.01)
    factor, _ = least_factor(threshold(up=1.2, down=1 / 1.3), max_factor=4.0)
    assert 1.2 <= factor <= 1.2 * math.exp(0.01)


def test_nothing_within_the_range_is_none_after_the_grid_alone():
    calls = []
    assert least_factor(threshold(up=4.5, calls=calls), max_factor=4.0, grid=10) is None
    assert len(calls) == 20 and max(calls) == pytest.approx(4.0) and min(calls) == pytest.approx(0.25)


def test_a_finer_refinement_gets_closer():
    factor, _ = least_factor(threshold(up=2.2), max_factor=4.0, grid=3, refine=1e-6)
    assert 0.0 <= math.log(factor / 2.2) <= 1e-6
