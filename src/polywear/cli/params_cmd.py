"""``polywear params``: show the resolved parameter set, write a default file."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from .common import ConfigOpt, JsonOpt, SetOpt, emit_json, info, load

app = typer.Typer(help="Show or write parameter sets (TOML).", no_args_is_help=True, rich_markup_mode=None)


@app.command("show")
def show(config: ConfigOpt = None, set_: SetOpt = None, json_: JsonOpt = False) -> None:
    """Print the resolved parameter set (defaults, file, --set) as TOML."""
    from ..params import to_toml

    params = load(config, set_)
    if json_:
        emit_json(params.model_dump())
    else:
        typer.echo(to_toml(params), nl=False)


@app.command("init")
def init(
    path: Annotated[Path, typer.Argument(help="File to write.")],
    force: Annotated[bool, typer.Option("--force", help="Overwrite an existing file.")] = False,
) -> None:
    """Write a commented TOML file with every key at its default."""
    from ..params import default_toml
    from .common import UserError

    if path.exists() and not force:
        raise UserError(f"{path}: exists (use --force to overwrite)")
    path.write_text(default_toml())
    info(f"wrote {path}")
