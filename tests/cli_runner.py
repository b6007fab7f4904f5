"""Run the real ``polywear`` entry point (``polywear.cli.app.main``) in-process."""

from __future__ import annotations

import io
import sys
from contextlib import redirect_stderr, redirect_stdout


def run_main(args: list[str]) -> tuple[int, str, str]:
    """``polywear *args`` through ``main()``: (exit code, stdout, stderr)."""
    from polywear.cli.app import main

    out, err = io.StringIO(), io.StringIO()
    argv = sys.argv
    sys.argv = ["polywear", *args]
    try:
        with redirect_stdout(out), redirect_stderr(err):
            main()
        code = 0
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    finally:
        sys.argv = argv
    return code, out.getvalue(), err.getvalue()
