"""``polywear params``: show the resolved parameter set, write a default file, import a .tir file."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from .common import Inputs, Outputs, QuietOpt, info, out_option, output_file, save_text, write_output

app = typer.Typer(help="Show or write parameter sets (TOML).", no_args_is_help=True, rich_markup_mode=None)
TomlOutOpt = out_option("Write the resolved parameter set (TOML).")


@app.command("show")
def show(inputs: Inputs = Inputs(), outputs: Outputs = Outputs(takes_plot=False)) -> None:
    """Print the resolved parameter set and study table (defaults, file, --set) as TOML."""
    from ..params import STUDY_TABLE, to_toml

    params, study = inputs.load_with_study()
    outputs.show({**params.model_dump(), STUDY_TABLE: study.model_dump()},
                 lambda _: typer.echo(to_toml(params, study=study), nl=False))


@app.command("init")
def init(
    path: Annotated[Path, typer.Argument(help="File to write.")],
    force: Annotated[bool, typer.Option("--force", help="Overwrite an existing file.")] = False,
    quiet: QuietOpt = False,
) -> None:
    """Write a commented TOML file with every key at its default."""
    from ..params import default_toml
    from .common import UserError

    output_file(path, "params init", (".toml",))
    if path.exists() and not force:
        raise UserError(f"{path}: exists (use --force to overwrite)")
    write_output(path, save_text(default_toml()), quiet)


@app.command("from-tir")
def from_tir(
    tir: Annotated[Path, typer.Argument(help="Tyre property file (.tir): MF 5.2 (MF_05, PAC2002), MF 6.1, MF 6.2.")],
    out: TomlOutOpt = None,
    belt_mode: Annotated[
        bool,
        typer.Option("--belt-mode", help="Also map the belt's lateral mode (BELT_MASS, FREQ_LAT, DAMP_LAT) onto tread.*."),
    ] = False,
    inputs: Inputs = Inputs(),
    outputs: Outputs = Outputs(takes_plot=False),
) -> None:
    """Read a .tir file and say, for every key, whether it came from the file (which tir
    keys, which formula), from --config/--set, or stays a default."""
    from ..params import load_study, to_toml
    from ..measured.tir import load_with_tir

    output_file(out, "--out", (".toml",))
    loaded = load_with_tir(tir, inputs.config, inputs.set_ or (), belt_mode=belt_mode)
    params, mapping = loaded.params, loaded.mapping
    summary = loaded.summary()
    rows = summary["parameters"]
    if out is not None:
        header = [f"# polywear parameters from {tir} ({mapping.tir.family}); sources:"]
        header += [f"#   {r['key']} <- {r['source']}" for r in rows if r["source"] != "default"]
        text = "\n".join(header) + "\n" + to_toml(params, study=load_study(inputs.config))  # --config's [study] kept
        write_output(out, save_text(text), outputs.quiet)
    outputs.show(summary, lambda _: _print_sources(tir, mapping, rows, summary["file_values"], outputs.quiet))


def _print_sources(tir: Path, mapping, rows: list[dict], file_values: list[dict], quiet: bool) -> None:
    """Each key's value and source as text on stdout; the mapping's notes and the file's values
    used, noted or ignored on stderr."""
    typer.echo(f"{tir}: {mapping.tir.family} ({mapping.tir.format_label}); evaluated at "
               f"Fz = {mapping.conditions['load_n']:g} N, camber {mapping.conditions['camber_deg']:g} deg, "
               f"{mapping.conditions['speed_kmh']:g} km/h")
    width = max(len(r["key"]) for r in rows)
    for r in rows:
        value = r["value"]
        shown = f"{value:.6g}" if isinstance(value, float) else str(value)
        typer.echo(f"{r['key']:<{width}}  {shown:>12}  {r['source']}")
    for note in mapping.notes:
        info(f"note: {note}", quiet)
    for use in ("used", "noted", "ignored"):
        keys = [v["key"] for v in file_values if v["use"] == use]
        info(f"file values {use}: {', '.join(keys) if keys else 'none'}", quiet)
