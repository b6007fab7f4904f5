"""Shared pieces of the command-line interface: options, parameter loading, output.

Heavy libraries are imported inside the commands, never at module level, so that
``polywear --help`` stays fast.
"""

from __future__ import annotations

import json
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Any, Iterator, Optional

import typer

ConfigOpt = Annotated[
    Optional[Path],
    typer.Option("--config", "-c", help="TOML parameter file (defaults for missing keys)."),
]
SetOpt = Annotated[
    Optional[list[str]],
    typer.Option("--set", "-s", help="Override a key: table.key=value (repeatable)."),
]
JsonOpt = Annotated[bool, typer.Option("--json", help="Print the summary as JSON on stdout.")]
PlotOpt = Annotated[Optional[Path], typer.Option("--plot", help="Write a figure (png, pdf, svg).")]
OutOpt = Annotated[Optional[Path], typer.Option("--out", "-o", help="Write the result (netCDF .nc).")]


class UserError(Exception):
    """Bad input from the user: reported as one line, exit code 2, no traceback."""


def load(config: Path | None, sets: list[str] | None):
    """Resolved, validated parameters from a file and ``--set`` overrides."""
    from ..params import load_params

    return load_params(config, sets or ())


def emit_json(payload: Any) -> None:
    """Write a JSON summary to stdout (numpy scalars and arrays converted)."""
    typer.echo(json.dumps(payload, indent=2, default=_jsonable, allow_nan=False))


def _jsonable(obj: Any) -> Any:
    import numpy as np

    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"not JSON serializable: {type(obj).__name__}")


def info(message: str, quiet: bool = False) -> None:
    """A status line on stderr (stdout is kept clean for --json)."""
    if not quiet:
        typer.echo(message, err=True)


@contextmanager
def progress(description: str, total: float | None, enabled: bool = True) -> Iterator[Any]:
    """A rich progress bar on stderr (a terminal only: logs stay clean); yields ``advance(n=1)``."""
    from rich.console import Console

    console = Console(stderr=True)
    if not (enabled and console.is_terminal):
        yield lambda n=1: None
        return
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    count = "{task.completed:.0f}/{task.total:.0f}" if total is not None else "{task.completed:.0f} steps"
    columns = [
        TextColumn("[progress.description]{task.description}"),
        BarColumn(),
        TextColumn(count),
        TimeElapsedColumn(),
    ]
    if total is not None:
        columns.append(TimeRemainingColumn())
    with Progress(*columns, console=console, transient=True) as bar:
        task = bar.add_task(description, total=total)
        yield lambda n=1: bar.advance(task, n)


def write_figure(path: Path, make_figure, quiet: bool = False) -> None:
    """Build a figure with ``make_figure()`` on the Agg backend, write it to ``path``, close it."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = make_figure()
    fig.savefig(path, dpi=150, bbox_inches="tight")
    plt.close(fig)
    info(f"wrote {path}", quiet)


def one_axes(draw, figsize=(8.0, 4.5)):
    """A figure with one axes drawn by ``draw(ax)`` (e.g. a result's ``.plot``)."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=figsize)
    draw(ax)
    return fig
