"""The fuzz harness of the command line run longer than in CI (tests/test_cli_fuzz.py).

Runs every property of tests/test_cli_fuzz.py with ``--examples`` generated cases each
(CI runs 40) in a child pytest, and prints per property the outcome, the wall time and
the child's CPU time (user + system; less sensitive to other jobs on a shared machine),
then the slowest calls (CPU time and arguments). Every call is stopped after
``--call-cpu-s`` of CPU (10 times that of wall time) and fails its property with its
arguments, so a call that hangs is found instead of hanging the run. A failing case is
printed by hypothesis (as found with ``--no-shrink``, else the smallest example: shrinking
a slow call repeats it); the exit code is pytest's.

    .venv/bin/python benchmarks/bench_fuzz.py [--examples 2000] [-k input_file_kind] [--call-cpu-s 60] [--no-shrink]
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--examples", type=int, default=2000, help="generated cases per property")
    parser.add_argument("-k", default="", help="only the properties whose name contains this (pytest -k)")
    parser.add_argument("--call-cpu-s", type=float, default=120.0, help="CPU limit of one call [s]")
    parser.add_argument("--no-shrink", action="store_true", help="report a failing case as found")
    parser.add_argument("--slowest", type=int, default=10, help="slowest calls printed")
    args = parser.parse_args()
    cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "--durations=0",
           "tests/test_cli_fuzz.py", *(["-k", args.k] if args.k else [])]
    log = Path(tempfile.mkstemp(prefix="fuzz_calls_", suffix=".tsv")[1])
    env = {**os.environ, "POLYWEAR_FUZZ_EXAMPLES": str(args.examples), "POLYWEAR_FUZZ_CALL_CPU_S": str(args.call_cpu_s),
           "POLYWEAR_FUZZ_SHRINK": "0" if args.no_shrink else "1", "POLYWEAR_FUZZ_LOG": str(log)}
    c0, t0 = _cpu(), time.perf_counter()
    run = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
    wall, cpu = time.perf_counter() - t0, _cpu() - c0
    lines = run.stdout.splitlines()
    durations = re.compile(r"^[\d.]+s call ")  # pytest --durations lines (not "most recent call last")
    print("\n".join(line for line in lines if durations.match(line) or "passed" in line or "failed" in line
                    or line.startswith(("E ", "FAILED"))))
    calls = [line.split("\t", 1) for line in log.read_text().splitlines()]
    log.unlink()
    calls.sort(key=lambda c: -float(c[0]))
    print(f"{len(calls)} calls; the slowest (CPU s, arguments):")
    for spent, call in calls[:args.slowest]:
        print(f"  {float(spent):8.2f}  {call}")
    print(f"{args.examples} examples per property: wall {wall:.1f} s, CPU {cpu:.1f} s "
          f"(load average {os.getloadavg()[0]:.1f}), exit {run.returncode}")
    return run.returncode


if __name__ == "__main__":
    sys.exit(main())
