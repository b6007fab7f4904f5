"""``polywear simulate``: time simulation, steady-state amplitudes, phase portraits."""

from __future__ import annotations

import math
from typing import Annotated, Optional

import typer

from .common import (
    ConfigOpt,
    JsonOpt,
    OutOpt,
    PlotOpt,
    SetOpt,
    UserError,
    emit_json,
    info,
    load,
    progress,
    write_figure,
)


def _numbers(texts: list[str], what: str) -> list[float]:
    """Floats from repeated and/or comma-separated option values."""
    values = []
    for text in texts:
        for part in text.split(","):
            try:
                value = float(part)
            except ValueError:
                raise UserError(f"{what} {part.strip()!r}: not a number") from None
            if not math.isfinite(value):
                raise UserError(f"{what} {part.strip()!r}: must be finite")
            values.append(value)
    return values


def _parse_sweep(text: str) -> tuple[str, list[float]]:
    key, sep, values = text.partition("=")
    if not sep or not key.strip() or not values.strip():
        raise UserError(f"--sweep {text!r}: expected table.key=v1,v2,...")
    return key.strip(), _numbers([values], f"--sweep {key.strip()}")


def _status(run) -> str:
    st = run.steady
    x = run.model.index("x")
    head = f"{run.label + ': ' if run.label else ''}{run.speed_kmh:g} km/h, {run.duration_s:g} s: {st.outcome}"
    if run.contact_lost:
        head += " (the tire lost contact with the road)"
    if st.outcome == "equilibrium":
        return head
    freq = f", {st.frequency:.2f} Hz, polygon order {run.polygon_order:.2f}" if math.isfinite(st.frequency) else ""
    return f"{head}, x amplitude {st.amplitude[x] * 1e3:.4g} mm{freq}"


def simulate(
    config: ConfigOpt = None,
    set_: SetOpt = None,
    speed: Annotated[
        Optional[float], typer.Option("--speed", help="Speed [km/h] (default: operating.speed_kmh).")
    ] = None,
    duration: Annotated[float, typer.Option("--duration", help="Simulated time [s].")] = 1.0,
    disturbance: Annotated[
        Optional[list[str]],
        typer.Option(
            "--disturbance", "-d",
            help="Initial tread displacement from equilibrium [m]; repeat or comma-separate for "
            "several runs (phase portraits from several starts). Default 1e-4.",
        ),
    ] = None,
    sweep: Annotated[
        Optional[str],
        typer.Option("--sweep", help="One run per value of a key: table.key=v1,v2,... (e.g. operating.toe_deg=0.3,0.5,0.7); the plot then shows the analysed final part of each run."),
    ] = None,
    method: Annotated[str, typer.Option("--method", help="rodas (compiled), radau, bdf, lsoda, dop853.")] = "rodas",
    rtol: Annotated[float, typer.Option("--rtol", help="Relative tolerance of the integrator.")] = 1e-8,
    json_: JsonOpt = False,
    plot: PlotOpt = None,
    out: OutOpt = None,
) -> None:
    """Simulate from a disturbed steady rolling state: amplitudes, SEV frequency, polygon order.

    Phase portraits of every coordinate; --sweep KEY=v1,v2 compares parameter values."""
    params = load(config, set_)
    from ..analysis.simulation import SimulationSettings, simulate_disturbances, simulate_values

    disturbances = _numbers(disturbance or ["1e-4"], "--disturbance")
    if speed is not None and not (math.isfinite(speed) and speed > 0.0):
        raise UserError(f"--speed {speed!r}: must be a positive speed [km/h]")
    if not (math.isfinite(duration) and duration > 0.0):
        raise UserError(f"--duration {duration!r}: must be a positive time [s]")
    try:
        settings = SimulationSettings(method=method, rtol=rtol)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    if sweep and len(disturbances) > 1:
        raise UserError("--sweep runs one disturbance per value: give at most one --disturbance")
    key, values = _parse_sweep(sweep) if sweep else (None, [])
    if key:
        from ..params import get_value

        get_value(params, key)  # an unknown key is reported before anything runs
    n_runs = len(values) if key else len(disturbances)
    from ..solvers.integrate import IntegrationError

    with progress(f"simulating {duration:g} s", total=n_runs, enabled=not json_) as advance:
        try:
            if key:
                result = simulate_values(params, key, values, speed, duration, disturbance=disturbances[0],
                                         settings=settings, on_run=advance)
            else:
                result = simulate_disturbances(params, disturbances, speed, duration, settings=settings,
                                               on_run=advance)
        except IntegrationError as exc:
            raise UserError(str(exc)) from None
    runs = result.runs
    for run in runs:
        info(_status(run), quiet=json_)
    single = runs[0] if len(runs) == 1 else None
    if out:
        (single or result).save(out)
        info(f"wrote {out}", quiet=json_)
    if plot:
        # parameter sweeps compare the final cycles; disturbances show the way there
        tail = settings.window_fraction * duration if key else None
        write_figure(plot, lambda: (single or result).plot(tail_s=tail)[0].figure, quiet=json_)
    if json_:
        emit_json(single.summary() if single else result.summary())
