"""``polywear design``: parameter changes that move the SEV band out of an operating range."""

from __future__ import annotations

import math
from typing import Annotated, Optional

import typer

from ..units import DEFAULT_SPEED_RANGE_KMH
from .common import Inputs, OperatingRangeOpt, Outputs, SpeedRangeOpt
from .common import UserError, check_param_keys, check_speed_range, one_axes, user_errors


def design(
    inputs: Inputs = Inputs(),
    operating_range: OperatingRangeOpt = None,
    param: Annotated[
        Optional[list[str]],
        typer.Option("--param", "-p", help="Parameter to change alone (repeatable; default: toe, camber, "
                                           "axle bushings, tread stiffness and damping, adhesion)."),
    ] = None,
    combine: Annotated[
        Optional[list[str]], typer.Option("--combine", help="Parameters to change together (repeatable).")
    ] = None,
    max_change: Annotated[
        float, typer.Option("--max-change", help="Allowed relative change per parameter; larger ones are flagged.")
    ] = 0.5,
    search_factor: Annotated[
        float, typer.Option("--search-factor", help="Values searched: nominal / factor to nominal * factor.")
    ] = 3.0,
    margin: Annotated[
        float, typer.Option("--margin", help="Keep the band this far from the operating range [km/h].")
    ] = 2.0,
    speed_range: SpeedRangeOpt = DEFAULT_SPEED_RANGE_KMH,
    outputs: Outputs = Outputs("Write the options (.csv or .json).", (".csv", ".json")),
) -> None:
    """Least change of each parameter (or a combination) that clears the operating range of SEV.

    Both directions of each parameter are searched and every candidate is a full
    bifurcation diagram (paper section 6, Figs. 10-12). Options you control (toe, camber,
    axle bushings, tread) are listed first, adhesion as a road/compound option.
    Keys: any numeric configuration key, or adhesion_scale (mu_s and mu_c scaled together).
    """
    outputs.check()
    speed_range = check_speed_range(speed_range)
    operating_range = check_speed_range(operating_range, "--operating-range")
    if not (math.isfinite(max_change) and 0.0 < max_change <= 10.0):
        raise UserError(f"--max-change {max_change:g}: must be in (0, 10] (a relative change)")
    if not (math.isfinite(search_factor) and 1.0 < search_factor <= 10.0):
        raise UserError(f"--search-factor {search_factor:g}: must be in (1, 10]")
    if not (math.isfinite(margin) and 0.0 <= margin <= 100.0):
        raise UserError(f"--margin {margin:g}: must be in [0, 100] km/h")
    params = inputs.load()
    from ..dynamics.design import DEFAULT_KEYS, DesignSettings, default_operating_range, design

    operating_range = operating_range or default_operating_range(params.operating.speed_kmh)
    keys = tuple(dict.fromkeys(param or DEFAULT_KEYS))
    check_param_keys((*keys, *(combine or ())))
    outputs.note(f"design: {len(keys) + bool(combine)} options, each searched in both directions by bifurcation "
                 "diagrams ...")
    with outputs.progress("design: bifurcation diagrams") as update, user_errors(ValueError):
        result = design(
            params, operating_range, keys=keys, combine=tuple(combine or ()), max_relative_change=max_change,
            speed_range_kmh=speed_range, settings=DesignSettings(margin_kmh=margin, search_factor=search_factor),
            progress=update,
        )
    outputs.write(result.save, lambda: one_axes(result.plot))
    outputs.show(result.summary(), lambda _: _print_lines(result))


def _print_lines(result) -> None:
    """The options as text on stdout."""
    for line in result.lines():
        typer.echo(line)
