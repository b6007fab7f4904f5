"""The worked examples in examples/ run as scripts (Agg backend) and write their figures."""

from __future__ import annotations

import csv
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
PNG = b"\x89PNG\r\n\x1a\n"


def run_example(name: str, out_dir: Path) -> str:
    """Run ``examples/<name>`` in a fresh interpreter; its stdout."""
    env = {**os.environ, "MPLBACKEND": "Agg"}
    done = subprocess.run([sys.executable, str(EXAMPLES / name), str(out_dir)], capture_output=True, text=True,
                          env=env, timeout=300)
    assert done.returncode == 0, done.stderr
    return done.stdout


def test_quickstart(tmp_path):
    out = run_example("quickstart.py", tmp_path)
    for figure in ("quickstart_bifurcation.png", "quickstart_simulation.png"):
        assert (tmp_path / figure).read_bytes()[:8] == PNG
    assert out.count("Hopf point") == 2 and "SEV band" in out
    # the simulation from a small disturbance ends on the continuation's stable cycle
    cycle = next(line for line in out.splitlines() if "stable cycle, amplitude" in line)
    simulated = next(line for line in out.splitlines() if line.startswith("simulation from"))
    assert ": cycle," in simulated
    amplitude = lambda line: float(line.split("amplitude ")[1].split(" mm")[0])  # noqa: E731
    assert amplitude(simulated) == pytest.approx(amplitude(cycle), abs=2e-3)


@pytest.mark.slow
def test_toe_study_follows_the_sine_law(tmp_path):
    run_example("toe_study.py", tmp_path)
    assert (tmp_path / "toe_study.png").read_bytes()[:8] == PNG
    with open(tmp_path / "toe_study.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) >= 3
    # tread1dof: speed enters only through V sin(toe), so V_H sin(toe) is the same for every row
    for end in ("linear_lo_kmh", "linear_hi_kmh"):
        products = [float(r[end]) * math.sin(math.radians(float(r["toe_deg"]))) for r in rows]
        assert max(products) == pytest.approx(min(products), rel=1e-6)
    for r in rows:  # hard at the upper end: the SEV band reaches beyond the linear band
        assert float(r["sev_lo_kmh"]) == pytest.approx(float(r["linear_lo_kmh"]))
        assert float(r["sev_hi_kmh"]) > float(r["linear_hi_kmh"])


@pytest.mark.slow
def test_soft_hard(tmp_path):
    out = run_example("soft_hard.py", tmp_path)
    assert (tmp_path / "soft_hard.png").read_bytes()[:8] == PNG
    soft, hard = out.split("230 km/h:")
    assert "110 km/h: soft self-excitation" in soft and "hard self-excitation" in hard
    assert "start near steady rolling" in hard and "): equilibrium" in hard.split("start near steady rolling")[1].splitlines()[0]
    assert "): cycle" in hard.split("start outside cycle 1")[1].splitlines()[0]
