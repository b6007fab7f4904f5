"""Timing of the wear analysis: the linear map and the nonlinear evolution.

    .venv/bin/python benchmarks/bench_wear.py [--repeat 3] [--skip-evolution] [--axle] [--workers 2] [--critical-path]

Measured in one process, warm (compiled kernels cached), as CPU time (``time.process_time``:
the machine may be shared, and wall time then measures the load), best of N:

* the linear wear map, 60 orders x 300 speeds (20-300 km/h), both models, against a
  baseline in the same run: the same resolvent evaluated one (speed, order) at a time
  in a Python loop (``np.linalg.solve`` per pair) instead of one batched solve per speed;
* one simulated window of the evolution (a stable and a vibrating speed), and how its
  cost grows with the number of orders (20, 40, 60);
* the evolution over 60 000 km on the three-speed default drive cycle (tread1dof;
  axle4dof with ``--axle``), in one process (the baseline) and with the windows of the
  cycle's speeds in ``--workers`` processes at once (default 2): wall time, and CPU time
  of this process plus its finished worker processes (on a machine shared with other jobs
  the wall time is the CPU time stretched by the load, so both are printed, with the load);
* with ``--critical-path``, the one-process evolution with every window timed: the CPU
  time per step of the longest window plus everything outside the windows, i.e. what
  the evolution costs in wall time when the cycle's speeds run side by side on idle cores.
"""

from __future__ import annotations

import argparse
import math
import os
import resource
import time

import numpy as np

import polywear.wear.evolution as wear_evolution
from polywear.wear.evolution import evolve, initial_roughness, window_wear
from polywear.wear.map import load_to_power, wear_map
from polywear.models import get_model
from polywear.models.profile import coupled_model, profile_vector
from polywear.params import Params, with_updates


def best_of(repeat, fn):
    """Least CPU time [s] of ``repeat`` calls of ``fn`` and its last result."""
    times, result = [], None
    for _ in range(repeat):
        start = time.process_time()
        result = fn()
        times.append(time.process_time() - start)
    return min(times), result


def looped_map(params, speeds_kmh, K):
    """Baseline: the same transfer function, one (speed, order) pair at a time."""
    model = get_model(params.model)
    p = model.pack(params)
    R = params.operating.rolling_radius_m
    out = np.empty((len(speeds_kmh), K), dtype=complex)
    for i, v in enumerate(speeds_kmh):
        V = v / 3.6
        u0, A, B, C, D = load_to_power(model, p, V)
        for n in range(1, K + 1):
            s = 1j * n * V / R
            out[i, n - 1] = C @ np.linalg.solve(s * np.eye(model.n) - A, B) + D
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--skip-evolution", action="store_true", help="no 60 000 km evolutions")
    parser.add_argument("--axle", action="store_true", help="also the 60 000 km axle4dof evolution (minutes)")
    parser.add_argument("--workers", type=int, default=2, help="worker processes of the parallel evolution")
    parser.add_argument("--critical-path", action="store_true", help="time every window of the one-process evolution")
    args = parser.parse_args()
    speeds = np.linspace(20.0, 300.0, 300)
    for name in ("tread1dof", "axle4dof"):
        params = with_updates(Params(), {"model": name})
        wear_map(params, speeds[:3])
        t_map, _ = best_of(args.repeat, lambda: wear_map(params, speeds))
        t_loop, _ = best_of(1, lambda: looped_map(params, speeds, 60))
        print(f"wear map {name}, 60 orders x 300 speeds: {t_map:.3f} s CPU (looped baseline {t_loop:.3f} s, "
              f"x{t_loop / t_map:.1f})")
    params = Params()
    base = get_model(params.model)
    coupled = coupled_model(base)
    for v_kmh in (50.0, 120.0):
        V = v_kmh / 3.6
        for K in (20, 40, 60):
            p_k = with_updates(params, {"wear.max_order": K})
            W = initial_roughness(p_k)
            u0 = coupled.equilibrium(V, profile_vector(base, p_k, V))
            revs = 16 if v_kmh == 120.0 else 3
            t_win, _ = best_of(args.repeat, lambda: window_wear(p_k, V, W, u0, 0.2, revs, base))
            T = 2 * math.pi * params.operating.rolling_radius_m / V
            print(f"window at {v_kmh:.0f} km/h, {K} orders: {t_win:.3f} s CPU for {0.2 + revs * T:.2f} s simulated")
    if args.skip_evolution:
        return
    for name in ("tread1dof",) + (("axle4dof",) if args.axle else ()):
        p_m = with_updates(params, {"model": name})
        walls = {}
        for workers in (1, args.workers):
            load = os.getloadavg()[0]
            start, cpu = time.perf_counter(), cpu_seconds()
            result = evolve(p_m, 60000.0, workers=workers)
            walls[workers], cpu = time.perf_counter() - start, cpu_seconds() - cpu
            s = result.summary()
            print(f"evolution {name}, 60 000 km, cycle {[c[0] for c in result.cycle]} km/h, {workers} process(es): "
                  f"{walls[workers]:.1f} s wall, {cpu:.1f} s CPU ({len(result.distance_km) - 1} steps; load "
                  f"{load:.1f} on {os.cpu_count()} CPUs); depth {s['final_depth_mm']:.4f} mm, order "
                  f"{s['dominant_order']}, visible {s['visible_km']}")
        print(f"  wall time 1 process / {args.workers}: x{walls[1] / walls[args.workers]:.2f}")
        if args.critical_path:
            critical_path(p_m)


def critical_path(params) -> None:
    """One-process evolution with every window timed (CPU): total, windows, and the
    critical path (per step the longest window, plus all the time outside windows)."""
    calls, steps, depth = [], [], [0]
    original = wear_evolution.window_wear

    def timed(*args, **kwargs):
        start = time.process_time()
        depth[0] += 1  # a lengthened window calls itself again: count the outermost call only
        try:
            return original(*args, **kwargs)
        finally:
            depth[0] -= 1
            if depth[0] == 0:
                calls.append(time.process_time() - start)

    wear_evolution.window_wear = timed
    try:
        start = time.process_time()
        evolve(params, 60000.0, progress=lambda done, total, message="": steps.append(len(calls)))
        total = time.process_time() - start
    finally:
        wear_evolution.window_wear = original
    longest = sum(max(calls[a:b], default=0.0) for a, b in zip([0] + steps[:-1], steps))
    print(f"  critical path {params.model}: {total - sum(calls) + longest:.1f} s CPU of {total:.1f} s "
          f"({len(calls)} windows in {len(steps)} steps, {sum(calls):.1f} s in windows)")


def cpu_seconds() -> float:
    """CPU time [s] of this process and of its finished child processes (the pool's workers)."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


if __name__ == "__main__":
    main()
