"""Start-up time: ``import polywear`` and ``polywear --help`` in fresh processes.

Baseline measured in the same run: a bare ``python -c pass``. Prints the best and the
median wall time of ``--repeat`` runs of each, the best CPU time (user + system of the
child; less sensitive to other jobs on a shared machine) and the wall time on top of
the bare interpreter (goal: < 0.5 s for each command).

    .venv/bin/python benchmarks/bench_startup.py [--repeat 7]
"""

from __future__ import annotations

import argparse
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path


def _cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _time(cmd: list[str], repeat: int) -> tuple[list[float], list[float]]:
    wall, cpu = [], []
    for _ in range(repeat):
        c0, t0 = _cpu(), time.perf_counter()
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        wall.append(time.perf_counter() - t0)
        cpu.append(_cpu() - c0)
    return wall, cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    args = parser.parse_args()
    exe = sys.executable
    cli = str(Path(exe).parent / "polywear")
    cases = {
        "python -c pass (baseline)": [exe, "-c", "pass"],
        "import polywear": [exe, "-c", "import polywear"],
        "polywear --help": [cli, "--help"],
    }
    results = {name: _time(cmd, args.repeat) for name, cmd in cases.items()}
    base = min(results["python -c pass (baseline)"][0])
    print(f"{'command':28s} {'best wall [s]':>14s} {'median [s]':>11s} {'best CPU [s]':>13s} "
          f"{'over baseline [s]':>18s} {'x baseline':>11s}")
    for name, (wall, cpu) in results.items():
        best = min(wall)
        print(f"{name:28s} {best:14.3f} {statistics.median(wall):11.3f} {min(cpu):13.3f} "
              f"{best - base:18.3f} {best / base:11.1f}")
    for name in ("import polywear", "polywear --help"):
        ok = "met" if min(results[name][0]) < 0.5 else "NOT met"
        print(f"{name}: goal < 0.5 s (best wall) {ok}")


if __name__ == "__main__":
    main()
