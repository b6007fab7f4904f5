"""Sensitivity timings: exact local sensitivities, a Sobol study on the Hopf speeds, Dask scaling.

1. All local sensitivities (the paper's seven parameters, adhesion read both ways: 8
   keys) of the ``axle4dof`` defaults by the exact method, timed with and without the
   nominal bifurcation diagram they need (goal < 1 s). Baseline: the paper's forward
   differences (eq. 3), which re-run the diagram once per parameter.
2. A Sobol study (Saltelli sampling, N = 1024, second order) over the paper's seven
   parameters on the Hopf speeds: 16 384 evaluations of the fast linear band, on the
   default backend (local processes, 2 workers; goal < 60 s). Baselines: the serial
   backend, and the per-evaluation cost of the full ``stability``.
3. The same study on a local Dask cluster (``distributed.LocalCluster``, one thread per
   worker process) with 1 and with 2 workers, workers warmed up first (goal >= 1.7x).

All timings are wall-clock in this run; nothing is asserted.

    .venv/bin/python benchmarks/bench_sensitivity.py [--model tread1dof] [--n-base 1024] [--skip local,sobol,dask]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from polywear.params import Params, StudySpec, with_updates


def _timed(fn, *args, **kwargs):
    t0 = time.perf_counter()
    out = fn(*args, **kwargs)
    return out, time.perf_counter() - t0


def bench_local() -> None:
    from polywear.dynamics.bifurcation import bifurcation
    from polywear.dynamics.sensitivity import PAPER_PARAMETERS, sensitivity

    params = with_updates(Params(), {"model": "axle4dof"})
    bifurcation(params)  # compile / load caches
    diagram, t_diagram = _timed(bifurcation, params)
    exact, t_exact = _timed(sensitivity, params, PAPER_PARAMETERS, "exact", diagram=diagram)
    forward, t_forward = _timed(sensitivity, params, PAPER_PARAMETERS, "forward", 1e-4, diagram=diagram)
    quantities = sorted({r["quantity"] for r in exact.rows})
    worst = max(
        abs(f["derivative"] - e["derivative"]) / abs(e["derivative"])
        for e, f in zip(exact.rows, forward.rows)
        if e["derivative"]
    )
    print(f"\n1. local sensitivities of axle4dof: {len(PAPER_PARAMETERS)} keys x {len(quantities)} quantities "
          f"({', '.join(quantities)})")
    print(f"   exact, derivatives only (nominal diagram given)  {t_exact:8.3f} s   (goal < 1 s)")
    print(f"   exact, nominal diagram included                  {t_exact + t_diagram:8.3f} s   "
          f"(diagram {t_diagram:.3f} s)")
    print(f"   baseline: forward differences (paper eq. 3)      {t_forward:8.3f} s   "
          f"-> exact is {t_forward / t_exact:.0f}x faster without the diagram, "
          f"{(t_forward + t_diagram) / (t_exact + t_diagram):.1f}x with it")
    print(f"   largest relative difference forward (step 1e-4) vs exact: {worst:.1e} (first order in the step)")


def _study(run, params, study, **kwargs):
    """(result, whole time, time until the last evaluation came back) of a global study."""
    done, finished = [0], [0.0]
    t0 = time.perf_counter()

    def progress(k, total, message=""):
        done[0] = k
        finished[0] = time.perf_counter() - t0

    result = run(params, study, progress=progress, **kwargs)
    return result, time.perf_counter() - t0, finished[0]


def _study_params(model: str, n_base: int) -> tuple[Params, StudySpec]:
    study = StudySpec().with_updates({"method": "sobol", "outputs": "hopf", "n_base": n_base, "second_order": True})
    return with_updates(Params(), {"model": model}), study


def bench_sobol(model: str, n_base: int) -> None:
    from polywear.studies.global_sensitivity import study
    from polywear.dynamics.stability import fast_linear_band
    from polywear.dynamics.stability import stability

    params, spec = _study_params(model, n_base)
    base = with_updates(Params(), {"model": model})
    fast_linear_band(base)
    stability(base)
    _, t_fast = _timed(lambda: [fast_linear_band(base) for _ in range(50)])
    _, t_full = _timed(lambda: [stability(base, (20.0, 300.0)) for _ in range(10)])
    print(f"\n2. Sobol study of {model}: N = {n_base}, 7 parameters, second order, Hopf speeds")
    print(f"   one evaluation: fast linear band {t_fast / 50 * 1e3:6.2f} ms, stability (400 speeds) "
          f"{t_full / 10 * 1e3:6.2f} ms ({t_full / 10 / (t_fast / 50):.0f}x)")
    result, t_proc, t_proc_eval = _study(study, params, spec, backend="processes", workers=2)
    n = len(result.status)
    print(f"   processes, 2 workers: {n} evaluations in {t_proc_eval:6.2f} s, whole study (sampling, pool start, "
          f"SALib with bootstrap) {t_proc:6.2f} s (goal < 60 s); failures: {result.failures() or 'none'}")
    serial, t_serial, t_serial_eval = _study(study, params, spec, backend="serial")
    assert np.array_equal(serial.values, result.values, equal_nan=True)
    print(f"   baseline serial:      {n} evaluations in {t_serial_eval:6.2f} s ({t_serial_eval / n * 1e3:.2f} ms each), "
          f"whole study {t_serial:6.2f} s -> processes {t_serial / t_proc:.2f}x")
    for out in result.outputs:
        ind = result.indices[out]
        order = np.argsort(-ind["ST"])
        top = ", ".join(f"{result.names[j].split('.')[-1]} {ind['ST'][j]:.2f}" for j in order[:3])
        print(f"   {out:24s} ST: {top}  (converged: {result.convergence[out]['converged']})")


def _warm() -> None:
    from polywear.dynamics.stability import fast_linear_band

    fast_linear_band(Params())
    fast_linear_band(with_updates(Params(), {"model": "axle4dof"}))


def _burn(_) -> float:
    """Pure-Python CPU work (~0.3 s): the ideal parallel task."""
    total = 0
    for i in range(6_000_000):
        total += i * i
    return float(total)


def bench_dask(model: str, n_base: int) -> None:
    from distributed import Client, LocalCluster

    from polywear.studies.global_sensitivity import study

    params, spec = _study_params(model, n_base)
    times, ideal = {}, {}
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with Client(cluster) as client:
            for n_workers in (1, 2):
                cluster.scale(n_workers)
                client.wait_for_workers(n_workers)
                client.run(_warm)
                _, ideal[n_workers] = _timed(lambda: client.gather(client.map(_burn, range(8), pure=False)))
                result, _, times[n_workers] = _study(study, params, spec, backend="dask",
                                                     scheduler=cluster.scheduler_address)
    n = len(result.status)
    print(f"\n3. the same study on a local Dask cluster (1 thread per worker process), time of the {n} evaluations")
    print(f"   1 worker  {times[1]:7.2f} s")
    print(f"   2 workers {times[2]:7.2f} s   speed-up {times[1] / times[2]:.2f}x (goal >= 1.7x)")
    print(f"   baseline: 8 pure-Python CPU tasks on the same cluster: speed-up {ideal[1] / ideal[2]:.2f}x "
          f"(the CPU this machine gave us; other jobs share its 2 cores)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="tread1dof", help="model of the Sobol and Dask studies")
    parser.add_argument("--n-base", type=int, default=1024, help="Sobol base samples N (power of 2)")
    parser.add_argument("--skip", default="", help="comma-separated parts to skip: local, sobol, dask")
    args = parser.parse_args()
    skip = set(filter(None, args.skip.split(",")))
    if "local" not in skip:
        bench_local()
    if "sobol" not in skip:
        bench_sobol(args.model, args.n_base)
    if "dask" not in skip:
        bench_dask(args.model, args.n_base)


if __name__ == "__main__":
    main()
