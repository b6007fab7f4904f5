"""``polywear fleet``: the share of a built fleet whose SEV band reaches the customers' speeds."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Optional

import typer

from ..params import MAX_WEAR_KM
from .common import BackendOpt, ConfigOpt, JsonOpt, PlotOpt, QuietOpt, SchedulerOpt, SetOpt, WorkersOpt, out_option
from .common import (
    PLOT_SUFFIXES,
    UserError,
    chosen_backend,
    dask_connect_timeout,
    emit_json,
    info,
    load,
    output_file,
    progress,
    write_figure,
    write_output,
)

FleetOutOpt = out_option("Write the result: .nc (every car), .csv or .json.")


def fleet(
    spec: Annotated[Path, typer.Option("--spec", help="Fleet spec TOML with a [fleet] table (docs/fleet.md).")],
    config: ConfigOpt = None,
    set_: SetOpt = None,
    backend: BackendOpt = None,
    scheduler: SchedulerOpt = None,
    workers: WorkersOpt = None,
    checkpoint: Annotated[
        Optional[Path], typer.Option("--checkpoint", help="Folder for the checkpoint (fleet_checkpoint.npz).")
    ] = None,
    resume: Annotated[bool, typer.Option("--resume", help="Continue from the checkpoint in --checkpoint.")] = False,
    wear_km: Annotated[
        Optional[float], typer.Option("--wear-km", help="Wear risk: evolve every car's wear over this distance [km] "
                                                        "on the usage cycle (default: the spec's wear_km).")
    ] = None,
    json_: JsonOpt = False,
    plot: PlotOpt = None,
    out: FleetOutOpt = None,
    quiet: QuietOpt = False,
) -> None:
    """Fleet risk: probability that the SEV band overlaps the usage speeds, with an exact CI; with --wear-km, the
    probability that a polygon becomes visible within that distance (docs/fleet.md)."""
    output_file(out, "--out", (".nc", ".csv", ".json"))
    output_file(plot, "--plot", PLOT_SUFFIXES)
    if wear_km is not None and not (math.isfinite(wear_km) and 0.0 < wear_km <= MAX_WEAR_KM):
        raise UserError(f"--wear-km {wear_km:g}: must be in (0, {MAX_WEAR_KM:g}]")
    if resume and checkpoint is None:
        raise UserError("--resume needs --checkpoint FOLDER")
    if checkpoint is not None and not checkpoint.exists():
        raise UserError(f"--checkpoint {checkpoint}: no such folder (create it, or name an existing one)")
    if checkpoint is not None and not checkpoint.is_dir():
        raise UserError(f"--checkpoint {checkpoint}: a file, not a folder")
    fleet_sets = [item for item in set_ or () if item.strip().startswith("fleet.")]
    params = load(config, [item for item in set_ or () if item not in fleet_sets])
    from ..parallel import Executor
    from ..studies.fleet import CHECKPOINT_FILE, fleet, load_fleet_spec

    if resume and not (checkpoint / CHECKPOINT_FILE).exists():
        raise UserError(f"--resume: no checkpoint in {checkpoint} (no {CHECKPOINT_FILE}); run without --resume to start")

    fleet_spec = load_fleet_spec(spec, params, fleet_sets)
    chosen = chosen_backend(backend, scheduler, 5.0)
    info(f"fleet of {fleet_spec.samples} {params.model} cars, {len(fleet_spec.parameter)} parameters, on {chosen}",
         quiet)
    with progress("fleet", enabled=not quiet) as update, dask_connect_timeout(
        5.0 if chosen == "dask" else None
    ):
        result = fleet(params, fleet_spec, executor=Executor(chosen, workers, scheduler),
                       checkpoint_dir=checkpoint, resume=resume, progress=update, wear_km=wear_km)
    if out:
        write_output(out, result.save, quiet)
    if plot:
        write_figure(plot, result.figure, quiet)
    s = result.summary()
    if json_:
        emit_json(s)
    else:
        paths = s["paths"]
        typer.echo(f"{s['model']}: {s['n_evaluated']} of {s['n_samples']} cars evaluated "
                   f"({s['failed_samples']} failed); Hopf points alone {paths['hopf']}, fast band {paths['fast']}, "
                   f"full continuation {paths['full']}, pilot stage {paths['pilot']}")
        for reason, count in s["fallback_reasons"].items():
            typer.echo(f"  full continuation because of {reason}: {count} cars")
        for car in s["failed_cars"]:
            typer.echo(f"  car {car['car']} {car['reason']}")
        if s["failed_samples"] > len(s["failed_cars"]):
            typer.echo(f"  ... {s['failed_samples'] - len(s['failed_cars'])} more failed cars (all in --out .nc/.csv)")
        if not s["n_evaluated"]:
            typer.echo("no car evaluated: no risk probability")
            return
        typer.echo(f"risk probability {s['risk_probability']:.4f}, {s['confidence']:.0%} CI "
                   f"[{s['risk_ci'][0]:.4f}, {s['risk_ci'][1]:.4f}] (Clopper-Pearson)")
        typer.echo(f"hard excitation at a usage speed: {s['hard_excitation_share']:.4f}")
        if s["gap_after_pd_ns_share"]:
            typer.echo(f"usage speed in a gap of the band after a period doubling or torus bifurcation "
                       f"(not counted at risk): {s['gap_after_pd_ns_share']:.4f}")
            if s["gap_sev_share"] is None:
                typer.echo("  whether SEV is reached there: simulate_gaps = true in [fleet] decides it by simulation")
            else:
                typer.echo(f"  of the fleet, a simulation ends in SEV there: {s['gap_sev_share']:.4f}, "
                           f"{s['confidence']:.0%} CI [{s['gap_sev_ci'][0]:.4f}, {s['gap_sev_ci'][1]:.4f}]")
        for name in ("first_bifurcation_speed_kmh", "second_bifurcation_speed_kmh"):
            q = s[name]
            if "p50" in q:  # some cars have that speed inside the range
                typer.echo(f"{name}: 5 % {q['p5']:.1f}, median {q['p50']:.1f}, 95 % {q['p95']:.1f}")
        typer.echo("drivers (main effect on the risk): " + ", ".join(
            f"{k} {v:.3f}" for k, v in s["drivers_main_effect"].items() if v is not None))
        if s["drivers_importance"] is not None:
            c = s["drivers_classifier"]
            typer.echo(f"drivers (drop of a classifier's held-out ROC AUC {c['held_out_auc']:.3f} when shuffled, "
                       "interactions included): " + ", ".join(f"{k} {v:.3f}" for k, v in s["drivers_importance"].items()))
        if s["wear_risk_probability"] is not None:
            _print_wear_risk(s)
        if s.get("wear_over_budget"):
            typer.echo(f"wear: {s['wear_over_budget']} car(s) over the budget of {s['wear_max_steps']} distance steps "
                       f"or {s['wear_max_revolutions']:,} simulated revolutions per evolution, not counted in the wear "
                       "risk (fleet.wear_max_steps, fleet.wear_max_revolutions):")
            for car in s["wear_over_budget_cars"]:
                typer.echo(f"  car {car['car']}: {car['reason']}; " + ", ".join(
                    f"{k} = {v:.6g}" for k, v in car["parameters"].items()))
            if s["wear_over_budget"] > len(s["wear_over_budget_cars"]):
                typer.echo(f"  ... {s['wear_over_budget'] - len(s['wear_over_budget_cars'])} more "
                           "(all in --out .nc/.csv, column wear_note)")


def _print_wear_risk(s: dict) -> None:
    """The wear risk lines of the summary ``s`` on stdout."""
    lo, hi = s["wear_risk_ci"]
    cycle = ", ".join(f"{c['speed_kmh']:g} km/h {c['share']:.0%}" for c in s["wear_cycle"])
    typer.echo(f"wear risk (a polygon visible within {s['wear_km']:,.0f} km on the usage cycle {cycle}, nonlinear "
               f"evolution): {s['wear_risk_probability']:.4f}, {s['confidence']:.0%} CI [{lo:.4f}, {hi:.4f}] "
               f"(Clopper-Pearson, {s['wear_n_evaluated']} cars); distances scale as 1/k_e")
    if s["wear_most_dangerous_order"] is not None:
        q = s["wear_visible_km"]
        typer.echo(f"  most dangerous order {s['wear_most_dangerous_order']} (visible polygons by order: "
                   + ", ".join(f"{o}: {c}" for o, c in s["wear_orders"].items())
                   + f"); visible after 5 % {q['p5']:,.0f}, median {q['p50']:,.0f}, 95 % {q['p95']:,.0f} km")
    typer.echo("  drivers of the wear risk (main effect): " + ", ".join(
        f"{k} {v:.3f}" for k, v in s["wear_drivers_main_effect"].items() if v is not None))
    if s["wear_drivers_importance"] is not None:
        typer.echo(f"  drivers (classifier, held-out ROC AUC {s['wear_drivers_classifier']['held_out_auc']:.3f}): "
                   + ", ".join(f"{k} {v:.3f}" for k, v in s["wear_drivers_importance"].items()))
