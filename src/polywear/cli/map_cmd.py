"""``polywear map``: stability map of one parameter against speed (two-parameter continuation)."""

from __future__ import annotations

import math
from typing import Annotated, Optional

import typer

from ..units import DEFAULT_SPEED_RANGE_KMH
from .common import Inputs, Outputs, SpeedRangeOpt
from .common import UserError, check_param_keys, check_speed_range, one_axes


def map_(
    inputs: Inputs = Inputs(),
    param: Annotated[str, typer.Option("--param", "-p", help="Parameter key, e.g. operating.toe_deg or adhesion_scale.")]
    = "operating.toe_deg",
    range_: Annotated[
        Optional[tuple[float, float]],
        typer.Option("--range", help="Lowest and highest parameter value [key units] (default: nominal x0.5 .. x1.5)."),
    ] = None,
    speed_range: SpeedRangeOpt = DEFAULT_SPEED_RANGE_KMH,
    operating_range: Annotated[
        Optional[tuple[float, float]],
        typer.Option("--operating-range", help="Operating speeds to keep free of SEV [km/h] (drawn, safe values)."),
    ] = None,
    no_folds: Annotated[bool, typer.Option("--no-folds", help="Hopf curves only (no cycle continuation).")] = False,
    outputs: Outputs = Outputs("Write the map (.nc, or JSON otherwise).", (".nc", ".json")),
) -> None:
    """Stability map: Hopf and fold-of-cycles curves in the (speed, parameter) plane, linear and hard bands."""
    outputs.check()
    speed_range = check_speed_range(speed_range)
    operating_range = check_speed_range(operating_range, "--operating-range")
    params = inputs.load()
    from ..dynamics.sensitivity import nominal_value
    from ..dynamics.stability_map import stability_map

    check_param_keys([param])
    if range_ is None:
        nominal = nominal_value(params, param)
        if nominal == 0.0:
            raise UserError(f"{param} = 0: give --range LOW HIGH")
        range_ = tuple(sorted((0.5 * nominal, 1.5 * nominal)))
    lo, hi = range_
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise UserError(f"--range {lo} {hi}: need finite low < high")
    with outputs.progress(f"map of {param}: continuation steps") as update:
        result = stability_map(params, param, (lo, hi), tuple(speed_range), operating_range, folds=not no_folds,
                               progress=update)
    outputs.write(result.save, lambda: one_axes(result.plot, (10, 5.5)))
    outputs.show(result.summary(), _print_summary)


def _print_summary(s: dict) -> None:
    typer.echo(f"model {s['model']}: {s['param']} from {s['range'][0]:g} to {s['range'][1]:g} "
               f"(nominal {s['nominal']:g}), speeds {s['speed_range_kmh'][0]:g}-{s['speed_range_kmh'][1]:g} km/h")
    for kind in ("hopf_curves", "fold_curves"):
        for k, c in enumerate(s[kind], 1):
            typer.echo(f"  {kind[:-7]} curve {k}: {c['n_points']} points, {s['param']} {c['value_range'][0]:.4g}.."
                       f"{c['value_range'][1]:.4g}, {c['speed_range_kmh'][0]:.1f}..{c['speed_range_kmh'][1]:.1f} km/h "
                       f"(ends: {'; '.join(c['end_reasons'])})")
    for b in s["band_closures"]:
        typer.echo(f"  linear band closes at {s['param']} = {b['value']:.6g} ({b['speed_kmh']:.2f} km/h)")
    for b in s["bautin_points"]:
        typer.echo(f"  Bautin point (soft/hard switch) at {s['param']} = {b['value']:.6g} ({b['speed_kmh']:.2f} km/h)")
    if s["at_nominal"]:
        sev = s["at_nominal"]["sev"]
        typer.echo("  at the nominal value: SEV " + (", ".join(f"{a:.1f}..{b:.1f}" for a, b in sev) or "none") + " km/h")
    if s["operating_range_kmh"]:
        lo, hi = s["operating_range_kmh"]
        safe = ", ".join(f"{a:.4g}..{b:.4g}" for a, b in s["safe_values"]) or "none in the range"
        typer.echo(f"  no SEV in {lo:g}-{hi:g} km/h for {s['param']} in: {safe}")
    for note in s["notes"]:
        typer.echo(f"  note: {note}")
