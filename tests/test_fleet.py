"""Fleet risk: spec validation (one-line errors), distributions and the copula against
scipy and closed forms, exact binomial intervals that cover, risk against the toe law of
tread1dof, paths and fallback reasons counted, failed cars listed with their reasons,
the pilot stage's references serving cars of another Hopf signature, bit-identical
resume, the same numbers on serial, processes and Dask, and on a Dask cluster that loses
a worker in the middle of the run."""

from __future__ import annotations

import json
import math
import os

import numpy as np
import pytest
from scipy import stats

from polywear.dynamics.bifurcation import bifurcation
from polywear.studies.fast_band import _FIXED_RANGE, FastBand, band_reference
from polywear.studies.fleet import (
    CAR_FIELDS,
    OUTPUTS,
    CarOutcome,
    FleetEvaluator,
    FleetResult,
    FleetSpec,
    classifier_importances,
    fleet,
    load_fleet_spec,
    main_effects,
    sample_fleet,
)
from polywear.params import ParameterError, Params, with_updates

from .cli_runner import run_main

TOE_SPEC = """
[fleet]
samples = {samples}
seed = {seed}
checkpoint_every = {every}
speed_range_kmh = [10.0, 600.0]
[[fleet.parameter]]
key = "operating.toe_deg"
distribution = "normal"
mean = 0.5
std = 0.08
[[fleet.usage]]
speed_kmh = 110
share = 0.7
[[fleet.usage]]
speed_kmh = 60
share = 0.3
"""


def _spec(tmp_path, samples=12, seed=3, every=5, text=TOE_SPEC):
    path = tmp_path / "fleet.toml"
    path.write_text(text.format(samples=samples, seed=seed, every=every))
    return load_fleet_spec(path, Params())


@pytest.fixture(scope="module")
def reference():
    """The nominal car's diagram (toe 0.5 deg), shared by the evaluations below."""
    return band_reference(bifurcation(Params(), (10.0, 600.0), **_FIXED_RANGE))


# -- spec validation ---------------------------------------------------------------------------
BAD_SPECS = [
    ("[other]\nx = 1\n", "no [fleet] table"),
    ("[fleet\n", "not valid TOML"),
    ('[fleet]\n[[fleet.parameter]]\nkey = "operating.toe_deg"\ndistribution = "normal"\nmean = 0.3\n'
     '[[fleet.usage]]\nspeed_kmh = 100\nshare = 1\n', "normal needs std"),
    ('[fleet]\n[[fleet.parameter]]\nkey = "operating.nope"\ndistribution = "uniform"\nlow = 0\nhigh = 1\n'
     '[[fleet.usage]]\nspeed_kmh = 100\nshare = 1\n', "unknown key operating.nope"),
    ('[fleet]\n[[fleet.parameter]]\nkey = "operating.toe_deg"\ndistribution = "gamma"\n'
     '[[fleet.usage]]\nspeed_kmh = 100\nshare = 1\n', "fleet.parameter.0.distribution"),
    ('[fleet]\n[[fleet.parameter]]\nkey = "operating.toe_deg"\ndistribution = "uniform"\nlow = 0.2\nhigh = 0.4\n'
     '[[fleet.usage]]\nspeed_kmh = 100\nshare = 0\n', "fleet.usage.0.share: Input should be greater than 0"),
    ('[fleet]\n[[fleet.parameter]]\nkey = "operating.toe_deg"\ndistribution = "uniform"\nlow = 0.2\nhigh = 0.4\n'
     '[[fleet.usage]]\nspeed_kmh = 100\nshare = 0.9\n[[fleet.usage]]\nspeed_kmh = 120\nshare = 0.4\n',
     "fleet.usage: shares sum to 1.3: must sum to 1 (within 0.01)"),
    ('[fleet]\n[[fleet.parameter]]\nkey = "operating.vertical_load_n"\ndistribution = "discrete"\n'
     'values = [100000, 200000]\nweights = [1, 1]\n[[fleet.usage]]\nspeed_kmh = 100\nshare = 1\n',
     "fleet.parameter operating.vertical_load_n: discrete value 100000 is not valid for the model"),
    ('[fleet]\n[[fleet.parameter]]\nkey = "operating.vertical_load_n"\ndistribution = "normal"\nmean = -4000\n'
     'std = 100\n[[fleet.usage]]\nspeed_kmh = 100\nshare = 1\n',
     "fleet.parameter operating.vertical_load_n: normal centre -4000 is not valid for the model"),
    ('[fleet]\n[[fleet.parameter]]\nkey = "operating.toe_deg"\ndistribution = "uniform"\nlow = 0.2\nhigh = 0.4\n'
     '[[fleet.parameter]]\nkey = "operating.camber_deg"\ndistribution = "normal"\nmean = -1\nstd = 0.2\n'
     '[fleet.correlation]\nkeys = ["operating.toe_deg", "operating.camber_deg"]\nmatrix = [[1, 1.2], [1.2, 1]]\n'
     '[[fleet.usage]]\nspeed_kmh = 100\nshare = 1\n', "fleet.correlation"),
    ('[fleet]\n[[fleet.parameter]]\nkey = "operating.vertical_load_n"\ndistribution = "discrete"\n'
     'values = [3000, 4000]\nweights = [1]\n[[fleet.usage]]\nspeed_kmh = 100\nshare = 1\n', "as many weights"),
]


@pytest.mark.parametrize("text, fragment", BAD_SPECS)
def test_bad_specs_are_one_line_errors(tmp_path, text, fragment):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    code, out, err = run_main(["fleet", "--spec", str(path), "--backend", "serial", "-q"])
    assert code == 2 and out == ""
    assert fragment in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err, err


# -- sampling ------------------------------------------------------------------------------------
MARGINALS = [
    {"key": "tread.mass_kg", "distribution": "normal", "mean": 0.1, "std": 0.01},
    {"key": "operating.toe_deg", "distribution": "truncnormal", "mean": 0.3, "std": 0.1, "low": 0.2, "high": 0.5},
    {"key": "operating.vertical_load_n", "distribution": "lognormal", "mean": 4000.0, "std": 600.0},
    {"key": "tread.lateral_damping_ns_per_m", "distribution": "uniform", "low": 60.0, "high": 100.0},
    {"key": "friction.mu_static", "distribution": "discrete", "values": [0.6, 0.8, 1.0], "weights": [1, 2, 1]},
]


def _frozen(q):
    if q["distribution"] == "normal":
        return stats.norm(q["mean"], q["std"])
    if q["distribution"] == "truncnormal":
        a, b = (q["low"] - q["mean"]) / q["std"], (q["high"] - q["mean"]) / q["std"]
        return stats.truncnorm(a, b, loc=q["mean"], scale=q["std"])
    if q["distribution"] == "lognormal":
        s2 = math.log1p((q["std"] / q["mean"]) ** 2)
        return stats.lognorm(math.sqrt(s2), scale=q["mean"] * math.exp(-0.5 * s2))
    return stats.uniform(q["low"], q["high"] - q["low"])


def test_marginals_follow_their_distributions():
    rho = 0.6
    spec = FleetSpec(samples=20000, seed=11, parameter=MARGINALS, usage=[{"speed_kmh": 100.0, "share": 1.0}],
                     correlation={"keys": ["tread.mass_kg", "operating.toe_deg"], "matrix": [[1, rho], [rho, 1]]})
    X = sample_fleet(spec)
    for j, q in enumerate(MARGINALS[:4]):
        assert stats.kstest(X[:, j], _frozen(q).cdf).pvalue > 1e-3, q["key"]
    lognormal = X[:, 2]
    assert abs(lognormal.mean() - 4000.0) < 4 * 600.0 / math.sqrt(len(lognormal))
    truncated = X[:, 1]
    assert truncated.min() >= 0.2 and truncated.max() <= 0.5
    counts = np.array([np.sum(X[:, 4] == v) for v in (0.6, 0.8, 1.0)])
    assert counts.sum() == len(X)
    assert stats.chisquare(counts, len(X) * np.array([0.25, 0.5, 0.25])).pvalue > 1e-3
    # Gaussian copula: Spearman's rho of the pair is (6 / pi) asin(rho / 2) whatever the marginals
    expected = 6.0 / math.pi * math.asin(rho / 2.0)
    assert abs(stats.spearmanr(X[:, 0], X[:, 1]).statistic - expected) < 0.02
    # uncorrelated pairs stay uncorrelated
    assert abs(stats.spearmanr(X[:, 2], X[:, 3]).statistic) < 0.03
    # a seed gives the same samples; another seed others
    np.testing.assert_array_equal(X, sample_fleet(spec))
    assert not np.array_equal(X, sample_fleet(spec.model_copy(update={"seed": 12})))


def test_clopper_pearson_intervals_cover():
    """Exact binomial intervals of the risk cover the true probability at least 95 % of the time."""
    spec = FleetSpec(samples=60, parameter=MARGINALS[:1], usage=[{"speed_kmh": 100.0, "share": 1.0}])
    rng = np.random.default_rng(5)
    p_true, covered, trials = 0.17, 0, 150
    for _ in range(trials):
        values = np.zeros((60, len(OUTPUTS)))
        values[:, 2] = rng.random(60) < p_true
        result = FleetResult(Params(), spec, np.zeros((60, 1)), values, [CarOutcome(path="fast")] * 60)
        _, _, lo, hi = result.risk_ci()
        covered += lo <= p_true <= hi
    assert covered / trials >= 0.95 - 3 * math.sqrt(0.05 * 0.95 / trials)


def test_main_effects_find_the_driver():
    rng = np.random.default_rng(2)
    X = rng.random((4000, 3))
    y = (X[:, 1] > 0.7).astype(float)  # only the second column matters: Var(E[y|x2]) / Var(y) = 1
    effects = main_effects(X, y)
    assert effects[1] > 0.95 and max(effects[0], effects[2]) < 0.02


# -- evaluation ----------------------------------------------------------------------------------
@pytest.mark.slow
def test_risk_matches_the_toe_law(tmp_path, reference):
    """tread1dof: every speed scales as 1/sin(toe), so the cars at risk are those with toe in a
    closed-form interval; the exact interval of the sampled risk must cover that probability."""
    spec = _spec(tmp_path, samples=40, seed=4, every=40)
    result = fleet(Params(), spec, backend="serial", reference=reference)
    s = result.summary()
    assert s["failed_samples"] == 0 and s["failed_cars"] == [] and s["fallback_reasons"] == {}
    assert s["paths"] == {"hopf": 0, "fast": 39, "full": 0, "pilot": 1}  # car 0: the pilot stage's (1 per 32)
    assert result.paths == ["pilot"] + ["fast"] * 39
    band = reference.band
    v1, v2 = band.first_bifurcation_speed_kmh, band.second_bifurcation_speed_kmh
    s0 = math.sin(math.radians(0.5))
    toe = stats.norm(0.5, 0.08)

    def p_in_band(v):  # V1(toe) <= v <= V2(toe)  <=>  s0 v1 / v <= sin(toe) <= s0 v2 / v
        lo = math.degrees(math.asin(s0 * v1 / v))
        hi = math.degrees(math.asin(min(s0 * v2 / v, 1.0)))
        return lo, hi

    (a1, b1), (a2, b2) = p_in_band(110.0), p_in_band(60.0)
    lo, hi = min(a1, a2), max(b1, b2)  # the two toe intervals overlap for these speeds
    assert max(a1, a2) <= min(b1, b2)
    expected = toe.cdf(hi) - toe.cdf(lo)
    k, n, ci_lo, ci_hi = result.risk_ci()
    assert ci_lo <= expected <= ci_hi, (k, n, expected)
    # each car individually: at risk exactly when its toe lies in [lo, hi]
    np.testing.assert_array_equal(result.values[:, 2] == 1.0, (result.samples[:, 0] >= lo) & (result.samples[:, 0] <= hi))


@pytest.mark.slow
def test_band_every_keeps_risk_exact(tmp_path, reference):
    """band_every = 3: risk, hard excitation and the first speed of every car as with whole
    bands; both speeds for cars 0, 3, 6; the second speed left out for the others."""
    whole = fleet(Params(), _spec(tmp_path, samples=9, every=9), backend="serial", reference=reference)
    text = TOE_SPEC.replace("[[fleet.parameter]]", "band_every = 3\n[[fleet.parameter]]", 1)
    lazy = fleet(Params(), _spec(tmp_path, samples=9, every=9, text=text), backend="serial", reference=reference)
    np.testing.assert_array_equal(whole.values[:, 2:4], lazy.values[:, 2:4])
    np.testing.assert_allclose(whole.values[:, 0], lazy.values[:, 0], rtol=1e-12)
    np.testing.assert_array_equal(whole.values[::3, :2], lazy.values[::3, :2])
    assert np.all(np.isnan(np.delete(lazy.values[:, 1], [0, 3, 6])))


@pytest.mark.slow
def test_resume_is_bit_identical(tmp_path, reference):
    """40 cars (car 0 the pilot car), checkpoints every 16: interrupted after 32, resumed
    (the pilot stage solved again) to the same numbers, statuses and paths. A checkpoint of
    another spec, of an older polywear (no pilot stage) or with other pilot cars is refused."""
    text = TOE_SPEC.replace("[[fleet.parameter]]", "band_every = 2\n[[fleet.parameter]]", 1)
    spec = _spec(tmp_path, samples=40, every=16, text=text)
    whole = fleet(Params(), spec, backend="serial", reference=reference)
    assert whole.paths[0] == "pilot" and whole.summary()["paths"]["pilot"] == 1

    def interrupt(done, total, message=""):  # after the second chunk is computed, before its checkpoint is written
        if done >= 32:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        fleet(Params(), spec, backend="serial", reference=reference, checkpoint_dir=tmp_path,
              progress=interrupt, batch_size=4)
    ckpt = tmp_path / "fleet_checkpoint.npz"
    assert int(np.load(ckpt)["done"]) == 16
    np.testing.assert_array_equal(np.load(ckpt)["pilot"], [0])
    resumed = fleet(Params(), spec, backend="serial", reference=reference, checkpoint_dir=tmp_path,
                    resume=True)
    np.testing.assert_array_equal(whole.values, resumed.values)
    assert whole.status == resumed.status and whole.paths == resumed.paths
    other = _spec(tmp_path, samples=40, every=16, seed=99, text=text)
    with pytest.raises(ParameterError, match="checkpoint of another"):
        fleet(Params(), other, backend="serial", reference=reference, checkpoint_dir=tmp_path, resume=True)
    with pytest.raises(ParameterError, match="other pilot cars"):  # written with the pilot stage, resumed without
        fleet(Params(), spec, backend="serial", reference=reference, checkpoint_dir=tmp_path, resume=True,
              pilot=False)
    data = dict(np.load(ckpt))
    np.savez(ckpt, **{name: value for name, value in data.items() if name != "pilot"})
    with pytest.raises(ParameterError, match="older polywear [(]no pilot stage[)]"):
        fleet(Params(), spec, backend="serial", reference=reference, checkpoint_dir=tmp_path, resume=True)
    np.savez(ckpt, **(data | {"values": data["values"][:, :6]}))  # before the gap output
    with pytest.raises(ParameterError, match="older polywear [(]other outputs per car[)]"):
        fleet(Params(), spec, backend="serial", reference=reference, checkpoint_dir=tmp_path, resume=True)


@pytest.mark.slow
def test_same_numbers_on_serial_processes_and_dask(tmp_path, reference):
    from distributed import LocalCluster

    text = TOE_SPEC.replace("[[fleet.parameter]]", "band_every = 4\n[[fleet.parameter]]", 1)
    spec = _spec(tmp_path, samples=32, every=32, text=text)  # car 0: the pilot car, solved on each backend
    serial = fleet(Params(), spec, backend="serial", reference=reference)
    assert serial.paths[0] == "pilot"
    processes = fleet(Params(), spec, backend="processes", workers=2, reference=reference)
    np.testing.assert_array_equal(serial.values, processes.values)
    environ = dict(os.environ)  # the nannies write their workers' OMP/OPENBLAS_NUM_THREADS=1 etc. into ours
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, host="127.0.0.1", dashboard_address=None,
                           processes=True)
    try:
        dask = fleet(Params(), spec, backend="dask", scheduler=cluster.scheduler_address, reference=reference,
                     batch_size=1)
    finally:
        cluster.close()
        os.environ.clear()
        os.environ.update(environ)
    np.testing.assert_array_equal(serial.values, dask.values)
    assert serial.status == processes.status == dask.status
    assert serial.paths == processes.paths == dask.paths


@pytest.mark.slow
def test_cli_json_summary(tmp_path):
    path = tmp_path / "fleet.toml"
    path.write_text(TOE_SPEC.format(samples=3, seed=1, every=3))
    code, out, err = run_main(["fleet", "--spec", str(path), "--backend", "serial", "--json", "-q",
                               "--out", str(tmp_path / "fleet.nc")])
    assert code == 0, err
    import json

    s = json.loads(out)
    assert s["n_samples"] == 3 and s["failed_samples"] == 0 and s["failures"] == {} and s["failed_cars"] == []
    assert 0.0 <= s["risk_ci"][0] <= s["risk_probability"] <= s["risk_ci"][1] <= 1.0
    assert sum(s["paths"].values()) == 3 and set(s["paths"]) == {"hopf", "fast", "full", "pilot"}
    assert s["fallback_reasons"] == {}
    assert (tmp_path / "fleet.nc").exists()


@pytest.mark.slow
def test_cli_resume_is_bit_identical(tmp_path):
    """`--checkpoint` then `--resume` from a checkpoint cut back to its first round (as an
    interruption leaves it): the same summary and the same cars as the uninterrupted run."""
    path = tmp_path / "fleet.toml"
    path.write_text(TOE_SPEC.format(samples=4, seed=6, every=2))
    ckpt = tmp_path / "ckpt"
    ckpt.mkdir()
    args = ["fleet", "--spec", str(path), "--backend", "serial", "--json", "-q", "--checkpoint", str(ckpt)]
    code, whole, err = run_main(args + ["--out", str(tmp_path / "whole.csv")])
    assert code == 0, err
    data = dict(np.load(ckpt / "fleet_checkpoint.npz"))
    assert int(data["done"]) == 4
    data["values"][2:] = np.nan
    np.savez(ckpt / "fleet_checkpoint.npz", **(data | {"done": 2} | {name: data[name][:2] for name in CAR_FIELDS}))
    code, resumed, err = run_main(args + ["--resume", "--out", str(tmp_path / "resumed.csv")])
    assert code == 0, err
    assert resumed == whole
    assert (tmp_path / "resumed.csv").read_text() == (tmp_path / "whole.csv").read_text()
    code, _, err = run_main(["fleet", "--spec", str(path), "--resume", "-q"])
    assert code == 2 and "--resume needs --checkpoint" in err


def test_paths_and_fallback_reasons_are_counted():
    """Summary: cars per path over the evaluated cars, fallbacks by reason tag, failed cars
    counted by kind and listed (index and whole reason)."""
    spec = FleetSpec(samples=8, parameter=MARGINALS[:1], usage=[{"speed_kmh": 100.0, "share": 1.0}])
    outcomes = [CarOutcome(path="pilot"), CarOutcome(path="hopf"), CarOutcome(path="fast"),
                CarOutcome(path="full", fallback="fold_out_of_range", fallback_detail="fold 1 at 612.3 km/h, outside the speed range"),
                CarOutcome(path="full", fallback="fold_out_of_range", fallback_detail="fold 1 at 640.0 km/h, outside the speed range"),
                CarOutcome(path="full", fallback="hopf_signature", fallback_detail="('soft',) vs ('soft', 'hard')"),
                CarOutcome(failure="ValueError", detail="tread.mass_kg must be > 0"),
                CarOutcome(failure="ValueError", detail="other")]
    result = FleetResult(Params(), spec, np.zeros((8, 1)), np.zeros((8, len(OUTPUTS))), outcomes)
    status = ["ok"] * 6 + ["failed: ValueError: tread.mass_kg must be > 0", "failed: ValueError: other"]
    assert result.status == status  # the texts of the files, composed from the fields
    assert result.paths == ["pilot", "hopf", "fast",
                            "full: fold_out_of_range: fold 1 at 612.3 km/h, outside the speed range",
                            "full: fold_out_of_range: fold 1 at 640.0 km/h, outside the speed range",
                            "full: hopf_signature: ('soft',) vs ('soft', 'hard')", "", ""]
    s = result.summary()
    assert s["paths"] == {"hopf": 1, "fast": 1, "full": 3, "pilot": 1}
    assert s["fallback_reasons"] == {"fold_out_of_range": 2, "hopf_signature": 1}
    assert s["failed_samples"] == 2 and s["failures"] == {"ValueError": 2}
    assert s["failed_cars"] == [{"car": 6, "reason": status[6]}, {"car": 7, "reason": status[7]}]


FAST_AND_FULL = """
[fleet]
samples = {samples}
seed = {seed}
checkpoint_every = {every}
speed_range_kmh = [10.0, 260.0]
[[fleet.parameter]]
key = "operating.toe_deg"
distribution = "normal"
mean = 0.5
std = 0.08
[[fleet.parameter]]
key = "axle.inertia_x_kgm2"
distribution = "normal"
mean = 2.0
std = 1.5
[[fleet.usage]]
speed_kmh = 110
share = 1.0
"""


@pytest.mark.slow
def test_fallbacks_and_failures_per_car(tmp_path):
    """tread1dof on 10-260 km/h: the nominal fold is at 254.7 km/h and scales as 1/sin(toe),
    so the cars whose sin(toe) is below sin(0.5 deg) 254.7/260 have it above the range:
    fallback "fold_out_of_range" for those, fast path for the others. The axle inertia does
    not enter tread1dof; a car whose sampled inertia is not positive fails with its reason."""
    spec = _spec(tmp_path, samples=6, seed=2, every=6, text=FAST_AND_FULL)
    X = sample_fleet(spec)
    toe, inertia = X[:, 0], X[:, 1]
    ok = inertia > 0.0
    assert not np.all(ok) and np.any(ok & (toe < 0.48)) and np.any(ok & (toe > 0.5))
    path = tmp_path / "fleet.toml"
    code, out, err = run_main(["fleet", "--spec", str(path), "--backend", "serial", "--json", "-q",
                               "--out", str(tmp_path / "fleet.csv")])
    assert code == 0, err
    import json

    import pandas as pd

    s = json.loads(out)
    nominal = bifurcation(Params(), (10.0, 260.0), **_FIXED_RANGE).folds[0].speed_kmh
    outside = np.sin(np.radians(toe)) < math.sin(math.radians(0.5)) * nominal / 260.0
    failed = np.flatnonzero(~ok)
    assert s["failed_samples"] == len(failed) and [c["car"] for c in s["failed_cars"]] == failed.tolist()
    assert all("inertia_x_kgm2" in c["reason"] for c in s["failed_cars"])
    assert s["paths"] == {"hopf": 0, "fast": int(np.sum(ok & ~outside)), "full": int(np.sum(ok & outside)), "pilot": 0}
    assert s["fallback_reasons"] == {"fold_out_of_range": int(np.sum(ok & outside))}
    table = pd.read_csv(tmp_path / "fleet.csv", keep_default_na=False)
    assert [p.split(": ")[0] for p in table["path"]] == ["" if not o else "full" if x else "fast"
                                                          for o, x in zip(ok, outside)]


@pytest.mark.slow
def test_a_pilot_car_serves_its_hopf_signature():
    """axle4dof: mu_s 0.9 (3 of 4 cars; the nominal car's 0.911 too) gives soft and hard
    Hopf points, 0.945 two hard ones (a Bautin point crossed). Seed 6 makes car 0, the pilot
    car of 32, one of 0.945: it keeps its full diagram (path "pilot", the numbers the full
    path gives it), and the other cars of its Hopf signature start from it: cars 8 and 16
    (whole bands, band_every = 8) take the fast path, where the nominal reference alone has
    none of their signature (every such car fell back with hopf_signature)."""
    from polywear.studies.sampling import sample_params
    from polywear.dynamics.stability import stability

    base = with_updates(Params(), {"model": "axle4dof"})
    spec = FleetSpec(samples=32, seed=6, band_every=8, speed_range_kmh=(10.0, 600.0), usage=[
        {"speed_kmh": 110.0, "share": 1.0}], parameter=[
        {"key": "friction.mu_static", "distribution": "discrete", "values": [0.9, 0.945], "weights": [3, 1]},
        {"key": "operating.toe_deg", "distribution": "normal", "mean": 0.5, "std": 0.01}])
    keys = [q.key for q in spec.parameter]
    X = sample_fleet(spec)
    assert X[0, 0] == X[8, 0] == X[16, 0] == 0.945 and X[24, 0] == 0.9

    def signature(values):
        return tuple(h.criticality for h in stability(sample_params(base, keys, values), (10.0, 600.0)).hopf_points)

    assert signature([q.center for q in spec.parameter]) == ("soft", "hard")
    assert signature(X[0]) == signature(X[8]) == signature(X[16]) == ("hard", "hard")
    calls = []
    result = fleet(base, spec, backend="serial", progress=lambda *call: calls.append(call))
    # the pilot stage (nominal car and car 0) reports first, in its messages, at 0 cars done of 32
    pilot = [c for c in calls if c[2].startswith("pilot")]
    assert pilot == calls[:len(pilot)] and pilot[-1] == (0, 32, "pilot: 2 of 2 references by full continuation")
    assert calls[-1][:2] == (32, 32) and all(a[0] <= b[0] for a, b in zip(calls, calls[1:]))
    s = result.summary()
    assert result.settings["pilot_cars"] == 1 and s["failed_samples"] == 0
    assert result.paths[0] == "pilot" and s["paths"]["pilot"] == 1
    assert result.paths[8] == result.paths[16] == "fast" and result.paths[24] in ("fast", "hopf")
    assert "hopf_signature" not in s["fallback_reasons"]
    alone = FleetEvaluator(base, tuple(keys), FastBand((), speed_range_kmh=(10.0, 600.0)), (110.0,), band_every=8)
    values, outcome = alone((0, X[0]))  # no reference at all: the full path
    assert outcome.path == "full" and outcome.fallback == "no_reference"
    np.testing.assert_array_equal(values, result.values[0])


@pytest.mark.slow
def test_dask_fleet_survives_a_killed_worker(tmp_path, reference):
    """300 cars in 30 tasks on a scheduler and two workers (subprocesses on 127.0.0.1); one
    worker is killed (SIGKILL) when the first task is back: its running and held tasks are
    recomputed on the other, and every car's numbers, status and path are the serial run's
    (the 9 pilot cars are solved first, on both workers)."""
    from .test_parallel import DASK, Cluster

    if not DASK.exists():
        pytest.fail(f"{DASK} missing: dask[distributed] is a dependency")
    text = TOE_SPEC.replace("[[fleet.parameter]]", "band_every = 100\n[[fleet.parameter]]", 1)
    spec = _spec(tmp_path, samples=300, seed=21, every=300, text=text)
    serial = fleet(Params(), spec, backend="serial", reference=reference)
    cluster = Cluster(2, tmp_path)
    try:
        victim, done = cluster.workers[1], []

        def kill_after_first_task(n, total, message=""):
            if message.startswith("pilot"):  # the pilot stage, before the cars
                return
            done.append(n)
            if len(done) == 1:
                victim.kill()
                victim.wait(10)

        dask = fleet(Params(), spec, backend="dask", scheduler=cluster.address, batch_size=10,
                     reference=reference, progress=kill_after_first_task)
        assert victim.poll() is not None and done[0] < 300 and done[-1] == 300 and len(done) == 30
        assert cluster.n_workers() == 1
    finally:
        cluster.stop()
    np.testing.assert_array_equal(serial.values, dask.values)
    assert serial.status == dask.status and serial.paths == dask.paths
    assert serial.summary()["paths"]["hopf"] > 0  # the cheap path of band_every is exercised too


@pytest.mark.parametrize("model", ["tread1dof", "axle4dof"])
def test_stacked_eigenvalues_are_those_of_one_call_each(model):
    """The fleet's Hopf grid stacks the Jacobians into one LAPACK call; the eigenvalues are
    bit for bit those of one call per speed (so the fleet's numbers did not change)."""
    from polywear.dynamics.stability import equilibrium_eigenvalues
    from polywear.models import get_model
    from polywear.params import with_updates

    m = get_model(model)
    p = m.pack(with_updates(Params(), {"model": model}))
    speeds = np.linspace(2.0, 160.0, 37)
    states, eig = equilibrium_eigenvalues(m, p, speeds)
    for V, u, lam in zip(speeds, states, eig):
        np.testing.assert_array_equal(u, m.equilibrium(V, p))
        np.testing.assert_array_equal(lam, np.linalg.eigvals(m.jacobian(u, V, p)).astype(complex))


@pytest.mark.slow
def test_a_usage_speed_in_a_gap_after_a_period_doubling_is_counted():
    """The cascade car of tests/test_verdict.py (four Hopf points, a gap of its band from the
    period doubling at 56.55 to the Hopf point at 59.75 km/h, where a simulation reaches
    chaotic SEV): at a usage speed of 58 km/h it is not at risk by its band, but counted in
    ``gap_after_pd_ns_share``, and with ``simulate_gaps`` the simulation reaches SEV there
    (``gap_sev_share``); at 57 km/h (in the gap, back to rest) counted but not SEV; at
    100 km/h (inside the band) at risk and not counted."""
    from polywear.studies.fast_band import FastBand, band_reference
    from polywear.studies.global_sensitivity import DEFAULT_KEYS

    from .test_verdict import CASCADE_AXLE

    base = with_updates(Params(), {"model": "axle4dof"})
    nominal = band_reference(bifurcation(base, (10.0, 600.0), extend=False))
    solver = FastBand((nominal,), speed_range_kmh=(10.0, 600.0))
    values = [CASCADE_AXLE[k] for k in DEFAULT_KEYS]
    spec = FleetSpec(samples=3, parameter=MARGINALS[:1], usage=[{"speed_kmh": 58.0, "share": 1.0}])
    rows, outcomes = [], []
    for i, usage in enumerate(((58.0,), (100.0,), (57.0,))):
        out, outcome = FleetEvaluator(base, tuple(DEFAULT_KEYS), solver, usage, simulate_gaps=True)((i, values))
        assert outcome.path == "full" and outcome.fallback == "hopf_signature"
        rows.append(out)
        outcomes.append(outcome)
    (gap_lo, gap_hi), = [g for g in solver(with_updates(base, CASCADE_AXLE)).gaps_after_pd_ns_kmh if g[0] < 58.0 < g[1]]
    assert gap_lo == pytest.approx(56.55, abs=0.01) and gap_hi == pytest.approx(59.75, abs=0.01)
    at_risk, gap, sev = (OUTPUTS.index(k) for k in ("at_risk", "usage_in_gap_after_pd_ns", "gap_sev_by_simulation"))
    # 58 km/h: chaotic SEV from the window's cycle; 57 km/h: both starts return to rest
    assert [(r[at_risk], r[gap], r[sev]) for r in rows] == [(0.0, 1.0, 1.0), (1.0, 0.0, pytest.approx(np.nan, nan_ok=True)),
                                                            (0.0, 1.0, 0.0)]
    s = FleetResult(base, spec, np.zeros((3, 1)), np.array(rows), outcomes).summary()
    assert s["gap_after_pd_ns_share"] == 2 / 3 and s["gap_after_pd_ns_ci"][0] < 2 / 3 < s["gap_after_pd_ns_ci"][1]
    assert s["gap_sev_share"] is None  # the spec did not ask for the simulations
    spec = spec.model_copy(update={"simulate_gaps": True})
    s = FleetResult(base, spec, np.zeros((3, 1)), np.array(rows), outcomes).summary()
    assert s["gap_sev_share"] == 1 / 3 and s["gap_sev_ci"][0] < 1 / 3 < s["gap_sev_ci"][1]


def test_classifier_importances_see_what_main_effects_miss():
    """Risk where exactly one of two parameters is high (an interaction, XOR): neither has a
    main effect (E[y | x_i] = 1/2 in every bin: closed form), the third parameter none at
    all. The classifier's permutation importances credit both and not the third; the
    classifier separates the held-out cars (AUC near 1) and is deterministic for a seed."""
    rng = np.random.default_rng(7)
    X = rng.random((3000, 3))
    y = ((X[:, 0] > 0.5) ^ (X[:, 1] > 0.5)).astype(float)
    assert np.all(main_effects(X, y) < 0.01)
    out = classifier_importances(X, y, seed=1)
    assert out["auc"] > 0.98 and out["n_fit"] + out["n_test"] == 3000
    assert out["importance"][0] > 0.3 and out["importance"][1] > 0.3 and abs(out["importance"][2]) < 0.02
    np.testing.assert_array_equal(classifier_importances(X, y, seed=1)["importance"], out["importance"])
    assert classifier_importances(X, (X[:, 0] > 0.995).astype(float), seed=1) is None  # 15 cars at risk: too few

    spec = FleetSpec(samples=3000, seed=1, parameter=MARGINALS[:3], usage=[{"speed_kmh": 100.0, "share": 1.0}])
    values = np.zeros((3000, len(OUTPUTS)))
    values[:, OUTPUTS.index("at_risk")] = y
    result = FleetResult(Params(), spec, X, values, [CarOutcome(path="fast")] * 3000)
    s = result.summary()
    np.testing.assert_array_equal(list(s["drivers_importance"].values()), out["importance"])
    assert s["drivers_classifier"]["held_out_auc"] == out["auc"]
    main, importance = result.plot_drivers()  # two sets of bars, one bar per parameter
    assert len(main) == len(importance) == 3 and importance[0].get_width() > 0.3
    assert len(result.figure().axes) == 3


def test_a_car_records_a_numerical_failure_and_raises_a_programming_error():
    """A car whose band cannot be computed (ValueError of the speed range) fails with its
    reason, whether the Hopf points or the whole band are asked for; a solver that is no
    FastBand (AttributeError) is a programming error and raises."""
    solver = FastBand((), speed_range_kmh=(20.0, np.nan))
    for every in (1, 2):  # car 1: the whole band, then the Hopf verdict
        out, outcome = FleetEvaluator(Params(), ("operating.toe_deg",), solver, (100.0,), band_every=every)((1, [0.5]))
        assert np.all(np.isnan(out)) and outcome.failure == "ValueError" and "speed range" in outcome.detail
    with pytest.raises(AttributeError):
        FleetEvaluator(Params(), ("operating.toe_deg",), object(), (100.0,), band_every=2)((1, [0.5]))


def test_a_fleet_takes_an_executor_or_the_separate_options(tmp_path, reference):
    """The same cars with the same numbers from an Executor as from backend/batch_size; both at once is refused."""
    from polywear.parallel import Executor

    spec = _spec(tmp_path, samples=6, every=6)
    keywords = fleet(Params(), spec, backend="serial", batch_size=2, reference=reference)
    executed = fleet(Params(), spec, executor=Executor("serial", batch_size=4), reference=reference)
    np.testing.assert_array_equal(keywords.values, executed.values)
    assert keywords.outcomes == executed.outcomes and executed.settings["backend"] == "serial"
    with pytest.raises(ValueError, match="not both"):
        fleet(Params(), spec, workers=2, executor=Executor("serial"), reference=reference)


FLEET_SPEC = ('[fleet]\nsamples = 10000\n[[fleet.parameter]]\nkey = "operating.toe_deg"\ndistribution = "uniform"\n'
              'low = 0.2\nhigh = 0.4\n[[fleet.usage]]\nspeed_kmh = 100\nshare = 1\n')


def test_set_changes_the_spec_settings_as_study_does(tmp_path):
    path = tmp_path / "spec.toml"
    path.write_text(FLEET_SPEC)
    spec = load_fleet_spec(path, Params(), ["fleet.samples=3", "fleet.seed=7"])
    assert (spec.samples, spec.seed) == (3, 7)
    assert load_fleet_spec(path, Params()).samples == 10000
    for bad, fragment in (("fleet.samples=0", "fleet.samples"), ("fleet.parameter=1", "not a fleet setting"),
                          ("fleet.nope=1", "not a fleet setting")):
        code, out, err = run_main(["fleet", "--spec", str(path), "--set", bad, "--backend", "serial", "-q"])
        assert code == 2 and out == "" and fragment in err and len(err.strip().splitlines()) == 1, err
    code, out, err = run_main(["fleet", "--spec", str(path), "--set", "fleet.samples=2", "--set", "operating.speed_kmh=100",
                               "--backend", "serial", "-q", "--json"])
    assert code == 0, err
    assert json.loads(out)["n_samples"] == 2


@pytest.mark.parametrize("make, args, fragment", [
    (lambda d: None, ["--checkpoint", "missing"], "no such folder"),
    (lambda d: (d / "a_file").write_text("x"), ["--checkpoint", "a_file"], "a file, not a folder"),
    (lambda d: (d / "empty").mkdir(), ["--checkpoint", "empty", "--resume"], "--resume: no checkpoint in"),
])
def test_checkpoint_folder_messages(tmp_path, make, args, fragment):
    path = tmp_path / "spec.toml"
    path.write_text(FLEET_SPEC)
    make(tmp_path)
    args = [str(tmp_path / a) if not a.startswith("-") else a for a in args]
    code, out, err = run_main(["fleet", "--spec", str(path), *args, "--backend", "serial", "-q"])
    assert code == 2 and out == "" and fragment in err and len(err.strip().splitlines()) == 1, err


def test_a_derived_key_passes_the_value_check(tmp_path):
    """adhesion_scale is no field of the parameters but a key of the fleet: its values are checked as a factor."""
    path = tmp_path / "spec.toml"
    path.write_text(FLEET_SPEC.replace('key = "operating.toe_deg"\ndistribution = "uniform"\nlow = 0.2\nhigh = 0.4',
                                       'key = "adhesion_scale"\ndistribution = "discrete"\nvalues = [0.9, 1.1]\n'
                                       'weights = [1, 1]'))
    assert load_fleet_spec(path, Params()).parameter[0].key == "adhesion_scale"
    path.write_text(path.read_text().replace("values = [0.9, 1.1]", "values = [0.9, 10.0]"))
    with pytest.raises(ParameterError, match="discrete value 10 is not valid for the model"):
        load_fleet_spec(path, Params())
