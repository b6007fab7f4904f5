"""Quick start from Python: the defaults, the bifurcation diagram, the verdict at 110 km/h.

Run from the repository root (figures go to the directory given, default examples/out)::

    .venv/bin/python examples/quickstart.py [OUT_DIR]

The same numbers as ``polywear stability --json`` and ``polywear bifurcation --json``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # write files, never open a window
import matplotlib.pyplot as plt

import polywear as pw


def bands(intervals) -> str:
    """[[lo, hi], ...] [km/h] as "lo-hi" text (None: open, beyond the analysed range)."""
    return ", ".join(f"{lo:.1f}-{hi:.1f}" if None not in (lo, hi) else f"{lo}-{hi}" for lo, hi in intervals) or "none"


def main(out_dir: Path) -> None:
    out_dir.mkdir(parents=True, exist_ok=True)
    params = pw.load_params()  # built-in defaults: tread1dof, 110 km/h, toe 0.5 deg
    print(f"model {params.model}, toe {params.operating.toe_deg} deg, speed {params.operating.speed_kmh} km/h")

    # 1. linear stability of steady rolling: where it loses stability (Hopf points)
    stab = pw.stability(params)
    for hopf in stab.hopf_points:
        print(f"Hopf point {hopf.speed_kmh:7.2f} km/h, {hopf.frequency_hz:6.1f} Hz, {hopf.criticality}")

    # 2. the bifurcation diagram: stable and unstable cycles, folds, the SEV band
    diagram = pw.bifurcation(params)
    s = diagram.summary()
    print(f"linear band {bands(s['linear_band_kmh'])} km/h (steady rolling unstable)")
    print(f"SEV band {bands(s['sev_band_kmh'])} km/h: first and second bifurcation speeds "
          f"{s['first_bifurcation_speed_kmh']:.1f} and {s['second_bifurcation_speed_kmh']:.1f} km/h")
    print(f"hard self-excitation (needs a large disturbance) in {bands(s['hard_regions_kmh'])} km/h")
    fig = diagram.figure()
    fig.savefig(out_dir / "quickstart_bifurcation.png", dpi=110)
    plt.close(fig)

    # 3. what happens at the operating speed: the cycles there and a simulation
    speed = params.operating.speed_kmh
    x = diagram.state_names.index("x")
    for cycle in diagram.cycles_at(speed):
        kind = "stable" if cycle.stable else "unstable"
        print(f"{speed:g} km/h: {kind} cycle, amplitude {cycle.amplitude[x] * 1e3:.3f} mm, "
              f"{1.0 / cycle.period:.1f} Hz")
    run = pw.simulate(params, speed, duration_s=0.5)
    print(f"simulation from a 0.1 mm disturbance: {run.steady.outcome}, amplitude "
          f"{run.steady.amplitude[x] * 1e3:.3f} mm at {run.steady.frequency:.1f} Hz")
    fig, ax = plt.subplots(figsize=(5, 4))
    run.plot(ax=ax)
    fig.savefig(out_dir / "quickstart_simulation.png", dpi=110)
    plt.close(fig)
    print(f"figures written to {out_dir}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).parent / "out")
