"""``polywear excitation``: soft and hard self-excitation in the phase plane (paper Fig. 2)."""

from __future__ import annotations

from typing import Annotated, Optional

import typer

from .common import ConfigOpt, JsonOpt, PlotOpt, SetOpt, UserError, emit_json, info, load, write_figure


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
) -> None:
    """Soft and hard self-excitation in the phase plane (paper Fig. 2).

    Cycles from the continuation (stable solid, unstable dashed) and trajectories started
    inside and outside each of them, at soft and hard speeds."""
    params = load(config, set_)
    from ..analysis.bifurcation import bifurcation_diagram
    from ..analysis.excitation import default_speeds, excitation_portraits, portraits_figure

    if speed and any(v <= 0 for v in speed):
        raise UserError(f"--speed {speed}: speeds must be positive [km/h]")
    info("excitation: bifurcation diagram ...")
    diagram = bifurcation_diagram(params, (min([20.0, *(speed or [])]) * 0.5, max([300.0, *(speed or [])]) * 1.1))
    speeds = speed or default_speeds(diagram, params.operating.speed_kmh)
    if not speeds:
        raise UserError("no self-excited vibration in 10-330 km/h: give --speed")
    info(f"excitation: simulating at {', '.join(f'{v:.1f}' for v in speeds)} km/h ...")
    portraits = excitation_portraits(diagram, speeds, duration)
    if plot:
        write_figure(plot, lambda: portraits_figure(portraits))
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
