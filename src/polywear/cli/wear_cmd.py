"""``polywear wear``: polygonal wear itself (linear map, evolution over distance)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Optional

import typer

from .common import (
    MAX_GRID_POINTS,
    MAX_SPEED_KMH,
    PLOT_SUFFIXES,
    ConfigOpt,
    JsonOpt,
    PlotOpt,
    QuietOpt,
    SetOpt,
    UserError,
    check_count,
    check_speed_range,
    emit_json,
    info,
    load,
    one_axes,
    output_file,
    write_figure,
    write_output,
)

app = typer.Typer(
    help="Polygonal wear: which orders grow at which speeds (map), the worn profile over distance (evolve).",
    no_args_is_help=True,
    rich_markup_mode=None,
)

MAX_ORDER_LIMIT = 500
"""Highest polygon order a command accepts."""


def parse_speeds(text: str, option: str = "--speeds") -> list[float]:
    """``"40,55,210"`` -> speeds [km/h], each finite and in (0, MAX_SPEED_KMH]."""
    try:
        speeds = [float(item) for item in text.split(",") if item.strip()]
    except ValueError:
        raise UserError(f"{option} {text!r}: expected comma-separated speeds in km/h, e.g. 40,55,210") from None
    if not speeds:
        raise UserError(f"{option} {text!r}: no speed given")
    for v in speeds:
        if not (math.isfinite(v) and 0.0 < v <= MAX_SPEED_KMH):
            raise UserError(f"{option} {text!r}: speed {v:g} must be in (0, {MAX_SPEED_KMH:g}] km/h")
    if len(speeds) > MAX_GRID_POINTS:
        raise UserError(f"{option}: {len(speeds)} speeds, at most {MAX_GRID_POINTS}")
    return speeds


@app.command("map")
def map_(
    config: ConfigOpt = None,
    set_: SetOpt = None,
    speeds: Annotated[
        Optional[str], typer.Option("--speeds", help="Comma-separated speeds [km/h], e.g. 40,55,210 (else the range).")
    ] = None,
    speed_range: Annotated[
        tuple[float, float], typer.Option("--speed-range", help="Lowest and highest speed [km/h].")
    ] = (20.0, 300.0),
    n_speeds: Annotated[int, typer.Option("--n-speeds", help="Speeds of the range.")] = 300,
    max_order: Annotated[
        Optional[int], typer.Option("--max-order", help="Highest polygon order (default wear.max_order).")
    ] = None,
    all_orders: Annotated[bool, typer.Option("--all-orders", help="JSON: a row for every order, not only the most unstable.")] = False,
    sev_band: Annotated[
        bool, typer.Option("--sev-band", help="Figure: shade the SEV band too (runs the bifurcation diagram, seconds).")
    ] = False,
    json_: JsonOpt = False,
    plot: PlotOpt = None,
    out: Annotated[Optional[Path], typer.Option("--out", "-o", help="Write the map (.nc) or its rows (.csv).")] = None,
    quiet: QuietOpt = False,
) -> None:
    """Linear wear-stability map: growth of every polygon order at every speed (exact, no simulation)."""
    output_file(out, "--out", (".nc", ".csv"))
    output_file(plot, "--plot", PLOT_SUFFIXES)
    check_count(max_order, "--max-order", 1, MAX_ORDER_LIMIT)
    if speeds is not None:
        grid = parse_speeds(speeds)
    else:
        lo, hi = check_speed_range(speed_range)
        check_count(n_speeds, "--n-speeds", 2, MAX_GRID_POINTS)
        grid = [lo + (hi - lo) * i / (n_speeds - 1) for i in range(n_speeds)]
    params = load(config, set_)
    from ..analysis.wear_map import wear_map

    info(f"wear map: {len(grid)} speeds x {max_order or params.wear.max_order} orders ...", quiet)
    try:
        result = wear_map(params, grid, max_order)
    except (ValueError, RuntimeError, ArithmeticError) as exc:
        raise UserError(f"wear map: {exc}") from None
    if out:
        write_output(out, result.save if out.suffix.lower() == ".nc" else lambda p: _write_rows(p, result.rows(True)),
                     quiet)
    if plot:
        band = _sev_band(params, (min(grid), max(grid)), quiet) if sev_band else None
        write_figure(plot, lambda: one_axes(lambda ax: result.plot(ax, sev_band_kmh=band), (9, 5.5)), quiet)
    summary = result.summary(all_orders)
    if json_:
        emit_json(summary)
        return
    typer.echo(f"model {summary['model']}; distances scale as 1/k_e (k_e = {summary['energetic_rate_mm3_per_j']:g} mm^3/J)")
    rows = summary["rows"]
    for i, row in enumerate(rows):
        if not row["rolling_stable"]:
            first = i == 0 or rows[i - 1]["rolling_stable"]
            last = i == len(rows) - 1 or rows[i + 1]["rolling_stable"]
            if first or last:  # one line for each run of vibrating speeds
                typer.echo(f"{row['speed_kmh']:8.1f} km/h  {row['note']}" + ("" if last else "  ..."))
            continue
        efold = f"{row['efold_km']:10.0f} km" if row["efold_km"] is not None else "  no order grows"
        typer.echo(f"{row['speed_kmh']:8.1f} km/h  order {row['order']:3d}  {row['frequency_hz']:7.1f} Hz  "
                   f"e-fold {efold}  growth {row['growth_per_1000km']:+.4f}/1000 km  "
                   f"drift {row['drift_deg_per_rev']:+.2e} deg/rev")


def _write_rows(path: Path, rows: list[dict]) -> None:
    import csv

    with open(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def _sev_band(params, speed_range, quiet) -> tuple[float, float] | None:
    """Outer bounds of the SEV band from the bifurcation diagram (None if there is none)."""
    from ..analysis.bifurcation import bifurcation_diagram

    info("wear map: bifurcation diagram for the SEV band ...", quiet)
    bands = bifurcation_diagram(params, speed_range).sev_band_kmh
    return (bands[0][0], bands[-1][1]) if bands else None
