"""``polywear measure``: measured run-ups and coast-downs (Campbell map, SEV detection)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from .common import Inputs, Outputs
from .common import NETCDF_OUTPUTS, UserError, one_axes, output_file, save_text, write_output

app = typer.Typer(help="Measured data: Campbell maps of run-ups and coast-downs; worn tire profiles.", no_args_is_help=True,
                  rich_markup_mode=None)


@app.command("campbell")
def campbell(
    run_file: Annotated[Path, typer.Argument(help="Run: CSV with units in the header (time [s], speed [km/h], "
                                                  "channels) or MDF4 (.mf4, extra 'measure').")],
    channel: Annotated[Optional[list[str]], typer.Option("--channel", help="Acceleration channel (repeatable; "
                                                         "default: every other column).")] = None,
    time_column: Annotated[Optional[str], typer.Option("--time-column", help="Name of the time column.")] = None,
    speed_column: Annotated[Optional[str], typer.Option("--speed-column", help="Name of the speed column.")] = None,
    window_s: Annotated[float, typer.Option("--window", help="Spectrogram window [s] (resolution 1/window).")] = 0.5,
    predict: Annotated[bool, typer.Option("--predict/--no-predict", help="Draw the model's Hopf points and SEV "
                                          "band (a continuation).")] = True,
    ramp_correction: Annotated[bool, typer.Option("--ramp-correction/--no-ramp-correction",
                                                  help="Correct the SEV onset for the ramp delay (simulated).")] = True,
    disturbance_m: Annotated[float, typer.Option("--disturbance", help="Tread kicks of the ramp simulation, every "
                                                 "20 ms [m] (x0.1 and x10 enter the uncertainty).")] = 1e-6,
    observations: Annotated[Optional[Path], typer.Option("--observations", help="Write the ramp-corrected onset "
                                                        "and the frequency as calibrate observations (TOML).")] = None,
    inputs: Inputs = Inputs(),
    outputs: Outputs = NETCDF_OUTPUTS,
) -> None:
    """Campbell map (frequency against speed), order rays, predicted SEV band and Hopf points;
    order-tracking vs constant-frequency features; SEV onset/offset, frequency, amplitude."""
    import math

    outputs.check()
    output_file(observations, "--observations", (".toml",))
    if not (math.isfinite(window_s) and 0.01 <= window_s <= 60.0):
        raise UserError(f"--window {window_s}: must be between 0.01 and 60 s")
    if not (math.isfinite(disturbance_m) and 0.0 < disturbance_m < 1e-2):
        raise UserError(f"--disturbance {disturbance_m}: must be between 0 and 0.01 m")
    params = inputs.load()
    from ..measured.campbell import CampbellSettings, campbell as analyze
    from ..measured.run_file import read_run

    run = read_run(run_file, time_column, speed_column, channel or (), params.operating.rolling_radius_m)
    for note in run.notes:
        outputs.note(f"note: {note}")
    outputs.note(f"measure campbell: {len(run.t)} samples at {run.sample_rate_hz:g} Hz, {len(run.channels)} channel(s)"
                 + (", model prediction and ramp simulation ..." if predict or ramp_correction else " ..."))
    result = analyze(run, params, CampbellSettings(window_s=window_s, disturbance_m=disturbance_m), predict=predict,
                     correct_ramp=ramp_correction)
    if outputs.out:  # save() is atomic itself and writes the summary next to the map (.json)
        result.save(outputs.out)
        outputs.note(f"wrote {outputs.out} and {outputs.out.with_suffix('.json')}")
    onset = (result.sev or {}).get("onset") or {}
    if onset.get("warning"):
        typer.echo(f"warning: {onset['warning']}", err=True)
    if observations:
        entries = result.observations()
        if not entries:
            why = ("no SEV in this run" if result.sev is None else "the model's Hopf point is far from the onset"
                   if onset.get("warning") else "the SEV onset was not detected or not ramp-corrected")
            outputs.note(f"note: no observations written: {why}")
        else:
            text = "".join("[[observation]]\n" + "".join(f"{k} = {v!r}\n".replace("'", '"') for k, v in e.items())
                           + "\n" for e in entries)
            write_output(observations, save_text(text), outputs.quiet)
    outputs.write(make_figure=lambda: one_axes(result.plot, (9, 5.5)))
    outputs.show(result.summary(), lambda _: _print_run(result))


def _print_run(result) -> None:
    """The spectral features and the SEV found in the run as text on stdout."""
    for f in result.features:
        label = {"order": f"order {f.get('frequency_order', 0):.2f}", "constant_frequency": "constant frequency"}.get(
            f["kind"], f["kind"])
        extra = " <- SEV" if f["sev"] else (f" (harmonic {f['harmonic_of_sev']} of SEV)" if "harmonic_of_sev" in f
                                            else " (not SEV)" if "not_sev" in f else "")
        typer.echo(f"{label:<20} {f['frequency_from_hz']:7.1f}-{f['frequency_to_hz']:7.1f} Hz  "
                   f"{f['speed_from_kmh']:6.1f}-{f['speed_to_kmh']:6.1f} km/h  {f['level_db']:5.1f} dB{extra}")
    sev = result.sev
    if not sev:
        typer.echo(f"no SEV in this run: {result.no_sev}")
        return
    onset, offset = sev.get("onset"), sev.get("offset")
    if onset:
        typer.echo(f"SEV onset {onset['speed_kmh']:.1f} +- {onset['uncertainty_kmh']:.1f} km/h (detected)")
        if onset.get("corrected_speed_kmh") is not None:
            typer.echo(f"SEV onset {onset['corrected_speed_kmh']:.1f} +- {onset['corrected_uncertainty_kmh']:.1f} "
                       f"km/h ({onset['correction']})")
        elif onset.get("correction"):
            typer.echo(f"  {onset['correction']}")
    typer.echo(f"SEV offset {offset['speed_kmh']:.1f} +- {offset['uncertainty_kmh']:.1f} km/h" if offset
               else "SEV offset: not within the run")
    if "frequency_hz" in sev:
        typer.echo(f"SEV frequency at onset {sev['frequency_hz']:.2f} +- {sev['frequency_uncertainty_hz']:.2f} Hz, "
                   f"{sev['frequency_range_hz'][0]:.1f}-{sev['frequency_range_hz'][1]:.1f} Hz over the run")
    if "corrected_frequency_hz" in sev:
        typer.echo(f"SEV frequency at the Hopf point {sev['corrected_frequency_hz']:.2f} +- "
                   f"{sev['corrected_frequency_uncertainty_hz']:.2f} Hz (ramp-corrected by "
                   f"{-sev['frequency_shift_hz']:+.2f} Hz, the simulated ramp's shift)")
    unc = sev.get("amplitude_uncertainty")
    typer.echo(f"SEV amplitude {sev['amplitude']:.4g}" + (f" +- {unc:.2g}" if unc is not None else "")
               + f" {sev['unit']} (channel {sev['channel']})")
