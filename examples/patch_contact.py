"""Point contact against patch contact (tread1dof): lateral force, vibration and wear vs toe.

For toe angles 0.02 to 2 deg at the operating speed (110 km/h): the steady lateral force
of both contacts beside the brush model and C_alpha * alpha; the linear band of each
(steady rolling unstable, 20-300 km/h; for the patch at 0.05, 0.5 and 2 deg); what is
left of a 0.27 mm disturbance of the patch after one passage; the linear wear
map's fastest-growing polygon order and its e-folding distance. Writes
``patch_contact.png`` and ``patch_contact.csv`` to the directory given (default
examples/out)::

    .venv/bin/python examples/patch_contact.py [OUT_DIR]

Command-line equivalents: ``polywear friction steady --contact patch --json``,
``polywear stability --set friction.contact=patch``, ``polywear wear map --set friction.contact=patch``.
"""

from __future__ import annotations

import csv
import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import polywear as pw
from polywear.models import model_for
from polywear.models.patch import brush_force, steady_lateral_force
from polywear.units import kmh_to_ms
from polywear.wear.map import wear_map

TOES_DEG = (0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0)
STABILITY_TOES_DEG = (0.05, 0.5, 2.0)
SLIPS_DEG = np.geomspace(0.01, 10.0, 25)


def decay_after_disturbance(params, disturbance_m: float = 2.7e-4, transits: float = 1.0) -> float:
    """Largest tread deflection change left [m] after ``transits`` passages of the patch
    (time 2a/(V cos toe) each) when every element starts ``disturbance_m`` off steady rolling
    (trapezoidal rule, analytic Jacobian)."""
    model = model_for(params)
    p = model.pack(params)
    V = kmh_to_ms(params.operating.speed_kmh)
    steady = model.equilibrium(V, p)
    u = steady.copy()
    u[0::3] += disturbance_m
    t_end = transits * params.tire.contact_length_m / (V * math.cos(math.radians(params.operating.toe_deg)))
    steps = 400
    dt = t_end / steps
    eye = np.eye(model.n)
    for _ in range(steps):
        u0, f0 = u.copy(), model.f(u, V, p)
        for _ in range(20):
            r = u - u0 - 0.5 * dt * (f0 + model.f(u, V, p))
            du = np.linalg.solve(eye - 0.5 * dt * model.jacobian(u, V, p), -r)
            u += du
            if np.abs(du).max() <= 1e-14 + 1e-12 * np.abs(u).max():
                break
    return float(np.abs(u - steady)[0::3].max())


def main(out_dir: Path) -> None:
    out_dir.mkdir(parents=True, exist_ok=True)
    base = pw.load_params()
    patch = base.with_updates({"friction.contact": "patch"})
    rows = []
    for toe in TOES_DEG:
        row = {"toe_deg": toe}
        for name, params in (("point", base), ("patch", patch)):
            params = params.with_updates({"operating.toe_deg": toe})
            if name == "point" or toe in STABILITY_TOES_DEG:  # the patch: 70 ms per speed at M = 40
                bands = pw.stability(params, speed_range_kmh=(20.0, 300.0)).linear_band_kmh
                row[f"{name}_linear_band_kmh"] = "; ".join(f"{a:.1f}-{b:.1f}" for a, b in bands) or "none"
            else:
                row[f"{name}_linear_band_kmh"] = "not computed"
            wm = wear_map(params, [params.operating.speed_kmh])
            if wm.rolling_stable[0]:
                k = int(np.nanargmax(wm.growth_per_1000km[0]))
                row[f"{name}_fastest_order"] = int(wm.orders[k])
                row[f"{name}_efold_km"] = float(wm.efold_km[0, k])
            else:
                row[f"{name}_fastest_order"], row[f"{name}_efold_km"] = None, None  # vibrating
            row[f"{name}_mean_wear_mm_per_1000km"] = float(wm.mean_wear_mm_per_1000km[0])
        row["patch_left_after_one_transit_m"] = (
            decay_after_disturbance(patch.with_updates({"operating.toe_deg": toe})) if toe in STABILITY_TOES_DEG else None)
        rows.append(row)
        print(row, flush=True)
    with open(out_dir / "patch_contact.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)

    forces = {c: steady_lateral_force(base.with_updates({"friction.contact": c}), SLIPS_DEG) for c in ("point", "patch")}
    c_alpha = forces["patch"]["cornering_stiffness_n_per_rad"]
    k, L = base.tread.lateral_stiffness_n_per_m, base.tire.contact_length_m
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11.0, 4.3))
    for c, style in (("point", "C3-"), ("patch", "C0-")):
        ax1.loglog(SLIPS_DEG, [r["force_n"] for r in forces[c]["rows"]], style, label=f"{c} contact")
    ax1.loglog(SLIPS_DEG, brush_force(np.radians(SLIPS_DEG), k / L, L / 2, base.friction.mu_static, 4000.0),
               "k--", lw=1, label="brush, rigid bristle, mu_s")
    ax1.loglog(SLIPS_DEG, c_alpha * np.tan(np.radians(SLIPS_DEG)), "C0:", label=f"C_alpha alpha ({c_alpha / 1e3:.1f} kN/rad)")
    ax1.set_xlabel("slip angle (toe) [deg]")
    ax1.set_ylabel("steady lateral force [N]")
    ax1.set_title("tread1dof at 110 km/h, 4000 N")
    ax1.legend(fontsize=8)
    for c, style in (("point", "C3o-"), ("patch", "C0s-")):
        pts = [(r["toe_deg"], r[f"{c}_efold_km"]) for r in rows if r[f"{c}_efold_km"]]
        ax2.loglog(*zip(*pts), style, label=f"{c} contact")
    ax2.set_xlabel("toe [deg]")
    ax2.set_ylabel("e-folding distance of the fastest polygon order [km]")
    ax2.set_title("linear wear map at 110 km/h (point at 0.5 deg: vibrating)")
    ax2.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out_dir / "patch_contact.png", dpi=110)
    print(f"wrote {out_dir / 'patch_contact.png'} and {out_dir / 'patch_contact.csv'}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path("examples/out"))
