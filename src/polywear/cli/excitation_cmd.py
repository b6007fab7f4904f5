"""``polywear excitation``: soft and hard self-excitation in the phase plane (paper Fig. 2)."""

from __future__ import annotations

from typing import Annotated, Optional

import typer

from .common import MAX_SPEED_KMH, Inputs, Outputs, UserError
from .simulate_cmd import MAX_DURATION_S


def excitation(
    inputs: Inputs = Inputs(),
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
    outputs: Outputs = Outputs(),
) -> None:
    """Soft and hard self-excitation in the phase plane (paper Fig. 2).

    Cycles from the continuation (stable solid, unstable dashed) and trajectories started
    inside and outside each of them, at soft and hard speeds."""
    outputs.check()
    if speed and not all(0.0 < v <= MAX_SPEED_KMH for v in speed):
        raise UserError(f"--speed {speed}: speeds must be in (0, {MAX_SPEED_KMH:g}] [km/h]")
    if speed and len(speed) > 10:
        raise UserError(f"--speed: {len(speed)} speeds given, at most 10 (one portrait each)")
    if duration is not None and not duration <= MAX_DURATION_S:
        raise UserError(f"--duration {duration}: must be at most {MAX_DURATION_S:g} [s]")
    params = inputs.load()
    from ..dynamics.bifurcation import bifurcation
    from ..dynamics.excitation import ExcitationSettings, default_speeds, excitation

    outputs.note("excitation: bifurcation diagram ...")
    with outputs.progress("continuation steps") as update:
        diagram = bifurcation(params, (min([20.0, *(speed or [])]) * 0.5, max([300.0, *(speed or [])]) * 1.1),
                              progress=update)
    speeds = speed or default_speeds(diagram, params.operating.speed_kmh)
    if not speeds:  # the safe car: an answer, not an error
        lo, hi = diagram.speed_range_kmh
        note = f"no self-excited vibration in {lo:g}-{hi:g} km/h: no soft or hard speed to draw (give --speed)"
        outputs.show({"model": params.model, "portraits": [], "note": note}, lambda _: typer.echo(note))
        return
    outputs.note(f"excitation: simulating at {', '.join(f'{v:.1f}' for v in speeds)} km/h ...")
    with outputs.progress("excitation: simulations") as update:
        portraits = excitation(diagram, speeds, ExcitationSettings(duration_s=duration), progress=update)
    outputs.write(make_figure=portraits.figure)
    outputs.show(portraits.summary(), _print_portraits)


def _print_portraits(summary: dict) -> None:
    """The regime at each speed and what each start ends in, as text on stdout."""
    for p in summary["portraits"]:
        typer.echo(f"{p['speed_kmh']:.1f} km/h: {p['regime']}")
        for c in p["cycles"]:
            typer.echo(f"  {'stable' if c['stable'] else 'unstable'} cycle, amplitude {c['amplitude_x_mm']:.4f} mm")
        for r in p["runs"]:
            typer.echo(f"  start {r['start']:22s} -> {r['outcome']} (amplitude {r['final_amplitude_x_mm']:.4f} mm)")
