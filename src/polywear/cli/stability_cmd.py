"""``polywear stability``: eigenvalues of steady rolling along speed, Hopf speeds."""

from __future__ import annotations

from typing import Annotated

import typer

from ..units import STABILITY_SPEED_RANGE_KMH
from .common import Inputs, Outputs, SpeedRangeOpt
from .common import MAX_GRID_POINTS, NETCDF_OUTPUTS, check_count, check_speed_range, one_axes, user_errors


def stability(
    inputs: Inputs = Inputs(),
    speed_range: SpeedRangeOpt = STABILITY_SPEED_RANGE_KMH,
    n_speeds: Annotated[int, typer.Option("--n-speeds", help="Speed grid points for bracketing.")] = 400,
    outputs: Outputs = NETCDF_OUTPUTS,
) -> None:
    """Linear stability of steady rolling: Hopf speeds, frequencies, unstable speed bands."""
    outputs.check()
    lo, hi = check_speed_range(speed_range)
    check_count(n_speeds, "--n-speeds", 3, MAX_GRID_POINTS)
    params = inputs.load()
    from ..dynamics.stability import StabilitySettings, stability

    outputs.note(f"stability: eigenvalues at {n_speeds} speeds ...")
    with user_errors(ValueError):
        result = stability(params, (lo, hi), StabilitySettings(n_speeds=n_speeds))
    outputs.write(result.save, lambda: one_axes(result.plot, (7, 4)))
    outputs.show(result.summary(), lambda summary: _print_summary(result, summary))


def _band_text(lo: float, hi: float, result, open_ends: list[str]) -> str:
    """One unstable interval [km/h] in words; an end at the analysed range is no onset."""
    below = lo == float(result.speeds_kmh[0]) and "lower" in open_ends
    above = hi == float(result.speeds_kmh[-1]) and "upper" in open_ends
    if below and above:
        return (f"steady rolling unstable over the whole analysed range {lo:.3f} .. {hi:.3f} km/h "
                "(the band begins below it and ends above it)")
    if below:
        return (f"steady rolling unstable up to {hi:.3f} km/h; the onset lies below the analysed range "
                f"(which starts at {lo:.3f} km/h: widen it with --speed-range)")
    if above:
        return (f"steady rolling unstable from {lo:.3f} km/h to beyond the analysed range "
                f"(which ends at {hi:.3f} km/h: widen it with --speed-range)")
    return f"steady rolling unstable from {lo:.3f} to {hi:.3f} km/h"


def _print_summary(result, summary: dict) -> None:
    """The summary as text on stdout (the Hopf points from ``result``)."""
    typer.echo(f"model {summary['model']}")
    if not result.hopf_points:
        typer.echo("no Hopf point in the speed range: steady rolling is "
                   + ("unstable throughout" if summary["linear_band_kmh"] else "stable throughout"))
    for h in result.hopf_points:
        s = h.summary()
        typer.echo(
            f"Hopf {s['speed_kmh']:9.3f} km/h  {s['frequency_hz']:7.2f} Hz  {s['criticality']:4s} "
            f"({s['crossing']}, mode {s['mode']}, l1 = {s['first_lyapunov_coefficient']:.3g})"
        )
    for v in summary["real_eigenvalue_crossings_kmh"]:
        typer.echo(f"real eigenvalue crosses zero at {v:9.3f} km/h (static divergence / fold of equilibria)")
    for lo, hi in summary["linear_band_kmh"]:
        typer.echo(_band_text(lo, hi, result, summary["linear_band_open_ends"]))
    if "running_alignment" in summary:
        a = summary["running_alignment"]
        typer.echo(
            f"running toe {a['toe_deg']:.4f} deg, camber {a['camber_deg']:.4f} deg at {a['speed_kmh']:g} km/h "
            f"(toe {a['toe_range_deg'][0]:.4f} .. {a['toe_range_deg'][1]:.4f} deg over the speed range)"
        )
