"""``polywear report``: the main job, a full analysis with an HTML report."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from .common import ConfigOpt, JsonOpt, SetOpt, UserError, emit_json, info, load


def report(
    config: ConfigOpt = None,
    set_: SetOpt = None,
    out: Annotated[Path, typer.Option("--out", "-o", help="Output folder.")] = Path("out"),
    speed_range: Annotated[
        tuple[float, float], typer.Option("--speed-range", help="Speed range of the analysis [km/h].")
    ] = (20.0, 300.0),
    operating_range: Annotated[
        Optional[tuple[float, float]],
        typer.Option("--operating-range", help="Speeds to keep free of SEV [km/h] (default: operating speed -30/+20)."),
    ] = None,
    json_: JsonOpt = False,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress output.")] = False,
) -> None:
    """The main job: full analysis with figures, data and report.html in --out.

    Stability, bifurcation diagram, verdict at the operating speed with wear indicators,
    phase portraits, sensitivities and design options."""
    params = load(config, set_)
    if not 0.0 < speed_range[0] < speed_range[1]:
        raise UserError(f"--speed-range {speed_range[0]} {speed_range[1]}: need 0 < low < high [km/h]")
    if operating_range is not None and not operating_range[0] < operating_range[1]:
        raise UserError(f"--operating-range {operating_range[0]} {operating_range[1]}: need low < high [km/h]")
    from ..report import run_report, text_summary

    result = run_report(params, out, tuple(speed_range), operating_range,
                        progress=lambda message: info(f"polywear report: {message} ...", quiet))
    if json_:
        emit_json(result.summary)
        return
    for warning in result.summary["bifurcation"].get("warnings", []):
        typer.echo(f"warning: {warning}", err=True)
    for line in text_summary(result.summary):
        typer.echo(line)
    typer.echo(f"report: {out / 'report.html'}")
