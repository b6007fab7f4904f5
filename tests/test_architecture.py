"""The house's layers (docs/architecture.md), checked by import-linter on the code's own imports.

The contracts live in pyproject.toml (``[tool.importlinter]``): each package imports only
the packages below it (imports inside functions and under ``TYPE_CHECKING`` count too), and
no two modules of one package import each other, even through others. The second test
shows that the check can fail: an upward import and a circle planted in a copy of the
package break the contracts.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
LINT = Path(sys.executable).with_name("lint-imports")


def _lint(source_root: Path) -> subprocess.CompletedProcess:
    """lint-imports with the repository's contracts on the package found under ``source_root``."""
    env = {**os.environ, "PYTHONPATH": str(source_root)}
    return subprocess.run([str(LINT), "--config", str(REPO / "pyproject.toml"), "--no-cache"],
                          cwd=REPO, env=env, capture_output=True, text=True, timeout=120)


def test_no_upward_import_and_no_circle():
    run = _lint(REPO / "src")
    assert run.returncode == 0, run.stdout + run.stderr


@pytest.mark.parametrize("plant, broken", [
    ("wear/law.py", "Each package imports only the packages below it BROKEN"),  # wear -> report
    ("dynamics/points.py", "No circle of imports between the modules of a package BROKEN"),
])
def test_the_contracts_catch_a_planted_violation(tmp_path, plant, broken):
    shutil.copytree(REPO / "src" / "polywear", tmp_path / "polywear",
                    ignore=shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc"))
    line = {"wear/law.py": "from ..report import main as _planted\n",
            "dynamics/points.py": "from . import bifurcation as _planted\n"}[plant]  # bifurcation imports points
    target = tmp_path / "polywear" / plant
    target.write_text(target.read_text() + "\n" + line)
    run = _lint(tmp_path)
    assert run.returncode != 0
    assert broken in run.stdout
