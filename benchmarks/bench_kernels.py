"""CPU time of the two collocation kernels and of the default diagrams.

    PYTHONPATH=src .venv/bin/python benchmarks/bench_kernels.py [--calls 50] [--repeat 20]
        [--diagram-repeat 5] [--json]

For each model, in the order given: the first assembly in the process, on a constant
orbit (CPU time of loading the model's compiled kernels from numba's cache, and for the
first model the assembly kernel too; run once so that the caches exist); then a cycle of
its default bifurcation diagram (the middle point of its
first branch, on that point's mesh: 40 intervals, degree 4) is assembled
(``Collocation.evaluate``: the ``_assemble`` kernel and the model kernels it calls) and
its bordered Newton system (phase row and tangent) solved for two right-hand sides
(``Collocation.solve_system``: ``solve_bordered``); then the whole default diagram is
computed. Times are CPU time (``time.process_time``): the first assembly once; per call, the best of ``--repeat``
batches of ``--calls`` calls; the diagram, the best of ``--diagram-repeat`` runs. The best
of many short batches is what other jobs on a shared machine disturb least.

The script uses only interfaces that predate the kernels it times, so a "before" and an
"after" source tree can be compared by running it alternately with ``PYTHONPATH`` set to
each (``--json`` prints one machine-readable line). ``--compare BEFORE_SRC`` does that:
it runs the script ``--rounds`` times alternately in fresh processes on ``BEFORE_SRC`` (a
``src`` directory holding the old ``polywear``) and on the ``polywear`` imported here, and
prints the best of each; see ``docs/continuation.md``, Speed.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import polywear
from polywear.dynamics.bifurcation import bifurcation
from polywear.models import get_model
from polywear.params import load_params
from polywear.solvers.collocation import Collocation, PeriodicOrbit

QUANTITIES = ("first_assemble_s", "assemble_ms", "solve_ms", "diagram_s")
"""What is timed: the first assembly [s], assembly and bordered solve per call [ms], the diagram [s]."""


def best_cpu(repeat: int, fn) -> float:
    """Best CPU time [s] of ``repeat`` calls of ``fn``."""
    times = []
    for _ in range(repeat):
        start = time.process_time()
        fn()
        times.append(time.process_time() - start)
    return min(times)


def first_assembly(model_name: str) -> float:
    """CPU time [s] of the first ``Collocation.evaluate`` of a model in this process: loading
    its compiled kernels (and, the first time, the assembly) from numba's cache."""
    params = load_params(overrides=[f"model={model_name}"])
    model = get_model(params.model)
    p = model.pack(params)
    V = 100.0 / 3.6
    mesh = np.linspace(0.0, 1.0, 5)
    orbit = PeriodicOrbit(mesh, np.tile(model.equilibrium(V, p), (4 * 4, 1)), 0.01, V)
    coll = Collocation(model, p, mesh)
    X = coll.pack(orbit)
    start = time.process_time()
    coll.evaluate(X)
    return time.process_time() - start


def kernel_times(model_name: str, calls: int, repeat: int, diagram_repeat: int) -> dict[str, float]:
    """CPU time [s] of the first assembly in the process (:func:`first_assembly`), per-call CPU
    time [ms] of assembly and bordered solve on a cycle of the default diagram, and the CPU
    time [s] of the whole default diagram."""
    first = first_assembly(model_name)
    params = load_params(overrides=[f"model={model_name}"])
    diagram = bifurcation(params)  # compiles or loads the caches
    branch = diagram.branches[0]
    point = branch.points[len(branch.points) // 2]
    model = get_model(params.model)
    coll = Collocation(model, model.pack(params), point.orbit.mesh, point.orbit.m)
    X = coll.pack(point.orbit)
    border = np.vstack([coll.phase_row(point.orbit), point.tangent])
    rhs = np.zeros((coll.size, 2))
    rhs[:-2, 0] = -coll.evaluate(X)[0]
    rhs[-1, 1] = 1.0
    parts = coll.evaluate(X)[1:]

    def assemble() -> None:
        for _ in range(calls):
            coll.evaluate(X)

    def solve() -> None:
        for _ in range(calls):
            coll.solve_system(*parts, border, rhs)

    return {
        "first_assemble_s": first,
        "assemble_ms": 1e3 * best_cpu(repeat, assemble) / calls,
        "solve_ms": 1e3 * best_cpu(repeat, solve) / calls,
        "diagram_s": best_cpu(diagram_repeat, lambda: bifurcation(params)),
        "N": coll.N,
        "n": coll.n,
    }


def compare(before_src: str, rounds: int, passthrough: list[str]) -> None:
    """Alternate fresh-process runs on ``before_src`` and on this polywear; print the best of each."""
    trees = {"before": before_src, "after": str(Path(polywear.__file__).parents[1])}
    best: dict[str, dict] = {}
    for _ in range(rounds):
        for label, src in trees.items():
            env = {**os.environ, "PYTHONPATH": src}
            out = subprocess.run([sys.executable, __file__, "--json", *passthrough], env=env, check=True,
                                 capture_output=True, text=True).stdout
            for name, r in json.loads(out.splitlines()[-1]).items():
                old = best.setdefault(label, {}).setdefault(name, r)
                for key in QUANTITIES:
                    old[key] = min(old[key], r[key])
    print(f"best of {rounds} alternating runs; before = {trees['before']}, after = {trees['after']}")
    print(f"{'model':10s} {'quantity':16s} {'before':>10s} {'after':>10s} {'after/before':>13s}")
    for name in best["before"]:
        for key in QUANTITIES:
            b, a = best["before"][name][key], best["after"][name][key]
            print(f"{name:10s} {key:16s} {b:10.4f} {a:10.4f} {a / b:13.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=50)
    parser.add_argument("--repeat", type=int, default=20)
    parser.add_argument("--diagram-repeat", type=int, default=5)
    parser.add_argument("--models", nargs="+", default=["axle4dof", "tread1dof"])
    parser.add_argument("--json", action="store_true", help="one JSON line instead of the table")
    parser.add_argument("--compare", metavar="BEFORE_SRC", help="compare with the polywear in this src directory")
    parser.add_argument("--rounds", type=int, default=3, help="alternating runs per tree for --compare")
    args = parser.parse_args()
    if args.compare:
        compare(args.compare, args.rounds, ["--calls", str(args.calls), "--repeat", str(args.repeat),
                                            "--diagram-repeat", str(args.diagram_repeat), "--models", *args.models])
        return
    results = {name: kernel_times(name, args.calls, args.repeat, args.diagram_repeat) for name in args.models}
    if args.json:
        print(json.dumps(results))
        return
    print(f"{'model':10s} {'mesh':>8s} {'first assembly [s]':>19s} {'_assemble [ms]':>15s} "
          f"{'solve_bordered [ms]':>20s} {'diagram [s]':>12s}")
    for name, r in results.items():
        print(f"{name:10s} {r['N']:>4d}x{r['n']:<3d} {r['first_assemble_s']:19.3f} {r['assemble_ms']:15.3f} "
              f"{r['solve_ms']:20.3f} {r['diagram_s']:12.3f}")


if __name__ == "__main__":
    main()
