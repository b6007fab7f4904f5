"""``polywear excitation``: soft and hard self-excitation in the phase plane (paper Fig. 2)."""

from __future__ import annotations

from typing import Annotated, Optional

import typer

from .common import (
    MAX_SPEED_KMH,
    PLOT_SUFFIXES,
    ConfigOpt,
    JsonOpt,
    PlotOpt,
    QuietOpt,
    SetOpt,
    UserError,
    emit_json,
    info,
    load,
    output_file,
    progress,
    write_figure,
)
from .simulate_cmd import MAX_DURATION_S


def excitation(
    config: ConfigOpt = None,
    set_: SetOpt = None,
    speed: Annotated[
        Optional[list[float]],
        typer.Option("--speed", help="Speed [km/h] (repeatable; default: the operating speed or the middle of "
                     "the linear band, and the middle of the hard region)."),
    ] = None,
    duration: Annotated[
        Optional[float],
        typer.Option("--duration", min=0.01, help="Simulated time per start [s] (default: until the slowest "
                     "attractor settles, 0.6-8 s)."),
    ] = None,
    json_: JsonOpt = False,
    plot: PlotOpt = None,
    quiet: QuietOpt = False,
) -> None:
    """Soft and hard self-excitation in the phase plane (paper Fig. 2).

    Cycles from the continuation (stable solid, unstable dashed) and trajectories started
    inside and outside each of them, at soft and hard speeds."""
    output_file(plot, "--plot", PLOT_SUFFIXES)
    if speed and not all(0.0 < v <= MAX_SPEED_KMH for v in speed):
        raise UserError(f"--speed {speed}: speeds must be in (0, {MAX_SPEED_KMH:g}] [km/h]")
    if speed and len(speed) > 10:
        raise UserError(f"--speed: {len(speed)} speeds given, at most 10 (one portrait each)")
    if duration is not None and not duration <= MAX_DURATION_S:
        raise UserError(f"--duration {duration}: must be at most {MAX_DURATION_S:g} [s]")
    params = load(config, set_)
    from ..dynamics.bifurcation import bifurcation
    from ..dynamics.excitation import ExcitationSettings, default_speeds, excitation, portraits_figure

    info("excitation: bifurcation diagram ...", quiet)
    with progress("continuation steps", enabled=not quiet) as update:
        diagram = bifurcation(params, (min([20.0, *(speed or [])]) * 0.5, max([300.0, *(speed or [])]) * 1.1),
                              progress=update)
    speeds = speed or default_speeds(diagram, params.operating.speed_kmh)
    if not speeds:  # the safe car: an answer, not an error
        lo, hi = diagram.speed_range_kmh
        note = f"no self-excited vibration in {lo:g}-{hi:g} km/h: no soft or hard speed to draw (give --speed)"
        if json_:
            emit_json({"model": params.model, "portraits": [], "note": note})
        else:
            typer.echo(note)
        return
    info(f"excitation: simulating at {', '.join(f'{v:.1f}' for v in speeds)} km/h ...", quiet)
    with progress("excitation: simulations", enabled=not quiet) as update:
        portraits = excitation(diagram, speeds, ExcitationSettings(duration_s=duration), progress=update)
    if plot:
        write_figure(plot, lambda: portraits_figure(portraits), quiet)
    summary = {"model": params.model, "portraits": [p.summary() for p in portraits]}
    if json_:
        emit_json(summary)
        return
    for p in summary["portraits"]:
        typer.echo(f"{p['speed_kmh']:.1f} km/h: {p['regime']}")
        for c in p["cycles"]:
            typer.echo(f"  {'stable' if c['stable'] else 'unstable'} cycle, amplitude {c['amplitude_x_m'] * 1e3:.4f} mm")
        for r in p["runs"]:
            typer.echo(f"  start {r['start']:22s} -> {r['outcome']} (amplitude {r['final_amplitude_x_m'] * 1e3:.4f} mm)")
