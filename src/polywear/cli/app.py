"""The ``polywear`` command: one typer application, sub-commands registered here."""

from __future__ import annotations

import sys

import typer

from .. import __version__
from .common import UserError

app = typer.Typer(
    name="polywear",
    help="Friction-induced lateral self-excited vibration (SEV) of tire tread: "
    "at which speeds it happens, how strongly, what moves it.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


def _version(value: bool) -> None:
    if value:
        typer.echo(f"polywear {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", callback=_version, is_eager=True, help="Show the version."),
) -> None:
    """polywear: predict polygonal-wear self-excited vibration of tire tread."""


def _register() -> None:
    from . import (
        bifurcation_cmd,
        design_cmd,
        excitation_cmd,
        friction_cmd,
        map_cmd,
        params_cmd,
        report_cmd,
        sensitivity_cmd,
        simulate_cmd,
        stability_cmd,
        study_cmd,
    )

    app.add_typer(params_cmd.app, name="params")
    app.add_typer(friction_cmd.app, name="friction")
    app.command("stability")(stability_cmd.stability)
    app.command("bifurcation")(bifurcation_cmd.bifurcation)
    app.command("simulate")(simulate_cmd.simulate)
    app.command("sensitivity")(sensitivity_cmd.sensitivity)
    app.command("study")(study_cmd.study)
    app.command("map")(map_cmd.map_)
    app.command("excitation")(excitation_cmd.excitation)
    app.command("design")(design_cmd.design)
    app.command("report")(report_cmd.report)


_register()


def _is_user_error(exc: Exception) -> bool:
    """UserError or ParameterError; the latter checked without importing pydantic
    (0.1-0.4 s) on the way to ``--help``: it can only be raised once params is loaded."""
    params = sys.modules.get("polywear.params")
    return isinstance(exc, UserError) or (params is not None and isinstance(exc, params.ParameterError))


def main() -> None:
    """Console entry point: user errors become one line and exit code 2."""
    try:
        app(standalone_mode=False)
    except typer.Exit as exc:
        sys.exit(exc.exit_code)
    except typer.Abort:
        typer.echo("aborted", err=True)
        sys.exit(1)
    except Exception as exc:
        if _is_user_error(exc):
            typer.echo(f"error: {exc}", err=True)
            sys.exit(2)
        # click (vendored by typer) usage errors carry .show() and .exit_code (2)
        if hasattr(exc, "show") and hasattr(exc, "exit_code"):
            exc.show()
            sys.exit(exc.exit_code)
        raise
