"""Wall time of AUTO-07p's tread1dof bifurcation diagram (reference for the diagram benchmark).

    .venv/bin/python benchmarks/auto07p_timing.py [--repeat N]

Times :func:`polywear.validation.auto07p.tread1dof_diagram` on the defaults, 20-300 km/h:
the native path (bifpy ``transpile=True``: the model is traced, compiled with gfortran
and run as an AUTO-07p executable) split into compiling/linking (every gfortran call
is timed as it happens), AUTO's own solver time (its "Total Time") and the rest
(tracing, bifpy's parsing of AUTO's output files, amplitudes); and, as the baseline
measured in the same run, the interpreted path (AUTO calls back into Python). Prints
the best of ``--repeat`` runs and the ratios.

``time_auto07p_tread1dof(params, speed_range_kmh)`` returns ``(seconds, diagram)`` for
other benchmarks that compare against AUTO.
"""

from __future__ import annotations

import argparse
import subprocess
import time
from contextlib import contextmanager
from typing import Any

from polywear.params import Params
from polywear.validation.auto07p import AutoSettings, tread1dof_diagram


def time_auto07p_tread1dof(
    params: Params,
    speed_range_kmh: tuple[float, float] = (20.0, 300.0),
    settings: AutoSettings = AutoSettings(),
) -> tuple[float, dict[str, Any]]:
    """(wall seconds, diagram) of one AUTO-07p run of the whole tread1dof diagram."""
    start = time.perf_counter()
    diagram = tread1dof_diagram(params, speed_range_kmh, settings)
    return time.perf_counter() - start, diagram


@contextmanager
def gfortran_seconds():
    """Yields a list that collects the wall time of every gfortran call made meanwhile."""
    spent: list[float] = []
    original = subprocess.run

    def timed(args, *rest, **kwargs):
        start = time.perf_counter()
        try:
            return original(args, *rest, **kwargs)
        finally:
            if isinstance(args, (list, tuple)) and args and args[0] == "gfortran":
                spent.append(time.perf_counter() - start)

    subprocess.run = timed
    try:
        yield spent
    finally:
        subprocess.run = original


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="runs per path (best is kept)")
    args = parser.parse_args()
    params = Params()
    time_auto07p_tread1dof(params)  # warm-up: imports, numba caches, page cache

    native = []
    for _ in range(args.repeat):
        with gfortran_seconds() as spent:
            seconds, diagram = time_auto07p_tread1dof(params)
        native.append((seconds, sum(spent), diagram["auto_time_s"]))
    interpreted = [
        time_auto07p_tread1dof(params, settings=AutoSettings(transpile=False))[0] for _ in range(args.repeat)
    ]
    wall, compiling, solving = min(native)
    baseline = min(interpreted)
    cycles = diagram["cycles"]
    print(f"tread1dof diagram 20-300 km/h, AUTO-07p via {diagram['auto']['package']}, best of {args.repeat}")
    print(f"  points: equilibrium {len(diagram['equilibrium']['speed_kmh'])}, "
          f"cycles {sum(len(c['speed_kmh']) for c in cycles)} on {len(cycles)} branch(es)")
    print(f"  native (transpile=True)      {wall:7.2f} s")
    print(f"    compiling and linking      {compiling:7.2f} s")
    print(f"    without compiling          {wall - compiling:7.2f} s")
    print(f"    AUTO's own solver time     {solving:7.2f} s")
    print(f"  interpreted (baseline)       {baseline:7.2f} s")
    print(f"  ratio native / interpreted   {wall / baseline:7.2f}")
    print(f"  ratio native without compiling / interpreted {(wall - compiling) / baseline:7.2f}")


if __name__ == "__main__":
    main()
