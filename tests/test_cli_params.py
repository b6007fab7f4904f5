"""``polywear params``: show, show --set, init; bad input is one line on stderr, exit 2."""

from __future__ import annotations

import json
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from polywear.params import Params, StudySpec, load_params, load_study, to_toml

from .cli_runner import run_main


def test_show_prints_the_defaults_as_toml():
    code, out, err = run_main(["params", "show"])
    assert code == 0 and err == ""
    assert out == to_toml(Params(), study=StudySpec())  # the parameters and the [study] table
    assert tomllib.loads(out)["friction"]["mu_static"] == 0.9


def test_show_with_set_and_config(tmp_path):
    path = tmp_path / "p.toml"
    path.write_text("model = \"axle4dof\"\n[tread]\nmass_kg = 2.5\n")
    code, out, _ = run_main(["params", "show", "-c", str(path), "--set", "operating.speed_kmh=80",
                             "-s", "tread.mass_kg=3"])
    assert code == 0
    shown = tomllib.loads(out)
    assert shown["model"] == "axle4dof"
    assert shown["operating"]["speed_kmh"] == 80.0
    assert shown["tread"]["mass_kg"] == 3.0  # --set wins over the file
    assert shown["tread"]["lateral_stiffness_n_per_m"] == 1.0e6


def test_show_json_is_the_full_parameter_set():
    code, out, _ = run_main(["params", "show", "--json", "-s", "friction.mu_coulomb=0.4", "-s", "study.n_base=64"])
    assert code == 0
    data = json.loads(out)
    assert StudySpec.model_validate(data.pop("study")) == load_study(None, ["study.n_base=64"])
    assert Params.model_validate(data) == load_params(None, ["friction.mu_coulomb=0.4"])


def test_init_writes_a_file_that_loads_to_the_defaults(tmp_path):
    path = tmp_path / "params.toml"
    code, out, err = run_main(["params", "init", str(path)])
    assert code == 0 and out == "" and str(path) in err
    assert load_params(path) == Params() and load_study(path) == StudySpec()
    assert "# " in path.read_text()  # commented
    code, _, err = run_main(["params", "init", str(path)])
    assert code == 2 and err.startswith("error: ") and "exists" in err and err.count("\n") == 1
    path.write_text("junk")
    assert run_main(["params", "init", "--force", str(path)])[0] == 0
    assert load_params(path) == Params()


BAD = [
    (["params", "show", "-s", "tread.mass_kg=-1"], ["tread.mass_kg", "-1.0", "greater than or equal to 0.0001"]),
    (["params", "show", "-s", "tread.mass_kg=nan"], ["tread.mass_kg", "finite"]),
    (["params", "show", "-s", "tread.mass_kg=true"], ["tread.mass_kg", "True", "must be a number"]),
    (["params", "show", "-s", "tread.mass_kg=heavy"], ["tread.mass_kg", "'heavy'", "must be a number"]),
    (["params", "show", "-s", "tread.mas_kg=1"], ["tread.mas_kg", "unknown key"]),
    (["params", "show", "-s", "friction.mu_coulomb=0.95"], ["friction.mu_coulomb", "0.95", "must not exceed"]),
    (["params", "show", "-s", "friction.stribeck_velocity_m_per_s=0"], ["stribeck_velocity_m_per_s", "0.0", "greater than or equal to 0.0001"]),
    (["params", "show", "-s", "tread.mass_kg"], ["expected table.key=value"]),
    (["params", "show", "-s", "model=axle2dof"], ["model", "axle2dof"]),
    (["params", "show", "-c", "/nonexistent/p.toml"], ["/nonexistent/p.toml", "cannot read"]),
]


@pytest.mark.parametrize("args, fragments", BAD, ids=[" ".join(a[2:]) for a, _ in BAD])
def test_bad_input_is_one_line_exit_2(args, fragments):
    code, out, err = run_main(args)
    assert code == 2 and out == ""
    assert err.startswith("error: ") and err.count("\n") == 1, err
    for fragment in fragments:
        assert fragment in err, err


def test_bad_file_contents(tmp_path):
    path = tmp_path / "bad.toml"
    for text, fragment in [("[tread\n", "not valid TOML"), ("[tread]\nmass = 1\n", "tread.mass: unknown key"),
                           ("[friction]\nmu_static = inf\n", "finite")]:
        path.write_text(text)
        code, out, err = run_main(["params", "show", "-c", str(path)])
        assert code == 2 and out == "" and err.count("\n") == 1 and fragment in err, err


def test_end_to_end_exit_code_and_no_traceback(tmp_path):
    """The installed console script, in a fresh process."""
    exe = Path(sys.executable).parent / "polywear"
    bad = subprocess.run([str(exe), "params", "show", "-s", "tread.mass_kg=-1"], capture_output=True, text=True,
                         timeout=60)
    assert bad.returncode == 2 and bad.stdout == ""
    assert bad.stderr == "error: tread.mass_kg = -1.0: should be greater than or equal to 0.0001\n"
    path = tmp_path / "p.toml"
    good = subprocess.run([str(exe), "params", "init", str(path)], capture_output=True, text=True, timeout=60)
    assert good.returncode == 0 and load_params(path) == Params()


def test_usage_errors_exit_2_without_traceback():
    """Unknown options are click usage errors: exit 2, a short usage message, no traceback."""
    code, out, err = run_main(["params", "show", "--bogus"])
    assert code == 2 and out == ""
    assert "No such option: --bogus" in err and "Traceback" not in err
