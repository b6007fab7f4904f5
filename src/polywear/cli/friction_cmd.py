"""``polywear friction``: static curve, hysteresis loops, fitting to measured data."""

from __future__ import annotations

import math
from enum import Enum
from pathlib import Path
from typing import Annotated, Any, Optional

import typer

from .common import Inputs, Outputs
from .common import NETCDF_OUTPUTS, UserError, check_count, one_axes, save_text, user_errors

MAX_POINTS = 100_000
"""Most samples of a curve or per loop."""
MAX_VELOCITY_M_PER_S = 1000.0
"""Largest sliding velocity accepted [m/s] (far beyond any tire)."""

app = typer.Typer(help="LuGre friction: static curve, hysteresis loops, fits to measured mu(v) and loops.",
                  no_args_is_help=True, rich_markup_mode=None)


def _operating_sliding_velocity(params) -> float:
    """Sliding velocity v_r of steady rolling at the operating point [m/s]."""
    from ..models import model_for
    from ..units import kmh_to_ms

    model = model_for(params)
    p = model.pack(params)
    speed = kmh_to_ms(params.operating.speed_kmh)
    aux = model.diagnostics(model.equilibrium(speed, p), speed, p)
    return float(aux[model.aux_names.index("sliding_velocity")])


def _figure(result, extra=None):
    """The figure of ``result``, with ``extra(ax)`` drawn on top."""

    def draw(ax):
        result.plot(ax=ax)
        if extra is not None:
            extra(ax)

    return one_axes(draw, (6.4, 4.4))


def _velocity(value: float, option: str) -> float:
    if not (math.isfinite(value) and abs(value) <= MAX_VELOCITY_M_PER_S):
        raise UserError(f"{option} {value}: must be finite, at most {MAX_VELOCITY_M_PER_S:g} in size [m/s]")
    return value


@app.command("curve")
def curve(
    inputs: Inputs = Inputs(),
    v_max: Annotated[float, typer.Option("--v-max", min=1e-9, help="Velocity range -v_max..v_max [m/s].")] = 1.5,
    points: Annotated[int, typer.Option("--points", min=3, help="Points of the curve.")] = 601,
    outputs: Outputs = NETCDF_OUTPUTS,
) -> None:
    """Static (Stribeck) friction curve mu_ss(v), its falling branch and the operating point."""
    import numpy as np

    from ..friction import steady_curve
    from ..physics.lugre import steady_friction, steady_friction_slope

    outputs.check()
    _velocity(v_max, "--v-max")
    check_count(points, "--points", 3, MAX_POINTS)
    params = inputs.load()
    f = params.friction
    result = steady_curve(f, np.linspace(-v_max, v_max, points))
    v_op = _operating_sliding_velocity(params)
    args = (f.sigma2_s_per_m, f.mu_static, f.mu_coulomb, f.stribeck_velocity_m_per_s, f.stribeck_exponent)
    mu_op = float(steady_friction(v_op, *args))
    slope_op = float(steady_friction_slope(v_op, *args)) if v_op != 0.0 else None

    def mark_operating_point(ax):
        ax.plot([v_op], [mu_op], "o", color="C3", label=f"operating point, $v_r$ = {v_op:.3g} m/s")
        ax.legend(fontsize="small")

    outputs.write(result.save, lambda: _figure(result, mark_operating_point))
    summary = {
        **result.summary(),
        "operating_sliding_velocity_m_per_s": v_op,
        "operating_mu": mu_op,
        "operating_slope_s_per_m": slope_op,
    }
    outputs.show(summary, lambda _: _print_curve(f, result.falling_branch, v_op, mu_op, slope_op))


def _print_curve(f, branch, v_op: float, mu_op: float, slope_op: float | None) -> None:
    """The static curve's keys, falling branch [m/s] and operating point as text on stdout."""
    typer.echo(f"mu_s = {f.mu_static:g}, mu_c = {f.mu_coulomb:g}, v_s = {f.stribeck_velocity_m_per_s:g} m/s, "
               f"delta = {f.stribeck_exponent:g}, sigma2 = {f.sigma2_s_per_m:g} s/m")
    if branch is None:
        typer.echo("no falling branch: d mu_ss/dv >= 0 for all v > 0 (no negative damping from friction)")
    else:
        typer.echo(f"falling branch (d mu_ss/dv < 0): {branch[0]:.4g} to {branch[1]:.4g} m/s")
    slope_text = f"{slope_op:.4g} s/m" if slope_op is not None else "undefined (v_r = 0)"
    typer.echo(f"operating point: v_r = {v_op:.4g} m/s, mu_ss = {mu_op:.4g}, d mu_ss/dv = {slope_text}")


class Contact(str, Enum):
    point = "point"
    patch = "patch"


MAX_SLIPS = 1000
"""Most slip angles of ``polywear friction steady``."""


def _parse_slips(text: str) -> list[float]:
    try:
        values = [float(item) for item in text.split(",") if item.strip()]
    except ValueError:
        raise UserError(f"--slip-deg {text!r}: expected comma-separated numbers, e.g. 0.05,0.1,0.5") from None
    if not values or any(not math.isfinite(x) or abs(x) >= 20.0 for x in values):
        raise UserError(f"--slip-deg {text!r}: need one or more finite slip angles, less than 20 in size [deg]")
    if len(values) > MAX_SLIPS:
        raise UserError(f"--slip-deg: {len(values)} given, at most {MAX_SLIPS}")
    return values


@app.command("steady")
def steady(
    inputs: Inputs = Inputs(),
    contact: Annotated[
        Optional[Contact], typer.Option("--contact", help="Contact model (default: friction.contact).")
    ] = None,
    slip_deg: Annotated[
        str, typer.Option("--slip-deg", help="Slip angles (toe) [deg], comma-separated.")
    ] = "0.05,0.1,0.2,0.5,1,2,5,10",
    outputs: Outputs = Outputs(takes_plot=False),
) -> None:
    """Steady lateral force of the contact at the operating speed and load against the slip
    angle, with the patch contact's cornering stiffness (docs/patch_contact.md)."""
    from ..models.patch import steady_lateral_force
    from ..params import ParameterError

    outputs.check()
    slips = _parse_slips(slip_deg)
    params = inputs.load()
    if contact is not None:
        with user_errors(ParameterError):
            params = params.with_updates({"friction.contact": contact.value})
    with user_errors(ParameterError, ValueError):
        result = steady_lateral_force(params, slips)
    outputs.show(result, _print_steady)


def _print_steady(result: dict) -> None:
    """The steady lateral forces as text on stdout."""
    typer.echo(f"contact: {result['contact']}, load {result['load_n']:g} N, cornering stiffness of the patch "
               f"{result['cornering_stiffness_n_per_rad'] / 1e3:.4g} kN/rad")
    typer.echo(f"{'slip [deg]':>11} {'force [N]':>11} {'C_alpha*alpha [N]':>18}")
    for row in result["rows"]:
        linear = result["cornering_stiffness_n_per_rad"] * math.tan(math.radians(row["slip_deg"]))
        typer.echo(f"{row['slip_deg']:>11.4g} {row['force_n']:>11.5g} {linear:>18.5g}")


def _parse_frequencies(text: str) -> list[float]:
    try:
        values = [float(item) for item in text.split(",") if item.strip()]
    except ValueError:
        raise UserError(f"--frequencies {text!r}: expected comma-separated numbers, e.g. 0.5,5,50") from None
    from ..friction.loops import MAX_LOOP_FREQUENCY_HZ

    if not values or any(not (math.isfinite(x) and 0.0 < x <= MAX_LOOP_FREQUENCY_HZ) for x in values):
        raise UserError(f"--frequencies {text!r}: need one or more frequencies in (0, {MAX_LOOP_FREQUENCY_HZ:g}] Hz")
    if len(values) > 100:
        raise UserError(f"--frequencies: {len(values)} given, at most 100")
    return values


@app.command("loops")
def loops(
    inputs: Inputs = Inputs(),
    frequencies: Annotated[
        str, typer.Option("--frequencies", help="Excitation frequencies [Hz], comma-separated.")
    ] = "0.5,5,50",
    v_mean: Annotated[
        Optional[float],
        typer.Option("--v-mean", help="Mean sliding velocity [m/s] (default: that of steady rolling at the "
                     "operating point)."),
    ] = None,
    v_amplitude: Annotated[
        float, typer.Option("--v-amplitude", min=1e-12, help="Amplitude of the sliding velocity [m/s].")
    ] = 0.2,
    points: Annotated[int, typer.Option("--points", min=8, help="Samples per loop.")] = 400,
    outputs: Outputs = NETCDF_OUTPUTS,
) -> None:
    """Friction hysteresis loops for v_r = v_mean + v_amplitude sin(2 pi f t) (paper Fig. 1)."""
    from ..friction import LoopSettings, hysteresis_loops

    outputs.check()
    freqs = _parse_frequencies(frequencies)
    _velocity(v_amplitude, "--v-amplitude")
    check_count(points, "--points", 8, MAX_POINTS)
    if v_mean is not None:
        _velocity(v_mean, "--v-mean")
    params = inputs.load()
    if v_mean is None:
        v_mean = _operating_sliding_velocity(params)
    with outputs.progress("loops") as update:
        result = hysteresis_loops(params.friction, v_mean, v_amplitude, freqs,
                                  settings=LoopSettings(points_per_period=points), progress=update)
    outputs.write(result.save, lambda: _figure(result))
    outputs.show(result.summary(), lambda summary: _print_loops(summary, v_mean, v_amplitude))


def _print_loops(summary: dict, v_mean: float, v_amplitude: float) -> None:
    """One row per loop as text on stdout (velocities [m/s])."""
    typer.echo(f"v_r = {v_mean:.4g} + {v_amplitude:.4g} sin(2 pi f t) m/s")
    typer.echo(f"{'f [Hz]':>10} {'max |mu - mu_ss|':>17} {'area [m/s]':>11} {'mu min':>8} {'mu max':>8}")
    for row in summary["loops"]:
        typer.echo(f"{row['frequency_hz']:10.4g} {row['max_deviation_from_static']:17.4g} "
                   f"{row['area_m_per_s']:11.4g} {row['mu_min']:8.4f} {row['mu_max']:8.4f}")


SampleOpt = Annotated[bool, typer.Option("--sample", help="Fit the shipped sample data instead of FILE.")]
ConfidenceOpt = Annotated[
    float, typer.Option("--confidence", min=0.5, max=0.9999, help="Level of the confidence intervals.")
]
FIT_OUTPUTS = Outputs("Write the parameter set with the fitted values (.toml) or the fit (.nc).", (".toml", ".nc"))


def _fit_inputs(file: Path | None, sample: bool, kind: str, inputs: Inputs, outputs: Outputs) -> tuple[Path, Any]:
    """(data file: FILE or the shipped sample of ``kind``, parameters) of a fit; the output
    files are checked after the choice of data and before the parameters are loaded."""
    from ..friction import sample_path

    if sample == (file is not None):
        raise UserError("give either a CSV FILE or --sample")
    outputs.check()
    return (sample_path(kind) if sample else file), inputs.load()


def _report_fit(result, params, path: Path, outputs: Outputs) -> None:
    """Write --out/--plot, then the summary: JSON, or a table and the [friction] snippet."""
    save = result.save
    if outputs.out is not None and outputs.out.suffix == ".toml":
        from ..params import to_toml

        save = save_text(to_toml(result.updated_params(params), comments=True))
    outputs.write(save, lambda: _figure(result))
    for warning in result.warnings():
        typer.echo(f"warning: {warning}", err=True)
    outputs.show(result.summary(), lambda summary: _print_fit(result, path, summary))


def _print_fit(result, path: Path, summary: dict) -> None:
    """The fitted values, their intervals and the [friction] snippet as text on stdout."""
    note = " (negative-velocity values read as magnitudes)" if getattr(result, "magnitudes", False) else ""
    typer.echo(f"{path}: {result.n_points} points{note}")
    typer.echo(f"{'key':<28} {'value':>12} {'std. error':>11}  {100 * result.confidence:g}% interval")
    for name, row in summary["parameters"].items():
        if not row["fitted"]:
            typer.echo(f"{name:<28} {row['value']:12.6g} {'(fixed)':>11}")
            continue
        se, (lo, hi) = row["standard_error"], row["interval"]
        se_text = f"{se:11.3g}" if se is not None else f"{'n/a':>11}"
        ci_text = f"[{lo:.6g}, {hi:.6g}]" if se is not None else "not identifiable"
        typer.echo(f"{name:<28} {row['value']:12.6g} {se_text}  {ci_text}" + ("  at bound" if row["at_bound"] else ""))
    typer.echo(f"rms residual {result.rms:.4g}, R^2 {result.r_squared:.6f}, "
               f"{'converged' if result.converged else 'NOT converged'} ({result.message}, {result.nfev} evaluations)")
    typer.echo("")
    typer.echo(result.to_toml(), nl=False)


@app.command("fit")
def fit(
    file: Annotated[
        Optional[Path],
        typer.Argument(help="CSV with columns sliding_velocity_m_per_s [m/s] and friction_coefficient [-].",
                       show_default=False),
    ] = None,
    sample: SampleOpt = False,
    inputs: Inputs = Inputs(),
    fix: Annotated[
        Optional[list[str]],
        typer.Option("--fix", help="Keep a [friction] key at its configured value instead of fitting it "
                     "(repeatable): mu_static, mu_coulomb, stribeck_velocity_m_per_s, stribeck_exponent, "
                     "sigma2_s_per_m."),
    ] = None,
    confidence: ConfidenceOpt = 0.95,
    outputs: Outputs = FIT_OUTPUTS,
) -> None:
    """Fit mu_s, mu_c, v_s, delta, sigma2 of the static curve to measured steady mu(v) points."""
    from ..friction import STEADY_PARAMETERS, FrictionDataError, fit_steady_curve, read_steady_csv

    path, params = _fit_inputs(file, sample, "steady", inputs, outputs)
    unknown = sorted(set(fix or ()) - set(STEADY_PARAMETERS))
    if unknown:
        raise UserError(f"--fix {', '.join(unknown)}: not a fitted key (choose from {', '.join(STEADY_PARAMETERS)})")
    free = tuple(name for name in STEADY_PARAMETERS if name not in (fix or ()))
    if not free:
        raise UserError("--fix: every key is fixed, nothing left to fit")
    with user_errors(FrictionDataError):
        velocity, mu = read_steady_csv(path)
        result = fit_steady_curve(velocity, mu, params.friction, fit=free, confidence=confidence, source=str(path))
    _report_fit(result, params, path, outputs)


@app.command("fit-loops")
def fit_loops(
    file: Annotated[
        Optional[Path],
        typer.Argument(help="CSV with columns frequency_hz, time_s, sliding_velocity_m_per_s, "
                       "friction_coefficient.", show_default=False),
    ] = None,
    sample: SampleOpt = False,
    inputs: Inputs = Inputs(),
    harmonics: Annotated[
        int, typer.Option("--harmonics", min=1, max=20, help="Fourier harmonics kept of the measured velocity.")
    ] = 3,
    confidence: ConfidenceOpt = 0.95,
    outputs: Outputs = FIT_OUTPUTS,
) -> None:
    """Fit sigma0 and sigma1 to measured periodic loops (static-curve keys from -c/--set)."""
    from ..friction import FrictionDataError, LoopFitSettings, read_loops_csv
    from ..friction import fit_loops as fit_measured_loops

    path, params = _fit_inputs(file, sample, "loops", inputs, outputs)
    with user_errors(FrictionDataError):
        data = read_loops_csv(path)
        with outputs.progress("fitting loops: model evaluations") as update:
            result = fit_measured_loops(*data, params.friction, settings=LoopFitSettings(harmonics=harmonics),
                                        confidence=confidence, progress=update, source=str(path))
    _report_fit(result, params, path, outputs)
