"""Start-up time: ``import polywear`` and ``polywear --help`` in fresh processes.

Baseline measured in the same run: a bare ``python -c pass``. Prints the best and the
median of ``--repeat`` runs of each and the time on top of the bare interpreter
(goal: < 0.5 s for each command).

    .venv/bin/python benchmarks/bench_startup.py [--repeat 7]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time
from pathlib import Path


def _time(cmd: list[str], repeat: int) -> list[float]:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        times.append(time.perf_counter() - t0)
    return times


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
    base = min(results["python -c pass (baseline)"])
    print(f"{'command':30s} {'best [s]':>9s} {'median [s]':>11s} {'over baseline [s]':>18s} {'x baseline':>11s}")
    for name, times in results.items():
        best = min(times)
        print(f"{name:30s} {best:9.3f} {statistics.median(times):11.3f} {best - base:18.3f} {best / base:11.1f}")
    for name in ("import polywear", "polywear --help"):
        ok = "met" if min(results[name]) < 0.5 else "NOT met"
        print(f"{name}: goal < 0.5 s {ok}")


if __name__ == "__main__":
    main()
