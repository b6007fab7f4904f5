"""``polywear wear``: polygonal wear itself (linear map, evolution over distance)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Optional

import typer

from ..params import MAX_WEAR_KM, MAX_WEAR_ORDER
from ..units import DEFAULT_SPEED_RANGE_KMH
from .common import Inputs, JsonOpt, Outputs, PlotOpt, QuietOpt, SpeedRangeOpt
from .common import (
    MAX_GRID_POINTS,
    MAX_SPEED_KMH,
    PLOT_SUFFIXES,
    UserError,
    check_count,
    check_param_keys,
    check_speed_range,
    info,
    one_axes,
    output_file,
    user_errors,
    write_figure,
)

app = typer.Typer(
    help="Polygonal wear: which orders grow at which speeds (map), the worn profile over distance (evolve), "
    "what stops it (design).",
    no_args_is_help=True,
    rich_markup_mode=None,
)

MAX_ORDER_LIMIT = MAX_WEAR_ORDER
"""Highest polygon order a command accepts (the bound of wear.max_order)."""
DEFAULT_STEP_KM = 1000.0
"""First distance step of ``wear evolve`` when --step-km is not given (clipped to the distance) [km]."""
MIN_TOLERANCE, MAX_TOLERANCE = 1e-4, 0.5
"""Range of ``wear evolve --tolerance`` [-]: below it the steps of a vibrating car outgrow any
budget; above it a step may change the profile by half its largest harmonic unseen."""


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
    inputs: Inputs = Inputs(),
    speeds: Annotated[
        Optional[str], typer.Option("--speeds", help="Comma-separated speeds [km/h], e.g. 40,55,210 (else the range).")
    ] = None,
    speed_range: SpeedRangeOpt = DEFAULT_SPEED_RANGE_KMH,
    n_speeds: Annotated[int, typer.Option("--n-speeds", help="Speeds of the range.")] = 300,
    max_order: Annotated[
        Optional[int], typer.Option("--max-order", help="Highest polygon order (default wear.max_order).")
    ] = None,
    all_orders: Annotated[bool, typer.Option("--all-orders", help="JSON: a row for every order, not only the most unstable.")] = False,
    sev_band: Annotated[
        bool, typer.Option("--sev-band", help="Figure: shade the SEV band too (runs the bifurcation diagram, seconds).")
    ] = False,
    outputs: Outputs = Outputs("Write the map (.nc) or its rows (.csv).", (".nc", ".csv")),
) -> None:
    """Linear wear-stability map: growth of every polygon order at every speed (exact, no simulation)."""
    outputs.check()
    check_count(max_order, "--max-order", 1, MAX_ORDER_LIMIT)
    if speeds is not None:
        grid = parse_speeds(speeds)
    else:
        lo, hi = check_speed_range(speed_range)
        check_count(n_speeds, "--n-speeds", 2, MAX_GRID_POINTS)
        grid = [lo + (hi - lo) * i / (n_speeds - 1) for i in range(n_speeds)]
    params = inputs.load()
    from ..wear.map import WearMapSettings, wear_map

    outputs.note(f"wear map: {len(grid)} speeds x {max_order or params.wear.max_order} orders ...")
    with user_errors(ValueError, RuntimeError, ArithmeticError, prefix="wear map: "):
        result = wear_map(params, grid, WearMapSettings(max_order=max_order))
    rows_only = outputs.out is not None and outputs.out.suffix.lower() != ".nc"
    outputs.write((lambda p: _write_rows(p, result.rows(True))) if rows_only else result.save,
                  lambda: _map_figure(result, params, (min(grid), max(grid)), sev_band, outputs.quiet))
    outputs.show(result.summary(all_orders), lambda summary: _print_map(summary, collapse=speeds is None))


def _map_figure(result, params, speed_range: tuple[float, float], sev_band: bool, quiet: bool):
    """The wear map's figure; the SEV band in ``speed_range`` [km/h] shaded if ``sev_band``."""
    band = _sev_band(params, speed_range, quiet) if sev_band else None
    return one_axes(lambda ax: result.plot(ax, sev_band_kmh=band), (9, 5.5))


def _print_map(summary: dict, collapse: bool = True) -> None:
    """The most unstable order at each speed as text on stdout; with ``collapse`` (a speed
    range's grid) a run of vibrating speeds is shown by its first and last line, else
    (speeds the user listed) every speed gets its line."""
    typer.echo(f"model {summary['model']}; distances scale as 1/k_e (k_e = {summary['energetic_rate_mm3_per_j']:g} mm³/J)")
    rows = summary["rows"]
    for i, row in enumerate(rows):
        if not row["rolling_stable"]:
            first = i == 0 or rows[i - 1]["rolling_stable"]
            last = i == len(rows) - 1 or rows[i + 1]["rolling_stable"]
            if not collapse:
                typer.echo(f"{row['speed_kmh']:8.1f} km/h  {row['note']}")
            elif first or last:  # one line for each run of vibrating speeds
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
    from ..dynamics.bifurcation import bifurcation

    info("wear map: bifurcation diagram for the SEV band ...", quiet)
    bands = bifurcation(params, speed_range).sev_band_kmh
    return (bands[0][0], bands[-1][1]) if bands else None


CycleOpt = Annotated[
    Optional[str],
    typer.Option("--cycle", help="Drive cycle speed:share,... e.g. 120:0.3,80:0.4,50:0.3 (default [[wear.cycle]])."),
]
"""``--cycle`` of ``wear evolve`` and ``wear design``, read by :func:`parse_cycle`."""


def parse_cycle(text: str) -> tuple[tuple[float, float], ...]:
    """``"120:0.3,80:0.4,50:0.3"`` -> ((speed [km/h], share), ...), shares normalised
    (they must sum to 1 within the tolerance of ``[[wear.cycle]]``)."""
    from ..params import CYCLE_SHARE_TOLERANCE

    pairs = []
    for item in (s for s in text.split(",") if s.strip()):
        speed, sep, share = item.partition(":")
        try:
            pairs.append((float(speed), float(share) if sep else math.nan))
        except ValueError:
            raise UserError(f"--cycle {text!r}: expected speed:share pairs, e.g. 120:0.3,80:0.4,50:0.3") from None
    if not pairs or any(math.isnan(s) for _, s in pairs):
        raise UserError(f"--cycle {text!r}: expected speed:share pairs, e.g. 120:0.3,80:0.4,50:0.3")
    for v, s in pairs:
        if not (math.isfinite(v) and 0.0 < v <= MAX_SPEED_KMH):
            raise UserError(f"--cycle {text!r}: speed {v:g} must be in (0, {MAX_SPEED_KMH:g}] km/h")
        if not (math.isfinite(s) and 0.0 < s <= 1.0):
            raise UserError(f"--cycle {text!r}: share {s:g} must be in (0, 1]")
    if len({v for v, _ in pairs}) != len(pairs):
        raise UserError(f"--cycle {text!r}: a speed is given more than once")
    total = math.fsum(s for _, s in pairs)
    if abs(total - 1.0) > CYCLE_SHARE_TOLERANCE:
        raise UserError(f"--cycle {text!r}: shares sum to {total:.6g}, must sum to 1")
    return tuple((v, s / total) for v, s in pairs)


@app.command("evolve")
def evolve_(
    inputs: Inputs = Inputs(),
    distance_km: Annotated[float, typer.Option("--distance-km", help="Distance to drive [km].")] = 60000.0,
    cycle: CycleOpt = None,
    speed: Annotated[
        Optional[float], typer.Option("--speed", help="One speed for the whole distance [km/h] (instead of a cycle).")
    ] = None,
    step_km: Annotated[
        Optional[float], typer.Option("--step-km", help="Distance step between simulated windows [km] "
                                      "(default: 1000, or the distance if shorter).")
    ] = None,
    revolutions: Annotated[int, typer.Option("--revolutions", help="Simulated revolutions per window where the tread vibrates (at least; lengthened up to 64 to separate the vibration from its nearest integer order).")] = 16,
    tolerance: Annotated[
        Optional[float], typer.Option("--tolerance", help="Error allowed per distance step, relative to the largest "
                                      f"harmonic [-] ({MIN_TOLERANCE:g} to {MAX_TOLERANCE:g}; default: the evolution's, "
                                      "0.01; 0.0025: depths to about 1 % where several orders add up, at about twice "
                                      "the steps).")
    ] = None,
    json_: JsonOpt = False,
    plot: PlotOpt = None,
    polar: Annotated[Optional[Path], typer.Option("--polar", help="Polar figure of the worn tire (png, pdf, svg).")] = None,
    polar_km: Annotated[
        Optional[str], typer.Option("--polar-km", help="Distances of the polar figure [km], e.g. 20000,40000,60000 (default: four).")
    ] = None,
    waterfall: Annotated[Optional[Path], typer.Option("--waterfall", help="Order amplitudes over distance (png, pdf, svg).")] = None,
    out: Annotated[Optional[Path], typer.Option("--out", "-o", help="Write w(distance, angle) and the harmonics (.nc).")] = None,
    workers: Annotated[
        Optional[int], typer.Option("--workers", "-w", min=1, max=64,
                                    help="Threads that simulate the cycle's speeds side by side (same result; default: one per speed, at most the CPU count).")
    ] = None,
    start: Annotated[
        str, typer.Option("--start", help="Where the tread starts at each speed: rest (steady rolling, as a car drives) "
                          "or cycle (on the large stable cycle where it coexists with stable rolling: hard "
                          "self-excitation, as after a pothole; an error if no speed has one).")
    ] = "rest",
    quiet: QuietOpt = False,
) -> None:
    """Worn profile over distance from seeded roughness: depth, polygon order, visible distance."""
    outputs = Outputs(suffixes=(".nc",), json_=json_, plot=plot, out=out, quiet=quiet)
    outputs.check()
    for path, option in ((polar, "--polar"), (waterfall, "--waterfall")):
        output_file(path, option, PLOT_SUFFIXES)
    if not (math.isfinite(distance_km) and 0.0 < distance_km <= MAX_WEAR_KM):
        raise UserError(f"--distance-km {distance_km:g}: must be in (0, {MAX_WEAR_KM:g}]")
    if step_km is None:
        step_km = min(DEFAULT_STEP_KM, distance_km)
    if not (math.isfinite(step_km) and 0.0 < step_km <= distance_km):
        raise UserError(f"--step-km {step_km:g}: must be positive and at most --distance-km")
    if distance_km / step_km > 10_000:
        raise UserError(f"--step-km {step_km:g}: more than 10000 steps; use a longer step")
    check_count(revolutions, "--revolutions", 6, 1000)
    if tolerance is not None and not (math.isfinite(tolerance) and MIN_TOLERANCE <= tolerance <= MAX_TOLERANCE):
        raise UserError(f"--tolerance {tolerance:g}: must be in [{MIN_TOLERANCE:g}, {MAX_TOLERANCE:g}]")
    from ..wear.start import STARTS

    if start not in STARTS:
        raise UserError(f"--start {start!r}: one of {', '.join(STARTS)}")
    if speed is not None and cycle is not None:
        raise UserError("--speed and --cycle: give one of them")
    if speed is not None and not (math.isfinite(speed) and 0.0 < speed <= MAX_SPEED_KMH):
        raise UserError(f"--speed {speed:g}: must be in (0, {MAX_SPEED_KMH:g}] km/h")
    chosen = None
    if polar_km is not None:
        try:
            chosen = [float(v) for v in polar_km.split(",") if v.strip()]
        except ValueError:
            raise UserError(f"--polar-km {polar_km!r}: expected comma-separated distances in km") from None
        if not chosen or not all(math.isfinite(v) and 0.0 <= v <= distance_km for v in chosen):
            raise UserError(f"--polar-km {polar_km!r}: distances must lie in [0, --distance-km]")
    params = inputs.load()
    pairs = ((float(speed), 1.0),) if speed is not None else (parse_cycle(cycle) if cycle else None)
    from ..wear.evolution import EvolutionSettings, StepBudgetError, wear_evolution

    stopped = None
    with (
        outputs.progress("wear evolve [km]") as update,
        user_errors(ValueError, RuntimeError, ArithmeticError, prefix="wear evolve: "),
    ):
        try:
            result = wear_evolution(params, distance_km, pairs,
                                    EvolutionSettings(step_km=step_km, revolutions=revolutions,
                                                      **({} if tolerance is None else {"tolerance": tolerance})),
                                    progress=update, workers=workers, start=start)
        except StepBudgetError as exc:  # what was evolved is kept: written, then the error
            if exc.partial is None:
                raise
            result, stopped = exc.partial, exc
    if chosen is not None and stopped is not None:
        chosen = [v for v in chosen if v <= stopped.done_km] or None
    outputs.write(result.save, lambda: one_axes(result.plot, (8, 4.5)))
    if polar:
        write_figure(polar, lambda: _polar_figure(result, chosen), quiet)
    if waterfall:
        write_figure(waterfall, lambda: one_axes(result.plot_waterfall, (8, 4.5)), quiet)
    if stopped is not None:
        raise UserError(f"wear evolve: {stopped} (the evolution up to {stopped.done_km:,.0f} km is written)")
    outputs.show(result.summary(), _print_evolution)


def _print_evolution(summary: dict) -> None:
    """State at each cycle speed, depth and visible distance [km] as text on stdout."""
    visible = summary["visible_km"]
    typer.echo(f"model {summary['model']}: {summary['distance_km']:,.0f} km; distances scale as 1/k_e")
    for row in summary["cycle"]:
        state = ("no vibration" if row["vibration_order_end"] is None else
                 f"vibrating at order {row['vibration_order_end']:.4f}"
                 + (" (locked)" if row["locked_fraction"] else " (not locked)"))
        typer.echo(f"  {row['speed_kmh']:6.1f} km/h, share {row['share']:.2f}: {state}")
    typer.echo(f"depth {summary['initial_depth_mm']:.4f} -> {summary['final_depth_mm']:.4f} mm peak-to-valley, "
               f"dominant order {summary['dominant_order']}, mean wear {summary['mean_wear_mm']:.2f} mm")
    typer.echo(f"polygon visible ({summary['visible_depth_mm']} mm) after {visible:,.0f} km" if visible is not None
               else f"polygon not visible ({summary['visible_depth_mm']} mm) within the distance")


def _polar_figure(result, distances_km=None):
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(5.5, 5.5))
    result.plot_polar(fig.add_subplot(projection="polar"), distances_km)
    return fig


@app.command("design")
def design_(
    inputs: Inputs = Inputs(),
    target_km: Annotated[
        Optional[float],
        typer.Option("--target-km", help="Push the visible-polygon distance beyond this [km] (default: every order stable)."),
    ] = None,
    keys: Annotated[
        Optional[list[str]], typer.Option("--key", "-k", help="Parameter to change (repeatable; default: alignment, bushings, tread, adhesion).")
    ] = None,
    cycle: CycleOpt = None,
    max_factor: Annotated[float, typer.Option("--max-factor", help="Largest change searched: x or / this factor.")] = 4.0,
    verify_km: Annotated[
        Optional[float], typer.Option("--verify-km", help="Verify the best option found by the map by evolution over this distance [km] (minutes).")
    ] = None,
    judge: Annotated[
        str, typer.Option("--judge", help="What judges an option: map (linear wear map), evolution (nonlinear evolution "
                                          "over --target-km, minutes), auto (the evolution where the tread vibrates at a "
                                          "cycle speed, else the map).")
    ] = "auto",
    workers: Annotated[
        int, typer.Option("--workers", "-w", min=1, max=64, help="Processes that run a search step's probes side by side (default 1: threads in this process; same result).")
    ] = 1,
    levels: Annotated[
        Optional[int], typer.Option("--levels", min=1, help="Where the evolution judges: grid levels searched at most "
                                    "(default: all 8 up to --max-factor); 1 with --rounds 1 is the report's search "
                                    "for axle4dof.")
    ] = None,
    refine: Annotated[
        bool, typer.Option("--refine/--no-refine", help="Where the evolution judges: refine the least change found "
                           "on the grid to 2 % (default), or give the grid level itself.")
    ] = True,
    rounds: Annotated[
        Optional[int], typer.Option("--rounds", min=1, help="Where the evolution judges: rounds of the refinement at "
                                    "most, two probes per key each (default: until 2 %).")
    ] = None,
    outputs: Outputs = Outputs(takes_plot=False),
) -> None:
    """Least change (toe, camber, damping, stiffness, adhesion) that stops polygonal wear over the drive cycle, vibrating or not."""
    if target_km is not None and not (math.isfinite(target_km) and target_km > 0):
        raise UserError(f"--target-km {target_km:g}: must be positive")
    if not (math.isfinite(max_factor) and 1.0 < max_factor <= 100.0):
        raise UserError(f"--max-factor {max_factor:g}: must be in (1, 100]")
    if verify_km is not None and not (math.isfinite(verify_km) and 0 < verify_km <= 1e6):
        raise UserError(f"--verify-km {verify_km:g}: must be in (0, 1e6]")
    if rounds is not None and not refine:
        raise UserError(f"--rounds {rounds} with --no-refine: there is no refinement to bound")
    from ..wear.design import Judge, WearDesignSettings, verify_option, wear_design

    if judge not in tuple(Judge):
        raise UserError(f"--judge {judge!r}: one of {', '.join(j.value for j in Judge)}")
    if judge == Judge.EVOLUTION and target_km is None:
        raise UserError("--judge evolution needs --target-km")
    params = inputs.load()
    pairs = parse_cycle(cycle) if cycle else None
    check_param_keys(keys or (), "--key")
    from ..parallel import Executor

    outputs.note("wear design: searching (where the evolution judges, each probe is an evolution: minutes) ...")
    with (
        outputs.progress("wear design [evolutions]") as update,
        user_errors(ValueError, RuntimeError, ArithmeticError, prefix="wear design: "),
    ):
        settings = WearDesignSettings(max_factor, judge=Judge(judge), max_levels=levels, refine=refine,
                                      refine_rounds=rounds)
        result = wear_design(params, keys or None, target_km, pairs, settings,
                             executor=Executor("processes", workers) if workers > 1 else None, progress=update)
    if verify_km is not None and result.options and result.judge == Judge.MAP:
        outputs.note(f"wear design: verifying '{result.options[0].label}' by evolution over {verify_km:,.0f} km ...")
        verify_option(params, result.options[0], verify_km, pairs)
    outputs.show(result.summary(), _print_design)


def _evolution_text(ev: dict) -> str:
    """One evolution of the wear design in words."""
    return (f"evolution over {ev['distance_km']:,.0f} km: depth {ev['depth_mm']:.4f} mm, order {ev['dominant_order']}, "
            + ("not visible" if ev["visible_km"] is None else f"visible after {ev['visible_km']:,.0f} km"))


def _print_design(summary: dict) -> None:
    """The nominal growth and each option as text on stdout (growth per 1000 km)."""
    n = summary["nominal"]
    typer.echo(f"model {summary['model']}: {summary['criterion']}; distances scale as 1/k_e")
    ev = summary["nominal_evolution"]
    if ev is not None:
        typer.echo("nominal: " + ("the tread vibrates at a cycle speed; " if not n["rolling_stable_at_every_cycle_speed"]
                                  else "") + _evolution_text(ev))
    else:
        typer.echo("nominal: " + (f"fastest order {n['order']} grows {n['growth_per_1000km']:+.4f}/1000 km over the cycle"
                                  if n["rolling_stable_at_every_cycle_speed"] else
                                  "the tread vibrates at a cycle speed (linear band): an option must move the band"))
    for o in summary["options"]:
        line = f"  {o['label']}: {o['nominal']:.4g} -> {o['value']:.4g} ({o['relative_change']:+.1%}), "
        if o["evolution"] is not None:
            line += _evolution_text(o["evolution"])
        elif o["growth_per_1000km"] is None:
            line += "the tread vibrates at a cycle speed"
        else:
            line += f"fastest order {o['order']} at {o['growth_per_1000km']:+.4f}/1000 km"
        other = o.get("other_direction")
        if other is not None:
            line += (f"; or -> {other['value']:.4g} ({other['relative_change']:+.1%}), "
                     + _evolution_text(other["evolution"]))
        v = o["verification"]
        if v:
            line += (f"; evolution over {v['distance_km']:,.0f} km: depth {v['depth_mm']:.4f} mm "
                     f"(nominal {v['nominal_depth_mm']:.4f} mm), " + ("not visible" if v["visible_km"] is None
                                                                       else f"visible after {v['visible_km']:,.0f} km"))
        typer.echo(line)
    for note in summary["not_found"]:
        typer.echo(f"  {note}")
