"""The one definition of the SEV band (issue 26): where steady rolling is unstable, or a
stable vibration coexists with it; a period doubling (PD) or torus bifurcation (NS) leaves
a stretch undecided only where rolling is stable (a hard region)."""

import numpy as np
import pytest

from polywear.dynamics.attractor import reached_attractors
from polywear.dynamics.bifurcation import bifurcation
from polywear.dynamics.diagram import sev_band
from polywear.models import get_model
from polywear.params import Params, with_updates

from .test_continuation_robust import TWICE_LOST_AXLE
from .test_verdict import CASCADE_AXLE


def test_a_pd_inside_the_band_ends_nothing_and_only_gaps_at_a_pd_are_undecided():
    """Closed case: rolling unstable over 60-150 km/h, stable cycles 50-52 (ending at a PD),
    55-58 (ending at a Hopf point or fold) and 60-170 km/h, PDs at 52 and 100 km/h. The
    band is the union; the gap 52-55 starts at the PD (undecided), the gap 58-60 ends at no
    PD (decided: no vibration), the PD at 100 km/h inside the band ends nothing."""
    band, undecided = sev_band([(60.0, 150.0)], [(50.0, 52.0), (55.0, 58.0), (60.0, 170.0)], [52.0, 100.0])
    assert band == [(50.0, 52.0), (55.0, 58.0), (60.0, 170.0)]
    assert undecided == [(52.0, 55.0)]
    band, undecided = sev_band([(60.0, 150.0)], [(50.0, 52.0), (55.0, 58.0), (60.0, 170.0)], [60.0 - 1e-12])
    assert undecided == [(58.0, 60.0)]  # a PD at a gap's upper end (a stable run starting there)
    assert sev_band([], [], [70.0]) == ([], [])


def _axle(values):
    params = with_updates(Params(), {"model": "axle4dof", **values})
    return params, bifurcation(params, (10.0, 600.0), extend=False)


@pytest.mark.slow
def test_a_car_whose_pds_lie_where_rolling_is_unstable_has_no_undecided_gap():
    """TWICE_LOST_AXLE: its PDs (72.67, 79.43 km/h) lie inside the linear band 71.18-84.21
    km/h; the old rule (every gap of a diagram with a PD) listed the gap 84.21-86.18 km/h
    as one after a PD. That gap starts at a Hopf point (where the stable cycles of 79.43-84.21
    km/h shrink to zero) and ends at a fold: decided, no vibration. Checked by simulation:
    at 85.8 km/h both starts (the nearest stable cycle, rolling disturbed) return to rest."""
    params, d = _axle(TWICE_LOST_AXLE)
    linear = d.linear_band_kmh
    pds = [v for v in d.pd_ns_speeds_kmh]
    assert pds and all(any(a < v < b for a, b in linear) for v in pds)
    (lo, hi), = [(b, c) for (_, b), (c, _) in zip(d.sev_band_kmh[:-1], d.sev_band_kmh[1:])]
    assert lo == pytest.approx(84.2135, abs=1e-3) and hi == pytest.approx(86.1815, abs=1e-3)
    assert d.gaps_after_pd_ns_kmh == [] and d.summary()["gaps_after_pd_ns_kmh"] == []
    found = reached_attractors(d, 85.8)
    assert found and all(not a.oscillating for a in found)


@pytest.fixture(scope="module")
def cascade():
    return _axle(CASCADE_AXLE)


@pytest.mark.slow
def test_past_a_pd_where_rolling_is_unstable_the_tread_vibrates(cascade):
    """CASCADE_AXLE: the stable period-1 cycles from its first Hopf point (59.75 km/h) end at
    a PD at 60.14 km/h, and none is stable again before 71.57 km/h; rolling is unstable
    there, so the band holds 65 km/h. Simulation: the tread vibrates at 65 km/h."""
    params, d = cascade
    assert any(abs(v - 60.139) < 1e-3 for v in d.pd_ns_speeds_kmh)
    assert not any(c.stable for c in d.cycles_at(65.0))
    assert any(a <= 65.0 <= b for a, b in d.sev_band_kmh)
    assert not any(a <= 65.0 <= b for a, b in d.gaps_after_pd_ns_kmh)
    found = reached_attractors(d, 65.0)
    x = d.state_names.index("x")
    assert all(a.oscillating for a in found) and max(a.amplitude[x] for a in found) > 1e-4


@pytest.mark.slow
def test_a_pd_where_rolling_is_stable_is_decided_by_simulation(cascade):
    """CASCADE_AXLE: the window of stable cycles 56.19-56.55 km/h ends at a PD with steady
    rolling stable (eigenvalues at 58 km/h all in the left half-plane); the gap from that
    PD to the first Hopf point (59.75 km/h) is undecided, and a simulation decides it at
    58 km/h: started from the window's cycle the tread keeps vibrating (~0.56 mm)."""
    params, d = cascade
    (lo, hi), = d.gaps_after_pd_ns_kmh
    assert lo in d.pd_ns_speeds_kmh and hi == pytest.approx(d.hopf_points[0].speed_kmh, abs=1e-9)
    model = get_model("axle4dof")
    p = model.pack(params)
    V = 58.0 / 3.6
    assert np.linalg.eigvals(model.jacobian(model.equilibrium(V, p), V, p)).real.max() < 0.0
    found = reached_attractors(d, 58.0)
    x = d.state_names.index("x")
    assert found[0].oscillating and 0.4e-3 < found[0].amplitude[x] < 0.8e-3
    assert d.summary()["gaps_after_pd_ns_kmh"] == [[lo, hi]]
