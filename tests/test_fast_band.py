"""Fast band path against the full continuation: every sample either takes the fast path
and agrees with the full diagram (band edges to 1e-6 relative, same numbers of Hopf
points and folds), or falls back (and then is the full diagram); the toe law of tread1dof
(speeds scale as 1/sin(toe)) as a closed-form check of the fold relocation."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from polywear.dynamics.bifurcation import bifurcation, branch_start
from polywear.studies.fast_band import (_FIXED_RANGE, BandPath, Fallback, FallbackReason, FastBand, band_from_diagram,
                                         band_reference, pilot_indices, pilot_references)
from polywear.studies.global_sensitivity import DEFAULT_KEYS
from polywear.studies.sampling import sample_params
from polywear.parallel import Executor
from polywear.dynamics.stability import stability
from polywear.models import get_model
from polywear.params import Params, get_value, with_updates
from polywear.units import DEFAULT_SPEED_RANGE_KMH, kmh_to_ms
from polywear.solvers.continuation import cycle_along_branch, solve_at_speed, switching_times

AMPLITUDE_SPEEDS = (80.0, 130.0)


@pytest.fixture(scope="module")
def tread_solver():
    base = with_updates(Params(), {"model": "tread1dof"})
    ref = band_reference(bifurcation(base, **_FIXED_RANGE), AMPLITUDE_SPEEDS)
    return base, FastBand((ref,), amplitude_speeds_kmh=AMPLITUDE_SPEEDS)


def _edges(band) -> np.ndarray:
    return np.array([v for iv in band.linear_band_kmh + band.sev_band_kmh + band.hard_regions_kmh for v in iv]
                    + list(band.hopf_kmh) + list(band.folds_kmh))


def assert_agrees(fast, full, rtol=1e-6, amplitude_rtol=1e-4):
    """Same structure, edges within rtol, amplitudes within amplitude_rtol of the largest.

    Amplitudes are half peak-to-peak of the collocation polynomial sampled 16 times per
    mesh interval with a parabola through the top three samples: this depends on the
    mesh at ~1e-5, and the two paths solve the same cycle on different meshes."""
    assert len(fast.hopf_kmh) == len(full.hopf_kmh)
    assert len(fast.folds_kmh) == len(full.folds_kmh)
    assert fast.hopf_criticality == full.hopf_criticality
    for name in ("linear_band_kmh", "sev_band_kmh", "hard_regions_kmh"):
        assert len(getattr(fast, name)) == len(getattr(full, name)), name
    np.testing.assert_allclose(_edges(fast), _edges(full), rtol=rtol, atol=0.0)
    scale = max(full.amplitude_x_m, default=0.0)
    np.testing.assert_allclose(fast.amplitude_x_m, full.amplitude_x_m, rtol=0.0, atol=amplitude_rtol * scale)


def test_reference_reproduces_itself(tread_solver):
    base, solver = tread_solver
    band = solver(base)
    assert band.path is BandPath.FAST and band.path == "fast", band.detail
    assert band.reason is None and band.summary()["path"] == "fast"
    assert_agrees(band, solver.references[0].band, rtol=1e-9)


def test_fallback_reasons_are_typed(tread_solver):
    """No reference of the sample's model, or none with its Hopf signature: a typed reason."""
    base, solver = tread_solver
    axle = with_updates(Params(), {"model": "axle4dof"})
    out = solver.try_fast(axle)
    assert isinstance(out, Fallback) and out.reason is FallbackReason.NO_REFERENCE
    # a reference whose Hopf points are not the sample's (tread1dof: soft, hard)
    ref = solver.references[0]
    other = FastBand((replace(ref, band=replace(ref.band, hopf_criticality=("soft",))),))
    out = other.try_fast(base)
    assert out.reason is FallbackReason.HOPF_SIGNATURE and "('soft', 'hard')" in out.detail
    band = band_from_diagram(bifurcation(base, **_FIXED_RANGE), fallback=out)
    assert band.path is BandPath.FULL and band.summary()["reason"] == "hopf_signature"


def test_pilot_indices_are_spread_and_fixed():
    assert list(pilot_indices(5, 8)) == [0, 1, 2, 3, 4]
    idx = pilot_indices(9216, 32)
    assert len(idx) == 32 and idx[0] == 0 and idx[-1] == 9215 and np.all(np.diff(idx) > 280)


def test_toe_law_of_the_fold(tread_solver):
    """tread1dof: V enters only as V sin(toe), so every speed scales with 1/sin(toe)."""
    base, solver = tread_solver
    ref = solver.references[0].band
    for toe in (0.45, 0.56):
        band = solver(with_updates(base, {"operating.toe_deg": toe}))
        assert band.path == "fast", band.reason
        ratio = math.sin(math.radians(0.5)) / math.sin(math.radians(toe))
        np.testing.assert_allclose(band.folds_kmh, np.array(ref.folds_kmh) * ratio, rtol=1e-8)
        np.testing.assert_allclose(band.hopf_kmh, np.array(ref.hopf_kmh) * ratio, rtol=1e-9)
        # the cycle at a speed is the reference's at speed / ratio: same amplitude
        assert band.amplitude_x_m[0] > 0.0


@pytest.mark.slow
def test_random_samples_agree_with_full_continuation(tread_solver):
    """CI version of the 200-sample check (benchmarks/bench_fleet.py --agreement runs it in full)."""
    base, solver = tread_solver
    rng = np.random.default_rng(20261201)
    nominal = np.array([get_value(base, k) for k in DEFAULT_KEYS])
    paths = []
    for _ in range(6):
        params = sample_params(base, DEFAULT_KEYS, nominal * (1.0 + 0.1 * (2.0 * rng.random(len(nominal)) - 1.0)))
        fast = solver(params)
        full = solver.full(params)
        paths.append(fast.path)
        assert_agrees(fast, full)
    assert paths.count("fast") >= 4, paths


@pytest.mark.slow
def test_axle4dof_samples_agree_with_full_continuation():
    """axle4dof, +-5 % around the defaults (at +-10 % many samples change topology and fall back)."""
    base = with_updates(Params(), {"model": "axle4dof"})
    solver = FastBand((band_reference(bifurcation(base, **_FIXED_RANGE), AMPLITUDE_SPEEDS),),
                      amplitude_speeds_kmh=AMPLITUDE_SPEEDS)
    rng = np.random.default_rng(20261201)
    nominal = np.array([get_value(base, k) for k in DEFAULT_KEYS])
    paths = []
    for _ in range(3):
        params = sample_params(base, DEFAULT_KEYS, nominal * (1.0 + 0.05 * (2.0 * rng.random(len(nominal)) - 1.0)))
        fast = solver(params)
        paths.append(fast.path)
        assert_agrees(fast, solver.full(params))
    assert paths.count("fast") >= 2, paths


@pytest.mark.slow
def test_hard_region_the_continuation_missed_is_confirmed_by_simulation(tread_solver):
    """A tread1dof car (sample 36 of the 200-sample agreement run) where the continuation
    stepped over the fold and reported no hard region (until 613c3bb): the fast path finds
    the fold at 218.68 km/h. Time integration at 210 km/h decides: a 0.1 mm start decays to steady
    rolling, a 2 mm start settles on the stable cycle whose amplitude the fast path gives."""
    from polywear.dynamics.simulation import simulate

    base, _ = tread_solver
    car = with_updates(base, {
        "tread.lateral_stiffness_n_per_m": 1016870.045, "tread.lateral_damping_ns_per_m": 86.86956487,
        "operating.toe_deg": 0.4860230639, "friction.mu_static": 0.823947039, "tread.mass_kg": 0.9337926137,
        "operating.vertical_load_n": 3982.582287,
    })
    reference = band_reference(bifurcation(base, **_FIXED_RANGE), (210.0,))
    band = FastBand((reference,), amplitude_speeds_kmh=(210.0,))(car)
    assert band.path == "fast", band.reason
    ((lo, hi),) = band.hard_regions_kmh
    assert lo < 210.0 < hi and hi == pytest.approx(218.679, abs=1e-3)
    small = simulate(car, 210.0, 3.0, disturbance=1e-4).steady
    large = simulate(car, 210.0, 3.0, disturbance=2e-3).steady
    assert small.outcome == "equilibrium" and large.outcome == "cycle"
    assert large.amplitude[0] == pytest.approx(band.amplitude_x_m[0], rel=2e-3)


def test_cycle_near_a_hopf_point_is_found_by_the_diagram():
    """axle4dof sample 193 of the agreement run: soft Hopf point at 79.84 km/h. The diagram's
    Newton at 80 km/h from the bracketing branch points stalled at the round-off floor
    (steps of 1-2e-10 scaled against a tolerance of 1e-10) and reported no cycle there, so
    the full path's amplitude was 0 where the fast path finds the small stable cycle."""
    car = with_updates(Params(), {
        "model": "axle4dof", "tread.lateral_stiffness_n_per_m": 1061544.7405375906,
        "tread.lateral_damping_ns_per_m": 72.68078060402418, "operating.toe_deg": 0.4644238295129579,
        "operating.camber_deg": -0.987686207752469, "friction.mu_static": 0.9239243546312512,
        "tread.mass_kg": 0.9563313162239697, "operating.vertical_load_n": 3785.309079521403,
    })
    full = band_from_diagram(bifurcation(car, **_FIXED_RANGE), (80.0,))
    assert full.hopf_kmh[0] < 80.0 < full.sev_band_kmh[0][1]
    # square-root law from the Hopf point: ~2.5e-5 m at 0.16 km/h above it
    assert 1e-5 < full.amplitude_x_m[0] < 5e-5


@pytest.mark.slow
def test_a_second_reference_serves_its_hopf_signature():
    """axle4dof at +-5 %: samples whose first Hopf point is hard (a Bautin point crossed)
    fall back with the nominal reference alone (HOPF_SIGNATURE); with a reference of that
    topology (another such sample) they take the fast path and agree with the continuation."""
    base = with_updates(Params(), {"model": "axle4dof"})
    rng = np.random.default_rng(20261201)
    nominal = np.array([get_value(base, k) for k in DEFAULT_KEYS])
    samples = [sample_params(base, DEFAULT_KEYS, nominal * (1.0 + 0.05 * (2.0 * rng.random(len(nominal)) - 1.0)))
               for _ in range(10)]
    refs, failed = pilot_references([base, samples[3]], amplitude_speeds_kmh=AMPLITUDE_SPEEDS,
                                    executor=Executor("serial"))
    assert not failed and [r.band.hopf_criticality for r in refs] == [("soft", "hard"), ("hard", "hard")]
    alone = FastBand(refs[:1], amplitude_speeds_kmh=AMPLITUDE_SPEEDS)
    both = FastBand(refs, amplitude_speeds_kmh=AMPLITUDE_SPEEDS)
    paths = []
    for params in (samples[5], samples[8], samples[9]):
        assert alone.try_fast(params).reason is FallbackReason.HOPF_SIGNATURE
        band = both(params)
        paths.append(band.path)
        assert_agrees(band, both.full(params))
    assert paths.count(BandPath.FAST) >= 2, paths


def test_a_reference_whose_band_runs_to_the_range_end_is_not_used(tread_solver):
    """tread1dof, toe 0.38 deg: the fold lies above 300 km/h, so the SEV band ends at the
    range end. A sample at toe 0.43 deg (nearer to it than to the nominal 0.5 deg) has its
    fold at ~296 km/h; started from that reference it would report no fold and a band to
    300 km/h (8 of 200 samples did so in an agreement run). Such a reference is unusable."""
    base, solver = tread_solver
    beyond = band_reference(bifurcation(with_updates(base, {"operating.toe_deg": 0.38}), **_FIXED_RANGE),
                            AMPLITUDE_SPEEDS)
    assert beyond.unusable.startswith("an interval of the reference ends at an end of the speed range")
    car = with_updates(base, {"operating.toe_deg": 0.43})
    both = FastBand((solver.references[0], beyond), amplitude_speeds_kmh=AMPLITUDE_SPEEDS)
    band = both(car)
    assert band.path is BandPath.FAST and len(band.folds_kmh) == 1 and band.folds_kmh[0] < 300.0
    assert_agrees(band, both.full(car))


def test_cycle_along_branch_is_the_diagrams_cycle():
    """tread1dof: soft Hopf point at 58 km/h, fold at 255, hard Hopf point at 208 (one branch).
    Along the branch from a Hopf point, or from the fold on either side, the cycle at a speed
    is the diagram's there (with its stability); a branch that turns away first gives None."""
    diagram = bifurcation(with_updates(Params(), {"model": "tread1dof"}), **_FIXED_RANGE)
    model = get_model("tread1dof")
    p, ix = model.pack(diagram.params), model.index("x")
    soft, hard = (branch_start(hopf) for hopf in diagram.hopf_points)
    (branch,) = diagram.branches
    (fold,) = [point for label, point, _ in branch.special if label == "LP"]

    def along(start, v_kmh, **kw):
        return cycle_along_branch(model, p, start, kmh_to_ms(v_kmh), diagram.settings, **kw)

    (at_80,) = diagram.cycles_at(80.0)
    point = along(soft, 80.0)
    assert point.stable and point.orbit.amplitude()[ix] == pytest.approx(at_80.amplitude[ix], rel=1e-5)
    small, large = diagram.cycles_at(215.0)  # sorted by amplitude: unstable, stable
    assert (small.stable, large.stable) == (False, True)
    sides = sorted((along(fold, 215.0, scales=branch.scales, reverse=r) for r in (False, True)),
                   key=lambda pt: pt.orbit.amplitude()[ix])
    for point, cycle in zip(sides, (small, large)):
        assert point.stable == cycle.stable
        assert point.orbit.amplitude()[ix] == pytest.approx(cycle.amplitude[ix], rel=1e-5)
    point = along(hard, 215.0)
    assert not point.stable and point.orbit.amplitude()[ix] == pytest.approx(small.amplitude[ix], rel=1e-5)
    assert along(hard, 200.0) is None  # its cycles lie above 208 km/h


AXLE_REF_HARD = {  # a pilot reference with two hard Hopf points (87.3, 162.5) and folds at 86.0, 170.7 km/h
    "tread.lateral_stiffness_n_per_m": 965394.4553211121, "tread.lateral_damping_ns_per_m": 87.79642949340682,
    "operating.toe_deg": 0.48187108384855165, "operating.camber_deg": -1.0577097871640058,
    "friction.mu_static": 0.9665813721053189, "tread.mass_kg": 0.9782169613078388,
    "operating.vertical_load_n": 3950.3054984982386}
AXLE_FOLD_BELOW_80 = {  # the same topology with the lower fold at 70.6 km/h
    "tread.lateral_stiffness_n_per_m": 991003.4966304799, "tread.lateral_damping_ns_per_m": 72.90838979828666,
    "operating.toe_deg": 0.5495361659428997, "operating.camber_deg": -1.0777398613416667,
    "friction.mu_static": 0.9749383082952126, "tread.mass_kg": 0.9493151060147278,
    "operating.vertical_load_n": 3915.2882037799745}
AXLE_HOPF_BELOW_80 = {  # soft Hopf point at 79.81 km/h (nominal: 79.42)
    "tread.lateral_stiffness_n_per_m": 1076811.378839294, "tread.lateral_damping_ns_per_m": 82.26514728355968,
    "operating.toe_deg": 0.5069694274473808, "operating.camber_deg": -0.975257567225984,
    "friction.mu_static": 0.8839719507882834, "tread.mass_kg": 0.947897842536369,
    "operating.vertical_load_n": 3630.445829352991}


@pytest.mark.slow
def test_cycle_outside_the_references_stable_interval_is_found_along_the_branch():
    """axle4dof, two hard Hopf points (samples of a +-10 % study): the reference's lower fold
    lies at 86.0 km/h, so it has no stable cycle at 80 km/h to start from; the sample's lies at
    70.6 km/h. The cycle at 80 km/h is reached from the sample's fold (6 of 60 samples fell
    back for this before) and is the continuation's."""
    base = with_updates(Params(), {"model": "axle4dof"})
    ref = band_reference(bifurcation(with_updates(base, AXLE_REF_HARD), **_FIXED_RANGE), AMPLITUDE_SPEEDS)
    assert ref.band.hopf_criticality == ("hard", "hard") and not ref.unusable
    assert ref.band.folds_kmh[0] > 80.0 and ref.cycles[0] is None
    solver = FastBand((ref,), amplitude_speeds_kmh=AMPLITUDE_SPEEDS)
    car = with_updates(base, AXLE_FOLD_BELOW_80)
    band = solver(car)
    assert band.path is BandPath.FAST, band.detail
    assert band.folds_kmh[0] < band.hopf_kmh[0] < 80.0 and band.amplitude_x_m[0] > 0.0
    assert_agrees(band, solver.full(car))


@pytest.mark.slow
def test_small_cycle_just_above_a_hopf_point_is_found_either_way():
    """axle4dof: soft Hopf point at 79.81 km/h, 0.19 km/h below the chosen speed (the nominal
    reference's at 79.42), cycle of 2.25e-5 m against the reference's 4.0e-5 m. Newton from
    the nominal cycle converges only at its 8th iteration (the last allowed; with the error
    estimate of ``newton_converged``, before which it failed), so the branch from the
    sample's Hopf point must reach the same cycle too: both are the continuation's."""
    base = with_updates(Params(), {"model": "axle4dof"})
    ref = band_reference(bifurcation(base, **_FIXED_RANGE), AMPLITUDE_SPEEDS)
    solver = FastBand((ref,), amplitude_speeds_kmh=AMPLITUDE_SPEEDS)
    car = with_updates(base, AXLE_HOPF_BELOW_80)
    model, V = get_model("axle4dof"), kmh_to_ms(80.0)
    full = solver.full(car)
    newton = solve_at_speed(model, model.pack(car), ref.cycles[0], V, solver.settings)
    hopf = stability(car, DEFAULT_SPEED_RANGE_KMH).hopf_points[0]
    along = cycle_along_branch(model, model.pack(car), branch_start(hopf), V, solver.settings)
    for point in (newton, along):
        assert point is not None and point.stable
        assert point.orbit.amplitude()[model.index("x")] == pytest.approx(full.amplitude_x_m[0], rel=1e-6)
    band = solver(car)
    assert band.path is BandPath.FAST, band.detail
    assert 79.5 < band.hopf_kmh[0] < 80.0 and band.amplitude_x_m[0] > 0.0
    assert_agrees(band, solver.full(car))


TREAD_KINKED_130 = {  # tread1dof sample 84 of bench_fleet.py agreement --seed 0
    "tread.lateral_stiffness_n_per_m": 916748.0647793558, "tread.lateral_damping_ns_per_m": 77.16885908969309,
    "operating.toe_deg": 0.5427558809465962, "operating.camber_deg": -0.9945235057666965,
    "friction.mu_static": 0.9711853032865766, "tread.mass_kg": 0.991934990655405,
    "operating.vertical_load_n": 4204.094485248102}


def test_amplitude_of_a_kinked_cycle_is_solved_on_its_own_kinks(tread_solver):
    """tread1dof at 130 km/h: the sliding velocity reverses twice per period (kinks of the
    vector field). Solved on the reference's mesh the amplitude came out 1.4e-4 too large
    (kinks inside mesh intervals); on its own kink-aligned mesh it agrees with the
    continuation's and, to 2e-5, with the cycle solved on a 4x finer mesh."""
    base, solver = tread_solver
    car = with_updates(base, TREAD_KINKED_130)
    model, V = get_model("tread1dof"), kmh_to_ms(130.0)
    p = model.pack(car)
    band = solver(car)
    assert band.path is BandPath.FAST, band.detail
    diagram = bifurcation(car, **_FIXED_RANGE)
    (cycle,) = [c for c in diagram.cycles_at(130.0) if c.stable]
    assert switching_times(model, p, cycle.orbit).size == 2
    fine = solve_at_speed(model, p, cycle.orbit.with_mesh(np.linspace(0.0, 1.0, 4 * cycle.orbit.n_intervals + 1)), V)
    assert fine is not None and fine.stable
    assert band.amplitude_x_m[1] == pytest.approx(fine.orbit.amplitude(64)[model.index("x")], rel=2e-5)
    assert_agrees(band, band_from_diagram(diagram, AMPLITUDE_SPEEDS))


def test_a_pilot_records_a_numerical_failure_and_raises_a_programming_error():
    """A pilot whose diagram cannot be computed (ValueError) is no reference, with its reason;
    one that is no parameter set (AttributeError) is a programming error and raises."""
    from polywear.solvers.continuation import ContinuationSettings
    from polywear.studies.fast_band import _PilotReference

    reversed_range = _PilotReference((300.0, 20.0), (), ContinuationSettings())(Params())
    assert reversed_range.startswith("ValueError: speed range 300.0 20.0")
    with pytest.raises(AttributeError):
        _PilotReference((20.0, 300.0), (), ContinuationSettings())(None)
