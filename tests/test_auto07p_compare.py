"""The tread1dof and axle4dof bifurcation diagrams against AUTO-07p, the reference
continuation code.

For axle4dof AUTO runs the model's own compiled kernels (bifpy's callback path), so the
comparison checks the continuation, not the equations (tests/test_axle4dof.py does);
AUTO's refinement and a long time integration give the third opinion there.
"""

import numpy as np
import pytest

from polywear.dynamics.bifurcation import bifurcation
from polywear.dynamics.points import PointKind
from polywear.units import kmh_to_ms
from polywear.params import Params
from polywear.validation.auto07p import auto07p_available, special_points

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
    return bifurcation(params, (20.0, 300.0)), tread1dof_diagram(params, (20.0, 300.0))


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
    assert fold.speed_kmh == pytest.approx(a["speed_kmh"], rel=1e-6)
    assert 1.0 / fold.frequency_hz == pytest.approx(a["period_s"], rel=1e-6)
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


# -- axle4dof ---------------------------------------------------------------------------
AXLE_STATES = ("x", "alpha", "beta")


@pytest.fixture(scope="module")
def axle_both():
    from polywear.validation.auto07p import model_diagram

    params = Params(model="axle4dof")
    return bifurcation(params, (20.0, 300.0)), model_diagram(params, (20.0, 300.0))


@pytest.mark.parametrize("pair", ["both", "axle_both"])
def test_special_points_agree_one_to_one(pair, request):
    """Both diagrams as SpecialPoints: the same kinds in the same order (Hopf, Hopf, fold),
    at the same speeds and frequencies, with the same amplitudes at the fold."""
    ours, auto = request.getfixturevalue(pair)
    mine = [p for p in ours.special_points if p.kind in (PointKind.HOPF, PointKind.LP)]
    theirs = special_points(auto)
    assert [p.kind for p in mine] == [p.kind for p in theirs] == [PointKind.HOPF, PointKind.HOPF, PointKind.LP]
    for a, b in zip(mine, theirs):
        assert a.speed_kmh == pytest.approx(b.speed_kmh, rel=1e-6)
        assert a.frequency_hz == pytest.approx(b.frequency_hz, rel=1e-6)
    x = ours.state_names.index("x")
    assert mine[2].amplitude[x] == pytest.approx(theirs[2].amplitude[x], rel=1e-5)


def test_axle4dof_hopf_points_agree(axle_both):
    ours, auto = axle_both
    assert len(ours.hopf_points) == len(auto["hopf"]) == 2
    for h, a in zip(ours.hopf_points, auto["hopf"]):
        assert h.speed_kmh == pytest.approx(a["speed_kmh"], rel=1e-6)
        assert h.frequency_hz == pytest.approx(a["frequency_hz"], rel=1e-6)


def test_axle4dof_fold_of_cycles_agrees(axle_both):
    ours, auto = axle_both
    (fold,) = ours.folds
    (a,) = auto["folds"]
    assert fold.speed_kmh == pytest.approx(a["speed_kmh"], rel=1e-6)
    assert 1.0 / fold.frequency_hz == pytest.approx(a["period_s"], rel=1e-6)
    for name in AXLE_STATES:
        assert fold.amplitude[ours.state_names.index(name)] == pytest.approx(a["amplitude"][name], rel=1e-5)
    # the fold closes the SEV band: a hard region between the upper Hopf point and it
    assert ours.sev_band_kmh[-1][1] == pytest.approx(a["speed_kmh"], rel=1e-6)


def test_axle4dof_branch_joins_the_two_hopf_points(axle_both):
    ours, auto = axle_both
    (branch,) = auto["cycles"]
    (info,) = ours.branch_info
    assert branch["ended"] == "hopf" and info["to_hopf_kmh"] is not None
    assert branch["from_hopf_kmh"] == pytest.approx(info["from_hopf_kmh"], rel=1e-6)
    assert branch["end_speed_kmh"] == pytest.approx(info["to_hopf_kmh"], rel=1e-6)


def test_axle4dof_equilibrium_stability_agrees(axle_both):
    ours, auto = axle_both
    hopf = [h.speed_kmh for h in ours.hopf_points]
    checked = 0
    for speed, stable in zip(auto["equilibrium"]["speed_kmh"], auto["equilibrium"]["stable"]):
        if min(abs(speed - h) for h in hopf) < 1e-3 * speed:
            continue  # at a Hopf point the answer is a matter of rounding
        unstable = any(lo < speed < hi for lo, hi in ours.linear_band_kmh)
        assert stable == (not unstable), speed
        checked += 1
    assert checked > 20


def test_axle4dof_cycle_amplitudes_and_stability_agree_along_the_branch(axle_both):
    """At every 7th AUTO point away from the Hopf ends, our cycle at exactly that speed
    and on the same side of the fold (nearest in x) agrees in the amplitudes of x,
    alpha and beta, period and stability; both sides of the fold are visited."""
    ours, auto = axle_both
    (branch,) = auto["cycles"]
    index = {name: ours.state_names.index(name) for name in AXLE_STATES}
    checked, unstable = 0, 0
    for k in range(5, len(branch["speed_kmh"]) - 5, 7):
        v, amp = branch["speed_kmh"][k], branch["amplitude"]
        if amp["x"][k] < 0.02e-3:
            continue  # next to a Hopf point the amplitude is ill-conditioned in speed
        match = min(ours.cycles_at(v), key=lambda c: abs(c.amplitude[index["x"]] - amp["x"][k]))
        for name in AXLE_STATES:
            assert match.amplitude[index[name]] == pytest.approx(amp[name][k], rel=1e-4), (v, name)
        assert match.period == pytest.approx(branch["period_s"][k], rel=1e-6), v
        assert match.stable == branch["stable"][k], v
        checked += 1
        unstable += not match.stable
    assert checked >= 20 and unstable >= 3


def test_axle4dof_auto_refinement_moves_the_numbers_far_less_than_1e_4(axle_both):
    """AUTO at its refined settings (twice the mesh, tolerances / 10, steps / 2)."""
    from polywear.validation.auto07p import AUTO_MODELS, headline_numbers, model_diagram

    _, auto = axle_both
    base = headline_numbers(auto)
    fine = headline_numbers(model_diagram(Params(model="axle4dof"), (20.0, 300.0), AUTO_MODELS["axle4dof"].settings.refined()))
    assert base.keys() == fine.keys() and len(base) == 9
    for key in base:
        assert base[key] == pytest.approx(fine[key], rel=1e-5), key


def test_axle4dof_operating_cycle_equals_long_time_integration(axle_both):
    """Third opinion at 110 km/h: Rodas4 at rtol 1e-10 from the kicked equilibrium over
    200 periods (largest non-trivial multiplier 0.87: the transient decays to 1e-12),
    half peak-to-peak over the last 3 periods on a fine grid of the dense output."""
    from polywear.models.axle4dof import MODEL
    from polywear.solvers.integrate import integrate
    from polywear.validation.auto07p import AXLE4DOF_STATE_UNIT

    ours, auto = axle_both
    (cycle,) = auto["operating_point"]["cycles"]
    assert auto["operating_point"]["speed_kmh"] == 110.0 and cycle["stable"]
    assert cycle["floquet_max_modulus"] < 0.9
    p = MODEL.pack(Params(model="axle4dof"))
    V = kmh_to_ms(110.0)
    kick = np.zeros(MODEL.n)
    kick[MODEL.index("xdot")] = 0.2
    periods, period = 200, cycle["period_s"]
    run = integrate(
        MODEL, MODEL.equilibrium(V, p) + kick, V, p, periods * period, rtol=1e-10,
        atol=1e-16 * np.asarray(AXLE4DOF_STATE_UNIT), dense_from=(periods - 3) * period,
    )  # fmt: skip
    u = run.dense(np.linspace((periods - 3) * period, periods * period, 300_001))
    amplitude = 0.5 * (u.max(axis=0) - u.min(axis=0))
    (mine,) = ours.cycles_at(110.0)
    for name in AXLE_STATES:
        i = MODEL.index(name)
        assert cycle["amplitude"][name] == pytest.approx(amplitude[i], rel=1e-6), name
        assert mine.amplitude[i] == pytest.approx(amplitude[i], rel=1e-6), name
