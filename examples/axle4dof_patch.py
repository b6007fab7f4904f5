"""Point contact against patch contact on axle4dof: SEV band, amplitude and cost vs toe and M.

For toe angles 0 to 2 deg (camber -1 deg, running reference: the defaults): the linear
band (steady rolling unstable, 20-300 km/h) of both contacts; for the patch the least
damped eigenvalue over the speeds, overall and among the modes of 50-250 Hz (where the
point contact's vibration lives); time simulations at 110 km/h (and 40 km/h) from a kick of
the size of the point contact's limit cycle; the cost of a steady state, a Jacobian and
an eigenvalue problem against M. Writes ``axle4dof_patch.png`` and ``axle4dof_patch.csv``
to the directory given (default examples/out); with ``--wear``, instead, the wear map at
110 km/h and the 60 000 km evolutions (110 km/h, default cycle) of both contacts per toe,
``axle4dof_patch_wear.csv`` (some 15 minutes of CPU time)::

    OMP_NUM_THREADS=1 .venv/bin/python examples/axle4dof_patch.py [OUT_DIR] [--wear]

(one BLAS thread: on a loaded machine a threaded eigenvalue solve spins and its CPU time
means nothing). Command-line equivalent of a row: ``polywear stability --set model=axle4dof
--set friction.contact=patch --set operating.toe_deg=0.5``.
"""

from __future__ import annotations

import csv
import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import polywear as pw
from polywear.dynamics.simulation import simulate
from polywear.dynamics.stability import StabilitySettings, equilibrium_eigenvalues
from polywear.models import model_for
from polywear.units import kmh_to_ms

TOES_DEG = (0.0, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0)
SPEEDS_KMH = (20.0, 300.0)
SEV_HZ = (50.0, 250.0)
BASE = pw.Params().with_updates({"model": "axle4dof"})
PATCH = {"friction.contact": "patch"}


def _band(params, n_speeds):
    result = pw.stability(params, SPEEDS_KMH, StabilitySettings(n_speeds=n_speeds))
    return [tuple(round(v, 1) for v in b) for b in result.linear_band_kmh]


def _least_damped(params, speeds_kmh):
    """Max over speeds of the largest real part [1/s], overall and in SEV_HZ, with the
    frequency [Hz] and speed [km/h] where it is reached."""
    model = model_for(params)
    p = model.pack(params)
    _, eig = equilibrium_eigenvalues(model, p, kmh_to_ms(np.asarray(speeds_kmh)))
    hz = np.abs(eig.imag) / (2 * np.pi)
    out = []
    for mask in (np.ones_like(hz, dtype=bool), (hz >= SEV_HZ[0]) & (hz <= SEV_HZ[1])):
        re = np.where(mask, eig.real, -np.inf)
        i, k = np.unravel_index(np.argmax(re), re.shape)
        out.append((float(re[i, k]), float(hz[i, k]), float(speeds_kmh[i])))
    return out, eig


def _sev_max(eig):
    """Largest real part [1/s] among the eigenvalues of SEV_HZ, per speed."""
    hz = np.abs(eig.imag) / (2 * np.pi)
    return np.where((hz >= SEV_HZ[0]) & (hz <= SEV_HZ[1]), eig.real, -np.inf).max(axis=1)


def _kicked(params, speed_kmh, duration_s=0.5):
    """Simulate from the equilibrium kicked by the point contact's limit cycle at 0.5 deg,
    110 km/h (toe and camber rates 0.019 and 0.053 rad/s; every element 0.27 mm, 0.23 m/s)."""
    model = model_for(params)
    V = kmh_to_ms(speed_kmh)
    u = model.equilibrium(V, model.pack(params)).copy()
    u[3] += 0.0185
    u[4] += 0.053
    u[6::3] += 2.7e-4
    u[7::3] += 0.23
    return simulate(params, speed_kmh, duration_s, initial=u).summary()


def _cost(elements, speed_kmh=110.0, repeat=5):
    params = BASE.with_updates({**PATCH, "friction.patch_elements": elements, "operating.toe_deg": 0.5})
    model = model_for(params)
    p = model.pack(params)
    V = kmh_to_ms(speed_kmh)
    u = model.equilibrium(V, p)
    J = model.jacobian(u, V, p)
    np.linalg.eigvals(J)
    times = []
    for fn in (lambda: model.equilibrium(V, p), lambda: model.jacobian(u, V, p), lambda: np.linalg.eigvals(J)):
        t = time.process_time()
        for _ in range(repeat):
            fn()
        times.append((time.process_time() - t) / repeat * 1e3)
    ev = np.linalg.eigvals(J)
    i = int(np.argmax(ev.real))
    return model.n, times, float(ev[i].real), float(abs(ev[i].imag) / (2 * np.pi))


def main(out_dir: Path) -> None:
    out_dir.mkdir(parents=True, exist_ok=True)
    rows = []
    speeds = np.linspace(*SPEEDS_KMH, 57)
    curves = {}
    for toe in TOES_DEG:
        point = BASE.with_updates({"operating.toe_deg": toe})
        patch = point.with_updates(PATCH)
        (overall, sev), eig = _least_damped(patch, speeds)
        _, eig_point = _least_damped(point, speeds)
        curves[toe] = (_sev_max(eig_point), _sev_max(eig))
        row = {
            "toe_deg": toe,
            "point_band_kmh": _band(point, 400),
            "patch_band_kmh": _band(patch, 140),
            "patch_least_damped_re": overall[0],
            "patch_least_damped_hz": overall[1],
            "patch_sev_re": sev[0],
            "patch_sev_hz": sev[1],
            "patch_sev_speed_kmh": sev[2],
        }
        rows.append(row)
        print(row, flush=True)
    for toe, speed in ((0.5, 110.0), (2.0, 40.0), (2.0, 110.0)):
        for label, params in (("point", BASE), ("patch", BASE.with_updates(PATCH))):
            s = _kicked(params.with_updates({"operating.toe_deg": toe}), speed)
            print(
                f"kick toe {toe} deg, {speed} km/h, {label}: {s['outcome']}, {s['frequency_hz']:.1f} Hz, "
                f"x {s['amplitude']['x'] * 1e3:.3g} mm, alpha {s['amplitude']['alpha'] * 1e3:.3g} mrad",
                flush=True,
            )
    for elements in (10, 20, 40, 80, 160):
        n, (t_eq, t_jac, t_eig), re, hz = _cost(elements)
        print(
            f"M = {elements}: {n} states; steady state {t_eq:.2f} ms, Jacobian {t_jac:.2f} ms, "
            f"eigenvalues {t_eig:.1f} ms; least damped {re:.3f} /s at {hz:.2f} Hz",
            flush=True,
        )
    with open(out_dir / "axle4dof_patch.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)

    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    for toe, color in ((0.5, "C0"), (2.0, "C1")):
        point_re, patch_re = curves[toe]
        ax[0].plot(speeds, point_re, color=color, label=f"point, toe {toe} deg")
        ax[0].plot(speeds, patch_re, color=color, ls="--", label=f"patch (M = 40), toe {toe} deg")
    ax[0].axhline(0.0, color="k", lw=0.5)
    ax[0].set(xlabel="speed [km/h]", ylabel="largest real part, modes of 50-250 Hz [1/s]", title="axle4dof: steady rolling")
    ax[0].legend(fontsize=8)
    for i, row in enumerate(rows):
        for b in row["point_band_kmh"]:
            ax[1].plot(b, [i, i], color="C3", lw=6, solid_capstyle="butt", label="point" if i == 0 else None)
        for b in row["patch_band_kmh"]:
            ax[1].plot(b, [i + 0.25] * 2, color="C2", lw=6, solid_capstyle="butt")
    ax[1].set_yticks(range(len(rows)), [f"{r['toe_deg']:g}" for r in rows])
    ax[1].set(xlabel="speed [km/h]", ylabel="toe [deg]", xlim=SPEEDS_KMH, title="linear SEV band (point: red; patch: none)")
    fig.tight_layout()
    fig.savefig(out_dir / "axle4dof_patch.png", dpi=120)


def wear_table(out_dir: Path, distance_km: float = 60000.0) -> None:
    """Per toe, point and patch: the linear wear map at 110 km/h (fastest order, e-folding
    distance [km], mean wear [mm/1000 km]) and the evolution over ``distance_km`` at 110 km/h
    and on the default cycle (depth [mm], dominant order, visible at [km], mean wear [mm])."""
    from polywear.wear.evolution import wear_evolution
    from polywear.wear.map import wear_map

    rows = []
    for toe in TOES_DEG[1:]:
        for label, extra in (("point", {}), ("patch", PATCH)):
            params = BASE.with_updates({**extra, "operating.toe_deg": toe})
            row = wear_map(params, [110.0]).rows()[0]
            out = {"toe_deg": toe, "contact": label, "map_order": row["order"], "map_efold_km": row["efold_km"],
                   "map_rolling_stable": row["rolling_stable"]}
            for place, cycle in (("110", ((110.0, 1.0),)), ("cycle", None)):
                s = wear_evolution(params, distance_km, cycle).summary()
                out.update({f"{place}_depth_mm": s["final_depth_mm"], f"{place}_order": s["dominant_order"],
                            f"{place}_visible_km": s["visible_km"], f"{place}_mean_wear_mm": s["mean_wear_mm"]})
            rows.append(out)
            print(out, flush=True)
    with open(out_dir / "axle4dof_patch_wear.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if a != "--wear"]
    out = Path(args[0]) if args else Path("examples/out")
    if "--wear" in sys.argv:
        out.mkdir(parents=True, exist_ok=True)
        wear_table(out)
    else:
        main(out)
