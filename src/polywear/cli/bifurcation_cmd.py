"""``polywear bifurcation``: the bifurcation diagram of tread amplitude against speed."""

from __future__ import annotations

from enum import Enum
from pathlib import Path
from typing import Annotated, Optional

import typer

from ..units import DEFAULT_SPEED_RANGE_KMH
from .common import Inputs, Outputs, SpeedRangeOpt
from .common import (
    MAX_GRID_POINTS,
    NETCDF_OUTPUTS,
    UserError,
    check_count,
    check_speed_range,
    one_axes,
    output_file,
    write_output,
)

MAX_SWEEP_SPEEDS = 1000
"""Most speeds of the brute-force sweep (four simulations each)."""
MAX_INTERVALS = 1000
"""Most collocation mesh intervals (--ntst)."""


class Method(str, Enum):
    continuation = "continuation"
    sweep = "sweep"


def bifurcation(
    inputs: Inputs = Inputs(),
    speed_range: SpeedRangeOpt = DEFAULT_SPEED_RANGE_KMH,
    method: Annotated[
        Method, typer.Option("--method", help="continuation (default) or the paper's brute-force sweep.")
    ] = Method.continuation,
    n_intervals: Annotated[int, typer.Option("--ntst", min=4, help="Collocation mesh intervals.")] = 40,
    n_speeds: Annotated[
        Optional[int], typer.Option("--n-speeds", min=3, help="Speeds of the sweep (30) / stability grid (400).")
    ] = None,
    csv: Annotated[Optional[Path], typer.Option("--csv", help="Write the branch table as CSV.")] = None,
    outputs: Outputs = NETCDF_OUTPUTS,
) -> None:
    """Bifurcation diagram: Hopf points, cycle branches (stable and unstable), folds, SEV band."""
    outputs.check()
    output_file(csv, "--csv", (".csv",))
    if csv and method is Method.sweep:
        raise UserError("--csv: the sweep writes netCDF only (use --out FILE.nc)")
    lo, hi = check_speed_range(speed_range)
    check_count(n_intervals, "--ntst", 4, MAX_INTERVALS)
    check_count(n_speeds, "--n-speeds", 3, MAX_SWEEP_SPEEDS if method is Method.sweep else MAX_GRID_POINTS)
    params = inputs.load()
    if method is Method.sweep:
        from ..dynamics.bifurcation import OPERATING_MARGIN
        from ..dynamics.sweep import sweep_bands

        op = params.operating.speed_kmh  # the grid holds the operating speed, as the continuation's range does
        sweep_range = (min(lo, op / OPERATING_MARGIN), max(hi, op * OPERATING_MARGIN))
        result = _sweep(params, sweep_range, n_speeds or 30, outputs)
        summary = {**sweep_bands(result), **result.summary()}
    else:
        from ..dynamics.bifurcation import bifurcation
        from ..dynamics.stability import StabilitySettings
        from ..solvers.continuation import ContinuationSettings

        with outputs.progress("continuation steps") as update:
            result = bifurcation(
                params,
                (lo, hi),
                ContinuationSettings(n_intervals=n_intervals),
                StabilitySettings() if n_speeds is None else StabilitySettings(n_speeds=n_speeds),
                progress=update,
            )
        summary = result.summary()
    outputs.write(result.save, (lambda: one_axes(result.plot)) if method is Method.sweep else result.figure)
    if csv:
        write_output(csv, result.save, outputs.quiet)
    outputs.show(summary, _print_summary)


def _sweep(params, speed_range, n_speeds, outputs: Outputs):
    import numpy as np

    from ..dynamics.sweep import sweep

    speeds = np.linspace(speed_range[0], speed_range[1], n_speeds)
    with outputs.progress("sweep") as update:
        return sweep(params, speeds, progress=update)


def _print_summary(s: dict) -> None:
    """The summary as text on stdout; range notes and open-band warnings on stderr."""
    for note in [*s.get("range_notes", []), *s.get("continuation_notes", [])]:
        typer.echo(f"note: {note}", err=True)
    for warning in s.get("warnings", []):
        typer.echo(f"warning: {warning}", err=True)
    typer.echo(f"model {s['model']} ({s['method']})")
    if "speed_range_kmh" in s:
        typer.echo(f"  analysed speed range {s['speed_range_kmh'][0]:g} .. {s['speed_range_kmh'][1]:g} km/h")
    for h in s.get("hopf_points", []):
        typer.echo(f"  Hopf   {h['speed_kmh']:9.3f} km/h  {h['frequency_hz']:7.2f} Hz  {h['criticality']}")
    for f in s.get("folds", []):
        typer.echo(
            f"  fold   {f['speed_kmh']:9.3f} km/h  {f['frequency_hz']:7.2f} Hz  amplitude {f['amplitude_x_mm']:.4f} mm"
        )
    for v in s.get("period_doublings", []):
        typer.echo(f"  PD     {v:9.3f} km/h  period doubling (a multiplier crosses -1)")
    for v in s.get("torus_bifurcations", []):
        typer.echo(f"  NS     {v:9.3f} km/h  torus bifurcation (a complex multiplier pair leaves the unit circle)")
    for v in s.get("real_eigenvalue_crossings_kmh", []):
        typer.echo(f"  DIV    {v:9.3f} km/h  static divergence (a real eigenvalue of steady rolling crosses 0)")
    for lo, hi in s.get("linear_band_kmh", []):
        typer.echo(f"  steady rolling unstable      {_bound(lo)} .. {_bound(hi)} km/h")
    for lo, hi in s.get("divergence_kmh", []):
        typer.echo(f"  of which static divergence   {_bound(lo)} .. {_bound(hi)} km/h")
    for lo, hi in s.get("sev_band_kmh", []):
        typer.echo(f"  SEV after large disturbance  {_bound(lo)} .. {_bound(hi)} km/h")
    for lo, hi in s.get("gaps_after_pd_ns_kmh", []):
        typer.echo(f"  gap after PD/NS (period-1)   {_bound(lo)} .. {_bound(hi)} km/h: motions past the period "
                   "doublings may persist here; polywear report at such a speed simulates")
    first, second = s.get("first_bifurcation_speed_kmh"), s.get("second_bifurcation_speed_kmh")
    if s.get("sev_band_kmh"):
        typer.echo(f"  first / second bifurcation speed: {_bound(first).strip()} / {_bound(second).strip()} km/h")
    else:
        typer.echo("  no self-excited vibration in the speed range")
    for b in s.get("branches", []):
        status = "FAILED" if b["failed"] else "ended"
        typer.echo(f"  cycle branch {b['branch']} from Hopf {b['from_hopf_kmh']:9.3f} km/h, {status} at "
                   f"{b['at_speed_kmh']:9.3f} km/h: {b['end_reason']}")
    for t in s.get("trigger_amplitude", []):
        lo, hi = t["speed_range_kmh"]
        typer.echo(
            f"  hard excitation {_bound(lo).strip()} .. {_bound(hi).strip()} km/h: a disturbance of x above "
            f"{t['min_x_mm']:.4f} .. {t['max_x_mm']:.4f} mm starts SEV"
        )


def _bound(v) -> str:
    """A band bound [km/h], or "open" where the band runs into an end of the analysed range."""
    return f"{v:9.3f}" if v is not None else f"{'open':>9}"
