"""Timing of the full bifurcation diagram against AUTO-07p and against the brute-force sweep.

    .venv/bin/python benchmarks/bench_bifurcation.py [--repeat 3] [--sweep-speeds 40 | 0: no sweep]

Measured in one process, on the same machine:

* polywear's continuation of the whole tread1dof diagram over 20-300 km/h (equilibria,
  both Hopf points, the cycle branch through its fold back to the second Hopf point,
  Floquet multipliers at every point), warm (compiled kernels cached), best of N;
* AUTO-07p on the same problem (bifpy native path; total wall time, and AUTO's own
  solver time without compiling and output parsing) - skipped if AUTO-07p is missing;
* the paper's way: a speed sweep with small/large disturbances up and down
  (``polywear.dynamics.sweep``), which resolves the band edges only to the grid spacing;
* the full axle4dof diagram.

Prints seconds and the ratios; the accuracy columns compare Hopf and fold speeds. AUTO's
solver time is the "Total Time" it reports, its own CPU time (gfortran ``cpu_time``), so
AUTO solver / polywear CPU is the ratio that a loaded machine leaves alone; the load
average is printed at the start and the end.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from polywear.dynamics.bifurcation import bifurcation
from polywear.dynamics.sweep import sweep, sweep_bands
from polywear.params import Params, load_params
from polywear.solvers.continuation import ContinuationSettings


def best_of(repeat, fn):
    """(best wall time [s], result); the best CPU time [s] of this process is in ``CPU[fn]``."""
    times, cpu, result = [], [], None
    for _ in range(repeat):
        start, start_cpu = time.perf_counter(), time.process_time()
        result = fn()
        times.append(time.perf_counter() - start)
        cpu.append(time.process_time() - start_cpu)
    CPU[fn] = min(cpu)
    return min(times), result


CPU = {}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--sweep-speeds", type=int, default=40)
    args = parser.parse_args()
    print(f"load average {os.getloadavg()[0]:.1f} (1 min) on {os.cpu_count()} cores")
    params = Params()
    bifurcation(params)  # compile / load caches
    fn_ours = lambda: bifurcation(params, (20.0, 300.0))
    t_ours, ours = best_of(args.repeat, fn_ours)
    hopf = [h.speed_kmh for h in ours.hopf_points]
    fold = [f.speed_kmh for f in ours.folds]
    n_points = sum(len(b.points) for b in ours.branches)
    print(f"polywear continuation, tread1dof 20-300 km/h: {t_ours:.3f} s ({n_points} cycles)")
    print(f"  Hopf {', '.join(f'{v:.6f}' for v in hopf)} km/h, fold {', '.join(f'{v:.6f}' for v in fold)} km/h")
    # the same diagram in steps of full length (no turn limit), timed in this process: the
    # turn limit's cost as a load-independent ratio of CPU times, and its cycle count
    free = lambda: bifurcation(params, (20.0, 300.0), ContinuationSettings(max_turn=None))
    t_free, unlimited = best_of(args.repeat, free)
    n_free = sum(len(b.points) for b in unlimited.branches)
    print(f"  CPU {CPU[fn_ours]:.3f} s; without the turn limit {CPU[free]:.3f} s CPU ({n_free} cycles): "
          f"turn-limited / unlimited = {CPU[fn_ours] / CPU[free]:.3f} (CPU), {t_ours / t_free:.3f} (wall)")

    try:
        from polywear.validation.auto07p import auto07p_available, tread1dof_diagram

        ok, why = auto07p_available()
    except ImportError as exc:
        ok, why = False, str(exc)
    if ok:
        # AUTO and polywear alternately, so that both see the same load; AUTO's time is the
        # best of the repeats, as polywear's, and each pair gives a ratio of CPU times
        walls, solver_times, pair_ratios = [], [], []
        for _ in range(args.repeat):
            start = time.perf_counter()
            auto = tread1dof_diagram(params, (20.0, 300.0))
            walls.append(time.perf_counter() - start)
            solver_times.append(auto["auto_time_s"])
            start_cpu = time.process_time()
            fn_ours()
            pair_ratios.append(auto["auto_time_s"] / (time.process_time() - start_cpu))
        t_auto, solver = min(walls), min(solver_times)
        a_hopf = [h["speed_kmh"] for h in auto["hopf"]]
        a_fold = [f["speed_kmh"] for f in auto["folds"]]
        err = max(abs(a - b) / b for a, b in zip(hopf + fold, a_hopf + a_fold))
        print(f"AUTO-07p (bifpy native): {t_auto:.3f} s wall, {solver:.3f} s in AUTO's solver; "
              f"largest relative difference of Hopf/fold speeds {err:.1e}")
        print(f"  ratio AUTO wall / polywear = {t_auto / t_ours:.1f}x; AUTO solver only / polywear = "
              f"{solver / t_ours:.2f}x; AUTO solver CPU / polywear CPU = {solver / CPU[fn_ours]:.2f}x (best of each); "
              f"pairs run alternately: median {np.median(pair_ratios):.2f}x, range {min(pair_ratios):.2f}-"
              f"{max(pair_ratios):.2f}x")
    else:
        print(f"AUTO-07p skipped: {why}")

    if args.sweep_speeds > 0:
        sweep_ratios(args.sweep_speeds, params, t_ours)
    axle = load_params(overrides=["model=axle4dof"])
    bifurcation(axle)
    whole_axle = lambda: bifurcation(axle, (20.0, 300.0))
    t_axle, d = best_of(args.repeat, whole_axle)
    print(f"polywear continuation, axle4dof 20-300 km/h: {t_axle:.3f} s, {CPU[whole_axle]:.3f} s CPU "
          f"({sum(len(b.points) for b in d.branches)} cycles; goal < 3 s); SEV band "
          f"{d.sev_band_kmh[0][0]:.2f}-{d.sev_band_kmh[-1][1]:.2f} km/h")
    print(f"load average {os.getloadavg()[0]:.1f} (1 min)")


def sweep_ratios(n_speeds: int, params: Params, t_ours: float) -> None:
    """The brute-force sweep on ``n_speeds`` speeds against the continuation's ``t_ours`` [s]."""
    speeds = np.linspace(20.0, 300.0, n_speeds)
    t_sweep, sw = best_of(1, lambda: sweep(params, speeds))
    bands = sweep_bands(sw)
    print(f"sweep, {len(speeds)} speeds x 4 starts: {t_sweep:.2f} s; SEV band "
          f"{bands['first_bifurcation_speed_kmh']:.1f}-{bands['second_bifurcation_speed_kmh']:.1f} km/h "
          f"(grid spacing {bands['grid_spacing_kmh']:.1f} km/h)")
    print(f"  ratio sweep / polywear = {t_sweep / t_ours:.0f}x on this grid (goal >= 50x)")
    # the sweep finds the band edges only to its grid spacing; continuation to ~1e-8 km/h.
    # Cost of a sweep that resolves them to 1 km/h, at the per-speed cost just measured:
    per_speed = t_sweep / len(speeds)
    needed = int(np.ceil((speeds[-1] - speeds[0]) / 1.0)) + 1
    print(f"  a sweep resolving the edges to 1 km/h needs {needed} speeds: ~{per_speed * needed:.0f} s, "
          f"{per_speed * needed / t_ours:.0f}x the continuation (extrapolated from the measured per-speed cost)")


if __name__ == "__main__":
    main()
