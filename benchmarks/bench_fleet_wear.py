"""Fleet wear risk benchmark (issue 22 section 5): the cost per car of ``fleet(..., wear_km=D)``
and the projection to 1 000 cars on 2 cores (nothing is asserted).

    .venv/bin/python benchmarks/bench_fleet_wear.py sample --samples 40 [--wear-km 60000]
    .venv/bin/python benchmarks/bench_fleet_wear.py full --samples 1000 [--workers 2]

The fleet is the seven-parameter tread1dof fleet of ``bench_fleet.py fleet`` (toe, load,
damping, adhesion, mass, stiffness, camber; usage 110/130 km/h at 60/40 %), every car's
wear evolved over ``--wear-km`` on that cycle with the default step and work budgets
(``fleet.wear_max_steps``, ``fleet.wear_max_revolutions``); the nominal car's band reference is made outside the timings.

``sample``: the cars run serially in this process, one per batch, so the CPU time of every
car (band and evolution) is read from the progress after it; prints the per-car CPU
(median, 90 %, largest), the cars over the step budget with their CPU and parameters,
and the projection to 1 000 cars on 2 free cores: (pilot stage + 1 000 x the mean CPU
per car) / 2. CPU times do not depend on the load (they grow a little with it: shared
caches); wall times do, so the load average is printed.

``full``: the whole fleet on ``--workers`` local processes (batches of 4 cars, so a slow
car does not hold back a long batch): wall time and CPU (this process and the pool's
workers), and the cars over the step budget with their parameters.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_fleet import _cpu, _fleet_reference, _fleet_spec  # noqa: E402  (the band benchmark's fleet)

from polywear.params import Params  # noqa: E402
from polywear.studies.fleet import fleet  # noqa: E402


def sample(n: int, wear_km: float, target: int = 1000) -> None:
    spec = _fleet_spec(n)
    reference = _fleet_reference(spec)
    marks: list[tuple[float, float]] = []  # (cars done, CPU [s]) at the last report of that count

    def progress(done, total, message=""):
        if marks and done == marks[-1][0]:
            marks.pop()
        marks.append((done, time.process_time()))

    start = time.process_time()
    t = time.perf_counter()
    result = fleet(Params(), spec, backend="serial", batch_size=1, reference=reference, wear_km=wear_km,
                   progress=progress)
    wall = time.perf_counter() - t
    done = np.array([m[0] for m in marks])
    times = np.array([m[1] for m in marks])
    first = int(np.flatnonzero(done >= 1)[0])
    setup = times[first - 1] - start if first else 0.0  # the pilot stage (its progress reports 0 cars done)
    per_car = np.diff(times[first - 1:]) if first else np.diff(np.r_[start, times])
    s = result.summary()
    over = [i for i, c in enumerate(result.outcomes) if c.wear]
    typical = np.delete(per_car, over)
    print(f"tread1dof wear risk, {n} cars over {wear_km:,.0f} km, serial in one process: CPU {times[-1] - start:.1f} s "
          f"(pilot stage {setup:.1f} s, {s['settings']['pilot_cars']} pilot cars), wall {wall:.1f} s at load average "
          f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    print(f"  CPU per car: median {np.median(per_car):.2f} s, 90 % {np.percentile(per_car, 90):.2f} s, largest "
          f"{per_car.max():.2f} s (car {int(per_car.argmax())}), mean {per_car.mean():.2f} s; without the "
          f"{len(over)} car(s) over the step budget: mean {typical.mean():.2f} s, largest {typical.max():.2f} s")
    for i in over:
        print(f"  car {i} over the budget ({per_car[i]:.1f} s CPU): {result.outcomes[i].wear}; "
              + ", ".join(f"{k} = {v:.6g}" for k, v in zip(result.keys, result.samples[i])))
    print(f"  wear risk {s['wear_risk_probability']:.3f} {s['wear_risk_ci']} over {s['wear_n_evaluated']} cars, "
          f"most dangerous order {s['wear_most_dangerous_order']}, orders {s['wear_orders']}, visible km "
          f"{s['wear_visible_km']}; band risk {s['risk_probability']:.3f}; failed {s['failed_samples']}")
    pilot_target = min(32, target // 32) / max(s["settings"]["pilot_cars"], 1) * setup
    projected = pilot_target + target * per_car.mean()
    print(f"  {target} cars: CPU ~{projected / 60:.1f} min, wall on 2 free cores ~{projected / 2 / 60:.1f} min "
          f"(pilot stage scaled to {min(32, target // 32)} cars; the mean per car includes the "
          f"{len(over)}/{n} over the budget)")


def full(n: int, wear_km: float, workers: int) -> None:
    spec = _fleet_spec(n)
    reference = _fleet_reference(spec)
    c, t = _cpu(), time.perf_counter()
    result = fleet(Params(), spec, backend="processes", workers=workers, batch_size=4, reference=reference,
                   wear_km=wear_km)
    wall, cpu = time.perf_counter() - t, _cpu() - c
    s = result.summary()
    print(f"tread1dof wear risk, {n} cars over {wear_km:,.0f} km on {workers} processes: wall {wall / 60:.1f} min, "
          f"CPU {cpu / 60:.1f} min = {cpu / n:.2f} s per car (load average {os.getloadavg()[0]:.1f}); "
          f"wear risk {s['wear_risk_probability']:.3f} {s['wear_risk_ci']} over {s['wear_n_evaluated']} cars, "
          f"over the step budget {s['wear_over_budget']}, failed {s['failed_samples']}; most dangerous order "
          f"{s['wear_most_dangerous_order']}, band risk {s['risk_probability']:.3f}")
    for i, outcome in enumerate(result.outcomes):
        if outcome.wear:
            print(f"  car {i} over the budget: {outcome.wear}; "
                  + ", ".join(f"{k} = {v:.6g}" for k, v in zip(result.keys, result.samples[i])))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("what", choices=("sample", "full"))
    parser.add_argument("--samples", type=int, default=40)
    parser.add_argument("--wear-km", type=float, default=60000.0, help="distance of every car's evolution [km]")
    parser.add_argument("--workers", type=int, default=2, help="full: local processes")
    args = parser.parse_args()
    if args.what == "sample":
        sample(args.samples, args.wear_km)
    else:
        full(args.samples, args.wear_km, args.workers)


if __name__ == "__main__":
    main()
