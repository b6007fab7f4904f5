"""The ``polywear`` command: one typer application, sub-commands registered here."""

from __future__ import annotations

import sys

import typer

from .. import __version__
from .common import UserError, add_shared_options

app = typer.Typer(
    name="polywear",
    help="Friction-induced lateral self-excited vibration (SEV) of tire tread: "
    "at which speeds it happens, how strongly, what moves it.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,  # plain help: units in [brackets] stay, flags get no <bool> metavar
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
        calibrate_cmd,
        design_cmd,
        excitation_cmd,
        fleet_cmd,
        friction_cmd,
        map_cmd,
        measure_cmd,
        params_cmd,
        profile_cmd,
        report_cmd,
        sensitivity_cmd,
        simulate_cmd,
        stability_cmd,
        study_cmd,
        wear_cmd,
    )

    app.add_typer(params_cmd.app, name="params")
    app.add_typer(friction_cmd.app, name="friction")
    app.command("stability")(stability_cmd.stability)
    app.command("bifurcation")(bifurcation_cmd.bifurcation)
    app.command("simulate")(simulate_cmd.simulate)
    app.command("sensitivity")(sensitivity_cmd.sensitivity)
    app.command("study")(study_cmd.study)
    app.command("fleet")(fleet_cmd.fleet)
    app.command("map")(map_cmd.map_)
    app.command("excitation")(excitation_cmd.excitation)
    app.command("design")(design_cmd.design)
    app.command("report")(report_cmd.report)
    app.add_typer(wear_cmd.app, name="wear")
    app.command("calibrate")(calibrate_cmd.calibrate)
    measure_cmd.app.command("profile")(profile_cmd.profile)
    app.add_typer(measure_cmd.app, name="measure")


_register()
add_shared_options(app)


def _is_user_error(exc: Exception) -> bool:
    """UserError or ParameterError; the latter checked without importing pydantic
    (0.1-0.4 s) on the way to ``--help``: it can only be raised once params is loaded."""
    params = sys.modules.get("polywear.params")
    return isinstance(exc, UserError) or (params is not None and isinstance(exc, params.ParameterError))


def _interrupted(exc: BaseException | None) -> bool:
    """Ctrl-C: a KeyboardInterrupt anywhere in the exception's chain (click's Abort raised
    from one; a SystemError of a compiled numba function that returned while the
    interrupt was pending)."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


_SIGNAL_EXITS = {"SIGINT": (130, b"\ninterrupted\n"), "SIGTERM": (143, b"\nterminated\n")}
"""Exit code and line of each handled signal (128 + the signal's number, as a shell reports it)."""


def _exit_on_ctrl_c(signum, frame) -> None:
    """SIGINT and SIGTERM handler of the command line: remove the files being written,
    stop local worker processes, say "interrupted" (SIGINT, exit 130) or "terminated"
    (SIGTERM, exit 143) and exit at once, or right after the swap of a results folder
    if one is under way (:func:`polywear.io.when_safe`).

    Exiting here rather than raising KeyboardInterrupt is deliberate: raised while a
    compiled numba function hands back its result, the exception becomes a SystemError
    or even a segmentation fault, and broad ``except`` clauses in libraries can swallow it.
    """
    import os
    import signal

    from ..io import remove_partial, when_safe

    code, line = _SIGNAL_EXITS[signal.Signals(signum).name]

    def leave() -> None:
        remove_partial()
        multiprocessing = sys.modules.get("multiprocessing")
        if multiprocessing is not None:
            for child in multiprocessing.active_children():
                child.terminate()
        os.write(2, line)
        os._exit(code)

    when_safe(leave)


def main() -> None:
    """Console entry point: exit 0 on success, 2 with one line on bad input, 130 on Ctrl-C
    (SIGINT), 143 on SIGTERM.

    Bad input is a UserError, a ParameterError or a usage error found by click (unknown
    option, a value of the wrong type); none of them prints a traceback.
    """
    import signal
    import threading

    main_thread = threading.current_thread() is threading.main_thread()
    handled = (signal.SIGINT, signal.SIGTERM)
    previous = [signal.signal(s, _exit_on_ctrl_c) for s in handled] if main_thread else []
    # after Ctrl-C multiprocessing's resource tracker (a child started with these -W
    # options) unlinks the process pool's semaphores, as it should, and warns about them:
    # noise after the one "interrupted" line
    if "ignore:resource_tracker:UserWarning" not in sys.warnoptions:
        sys.warnoptions.append("ignore:resource_tracker:UserWarning")
    from ..parallel import one_blas_thread

    one_blas_thread()  # every matrix here is small: threads only add overhead on shared cores
    try:
        code = app(standalone_mode=False)  # typer returns an Exit's code here (a KeyboardInterrupt: 130)
        if code == 130:
            typer.echo("interrupted", err=True)
        if isinstance(code, int) and code:
            sys.exit(code)
    except typer.Exit as exc:
        sys.exit(exc.exit_code)
    except (KeyboardInterrupt, typer.Abort) as exc:
        if not _interrupted(exc):
            typer.echo("aborted", err=True)
            sys.exit(1)
        typer.echo("interrupted", err=True)
        sys.exit(130)
    except Exception as exc:
        if _interrupted(exc):
            typer.echo("interrupted", err=True)
            sys.exit(130)
        if _is_user_error(exc):
            typer.echo(f"error: {exc}", err=True)
            sys.exit(2)
        if type(exc).__name__ == "NoArgsIsHelpError":  # a bare group: its help, as click shows it
            exc.show()
            sys.exit(exc.exit_code)
        # click (vendored by typer) usage errors carry .format_message() and .exit_code (2)
        if hasattr(exc, "format_message") and hasattr(exc, "exit_code"):
            command = getattr(getattr(exc, "ctx", None), "command_path", "polywear")
            typer.echo(f"error: {exc.format_message()} (see {command} --help)", err=True)
            sys.exit(exc.exit_code)
        raise
    finally:
        for s, handler in zip(handled, previous):
            signal.signal(s, handler)
