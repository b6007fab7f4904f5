"""Console entry point of ``polywear``: Ctrl-C is handled from the first instruction.

Importing the command line (typer, click, rich, then numpy and numba on the way to a
command) takes a few tenths of a second; a Ctrl-C in that window used to print Python's
traceback. This module imports nothing heavy: it installs a minimal SIGINT handler
(one line, exit 130; SIGTERM: exit 143; nothing has been written yet) and then hands over to
:func:`polywear.cli.app.main`, which installs the full handler (removes files being
written, stops worker processes).
"""

from __future__ import annotations

import os

import _signal  # the C module: ``signal`` itself imports enum, costly this early


def _interrupted_while_starting(signum, frame) -> None:
    if signum == _signal.SIGTERM:
        os.write(2, b"\nterminated\n")
        os._exit(143)
    os.write(2, b"\ninterrupted\n")
    os._exit(130)


def main() -> None:
    """``polywear``: the minimal Ctrl-C (and SIGTERM) handler, then the command line."""
    _signal.signal(_signal.SIGINT, _interrupted_while_starting)
    _signal.signal(_signal.SIGTERM, _interrupted_while_starting)
    from .app import main as run

    run()
