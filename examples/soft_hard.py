"""Soft and hard self-excitation (the paper's Fig. 2), read from Python.

At 110 km/h (inside the linear band) steady rolling is unstable: any small disturbance
grows into the stable cycle (soft). At 230 km/h (above the upper Hopf speed, below the
fold) steady rolling is stable and a small disturbance dies out, but a start outside the
unstable cycle ends on the large stable one (hard): the unstable cycle's amplitude is the
trigger amplitude. Writes ``soft_hard.png`` to the directory given (default examples/out)::

    .venv/bin/python examples/soft_hard.py [OUT_DIR]

Command-line equivalent: ``polywear excitation --speed 110 --speed 230 --plot soft_hard.png``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

import polywear as pw

SPEEDS_KMH = (110.0, 230.0)


def main(out_dir: Path) -> None:
    out_dir.mkdir(parents=True, exist_ok=True)
    diagram = pw.bifurcation(pw.load_params())
    for region in diagram.trigger_amplitude():
        lo, hi = region["speed_range_kmh"]
        print(f"hard region {lo:.1f}-{hi:.1f} km/h: trigger amplitude of x "
              f"{region['min_x_mm']:.3f} to {region['max_x_mm']:.3f} mm (grows from the Hopf point to the fold)")
    portraits = pw.excitation(diagram, SPEEDS_KMH)
    fig, axes = plt.subplots(1, len(portraits), figsize=(10, 4.4))
    for portrait, ax in zip(portraits, axes):
        s = portrait.summary()
        print(f"{s['speed_kmh']:g} km/h: {s['regime']}")
        for cycle in s["cycles"]:
            print(f"  {'stable' if cycle['stable'] else 'unstable'} cycle, amplitude {cycle['amplitude_x_mm']:.3f} mm")
        for run in s["runs"]:
            print(f"  start {run['start']} ({run['initial_x_mm']:+.3f} mm): {run['outcome']}, "
                  f"final amplitude {run['final_amplitude_x_mm']:.3f} mm")
        portrait.plot(ax=ax)
    fig.tight_layout()
    fig.savefig(out_dir / "soft_hard.png", dpi=110)
    plt.close(fig)
    print(f"wrote {out_dir / 'soft_hard.png'}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).parent / "out")
