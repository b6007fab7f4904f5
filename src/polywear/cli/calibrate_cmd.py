"""``polywear calibrate``: fit parameters to observations, say what the data determine."""

from __future__ import annotations

from contextlib import ExitStack
from pathlib import Path
from typing import Annotated, Optional

import typer

from ..units import STABILITY_SPEED_RANGE_KMH
from .common import Inputs, JsonOpt, Outputs, PlotOpt, QuietOpt, SpeedRangeOpt
from .common import check_speed_range, info, one_axes, out_option, output_file, save_figure, save_text

JsonOutOpt = out_option("Write the result (JSON).")


def calibrate(
    observed: Annotated[Path, typer.Option("--observed", help="TOML file of [[observation]] tables.")],
    vary: Annotated[list[str], typer.Option("--vary", help="Parameter key to fit, table.key (repeatable).")],
    inputs: Inputs = Inputs(),
    speed_range: SpeedRangeOpt = STABILITY_SPEED_RANGE_KMH,
    profile: Annotated[
        bool, typer.Option("--profile/--no-profile", help="Profile-likelihood intervals (a refit per point).")
    ] = True,
    out: JsonOutOpt = None,
    fitted: Annotated[
        Optional[Path], typer.Option("--fitted", help="Write the fitted parameter set (TOML), identifiable keys only.")
    ] = None,
    json_: JsonOpt = False,
    plot: PlotOpt = None,
    quiet: QuietOpt = False,
) -> None:
    """Weighted least squares of --vary keys to observed onset speeds, frequencies, band edges
    and friction points; identifiability report, linearized and profile-likelihood intervals."""
    outputs = Outputs(json_=json_, plot=plot, quiet=quiet)  # --out, --fitted and --plot are written together, below
    output_file(out, "--out", (".json",))
    output_file(fitted, "--fitted", (".toml",))
    outputs.check()
    lo, hi = check_speed_range(speed_range)
    params = inputs.load()
    from ..io import atomic_path
    from ..measured.calibration import calibrate as fit, read_observations
    from ..params import to_toml

    observations = read_observations(observed, params)
    outputs.note(f"calibrate: {len(vary)} parameter(s) to {len(observations)} observation(s) ...")
    with outputs.progress("model evaluations") as update:
        result = fit(params, observations, vary, (lo, hi), profile=profile, progress=update)
    figure = save_figure(lambda: one_axes(result.plot, (7, 1.0 + 0.4 * len(observations))))
    written = [(path, save) for path, save in ((out, result.save), (fitted, save_text(to_toml(result.fitted))),
                                               (plot, figure)) if path is not None]
    with ExitStack() as stack:  # all or none: each file is renamed into place only once every one is written
        for path, save in written:
            save(stack.enter_context(atomic_path(path)))
    for path, _ in written:
        info(f"wrote {path}", quiet)
    for p in result.parameters:
        if not p["identifiable"]:
            outputs.note(f"refused: {p['key']}: {p['reason']}")
    for warning in result.identifiability["warnings"]:
        typer.echo(f"warning: {warning}", err=True)
    outputs.show(result.summary(), lambda _: _print_fit(result))


def _print_fit(result) -> None:
    """Fit, intervals, singular values and residuals as text on stdout."""
    ident = result.identifiability
    typer.echo(f"chi2 = {ident['chi2']:.4g} with {ident['dof']} degree(s) of freedom"
               f"{'' if ident['converged'] else ' (least squares did not converge)'}")
    for p in result.parameters:
        if p["identifiable"]:
            ci = p["profile_ci"] or p["linear_ci"]
            kind = "profile" if p["profile_ci"] else "linearized"
            shown = ["open" if c is None else f"{c:.6g}" for c in ci]
            typer.echo(f"{p['key']:<40} {p['value']:.6g}  95 % {kind}: [{shown[0]}, {shown[1]}]")
        else:
            typer.echo(f"{p['key']:<40} not identifiable (no value)")
    typer.echo("singular values (d r / d ln p): " + ", ".join(f"{s:.3g}" for s in ident["singular_values"]))
    for c in ident["undetermined"]:
        typer.echo(f"undetermined: {c['combination']} (singular value {c['singular_value']:.2g})")
    for r in result.residuals:
        typer.echo(f"{r['observation']:<48} observed {r['observed']:.5g} +- {r['sigma']:.3g}, "
                   f"predicted {r['predicted']:.5g} ({r['normalized']:+.2f} sigma)")
