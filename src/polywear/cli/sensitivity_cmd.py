"""``polywear sensitivity``: local sensitivity of the bifurcation speeds (the paper's Fig. 9)."""

from __future__ import annotations

from enum import Enum
from typing import Annotated, Optional

import typer

from ..units import DEFAULT_SPEED_RANGE_KMH
from .common import Inputs, Outputs, SpeedRangeOpt
from .common import UserError, check_param_keys, check_speed_range, user_errors

MAX_STEP = 0.5
"""Largest finite-difference step [relative]: beyond it a difference is no derivative."""


class Method(str, Enum):
    exact = "exact"
    central = "central"
    forward = "forward"


def sensitivity(
    inputs: Inputs = Inputs(),
    method: Annotated[
        Method, typer.Option("--method", help="exact (implicit-function theorem), central, or forward (paper eq. 3).")
    ] = Method.exact,
    step: Annotated[
        float, typer.Option("--step", help="Finite-difference step, relative to the nominal value (absolute if 0).")
    ] = 1e-4,
    param: Annotated[
        Optional[list[str]],
        typer.Option("--param", "-p", help="Parameter key (repeatable; default: the paper's seven, adhesion read "
                     "both ways). 'adhesion_scale' scales mu_s and mu_c together."),
    ] = None,
    speed_range: SpeedRangeOpt = DEFAULT_SPEED_RANGE_KMH,
    outputs: Outputs = Outputs("Write the rows (.csv, or JSON otherwise).", (".csv", ".json")),
) -> None:
    """Sensitivity of every Hopf speed, fold speed and first/second bifurcation speed to parameters."""
    outputs.check()
    lo, hi = check_speed_range(speed_range)
    if not 0.0 < step <= MAX_STEP:
        raise UserError(f"--step {step}: must be in (0, {MAX_STEP:g}]")
    params = inputs.load()
    from ..dynamics.sensitivity import PAPER_PARAMETERS, SensitivitySettings, parameter_direction, sensitivity
    from ..models import model_for

    keys = tuple(dict.fromkeys(param)) if param else PAPER_PARAMETERS
    check_param_keys(keys, example="tread.mass_kg")
    model = model_for(params)
    for key in keys:
        if not parameter_direction(model, params, key).any():
            outputs.note(f"note: {key} does not enter model {params.model}; its sensitivity is 0")
    with outputs.progress(f"{method.value} sensitivity: continuation steps") as update, user_errors(ValueError):
        result = sensitivity(params, keys, SensitivitySettings(method.value, step), (lo, hi), progress=update)
    for note in result.notes:  # why a bifurcation speed has no row (none in the range, an open band edge)
        outputs.note(f"note: {note}")
    outputs.write(result.save, result.figure if result.rows else None)
    outputs.show(result.summary(), lambda _: _print_rows(result))


def _print_rows(result) -> None:
    from ..dynamics.sensitivity import PARAMETER_LABELS

    typer.echo(f"model {result.params.model}, method {result.method}; S = (p/V) dV/dp, dV/dp in km/h per unit of p")
    quantities = list(dict.fromkeys(r["quantity"] for r in result.rows))
    for q in quantities:
        rows = [r for r in result.rows if r["quantity"] == q]
        typer.echo(f"\n{q} at {rows[0]['speed_kmh']:.3f} km/h")
        rows.sort(key=lambda r: -abs(r["normalized"] or 0.0))
        for r in rows:
            label = PARAMETER_LABELS.get(r["param"], r["param"])
            d = "n/a" if r["derivative"] is None else f"{r['derivative']:+.6g}"
            s = "n/a" if r["normalized"] is None else f"{r['normalized']:+.5f}"
            typer.echo(f"  {label:30s} S = {s:>9s}   dV/dp = {d:>13s}   ({r['param']} = {r['nominal']:g})")
