"""``polywear design``: parameter changes that move the SEV band out of an operating range."""

from __future__ import annotations

from typing import Annotated, Optional

import typer

from .common import (
    PLOT_SUFFIXES,
    ConfigOpt,
    JsonOpt,
    PlotOpt,
    QuietOpt,
    SetOpt,
    UserError,
    check_speed_range,
    emit_json,
    info,
    load,
    one_axes,
    output_file,
    write_figure,
)

DEFAULT_KEYS = ("operating.toe_deg", "adhesion_scale", "friction.mu_static", "tread.lateral_damping_ns_per_m")


def design(
    config: ConfigOpt = None,
    set_: SetOpt = None,
    operating_range: Annotated[
        tuple[float, float], typer.Option("--operating-range", help="Speeds to keep free of SEV [km/h].")
    ] = (80.0, 130.0),
    param: Annotated[
        Optional[list[str]], typer.Option("--param", "-p", help="Parameter to change alone (repeatable).")
    ] = None,
    combine: Annotated[
        Optional[list[str]], typer.Option("--combine", help="Parameters to change together (repeatable).")
    ] = None,
    max_change: Annotated[
        float, typer.Option("--max-change", min=0.0, help="Largest relative change allowed per parameter.")
    ] = 0.5,
    speed_range: Annotated[
        tuple[float, float], typer.Option("--speed-range", help="Speed range of the diagrams [km/h].")
    ] = (20.0, 300.0),
    json_: JsonOpt = False,
    plot: PlotOpt = None,
    quiet: QuietOpt = False,
) -> None:
    """Least change of each parameter (or a combination) that clears the operating range of SEV.

    Each candidate is verified by a full bifurcation diagram (paper section 6, Figs. 10-12).
    Keys: any configuration key, or adhesion_scale (mu_s and mu_c scaled together).
    """
    output_file(plot, "--plot", PLOT_SUFFIXES)
    operating_range = check_speed_range(operating_range, "--operating-range")
    speed_range = check_speed_range(speed_range)
    if not max_change <= 10.0:
        raise UserError(f"--max-change {max_change}: must be at most 10 (a relative change)")
    params = load(config, set_)
    from ..analysis.design import clear_operating_range
    from ..analysis.sensitivity import parameter_direction
    from ..models import get_model

    keys = tuple(param or DEFAULT_KEYS)
    model = get_model(params.model)
    for key in (*keys, *(combine or ())):
        parameter_direction(model, params, key)  # unknown keys -> ParameterError (exit 2)
    info(f"design: up to {len(keys) + bool(combine)} options, each a few bifurcation diagrams ...", quiet)
    try:
        result = clear_operating_range(
            params, tuple(operating_range), keys=keys, combine=tuple(combine or ()),
            max_relative_change=max_change, speed_range_kmh=tuple(speed_range),
        )
    except ValueError as exc:
        raise UserError(str(exc)) from None
    if plot:
        write_figure(plot, lambda: one_axes(result.plot), quiet)
    summary = result.summary()
    if json_:
        emit_json(summary)
        return
    lo, hi = operating_range
    band = ", ".join(f"{a:.1f}-{b:.1f}" for a, b in summary["original_sev_band_kmh"]) or "none"
    typer.echo(f"SEV band now: {band} km/h; operating range {lo:g}-{hi:g} km/h")
    if not summary["options"]:
        typer.echo("the operating range is already free of SEV")
    for o in summary["options"]:
        change = ", ".join(f"{k} {n:g} -> {v:.4g}" for k, n, v in zip(o["params"], o["nominal"], o["values"]))
        after = ", ".join(f"{a:.1f}-{b:.1f}" for a, b in o["sev_band_kmh"]) or "none"
        status = "clears the range" if o["achieved"] else f"does not clear it ({o['note']})"
        typer.echo(f"  {change} ({o['relative_change']:.0%}): {status}; SEV band after: {after} km/h")
