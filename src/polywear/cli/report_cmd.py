"""``polywear report``: the main job, a full analysis with an HTML report."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from ..params import MAX_WEAR_KM
from ..units import DEFAULT_SPEED_RANGE_KMH
from .common import (
    ConfigOpt,
    JsonOpt,
    OperatingRangeOpt,
    QuietOpt,
    SetOpt,
    SpeedRangeOpt,
    UserError,
    check_speed_range,
    emit_json,
    load,
    output_folder,
    status_lines,
    tir_path,
)


def report(
    config: ConfigOpt = None,
    set_: SetOpt = None,
    out: Annotated[Path, typer.Option("--out", "-o", help="Output folder.")] = Path("out"),
    speed_range: SpeedRangeOpt = DEFAULT_SPEED_RANGE_KMH,
    operating_range: OperatingRangeOpt = None,
    wear_km: Annotated[
        Optional[float],
        typer.Option("--wear-km", help="Distance [km] of the wear evolutions at the operating speed and on the "
                     "drive cycle (default: wear.report_km, 100000; 0: not run); the wear map is always included."),
    ] = None,
    wear_design: Annotated[Optional[bool], typer.Option(
        "--wear-design/--no-wear-design", help="For a car that vibrates on the drive cycle and wears a visible "
        "polygon within --wear-km: the least change (toe, camber, bushings, tread; adhesion where none of those "
        "does it) after which the evolution shows no polygon within --wear-km (ten to twenty evolutions). "
        "--wear-design: refined to the search's accuracy (2 %); --no-wear-design: not searched. Default: refined "
        "for tread1dof; for axle4dof one grid step of the search (+19 %/-16 % of each key) refined by one round "
        "(to a third or two thirds of that step), which fits its time budget (the refined search takes minutes "
        "there).", show_default=False)] = None,
    json_: JsonOpt = False,
    quiet: QuietOpt = False,
) -> None:
    """The main job: full analysis with figures, data and report.html in --out.

    One verdict on vibration and wear (how many sides, after how many km, what to change),
    stability, bifurcation diagram, verdict at the operating speed with wear indicators,
    phase portraits, sensitivities, design options judged by the band and the wear, the
    wear map and the wear evolutions."""
    output_folder(out, "--out", "report.html")
    speed_range = check_speed_range(speed_range)
    if operating_range is not None:
        operating_range = check_speed_range(operating_range, "--operating-range")
    if wear_km is not None and not (0.0 <= wear_km <= MAX_WEAR_KM):
        raise UserError(f"--wear-km {wear_km:g}: must be in [0, {MAX_WEAR_KM:g}] (0: no evolution)")
    params, cornering = _load_with_cornering(config, set_)
    from ..io import fresh_directory
    from ..report import main as main_job

    # written into a new folder that replaces --out only when complete: never a mix of two runs
    with fresh_directory(out) as folder:
        result = main_job.report(params, folder, speed_range, operating_range,
                                 progress=status_lines("polywear report: ", quiet), wear_evolution_km=wear_km,
                                 wear_design_by_evolution=wear_design, cornering_stiffness=cornering)
    summary = result.summary()
    if json_:
        emit_json(summary)
        return
    for warning in summary["bifurcation"].get("warnings", []):
        typer.echo(f"warning: {warning}", err=True)
    for line in main_job.text_summary(summary):
        typer.echo(line)
    typer.echo(f"report: {out / 'report.html'}")


def _load_with_cornering(config, set_):
    """(parameters, (C_alpha [N/rad], its source) from the ``--tir`` file at the load, or None
    without a file or without PKY1/PKY2 in it)."""
    tir = tir_path()
    if tir is None:
        return load(config, set_), None
    from ..measured.tir import load_with_tir

    loaded = load_with_tir(tir, config, set_ or ())
    c_alpha = loaded.mapping.conditions.get("cornering_stiffness_n_per_rad")
    if c_alpha is None:
        return loaded.params, None
    return loaded.params, (c_alpha, f"from {tir.name}, PKY1/PKY2 at {loaded.mapping.conditions['load_n']:g} N")
