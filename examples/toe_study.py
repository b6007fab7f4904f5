"""How the static toe angle moves the SEV band (tread1dof), from Python.

For a few toe angles: the linear band (steady rolling unstable) and the SEV band (any
stable vibration, first and second bifurcation speeds) from full bifurcation diagrams,
and a check of the exact law of tread1dof that both Hopf speeds scale as 1/sin(toe).
Writes ``toe_study.png`` and ``toe_study.csv`` to the directory given (default
examples/out)::

    .venv/bin/python examples/toe_study.py [OUT_DIR]

The command-line equivalent of one row: ``polywear bifurcation --set operating.toe_deg=0.6 --json``.
"""

from __future__ import annotations

import csv
import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

import polywear as pw

TOES_DEG = (0.4, 0.5, 0.6, 0.8)


def main(out_dir: Path) -> None:
    out_dir.mkdir(parents=True, exist_ok=True)
    base = pw.load_params()  # or pw.load_params("my_car.toml", ["operating.speed_kmh=90"])
    reference = pw.stability(base).hopf_points  # at the default toe, 0.5 deg
    rows = []
    for toe in TOES_DEG:
        params = base.with_updates({"operating.toe_deg": toe})
        s = pw.bifurcation(params, speed_range_kmh=(20.0, 400.0)).summary()
        (lin_lo, lin_hi), = s["linear_band_kmh"]
        (sev_lo, sev_hi), = s["sev_band_kmh"]
        # tread1dof: speed enters only through V sin(toe), so V_H sin(toe) is constant
        scale = math.sin(math.radians(base.operating.toe_deg)) / math.sin(math.radians(toe))
        predicted = [h.speed_kmh * scale for h in reference]
        rows.append({"toe_deg": toe, "linear_lo_kmh": lin_lo, "linear_hi_kmh": lin_hi,
                     "sev_lo_kmh": sev_lo, "sev_hi_kmh": sev_hi})
        print(f"toe {toe:.2f} deg: linear band {lin_lo:6.1f}-{lin_hi:6.1f} km/h "
              f"(1/sin(toe) law: {predicted[0]:6.1f}-{predicted[1]:6.1f}), SEV band {sev_lo:6.1f}-{sev_hi:6.1f} km/h")

    with open(out_dir / "toe_study.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)

    fig, ax = plt.subplots(figsize=(6, 4))
    toe = [r["toe_deg"] for r in rows]
    ax.fill_between(toe, [r["sev_lo_kmh"] for r in rows], [r["sev_hi_kmh"] for r in rows],
                    color="C1", alpha=0.25, label="SEV band (hard at its upper end)")
    ax.fill_between(toe, [r["linear_lo_kmh"] for r in rows], [r["linear_hi_kmh"] for r in rows],
                    color="C3", alpha=0.35, label="linear band (steady rolling unstable)")
    ax.axhline(base.operating.speed_kmh, color="k", lw=0.8, ls="--", label="operating speed")
    ax.set_xlabel("static toe-in [deg]")
    ax.set_ylabel("speed [km/h]")
    ax.set_title("tread1dof: where the tread self-excites")
    ax.legend(fontsize="small")
    fig.tight_layout()
    fig.savefig(out_dir / "toe_study.png", dpi=110)
    plt.close(fig)
    print(f"wrote {out_dir / 'toe_study.png'} and {out_dir / 'toe_study.csv'}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).parent / "out")
