"""The shipped package runs without sympy: only the axle4dof generator needs it
(extra ``generate``), the committed generated module and the kernels do not."""

from __future__ import annotations

import json
import subprocess
import sys

import polywear as pw

STABILITY_RANGE_KMH = (60.0, 170.0)
N_SPEEDS = 60
SIM_SPEED_KMH = 110.0
SIM_DURATION_S = 0.05

_WITHOUT_SYMPY = f"""
import importlib, json, pkgutil, sys
sys.modules["sympy"] = None  # every "import sympy" now raises ImportError
try:
    import sympy
except ImportError:
    pass
else:
    raise SystemExit("sympy was not blocked")
import polywear as pw
p = pw.load_params().with_updates({{"model": "axle4dof"}})
stab = pw.stability(p, {STABILITY_RANGE_KMH!r}, pw.StabilitySettings(n_speeds={N_SPEEDS}))
sim = pw.simulate(p, {SIM_SPEED_KMH!r}, {SIM_DURATION_S!r})
imported = []
for info in pkgutil.walk_packages(pw.__path__, "polywear."):
    if info.name == "polywear.models.axle4dof_derivation" or info.name.endswith(".__main__"):
        continue
    importlib.import_module(info.name)
    imported.append(info.name)
print(json.dumps({{"stability": stab.summary(), "simulation": sim.summary(), "imported": imported,
                  "derivation_loaded": "polywear.models.axle4dof_derivation" in sys.modules}}))
"""


def test_simulation_stability_and_every_module_run_with_sympy_blocked():
    done = subprocess.run([sys.executable, "-c", _WITHOUT_SYMPY], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    result = json.loads(done.stdout)
    assert not result["derivation_loaded"]
    assert {"polywear.models.axle4dof", "polywear.models.axle4dof_kernels", "polywear.cli.app"} <= set(result["imported"])

    # the same numbers as here, where sympy can be imported
    p = pw.load_params().with_updates({"model": "axle4dof"})
    stab = pw.stability(p, STABILITY_RANGE_KMH, pw.StabilitySettings(n_speeds=N_SPEEDS)).summary()
    assert result["stability"]["hopf_speeds_kmh"] == stab["hopf_speeds_kmh"]
    assert len(stab["hopf_speeds_kmh"]) == 2  # the default band lies inside the range
    sim = pw.simulate(p, SIM_SPEED_KMH, SIM_DURATION_S).summary()
    assert result["simulation"]["amplitude"] == sim["amplitude"]


def test_generator_without_sympy_names_the_extra():
    code = (
        "import sys; sys.modules['sympy'] = None\n"
        "try:\n    import polywear.models.axle4dof_derivation\n"
        "except ImportError as e:\n    print(e)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert "polywear[generate]" in done.stdout
