"""Fast band path and fleet risk: agreement with the full continuation, per-sample costs,
Sobol and fleet extrapolations, Dask 1 -> 2 workers, cost growth (nothing is asserted).

    .venv/bin/python benchmarks/bench_fleet.py agreement --model axle4dof --samples 200 --pilot 32
    .venv/bin/python benchmarks/bench_fleet.py agreement --model axle4dof --samples 40 --amplitude-speeds
    .venv/bin/python benchmarks/bench_fleet.py sobol --samples 16
    .venv/bin/python benchmarks/bench_fleet.py sobol --samples 64 --mode fast --spread 0.05
    .venv/bin/python benchmarks/bench_fleet.py fleet --samples 400
    .venv/bin/python benchmarks/bench_fleet.py fleet --samples 100000 --backend processes
    .venv/bin/python benchmarks/bench_fleet.py fleet --model axle4dof --samples 3000 --backend serial
    .venv/bin/python benchmarks/bench_fleet.py pilot --model axle4dof --samples 300
    .venv/bin/python benchmarks/bench_fleet.py pilot --model axle4dof --samples 300 --band-every 100
    .venv/bin/python benchmarks/bench_fleet.py dask --samples 200
    .venv/bin/python benchmarks/bench_fleet.py dask-sobol --samples 8 [--model axle4dof]
    .venv/bin/python benchmarks/bench_fleet.py growth
    .venv/bin/python benchmarks/bench_fleet.py edges --samples 200 [--seed 7] [--workers 2]
    .venv/bin/python benchmarks/bench_fleet.py windows --samples 10 [--seed 7] [--workers 2]
    .venv/bin/python benchmarks/bench_fleet.py top-fold --samples 50 [--seed 7] [--workers 2]
    .venv/bin/python benchmarks/bench_fleet.py gap-fold --samples 60 --seed 7 [--workers 1] [--no-full]

``agreement`` draws the paper's seven parameters uniformly within +-10 % of the model's
defaults (the default study ranges), evaluates every sample by the fast path and by the
full continuation, and prints every disagreement (band edges beyond 1e-6 relative, or a
different number of Hopf points, folds or bands); it also gives the per-sample costs of
both paths, measured on the same samples in the same run.

``edges`` draws axle4dof cars the same way, keeps the first ``--samples`` with four Hopf
points, and compares the edges-only continuation (:mod:`polywear.studies.edges`) with the
full one on each: every end of the SEV band, hard regions and gaps after PD/NS points
within 1e-6 km/h, the same failed branches; CPU of both per car. ``windows`` takes the
first ``--samples`` such cars whose first or second bifurcation speed is the fold of a
window (:func:`polywear.studies.edges.window_edges_kmh`) and simulates 0.1 km/h beyond that
fold, outside the band (:func:`polywear.dynamics.attractor.reached_attractors`: from the
nearest stable cycle and from steady rolling disturbed): SEV there would put the edge beyond the fold.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np

from polywear.dynamics.bifurcation import bifurcation
from polywear.studies.fast_band import _FIXED_RANGE, Fallback, FastBand, band_reference, pilot_references
from polywear.studies.fleet import FleetSpec, fleet
from polywear.studies.global_sensitivity import DEFAULT_KEYS
from polywear.studies.sampling import sample_params
from polywear.parallel import Executor
from polywear.params import Params, StudySpec, get_value, with_updates

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from tests.test_fast_band import _edges  # the test's flattening of the bands


def _samples(base, n, seed):
    rng = np.random.default_rng(seed)
    nominal = np.array([get_value(base, k) for k in DEFAULT_KEYS])
    return [sample_params(base, DEFAULT_KEYS, nominal * (1.0 + 0.1 * (2.0 * rng.random(len(nominal)) - 1.0)))
            for _ in range(n)]


def _references(base, n_pilot: int, seed: int, amplitude_speeds=()):
    """The nominal reference and those of ``n_pilot`` pilot samples (drawn with another seed
    than the samples compared), serial; prints their CPU time and topologies."""
    t = time.process_time()
    refs, failed = pilot_references([base, *_samples(base, n_pilot, seed + 1)], amplitude_speeds_kmh=amplitude_speeds,
                                    executor=Executor("serial"))
    topologies = Counter((r.band.hopf_criticality, len(r.band.folds_kmh), "unusable" if r.unusable else "")
                         for r in refs)
    print(f"{base.model}: nominal + {n_pilot} pilot references, {time.process_time() - t:.1f} s CPU, "
          f"{len(failed)} failed; topologies (Hopf criticalities, folds): {dict(topologies)}")
    return refs


def agreement(model: str, n: int, seed: int, n_pilot: int, amplitude_speeds=(80.0, 130.0)) -> None:
    base = with_updates(Params(), {"model": model})
    solver = FastBand(_references(base, n_pilot, seed, amplitude_speeds), amplitude_speeds_kmh=amplitude_speeds)
    t_fast, t_full, t_fast_on_fast, t_full_on_fast, paths, reasons, bad = 0.0, 0.0, 0.0, 0.0, Counter(), Counter(), []
    worst_edge = worst_amp = 0.0
    for i, params in enumerate(_samples(base, n, seed)):
        t0 = time.process_time()
        fast = solver(params)
        t1 = time.process_time()
        full = solver.full(params)
        t2 = time.process_time()
        t_fast += t1 - t0
        t_full += t2 - t1
        paths[fast.path] += 1
        if fast.path != "fast":
            reasons[fast.reason.value] += 1
            continue
        t_fast_on_fast += t1 - t0
        t_full_on_fast += t2 - t1
        same = (len(fast.hopf_kmh), len(fast.folds_kmh), len(fast.sev_band_kmh), len(fast.hard_regions_kmh)) == \
               (len(full.hopf_kmh), len(full.folds_kmh), len(full.sev_band_kmh), len(full.hard_regions_kmh))
        if not same:
            bad.append((i, "structure", fast.summary(), full.summary()))
            continue
        edge = float(np.max(np.abs(_edges(fast) - _edges(full)) / np.abs(_edges(full))))
        scale = max(full.amplitude_x_m, default=0.0)
        amp = float(np.max(np.abs(np.subtract(fast.amplitude_x_m, full.amplitude_x_m)))) / scale if scale else 0.0
        worst_edge, worst_amp = max(worst_edge, edge), max(worst_amp, amp)
        if edge > 1e-6:
            bad.append((i, f"edges differ by {edge:.2e}", fast.summary(), full.summary()))
        elif amp > 1e-4:
            bad.append((i, f"amplitudes differ by {amp:.2e} of the largest", fast.summary(), full.summary()))
    n_fast = paths["fast"]
    print(f"  samples {n}: fast path {n_fast}, fallback {n - n_fast}: {dict(reasons)}")
    print(f"  disagreements (fast path vs continuation): {len(bad)}; worst edge {worst_edge:.2e} relative, "
          f"worst amplitude {worst_amp:.2e} of the largest")
    for i, what, a, b in bad:
        print(f"    sample {i}: {what}\n      fast {a}\n      full {b}")
    if n_fast:
        print(f"  per sample: fast path (where it applied) {1e3 * t_fast_on_fast / n_fast:.1f} ms, "
              f"full continuation {1e3 * t_full_on_fast / n_fast:.1f} ms on the same samples -> "
              f"{t_full_on_fast / t_fast_on_fast:.1f}x")
    print(f"  all samples: fast path with fallbacks {t_fast:.1f} s, continuation only {t_full:.1f} s -> "
          f"{t_full / t_fast:.2f}x")


def _cpu() -> float:
    """CPU time [s] of this process and of its children waited for (the pool's workers)."""
    import resource

    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + kids.ru_utime + kids.ru_stime


def _sobol_spec(n_base: int, spread: float):
    """axle4dof and the study table of ``sobol``: first-order Sobol layout, N = n_base, the
    paper's 7 parameters uniform within +-spread of the defaults, bifurcation outputs."""
    params = with_updates(Params(), {"model": "axle4dof"})
    ranges = [sorted((get_value(params, k) * (1 - spread), get_value(params, k) * (1 + spread))) for k in DEFAULT_KEYS]
    return params, StudySpec().with_updates({"method": "sobol", "outputs": "bifurcation", "n_base": n_base,
                                             "second_order": False, "bootstrap": 100,
                                             "parameters": [{"key": k, "low": lo, "high": hi}
                                                            for k, (lo, hi) in zip(DEFAULT_KEYS, ranges)]})


def sobol(n_base: int, modes=("edges", "full"), spread: float = 0.1, workers: int = 2) -> None:
    """Sobol study of axle4dof, N = n_base (first-order layout: 9 runs per base sample),
    the paper's 7 parameters uniform within +-spread of the defaults (0.1: the default
    study ranges), both bifurcation speeds, ``workers`` local processes, with the fast band
    path (and its pilot stage) and the edges-only continuation where it does not apply, the
    band's top (and for hard, soft, hard, hard cars the gap) from the fold followed in the
    parameters where it can be (``edges``, the study's default; ``edges-branch``: those
    branches continued instead), the fast band
    path and whole diagrams (``fast``), and/or the continuation only (``full``). CPU time
    (this process and the pool's workers) and wall time; N = 1024 extrapolated linearly
    from the CPU time on 2 cores."""
    from polywear.studies.fast_band import pilot_size
    from polywear.studies.global_sensitivity import study

    for mode in modes:
        params, spec = _sobol_spec(n_base, spread)
        c, t = _cpu(), time.perf_counter()
        result = study(params, spec, backend="processes", workers=workers, fast_band=mode != "full",
                       edges_only=mode.startswith("edges"), top_fold=mode == "edges")
        dt, dc = time.perf_counter() - t, _cpu() - c
        runs = len(result.status)
        pilot = pilot_size(runs) if mode != "full" else 0
        print(f"axle4dof Sobol N = {n_base} ({runs} runs, +-{spread:.0%}), {mode}: wall {dt:.1f} s, CPU {dc:.1f} s "
              f"({1e3 * dc / runs:.0f} ms per run incl. {pilot} pilot diagrams), "
              f"{result.settings.get('fast_band_samples', 0)} on the fast path, "
              f"{result.settings.get('edges_only_samples', 0)} edges only "
              f"({result.settings.get('top_fold_samples', 0)} with the top fold followed, "
              f"{result.settings.get('gap_fold_samples', 0)} with the gap fold), "
              f"{result.settings.get('gap_after_pd_ns_samples', 0)} with a gap after a PD/NS point, "
              f"failures {result.failures()}; "
              f"N = 1024 ({1024 * 9} runs) on 2 free cores: ~{dc / runs * 1024 * 9 / 2 / 60:.1f} min")
        for values, outcome in zip(result.samples, result.status):
            if outcome.status.value not in ("ok", "no band in the speed range", "band reaches the edge of the speed range"):
                # failed or undecided: the parameter values to reproduce it
                print(f"  {outcome}\n    {dict(zip(DEFAULT_KEYS, values.tolist()))}")


def sobol_split(n_base: int, spread: float = 0.1) -> None:
    """The runs of ``sobol``'s study (same design, pilot stage and references), serially in
    this process, CPU of each by class: fast band path, edges only (each such run twice,
    alternately: with the top fold followed and with the top's branch continued, outputs
    compared), failed; and the time for N = 1024 on 2 cores from these per-class costs."""
    from SALib.sample import sobol as sobol_sample

    from polywear.studies.fast_band import pilot_stage
    from polywear.studies.global_sensitivity import _salib_problem, _seeds, study_parameters
    from polywear.studies.study_evaluator import StudyEvaluator

    params, spec = _sobol_spec(n_base, spread)
    problem = _salib_problem(study_parameters(params, spec))
    X = sobol_sample.sample(problem, n_base, calc_second_order=False, seed=np.random.default_rng(_seeds(spec.seed)[0]))
    t = time.process_time()
    pilot = pilot_stage(params, problem["names"], X, params, spec.speed_range_kmh, spec.operating_range_kmh,
                        executor=Executor("serial"))
    t_pilot = time.process_time() - t
    fast = FastBand(pilot.references, tuple(spec.speed_range_kmh), tuple(spec.operating_range_kmh))
    make = lambda top: StudyEvaluator(params, tuple(problem["names"]), "bifurcation", spec.speed_range_kmh,
                                      spec.operating_range_kmh, fast, edges_only=True, top_fold=top)
    evaluators = {True: make(True), False: make(False)}
    cost, worst, differ = {}, 0.0, []
    for i, x in enumerate(X):
        order = (True, False) if i % 2 else (False, True)  # alternate which goes first
        out = {}
        for top in order:
            t0 = time.process_time()
            out[top] = evaluators[top](x)
            out[top] = (*out[top], time.process_time() - t0)
            if out[top][1].fast:
                break
        (y, o, dt) = out[True] if True in out else out[False]
        kind = "fast" if o.fast else "failed" if o.status.value == "failed" else \
            "edges + top fold" if o.top_fold else "edges, no top fold"
        cost.setdefault(kind, []).append(dt)
        if not o.fast:
            cost.setdefault(f"{kind} (before)", []).append(out[False][2])
            y0 = np.asarray(out[False][0])
            d = np.abs(np.asarray(y) - y0)
            same_nan = np.isnan(y) == np.isnan(y0)
            worst = max(worst, float(np.nanmax(d, initial=0.0)))
            if not same_nan.all() or np.nanmax(d, initial=0.0) > 1e-6 or str(o) != str(out[False][1]):
                differ.append((i, y, y0, str(o), str(out[False][1])))
    runs = len(X)
    print(f"axle4dof Sobol N = {n_base} ({runs} runs, +-{spread:.0%}), serially: pilot stage "
          f"{len(pilot.references)} references {t_pilot:.1f} s CPU")
    total = {True: t_pilot, False: t_pilot}
    for kind, v in cost.items():
        print(f"  {kind}: {len(v)} runs, {sum(v):.1f} s CPU, mean {np.mean(v):.3f} s, median {np.median(v):.3f} s, "
              f"largest {max(v):.2f} s")
        if not kind.endswith("(before)"):
            total[True] += sum(v)
            total[False] += sum(v) if kind == "fast" else 0.0
        else:
            total[False] += sum(v)
    print(f"  outputs of the edges-only runs with and without the top fold: largest difference {worst:.1e}; "
          f"runs that differ: {len(differ)}")
    for i, y, y0, a, b in differ:
        print(f"    run {i}: {np.round(y, 9).tolist()} ({a}) vs {np.round(y0, 9).tolist()} ({b})")
    for top in (False, True):
        print(f"  {'with' if top else 'without'} the top fold: {total[top]:.1f} s CPU; N = 1024 at these per-class "
              f"costs (the pilot of 33 diagrams at this one's mean) on 2 cores: "
              f"~{((total[top] - t_pilot) * 1024 / n_base + 33 * t_pilot / len(pilot.references)) / 2 / 60:.1f} min")


TOE_LOAD = [
    {"key": "operating.toe_deg", "distribution": "normal", "mean": 0.5, "std": 0.05},
    {"key": "operating.vertical_load_n", "distribution": "discrete", "values": [3500.0, 4000.0, 4500.0],
     "weights": [1.0, 2.0, 1.0]},
    {"key": "tread.lateral_damping_ns_per_m", "distribution": "truncnormal", "mean": 80.0, "std": 4.0,
     "low": 70.0, "high": 90.0},
    {"key": "friction.mu_static", "distribution": "normal", "mean": 0.9, "std": 0.02},
    {"key": "tread.mass_kg", "distribution": "lognormal", "mean": 1.0, "std": 0.03},
    {"key": "tread.lateral_stiffness_n_per_m", "distribution": "normal", "mean": 1.0e6, "std": 3.0e4},
    {"key": "operating.camber_deg", "distribution": "normal", "mean": -1.0, "std": 0.2},
]


def _fleet_spec(n, n_params=7, seed=1) -> FleetSpec:
    return FleetSpec(samples=n, seed=seed, checkpoint_every=max(n, 1), parameter=TOE_LOAD[:n_params],
                     usage=[{"speed_kmh": 110.0, "share": 0.6}, {"speed_kmh": 130.0, "share": 0.4}],
                     speed_range_kmh=(10.0, 600.0))


def _fleet_reference(spec, base: Params | None = None):
    """The nominal car's reference, as fleet makes it (made once, outside the timings)."""
    nominal = sample_params(base or Params(), [q.key for q in spec.parameter], [q.center for q in spec.parameter])
    return band_reference(bifurcation(nominal, spec.speed_range_kmh, **_FIXED_RANGE))


WHOLE_BAND_CARS = 400
"""At most this many cars in the whole-band run (``band_every = 1``, ~0.1 s per car)."""


def fleet_timing(n: int, backends, model: str = "tread1dof") -> None:
    """Whole bands for every car (on n // 10 cars, at most WHOLE_BAND_CARS), and for every
    100th (band_every = 100: the others get the Hopf points and only the folds their risk
    needs) on n cars, on each backend (serial, 2 local processes). Wall time, CPU per car
    (this process and the pool's workers: ``getrusage`` of the children waited for; the
    pilot stage included, the nominal reference not) and cars per path."""
    base = with_updates(Params(), {"model": model})
    reference = _fleet_reference(_fleet_spec(n), base)
    for every, size in ((1, min(n // 10, WHOLE_BAND_CARS)), (100, n)):
        spec = _fleet_spec(size).model_copy(update={"band_every": every})
        for backend in backends:
            workers = 1 if backend == "serial" else 2
            c, t = _cpu(), time.perf_counter()
            result = fleet(base, spec, backend=backend, workers=workers, reference=reference)
            dt, dc = time.perf_counter() - t, _cpu() - c
            s = result.summary()
            print(f"{model} fleet of {size}, band_every {every}, {backend} ({workers}): wall {dt:.1f} s = "
                  f"{1e3 * dt / size:.2f} ms per car, CPU {1e3 * dc / size:.2f} ms per car; paths {s['paths']}, "
                  f"fallbacks {s['fallback_reasons']}, failed {s['failed_samples']}; "
                  f"risk {s['risk_probability']:.3f} {s['risk_ci']}; 1e5 cars: wall ~{dt * 1e5 / size / 60:.1f} min")


def pilot(n: int, model: str, band_every: int = 1) -> None:
    """n cars of the model (whole bands for every ``band_every``-th), serial, in this process:
    warm started from the nominal reference alone, then from the pilot stage's references too.
    CPU per car (the pilot stage included, the nominal reference not), cars per path and
    fallbacks by reason; the cars' numbers where both runs took the same path."""
    base = with_updates(Params(), {"model": model})
    spec = _fleet_spec(n).model_copy(update={"band_every": band_every})
    reference = _fleet_reference(spec, base)
    runs = {}
    for use_pilot in (False, True):
        c = time.process_time()
        runs[use_pilot] = result = fleet(base, spec, backend="serial", reference=reference, pilot=use_pilot)
        dc = time.process_time() - c
        s = result.summary()
        print(f"{model} fleet of {n}, band_every {band_every}, "
              f"{'with the pilot stage' if use_pilot else 'nominal reference alone'}: "
              f"CPU {dc:.1f} s = {1e3 * dc / n:.0f} ms per car; paths {s['paths']}, "
              f"fallbacks {s['fallback_reasons']}, failed {s['failed_samples']}; risk {s['risk_probability']:.4f}")
    before, after = runs[False], runs[True]
    same = np.array([a == b for a, b in zip(before.paths, after.paths)])
    both = same & before.ok & after.ok
    at_risk = np.sum(before.values[:, 2] != after.values[:, 2])
    speeds = np.abs(before.values[both, :2] - after.values[both, :2]) / np.abs(before.values[both, :2])
    print(f"  at-risk flags that differ: {at_risk} of {n}; bifurcation speeds of the {both.sum()} cars on the same "
          f"path in both runs: largest relative difference {np.nanmax(speeds, initial=0.0):.1e}")


def dask(n: int) -> None:
    from distributed import LocalCluster

    spec = _fleet_spec(n).model_copy(update={"band_every": 100})
    reference = _fleet_reference(spec)
    times = {}
    for workers in (1, 2):
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, host="127.0.0.1", dashboard_address=None)
        try:
            fleet(Params(), _fleet_spec(8), backend="dask", scheduler=cluster.scheduler_address,
                  reference=reference)  # warm the workers (imports, numba caches)
            t = time.perf_counter()
            fleet(Params(), spec, backend="dask", scheduler=cluster.scheduler_address, reference=reference)
            times[workers] = time.perf_counter() - t
        finally:
            cluster.close()
        print(f"Dask, {workers} worker(s): {times[workers]:.1f} s for {n} cars")
    print(f"Dask speed-up 1 -> 2 workers: {times[1] / times[2]:.2f}x")


def _noop(x):
    return x


def dask_sobol(n_base: int, model: str, spread: float = 0.1) -> None:
    """A small Sobol study (first-order layout, ``model``, the paper's 7 parameters within
    +-spread) on local Dask clusters of 1 and 2 workers (127.0.0.1, one thread each, started
    and stopped here), wall and CPU time (this process and the workers, reaped at close);
    the scheduler's cost per task from 400 no-op tasks; and the expected wall time on W
    free workers, T(W) = R c / W + B(W) o, with c the CPU per run, R the runs, B(W) the
    tasks (batches) and o the cost per task (the smaller of the two measured). The rest of
    each measured wall time (start-up, and on a loaded machine the wait for a core) is
    printed beside it: where it dominates, the wall times do not scale as 1/W here."""
    from distributed import Client, LocalCluster

    from polywear.parallel import TASKS_PER_SLOT
    from polywear.studies.global_sensitivity import study

    params = with_updates(Params(), {"model": model})
    ranges = [sorted((get_value(params, k) * (1 - spread), get_value(params, k) * (1 + spread))) for k in DEFAULT_KEYS]
    spec = StudySpec().with_updates({"method": "sobol", "outputs": "bifurcation", "n_base": n_base,
                                     "second_order": False, "bootstrap": 100,
                                     "parameters": [{"key": k, "low": lo, "high": hi}
                                                    for k, (lo, hi) in zip(DEFAULT_KEYS, ranges)]})
    wall, cpu, per_tasks = {}, {}, []
    for workers in (1, 2):
        c = _cpu()
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, host="127.0.0.1", dashboard_address=None)
        try:
            with Client(cluster.scheduler_address) as client:
                client.run(bifurcation, params)  # warm the workers (imports, compiled kernels)
                t = time.perf_counter()
                client.gather(client.map(_noop, range(400), pure=False))
                per_tasks.append((time.perf_counter() - t) / 400)
            t = time.perf_counter()
            result = study(params, spec, backend="dask", scheduler=cluster.scheduler_address)
            wall[workers] = time.perf_counter() - t
        finally:
            cluster.close()
        cpu[workers] = _cpu() - c
        runs = len(result.status)
        print(f"Dask, {workers} worker(s): Sobol N = {n_base} of {model} ({runs} runs): wall {wall[workers]:.1f} s, "
              f"CPU {cpu[workers]:.1f} s (workers' warm-up included); scheduler {1e3 * per_tasks[-1]:.1f} ms per no-op task")
    batches = lambda n, w: int(np.ceil(n / max(1, int(np.ceil(n / (w * TASKS_PER_SLOT))))))
    per_run = min(cpu.values()) / runs
    per_task = min(per_tasks)
    expected = lambda n, w: n * per_run / w + batches(n, w) * per_task
    print(f"speed-up 1 -> 2 workers {wall[1] / wall[2]:.2f}x (ideal 2); per run {1e3 * per_run:.0f} ms CPU; "
          f"wall time not explained by R c / W + B o: {wall[1] - expected(runs, 1):.1f} s (1 worker), "
          f"{wall[2] - expected(runs, 2):.1f} s (2 workers)")
    for w in (16, 64):
        print(f"  expected on {w} free workers: {expected(runs, w):.1f} s for these {runs} runs; "
              f"N = 1024 ({1024 * 9} runs): {expected(1024 * 9, w) / 60:.1f} min")


def growth() -> None:
    spec = _fleet_spec(50)
    reference = _fleet_reference(spec)
    for n in (25, 50, 100):
        t = time.perf_counter()
        fleet(Params(), _fleet_spec(n), backend="serial", reference=reference)
        print(f"samples {n:4d}, 7 parameters: {time.perf_counter() - t:.1f} s")
    for d in (1, 3, 7):
        spec_d = _fleet_spec(50, d)
        ref_d = _fleet_reference(spec_d)
        t = time.perf_counter()
        result = fleet(Params(), spec_d, backend="serial", reference=ref_d)
        print(f"samples 50, {d} parameter(s): {time.perf_counter() - t:.1f} s, "
              f"fast path {result.summary()['fast_path_share']:.0%}")


def _hopf_count(params) -> int:
    """Number of Hopf points of ``params`` in 20-300 km/h (the stability analysis's default grid)."""
    from polywear.dynamics.stability import stability

    return len(stability(params, (20.0, 300.0)).hopf_points)


def _edges_car(item):
    """One car of ``edges``: (index, values, CPU of the full and of the edges-only
    continuation [s], what differs (empty: none), counts of its kinds)."""
    from polywear.studies.edges import edges_diagram, pd_ns_edges_kmh

    i, values, params = item
    t0 = time.process_time()
    full = bifurcation(params, (20.0, 300.0))
    t1 = time.process_time()
    edges = edges_diagram(params, (20.0, 300.0))
    t2 = time.process_time()
    diff = []
    for name in ("sev_band_kmh", "hard_regions_kmh", "gaps_after_pd_ns_kmh"):
        a, b = getattr(full, name), getattr(edges, name)
        if len(a) != len(b):
            diff.append(f"{name}: {len(a)} intervals (full) vs {len(b)} (edges): {a} vs {b}")
        elif a and float(np.max(np.abs(np.subtract(a, b)))) > 1e-6:
            diff.append(f"{name}: ends differ by {float(np.max(np.abs(np.subtract(a, b)))):.2e} km/h: {a} vs {b}")
    lost = lambda d: sorted(round(info["from_hopf_kmh"], 3) for info in d.branch_info if info["failed"])
    if lost(full) != lost(edges):
        diff.append(f"failed branches from {lost(full)} km/h (full) vs {lost(edges)} km/h (edges)")
    kinds = {"gap_after_pd_ns": bool(full.gaps_after_pd_ns_kmh), "pd_ns_edge": bool(pd_ns_edges_kmh(full)),
             "failed": bool(lost(full) or lost(edges)), "rerun_full": bool(full.continuation_notes),
             "rerun_edges": bool(edges.continuation_notes),
             "points": (sum(len(b.points) for b in full.branches), sum(len(b.points) for b in edges.branches))}
    return i, values, t1 - t0, t2 - t1, diff, kinds


def _four_hopf_cars(pool, n: int, seed: int) -> list:
    """The first ``n`` axle4dof cars with four Hopf points, the paper's seven parameters within
    +-10 % of the defaults drawn by ``seed`` (Hopf points counted in ``pool``): (index drawn,
    values, params) each; prints how many were drawn."""
    base = with_updates(Params(), {"model": "axle4dof"})
    rng = np.random.default_rng(seed)
    nominal = np.array([get_value(base, k) for k in DEFAULT_KEYS])
    cars, drawn = [], 0
    while len(cars) < n:
        values = [nominal * (1.0 + 0.1 * (2.0 * rng.random(len(nominal)) - 1.0)) for _ in range(200)]
        params = [sample_params(base, DEFAULT_KEYS, v) for v in values]
        for k, count in enumerate(pool.map(_hopf_count, params, chunksize=20)):
            if count == 4 and len(cars) < n:
                cars.append((drawn + k, values[k], params[k]))
        drawn += len(values) if len(cars) < n else cars[-1][0] + 1 - drawn
    print(f"axle4dof, seed {seed}: {n} cars with four Hopf points among the first {drawn} drawn", flush=True)
    return cars


def edges(n: int, seed: int, workers: int = 1) -> None:
    """The first ``n`` axle4dof cars with four Hopf points (the paper's seven parameters within
    +-10 % of the defaults, drawn by ``seed``): edges-only continuation against the full one."""
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(workers) as pool:
        cars = _four_hopf_cars(pool, n, seed)
    t_full = t_edges = 0.0
    bad, counts, points = [], Counter(), np.zeros(2)
    with ProcessPoolExecutor(workers) as pool:
        for i, values, a, b, diff, kinds in pool.map(_edges_car, cars):
            t_full, t_edges = t_full + a, t_edges + b
            points += kinds.pop("points")
            counts.update(k for k, v in kinds.items() if v)
            print(f"  car {i}: full {a:.2f} s, edges {b:.2f} s CPU, {', '.join(k for k, v in kinds.items() if v)}; "
                  f"{'; '.join(diff) or 'same edges'}", flush=True)
            if diff:
                bad.append((i, values, diff))
                print(f"    {dict(zip(DEFAULT_KEYS, values.tolist()))}", flush=True)
    print(f"  disagreements: {len(bad)} of {n} cars; counts {dict(counts)}")
    print(f"  CPU per car: full {t_full / n:.3f} s, edges only {t_edges / n:.3f} s -> {t_full / t_edges:.2f}x; "
          f"cycle points per car {points[0] / n:.0f} vs {points[1] / n:.0f}")


def _top_fold_car(item):
    """One car of ``top-fold``: (index, values, CPU of the full continuation, the edges-only
    one and the edges-only one with the top fold followed [s], what differs from the full
    continuation and from the edges-only one (empty: none), the top fold or why not)."""
    from polywear.studies.edges import edges_diagram
    from polywear.studies.study_evaluator import edges_band

    i, values, params, fast = item
    t0 = time.process_time()
    full = bifurcation(params, (20.0, 300.0))
    t1 = time.process_time()
    edges = edges_diagram(params, (20.0, 300.0))
    t2 = time.process_time()
    sev, gaps, diagram, top, _ = edges_band(params, (20.0, 300.0), fast)
    t3 = time.process_time()
    diffs = []
    for other in (full, edges):
        diff = []
        for name, a, b in (("sev_band_kmh", other.sev_band_kmh, sev),
                           ("gaps_after_pd_ns_kmh", other.gaps_after_pd_ns_kmh, gaps)):
            if len(a) != len(b):
                diff.append(f"{name}: {len(a)} vs {len(b)} intervals: {a} vs {b}")
            elif a and float(np.max(np.abs(np.subtract(a, b)))) > 1e-6:
                diff.append(f"{name}: ends differ by {float(np.max(np.abs(np.subtract(a, b)))):.2e} km/h: {a} vs {b}")
        failed = lambda d: sorted(round(info["from_hopf_kmh"], 3) for info in d.branch_info if info["failed"])
        if failed(other) != failed(diagram):
            diff.append(f"failed branches from {failed(other)} vs {failed(diagram)} km/h")
        worst = float(np.max(np.abs(np.subtract(other.sev_band_kmh, sev)))) if len(other.sev_band_kmh) == len(sev) \
            and sev else np.nan
        diffs.append((diff, worst))
    return i, values, (t1 - t0, t2 - t1, t3 - t2), diffs, top if top is not None else fast.top_fold(params)


def top_fold(n: int, seed: int, workers: int = 1, n_pilot: int = 32) -> None:
    """The first ``n`` axle4dof cars with four Hopf points (as ``edges`` draws them): the SEV
    band of the studies' edges-only path with the top fold followed in the parameters
    (:func:`polywear.studies.global_sensitivity.edges_band`, the nominal and ``n_pilot``
    pilot references of another seed, as a study's) against the full continuation and the
    edges-only continuation; CPU of the three per car."""
    from concurrent.futures import ProcessPoolExecutor

    fast = FastBand(_references(with_updates(Params(), {"model": "axle4dof"}), n_pilot, seed), (20.0, 300.0))
    with ProcessPoolExecutor(workers) as pool:
        cars = [(*car, fast) for car in _four_hopf_cars(pool, n, seed)]
        times, bad, worst, tops = np.zeros(3), [], np.zeros(2), 0
        for i, values, dt, diffs, top in pool.map(_top_fold_car, cars):
            times += dt
            tops += not isinstance(top, Fallback)
            worst = np.fmax(worst, [w for _, w in diffs])
            print(f"  car {i}: full {dt[0]:.2f} s, edges {dt[1]:.2f} s, edges + top fold {dt[2]:.2f} s CPU; "
                  f"{top}; vs full: {'; '.join(diffs[0][0]) or 'same'}; vs edges: {'; '.join(diffs[1][0]) or 'same'}",
                  flush=True)
            if diffs[0][0] or diffs[1][0]:
                bad.append(i)
                print(f"    {dict(zip(DEFAULT_KEYS, values.tolist()))}", flush=True)
    print(f"  top fold followed on {tops} of {n} cars; cars with a difference: {len(bad)} {bad}; largest difference "
          f"of the band's ends where the counts agree: {worst[0]:.1e} km/h (full), {worst[1]:.1e} km/h (edges only)")
    print(f"  CPU per car: full {times[0] / n:.3f} s, edges only {times[1] / n:.3f} s, edges + top fold "
          f"{times[2] / n:.3f} s -> {times[1] / times[2]:.2f}x less than edges only")


def _band_differences(first, second) -> tuple[list[str], float]:
    """What differs between two paths' (SEV band, gaps after PD/NS points, diagram) in the
    bands, the gaps and the failed branches (ends beyond 1e-6 km/h), and the largest
    difference of the band's ends [km/h] where the counts agree (NaN otherwise)."""
    (a_sev, a_gaps, a_diagram), (b_sev, b_gaps, b_diagram) = first, second
    diff = []
    for name, a, b in (("sev_band_kmh", a_sev, b_sev), ("gaps_after_pd_ns_kmh", a_gaps, b_gaps)):
        if len(a) != len(b):
            diff.append(f"{name}: {len(a)} vs {len(b)} intervals: {a} vs {b}")
        elif a and float(np.max(np.abs(np.subtract(a, b)))) > 1e-6:
            diff.append(f"{name}: ends differ by {float(np.max(np.abs(np.subtract(a, b)))):.2e} km/h: {a} vs {b}")
    failed = lambda d: sorted(round(info["from_hopf_kmh"], 3) for info in d.branch_info if info["failed"])
    if failed(a_diagram) != failed(b_diagram):
        diff.append(f"failed branches from {failed(a_diagram)} vs {failed(b_diagram)} km/h")
    worst = float(np.max(np.abs(np.subtract(a_sev, b_sev)))) if len(a_sev) == len(b_sev) and a_sev else np.nan
    return diff, worst


def _gap_fold_car(item):
    """One car of ``gap-fold``: (index, values, Hopf criticalities, CPU of the full continuation,
    of the edges path with the top fold and of that with the gap fold too [s], what the latter
    differs in from the full continuation and from the edges path with the top fold, and the
    gap fold or why not). The two edges paths run in alternating order (``first``)."""
    from polywear.studies.study_evaluator import edges_band

    i, values, params, fast, first, with_full = item
    t0 = time.process_time()
    full = bifurcation(params, (20.0, 300.0)) if with_full else None
    dt = {"full": time.process_time() - t0}
    out = {}
    for gap in ((False, True) if first else (True, False)):
        t = time.process_time()
        out[gap] = edges_band(params, (20.0, 300.0), fast, gap_fold=gap)
        dt[gap] = time.process_time() - t
    new, diagram, gap = out[True][:3], out[True].diagram, out[True].gap
    diffs = [_band_differences((full.sev_band_kmh, full.gaps_after_pd_ns_kmh, full), new) if with_full
             else ([], np.nan), _band_differences(out[False][:3], new)]
    criticality = tuple(str(h.criticality) for h in diagram.hopf_points)
    points = tuple(sum(info["n_points"] for info in out[g].diagram.branch_info) for g in (False, True))
    return i, values, criticality, (dt["full"], dt[False], dt[True]), points, diffs, gap if gap is not None \
        else fast.gap_fold(params)


def gap_fold(n: int, seed: int, workers: int = 1, n_pilot: int = 32, with_full: bool = True) -> None:
    """The first ``n`` axle4dof cars with four Hopf points (as ``edges`` and ``top-fold`` draw
    them): the SEV band of the studies' edges path with the top fold and the gap fold followed
    in the parameters (:func:`polywear.studies.global_sensitivity.edges_band` with
    ``gap_fold=True``; the nominal and ``n_pilot`` pilot references of another seed, as a
    study's) against the full continuation and the edges path with the top fold alone; CPU of
    the three per car (the two edges paths alternately first), and the gap fold's fallbacks
    by reason."""
    from concurrent.futures import ProcessPoolExecutor

    from polywear.studies.fast_band import GAP_FOLD_CRITICALITY

    refs = _references(with_updates(Params(), {"model": "axle4dof"}), n_pilot, seed)
    print(f"  references with a gap fold: {sum(r.gap_fold is not None for r in refs)}; with the Hopf points "
          f"{GAP_FOLD_CRITICALITY}: {sum(r.band.hopf_criticality == GAP_FOLD_CRITICALITY for r in refs)}", flush=True)
    fast = FastBand(refs, (20.0, 300.0))
    times, times_target, bad, worst, reasons, n_target = np.zeros(3), np.zeros(3), [], np.zeros(2), Counter(), 0
    points, points_target = np.zeros(2), np.zeros(2)
    with ProcessPoolExecutor(workers) as pool:
        cars = [(*car, fast, k % 2 == 0, with_full) for k, car in enumerate(_four_hopf_cars(pool, n, seed))]
        for i, values, criticality, dt, n_points, diffs, gap in pool.map(_gap_fold_car, cars):
            times += dt
            points += n_points
            target = criticality == GAP_FOLD_CRITICALITY
            n_target += target
            if target:
                times_target += dt
                points_target += n_points
                reasons["followed" if not isinstance(gap, Fallback) else gap.reason.value] += 1
            worst = np.fmax(worst, [w for _, w in diffs])
            print(f"  car {i} {'/'.join(c[0] for c in criticality)}: full {dt[0]:.2f} s, edges + top fold "
                  f"{dt[1]:.2f} s, + gap fold {dt[2]:.2f} s CPU, cycle points {n_points[0]} / {n_points[1]}; "
                  f"{gap if target else '-'}; vs full: "
                  f"{'; '.join(diffs[0][0]) or 'same'}; vs edges + top fold: {'; '.join(diffs[1][0]) or 'same'}",
                  flush=True)
            if diffs[0][0] or diffs[1][0]:
                bad.append(i)
                print(f"    {dict(zip(DEFAULT_KEYS, values.tolist()))}", flush=True)
    print(f"  {n_target} of {n} cars with the Hopf points {GAP_FOLD_CRITICALITY}; gap fold: {dict(reasons)}")
    print(f"  cars with a difference: {len(bad)} {bad}; largest difference of the band's ends where the counts "
          f"agree: {f'{worst[0]:.1e} km/h' if with_full else 'not run'} (full), {worst[1]:.1e} km/h (edges + top fold)")
    for name, t, pts, m in (("all cars", times, points, n), ("those cars", times_target, points_target, n_target)):
        if m:
            print(f"  CPU per car, {name}: full {t[0] / m:.3f} s, edges + top fold {t[1] / m:.3f} s, + gap fold "
                  f"{t[2] / m:.3f} s -> {t[1] / t[2]:.2f}x less than with the top fold alone; cycle points per car "
                  f"{pts[0] / m:.1f} / {pts[1] / m:.1f}")


def _window_car(item):
    """One car of ``windows``: (index, values, [(edge, speed simulated, SEV reached, regimes)])."""
    from polywear.dynamics.attractor import reached_attractors
    from polywear.studies.edges import edges_diagram, window_edges_kmh

    i, values, params = item
    diagram = edges_diagram(params, (20.0, 300.0))
    sev = diagram.sev_band_kmh
    out = []
    for edge in window_edges_kmh(diagram):
        v = edge - 0.1 if edge == sev[0][0] else edge + 0.1
        found = reached_attractors(diagram, v)
        out.append((edge, v, any(a.oscillating for a in found), [str(a.regime) for a in found]))
    return i, values, out


def windows(n: int, seed: int, workers: int = 1) -> None:
    """Simulation past the window folds of the first ``n`` four-Hopf cars that have one."""
    from concurrent.futures import ProcessPoolExecutor

    from polywear.dynamics.stability import stability

    base = with_updates(Params(), {"model": "axle4dof"})
    rng = np.random.default_rng(seed)
    nominal = np.array([get_value(base, k) for k in DEFAULT_KEYS])
    drawn, checked, sev_cars = 0, 0, 0
    with ProcessPoolExecutor(workers) as pool:
        while checked < n:
            batch = []
            while len(batch) < 2 * workers:
                values = nominal * (1.0 + 0.1 * (2.0 * rng.random(len(nominal)) - 1.0))
                params = sample_params(base, DEFAULT_KEYS, values)
                if len(stability(params, (20.0, 300.0)).hopf_points) == 4:
                    batch.append((drawn, values, params))
                drawn += 1
            for i, values, out in pool.map(_window_car, batch):
                if not out or checked >= n:
                    continue
                checked += 1
                sev_cars += any(hit for _, _, hit, _ in out)
                for edge, v, hit, regimes in out:
                    print(f"  car {i}: window fold at {edge:.3f} km/h, at {v:.3f} km/h: "
                          f"{'SEV' if hit else 'no SEV'} {regimes}", flush=True)
    print(f"{checked} cars with a window fold as a band bound (first {drawn} drawn, seed {seed}): "
          f"SEV beyond the fold in {sev_cars}")


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("what", choices=("agreement", "sobol", "fleet", "pilot", "dask", "dask-sobol", "growth", "edges",
                                         "windows", "top-fold", "gap-fold"))
    parser.add_argument("--model", default="tread1dof")
    parser.add_argument("--samples", type=int, default=200)
    parser.add_argument("--seed", type=int, default=20261201)
    parser.add_argument("--backend", choices=("serial", "processes"), action="append",
                        help="fleet: backend(s) to time (default: both)")
    parser.add_argument("--mode", choices=("edges", "edges-branch", "fast", "full"), action="append",
                        help="sobol: fast band path with pilot and edges-only fallbacks (with the top fold followed "
                             "in the parameters; edges-branch: without), the same with whole diagrams, or "
                             "continuation only (default: edges and full)")
    parser.add_argument("--split", action="store_true",
                        help="sobol: every run serially in this process, CPU per class of run (fast, edges only "
                             "with and without the top fold, alternately, failed) instead of the study")
    parser.add_argument("--pilot", type=int, default=32, help="pilot samples (references besides the nominal one)")
    parser.add_argument("--amplitude-speeds", type=float, nargs="*", default=[80.0, 130.0],
                        help="agreement: speeds [km/h] of the amplitudes (none: the bands alone, as fleets need)")
    parser.add_argument("--band-every", type=int, default=1, help="pilot: whole bands for every k-th car")
    parser.add_argument("--spread", type=float, default=0.1, help="sobol: parameter ranges +-spread of the defaults")
    parser.add_argument("--workers", type=int, help="local processes (edges, windows, top-fold, gap-fold: 1; sobol: 2)")
    parser.add_argument("--no-full", action="store_true", help="gap-fold: without the full continuation")
    args = parser.parse_args()
    if args.what == "agreement":
        agreement(args.model, args.samples, args.seed, args.pilot, tuple(args.amplitude_speeds))
    elif args.what == "sobol":
        if args.split:
            sobol_split(args.samples, args.spread)
        else:
            sobol(args.samples, args.mode or ("edges", "full"), args.spread, args.workers or 2)
    elif args.what == "fleet":
        fleet_timing(args.samples, args.backend or ("serial", "processes"), args.model)
    elif args.what == "pilot":
        pilot(args.samples, args.model, args.band_every)
    elif args.what == "dask":
        dask(args.samples)
    elif args.what == "dask-sobol":
        dask_sobol(args.samples, args.model, args.spread)
    elif args.what == "edges":
        edges(args.samples, args.seed, args.workers or 1)
    elif args.what == "windows":
        windows(args.samples, args.seed, args.workers or 1)
    elif args.what == "top-fold":
        top_fold(args.samples, args.seed, args.workers or 1, args.pilot)
    elif args.what == "gap-fold":
        gap_fold(args.samples, args.seed, args.workers or 1, args.pilot, not args.no_full)
    else:
        growth()


if __name__ == "__main__":
    main()
