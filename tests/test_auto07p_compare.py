"""The tread1dof bifurcation diagram against AUTO-07p, the reference continuation code."""

import numpy as np
import pytest

from polywear.analysis.bifurcation import bifurcation_diagram
from polywear.params import Params
from polywear.validation.auto07p import auto07p_available

available, why = auto07p_available()
pytestmark = [
    pytest.mark.auto07p,
    pytest.mark.slow,
    pytest.mark.skipif(not available, reason=why),
]


@pytest.fixture(scope="module")
def both():
    from polywear.validation.auto07p import tread1dof_diagram

    params = Params()
    return bifurcation_diagram(params, (20.0, 300.0)), tread1dof_diagram(params, (20.0, 300.0))


def test_hopf_points_agree(both):
    ours, auto = both
    assert len(ours.hopf_points) == len(auto["hopf"]) == 2
    for h, a in zip(ours.hopf_points, auto["hopf"]):
        assert h.speed_kmh == pytest.approx(a["speed_kmh"], rel=1e-6)
        assert h.frequency_hz == pytest.approx(a["frequency_hz"], rel=1e-6)


def test_fold_of_cycles_agrees(both):
    ours, auto = both
    (fold,) = ours.folds
    (a,) = auto["folds"]
    assert fold.speed * 3.6 == pytest.approx(a["speed_kmh"], rel=1e-6)
    assert fold.period == pytest.approx(a["period_s"], rel=1e-6)
    assert fold.amplitude[0] == pytest.approx(a["amplitude_x_m"], rel=1e-5)


def test_cycle_amplitudes_and_stability_agree_along_the_branch(both):
    """At every AUTO point away from the Hopf ends, our cycle at exactly that speed and on
    the same side of the fold agrees in amplitude of x, period and stability."""
    ours, auto = both
    (branch,) = auto["cycles"]
    speeds = np.asarray(branch["speed_kmh"])
    amps = np.asarray(branch["amplitude"]["x"])
    periods = np.asarray(branch["period_s"])
    stable = np.asarray(branch["stable"])
    checked = 0
    for v, a, T, st in list(zip(speeds, amps, periods, stable))[5:-5:7]:
        if a < 0.02e-3:
            continue  # next to a Hopf point the amplitude is ill-conditioned in speed
        ours_here = ours.cycles_at(v)
        match = min(ours_here, key=lambda c: abs(c.amplitude[0] - a))
        assert match.amplitude[0] == pytest.approx(a, rel=1e-4), v
        assert match.period == pytest.approx(T, rel=1e-6), v
        assert match.stable == bool(st), v
        checked += 1
    assert checked >= 8
