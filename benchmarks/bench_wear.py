"""Timing of the wear analysis: the linear map and the nonlinear evolution.

    .venv/bin/python benchmarks/bench_wear.py [--repeat 3] [--skip-evolution] [--axle] [--km 60000]
                                             [--cycle default|110] [--only-fast]

Measured in one process, warm (compiled kernels cached), as CPU time (``time.process_time``:
the machine may be shared, and wall time then measures the load), best of N:

* the linear wear map, 60 orders x 300 speeds (20-300 km/h), both models, against a
  baseline in the same run: the same resolvent evaluated one (speed, order) at a time
  in a Python loop (``np.linalg.solve`` per pair) instead of one batched solve per speed;
* one simulated window of the evolution (a stable and a vibrating speed) with 20, 40 and
  60 orders, against the window of the evolution before it was made fast
  (``benchmarks/wear_evolution_baseline.py``: the load summed over every harmonic in every
  right-hand side, tolerance 1e-8, padded spectrum);
* the evolution over ``--km`` (default 60 000 km) on the three-speed default drive cycle
  (``--cycle 110``: 110 km/h alone), tread1dof (axle4dof too with ``--axle``), in one
  process: the fast evolution (``polywear.wear.evolution.wear_evolution``) and the baseline
  (today's implementation before issue 22, fixed 1000 km steps) in the same run, CPU and
  wall time, their ratio, the load, and the answers side by side (visible distance, depth
  at the end, dominant order); the fast one twice: in one thread, and with the cycle's
  speeds in threads (the default, at most one per CPU; the same answer bit for bit);
* with ``--design`` instead: the report's search for what stops the polygon on the default
  car (``--axle``: axle4dof) over 100 000 km on the default cycle, from the nominal car's
  evolution run once: one grid level screened and refined by one round (the axle4dof report's
  default) against the refined search (``--wear-design``), wall and CPU time, their ratio
  and the answers side by side.
"""

from __future__ import annotations

import argparse
import math
import os
import time
from functools import partial

import numpy as np

import wear_evolution_baseline as baseline
from polywear.wear.evolution import wear_evolution, initial_roughness
from polywear.wear.windows import window_wear
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


def design_search(model: str, km: float = 100000.0) -> None:
    """The report's wear design on the default ``model`` car: one grid level, screened, refined
    by one round, against the refined search (both from one nominal evolution), wall and CPU."""
    from polywear.report.main import report_search
    from polywear.wear.design import wear_design

    params = with_updates(Params(), {"model": model})
    nominal = wear_evolution(params, km)
    runs = {}
    for label, refined in (("one grid level, one round", False), ("refined", True)):
        load = os.getloadavg()[0]
        start, cpu = time.perf_counter(), time.process_time()
        found = wear_design(params, target_km=km, settings=report_search(refined), nominal=nominal)
        runs[label] = (time.perf_counter() - start, time.process_time() - cpu)
        answers = "; ".join(f"{o.label} {o.relative_change:+.1%}" + (
            f" (or {o.other_direction['relative_change']:+.1%})" if o.other_direction else "") for o in found.options)
        print(f"wear design {model}, {km:,.0f} km, {label}: {runs[label][0]:.1f} s wall, {runs[label][1]:.1f} s CPU "
              f"(load {load:.1f}; {found.evolutions} evolutions): {answers or 'no option'}")
    (wall_one, cpu_one), (wall_all, cpu_all) = runs["one grid level, one round"], runs["refined"]
    print(f"  one grid level, one round / refined: x{wall_all / wall_one:.1f} less wall, x{cpu_all / cpu_one:.1f} less CPU")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--skip-evolution", action="store_true", help="no evolutions")
    parser.add_argument("--axle", action="store_true", help="also the axle4dof evolution (baseline: minutes)")
    parser.add_argument("--km", type=float, default=60000.0, help="distance of the evolutions [km]")
    parser.add_argument("--cycle", choices=("default", "110"), default="default",
                        help="the default three-speed drive cycle, or 110 km/h alone")
    parser.add_argument("--only-fast", action="store_true", help="the fast evolution only (no baseline run)")
    parser.add_argument("--design", action="store_true",
                        help="only the report's wear design search: one grid level and one round against the refined search")
    args = parser.parse_args()
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
    if args.design:
        design_search("axle4dof" if args.axle else "tread1dof")
        return
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
            window_wear(p_k, V, W, u0, 0.2, revs, base)  # warm: numba compiles a kernel on its first call
            baseline.window_wear(p_k, V, W, u0, 0.2, revs, base)
            t_win, _ = best_of(args.repeat, lambda: window_wear(p_k, V, W, u0, 0.2, revs, base))
            t_old, _ = best_of(args.repeat, lambda: baseline.window_wear(p_k, V, W, u0, 0.2, revs, base))
            T = 2 * math.pi * params.operating.rolling_radius_m / V
            print(f"window at {v_kmh:.0f} km/h, {K} orders, {0.2 + revs * T:.2f} s simulated: {t_win:.3f} s CPU "
                  f"(baseline {t_old:.3f} s, x{t_old / t_win:.1f})")
    if args.skip_evolution:
        return
    cycle = None if args.cycle == "default" else ((110.0, 1.0),)
    for name in ("tread1dof",) + (("axle4dof",) if args.axle else ()):
        p_m = with_updates(params, {"model": name})
        runs = {}
        threads = min(os.cpu_count() or 1, len(cycle or params.wear.cycle))
        for label, run in (("fast", partial(wear_evolution, workers=1)),
                           (f"fast, {threads} threads", wear_evolution), ("baseline", baseline.wear_evolution)):
            if label == "baseline" and args.only_fast or label.endswith("threads") and threads == 1:
                continue
            load = os.getloadavg()[0]
            start, cpu = time.perf_counter(), time.process_time()
            result = run(p_m, args.km, cycle=cycle)
            wall, cpu = time.perf_counter() - start, time.process_time() - cpu
            runs[label] = (cpu, result.summary(), wall)
            s = runs[label][1]
            visible = f"{s['visible_km']:,.0f} km" if s["visible_km"] is not None else "not visible"
            print(f"evolution {name}, {args.km:,.0f} km, cycle {[c[0] for c in result.cycle]} km/h, {label}: "
                  f"{cpu:.1f} s CPU, {wall:.1f} s wall (load {load:.1f}; {len(result.distance_km) - 1} steps, "
                  f"{result.settings.get('windows', '')} windows); visible {visible}, depth "
                  f"{s['final_depth_mm']:.4f} mm, order {s['dominant_order']}")
        if "baseline" in runs:
            (t_fast, fast, _), (t_base, old, wall_base) = runs["fast"], runs["baseline"]
            visible = (f"{fast['visible_km'] / old['visible_km'] - 1:+.2%}"
                       if fast["visible_km"] is not None and old["visible_km"] is not None
                       else f"{fast['visible_km']} vs {old['visible_km']}")
            print(f"  fast / baseline: x{t_base / t_fast:.1f} less CPU; visible distance {visible}, depth "
                  f"{fast['final_depth_mm'] / old['final_depth_mm'] - 1:+.2%}, order {fast['dominant_order']} vs "
                  f"{old['dominant_order']}")
            if f"fast, {threads} threads" in runs:
                print(f"  fast in {threads} threads / baseline: x{wall_base / runs[f'fast, {threads} threads'][2]:.1f} "
                      "less wall time")


if __name__ == "__main__":
    main()
