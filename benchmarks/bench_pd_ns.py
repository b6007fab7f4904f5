"""Cost and accuracy of the PD/NS location on the complex axle4dof samples.

    .venv/bin/python benchmarks/bench_pd_ns.py [--samples 13,16,34,36,42,43,52,63,72] [--json out.json]

The samples are those of ``bench_fleet.py`` (axle4dof, every parameter of the sensitivity
study within +-10 % of its default, seed 0) whose diagrams have four Hopf points and many
period doublings (PD) and torus bifurcations (NS). Per sample: CPU time of the full diagram
(on the fixed range), the located PD/NS points, the correctors spent locating them (the
Newton correctors inside ``_locate_crossing``) and the largest distance of a located point's
multiplier from the crossing (|mu + 1| for PD, ||mu| - 1| for NS). Run it on an older commit
(e.g. in a ``git worktree``) for the numbers of another locator; ``--json`` writes the
special points and band edges for a comparison.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench_fleet import _samples

from polywear.dynamics.bifurcation import bifurcation
from polywear.studies.fast_band import _FIXED_RANGE
from polywear.params import Params, with_updates
from polywear.solvers.continuation import from_hopf, stepper

COMPLEX_SAMPLES = (13, 16, 34, 36, 42, 43, 52, 63, 72)


def _counting_correctors():
    """Make the branches' ``_locate_crossing`` count the correctors it calls; returns the counter."""
    count = {"inside": False, "correctors": 0, "calls": 0}
    correct, locate = stepper._Stepper.correct, from_hopf._locate_crossing

    def counted_correct(self, *args, **kwargs):
        count["correctors"] += count["inside"]
        return correct(self, *args, **kwargs)

    def counted_locate(*args, **kwargs):
        count["inside"], count["calls"] = True, count["calls"] + 1
        try:
            return locate(*args, **kwargs)
        finally:
            count["inside"] = False

    stepper._Stepper.correct = counted_correct
    from_hopf._locate_crossing = counted_locate
    return count


def _residual(label: str, multipliers: np.ndarray) -> float:
    mu = np.delete(multipliers, int(np.argmin(np.abs(multipliers - 1.0))))
    if label == "PD":
        return float(np.min(np.abs(mu + 1.0)))
    pair = mu[np.abs(mu.imag) >= 1e-8 * np.abs(mu)]
    return float(np.min(np.abs(np.abs(pair) - 1.0))) if pair.size else np.inf


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", default=",".join(map(str, COMPLEX_SAMPLES)))
    parser.add_argument("--json", default="")
    args = parser.parse_args()
    indices = [int(i) for i in args.samples.split(",")]
    samples = _samples(with_updates(Params(), {"model": "axle4dof"}), max(indices) + 1, 0)
    count = _counting_correctors()
    bifurcation(samples[indices[0]], **_FIXED_RANGE)  # compile / load caches
    total_cpu = total_points = total_correctors = total_calls = 0
    worst = 0.0
    out = {}
    for i in indices:
        count.update(correctors=0, calls=0)
        t = time.process_time()
        diagram = bifurcation(samples[i], **_FIXED_RANGE)
        cpu = time.process_time() - t
        located = [(label, pt) for b in diagram.branches for label, pt, _ in b.special if label in ("PD", "NS")]
        residual = max((_residual(label, pt.multipliers) for label, pt in located), default=0.0)
        n_pd = sum(label == "PD" for label, _ in located)
        print(f"sample {i:3d}: {cpu:5.2f} s CPU, {n_pd:2d} PD {len(located) - n_pd:2d} NS, "
              f"{count['calls']:2d} count changes, {count['correctors']:3d} correctors, "
              f"largest distance from the crossing {residual:.1e}")
        total_cpu += cpu
        total_points += len(located)
        total_correctors += count["correctors"]
        total_calls += count["calls"]
        worst = max(worst, residual)
        out[i] = {"cpu_s": cpu, "special": [(s.kind.value, s.speed_kmh) for s in diagram.special],
                  "hopf_kmh": [h.speed_kmh for h in diagram.hopf_points],
                  "stable_kmh": diagram.stable_cycle_intervals_kmh(), "sev_kmh": diagram.sev_band_kmh}
    print(f"total: {total_cpu:.2f} s CPU, {total_points} PD/NS points from {total_calls} count changes, "
          f"{total_correctors} correctors ({total_correctors / max(total_points, 1):.1f} per point), "
          f"largest distance from the crossing {worst:.1e}")
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
