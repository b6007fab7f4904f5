"""``polywear simulate``: time simulation, steady-state amplitudes, phase portraits."""

from __future__ import annotations

import math
from typing import Annotated, Optional

import typer

from .common import MAX_SPEED_KMH, NETCDF_OUTPUTS, Inputs, Outputs, UserError, user_errors

MAX_DURATION_S = 60.0
"""Longest simulated time per run [s] (50 000 stored samples per second and run)."""
MAX_RUNS = 100
"""Most runs (disturbances or sweep values) of one command."""
RTOL_RANGE = (1e-13, 1e-2)
"""Relative tolerances the integrators accept: tighter is below rounding, looser is meaningless."""


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
        return f"{head}: no oscillation, the disturbance decays"
    if not math.isfinite(st.amplitude[x]):
        return f"{head}: not settled and no whole cycle to measure (a longer --duration may settle it)"
    freq = f", {st.frequency:.2f} Hz, frequency order {run.frequency_order:.2f}" if math.isfinite(st.frequency) else ""
    return f"{head}, x amplitude {st.amplitude[x] * 1e3:.4g} mm{freq}"


def simulate(
    inputs: Inputs = Inputs(),
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
    outputs: Outputs = NETCDF_OUTPUTS,
) -> None:
    """Simulate from a disturbed steady rolling state: amplitudes, SEV frequency, frequency order.

    Phase portraits of every coordinate; --sweep KEY=v1,v2 compares parameter values."""
    outputs.check()
    disturbances = _numbers(disturbance or ["1e-4"], "--disturbance")
    if speed is not None and not (math.isfinite(speed) and 0.0 < speed <= MAX_SPEED_KMH):
        raise UserError(f"--speed {speed!r}: must be a speed in (0, {MAX_SPEED_KMH:g}] [km/h]")
    if not (math.isfinite(duration) and 0.0 < duration <= MAX_DURATION_S):
        raise UserError(f"--duration {duration!r}: must be a time in (0, {MAX_DURATION_S:g}] [s]")
    if not RTOL_RANGE[0] <= rtol <= RTOL_RANGE[1]:
        raise UserError(f"--rtol {rtol!r}: must be between {RTOL_RANGE[0]:g} and {RTOL_RANGE[1]:g}")
    params = inputs.load()
    from ..dynamics.simulation import SimulationSettings, simulate_disturbances, simulate_values

    with user_errors(ValueError):
        settings = SimulationSettings(method=method, rtol=rtol)
    if sweep and len(disturbances) > 1:
        raise UserError("--sweep runs one disturbance per value: give at most one --disturbance")
    key, values = _parse_sweep(sweep) if sweep else (None, [])
    if key:
        from ..params import get_value

        get_value(params, key)  # an unknown key is reported before anything runs
    n_runs = len(values) if key else len(disturbances)
    if n_runs > MAX_RUNS:
        raise UserError(f"{n_runs} runs: at most {MAX_RUNS} disturbances or sweep values")
    from ..solvers.integrate import IntegrationError

    with outputs.progress(f"simulating {duration:g} s") as update, user_errors(IntegrationError):
        if key:
            result = simulate_values(params, key, values, speed, duration, disturbance=disturbances[0],
                                     settings=settings, progress=update)
        else:
            result = simulate_disturbances(params, disturbances, speed, duration, settings=settings,
                                           progress=update)
    runs = result.runs
    shown = runs[0] if len(runs) == 1 else result  # a single run is written and summarised as itself
    # parameter sweeps compare the final cycles; disturbances show the way there
    tail = settings.window_fraction * duration if key else None
    outputs.write(shown.save, lambda: shown.plot(tail_s=tail)[0].figure)
    outputs.show(shown.summary(), lambda _: _print_runs(runs))


def _print_runs(runs) -> None:
    """One status line per run on stdout."""
    for run in runs:
        typer.echo(_status(run))
