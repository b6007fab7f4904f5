"""Nothing a user does leaves a broken state, and the user can read what the CLI says.

One test per class of problem: output paths checked before any computation, atomic
writes (files and the report folder), Ctrl-C (exit 130, one line, no partial file),
numeric limits (the same from an option and from the config), help text (units in
[brackets], no <bool> metavars), stdout/stderr separation and -q, and the bootstrap
script not reinstalling. The fuzz test of every command is in test_cli_fuzz.py.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from .cli_runner import run_main

REPO = Path(__file__).resolve().parents[1]
POLYWEAR = Path(sys.executable).parent / "polywear"


def _leaf_commands():
    """(path, click command) of every ``polywear`` sub-command."""
    import typer

    from polywear.cli.app import app

    def walk(cmd, path):
        if hasattr(cmd, "commands"):
            for name, sub in cmd.commands.items():
                yield from walk(sub, [*path, name])
        else:
            yield path, cmd

    return list(walk(typer.main.get_command(app), []))


def _options(cmd) -> set[str]:
    return {o for p in cmd.params for o in getattr(p, "opts", [])}


def _one_line_error(code: int, out: str, err: str, fragment: str) -> None:
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2, (code, err)
    assert out == "" and len(lines) == 1 and lines[0].startswith("error: "), err
    assert fragment in lines[0], err
    assert "Traceback" not in err


# -- output paths --------------------------------------------------------------------------
def _bad_paths(tmp_path: Path) -> dict[str, tuple[Path, str]]:
    """Kinds of unwritable output path and a fragment of the message that names the problem."""
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    return {
        "missing directory": (tmp_path / "missing" / "x", "does not exist"),
        "file as directory": (a_file / "x", "not a directory"),
        "directory as file": (tmp_path / "a_dir", "is a directory"),
        "unknown extension": (tmp_path / "x.unknown", "unknown extension"),
    }


# every command that writes files: (arguments before the path option, option, a valid suffix)
WRITERS = [
    (["stability"], "--out", ".nc"),
    (["stability"], "--plot", ".png"),
    (["bifurcation"], "--out", ".nc"),
    (["bifurcation"], "--csv", ".csv"),
    (["bifurcation"], "--plot", ".png"),
    (["simulate"], "--out", ".nc"),
    (["simulate"], "--plot", ".png"),
    (["sensitivity"], "--out", ".csv"),
    (["sensitivity"], "--plot", ".png"),
    (["study"], "--out", ".nc"),
    (["study"], "--plot", ".png"),
    (["map"], "--out", ".nc"),
    (["map"], "--plot", ".png"),
    (["excitation"], "--plot", ".png"),
    (["design"], "--plot", ".png"),
    (["design"], "--out", ".csv"),
    (["friction", "curve"], "--out", ".nc"),
    (["friction", "curve"], "--plot", ".png"),
    (["friction", "loops"], "--out", ".nc"),
    (["friction", "loops"], "--plot", ".png"),
    (["friction", "fit", "--sample"], "--out", ".toml"),
    (["friction", "fit", "--sample"], "--plot", ".png"),
    (["friction", "fit-loops", "--sample"], "--out", ".nc"),
    (["friction", "fit-loops", "--sample"], "--plot", ".png"),
    (["wear", "map"], "--out", ".nc"),
    (["wear", "map"], "--plot", ".png"),
    (["wear", "evolve"], "--out", ".nc"),
    (["wear", "evolve"], "--plot", ".png"),
]
NEEDS_INPUT = {"fleet", "calibrate", "params from-tir", "measure campbell", "measure profile"}
"""Commands that need an input file before their options mean anything (not in WRITERS)."""


@pytest.mark.parametrize("args, option, suffix", WRITERS, ids=lambda v: " ".join(v) if isinstance(v, list) else v)
def test_output_paths_are_checked_before_anything_runs(tmp_path, args, option, suffix):
    for kind, (path, fragment) in _bad_paths(tmp_path).items():
        if kind != "unknown extension":
            path = path.with_suffix(suffix)
        if kind == "directory as file":
            path.mkdir()
        # a bad key too: the path must be reported first, i.e. before the parameters are even read
        code, out, err = run_main([*args, option, str(path), "-s", "no.such_key=1"])
        _one_line_error(code, out, err, fragment)
        assert str(path) in err


def test_every_writing_option_is_covered():
    """Each --out/--plot/--csv file option of every command is in WRITERS (new commands: add them)."""
    covered = {(" ".join(a for a in args if not a.startswith("-")), option) for args, option, _ in WRITERS}
    missing = [
        f"{' '.join(path)} {option}"
        for path, cmd in _leaf_commands()
        if " ".join(path) not in NEEDS_INPUT | {"report", "params init"}  # a folder; an argument: below
        for option in ("--out", "--plot", "--csv")
        if option in _options(cmd) and (" ".join(path), option) not in covered
    ]
    assert not missing, f"not in WRITERS: {missing}"


def test_report_folder_checks(tmp_path):
    a_file = tmp_path / "report"
    a_file.write_text("x")
    _one_line_error(*run_main(["report", "--out", str(a_file)]), "is a file")
    other = tmp_path / "mine"
    other.mkdir()
    (other / "thesis.tex").write_text("keep me")
    _one_line_error(*run_main(["report", "--out", str(other)]), "other files")
    assert (other / "thesis.tex").read_text() == "keep me"
    _one_line_error(*run_main(["report", "--out", str(tmp_path / "no" / "such")]), "does not exist")


def test_params_init_path_checks(tmp_path):
    _one_line_error(*run_main(["params", "init", str(tmp_path / "p.txt")]), "unknown extension")
    _one_line_error(*run_main(["params", "init", str(tmp_path / "no" / "p.toml")]), "does not exist")
    code, out, err = run_main(["params", "init", str(tmp_path / "p.toml")])
    assert code == 0 and (tmp_path / "p.toml").read_text().startswith("#")
    assert err.strip() == f"wrote {tmp_path / 'p.toml'}"


@pytest.mark.skipif(not Path("/proc/self").exists(), reason="needs /proc (a directory nobody can write in)")
def test_unwritable_location_is_refused():
    code, out, err = run_main(["stability", "--out", "/proc/polywear-test.nc"])
    _one_line_error(code, out, err, "cannot write in /proc")


# -- atomic writes ---------------------------------------------------------------------------
def test_atomic_path_replaces_only_when_complete(tmp_path):
    from polywear.io import atomic_path, write_text

    target = tmp_path / "result.csv"
    write_text(target, "old")
    assert target.read_text() == "old"
    mask = os.umask(0o022)
    os.umask(mask)
    assert target.stat().st_mode & 0o777 == 0o666 & ~mask
    for error in (RuntimeError("writer failed"), KeyboardInterrupt()):
        with pytest.raises(type(error)):
            with atomic_path(target) as tmp:
                assert tmp.parent == tmp_path and tmp.suffix == ".csv" and tmp != target
                tmp.write_text("half of the new")
                raise error
        assert target.read_text() == "old"
        assert sorted(p.name for p in tmp_path.iterdir()) == ["result.csv"]
    with atomic_path(target) as tmp:
        tmp.write_text("new")
        assert target.read_text() == "old"  # readers see the old file until the rename
    assert target.read_text() == "new" and sorted(p.name for p in tmp_path.iterdir()) == ["result.csv"]


def test_fresh_directory_never_mixes_two_runs(tmp_path):
    from polywear.io import fresh_directory

    out = tmp_path / "out"
    with fresh_directory(out) as d:
        (d / "a.png").write_text("run 1")
        (d / "report.html").write_text("run 1")
    with pytest.raises(RuntimeError):
        with fresh_directory(out) as d:
            (d / "b.png").write_text("run 2, failed")
            raise RuntimeError
    assert sorted(p.name for p in out.iterdir()) == [".polywear-files", "a.png", "report.html"]
    with fresh_directory(out) as d:
        (d / "report.html").write_text("run 3")
    assert sorted(p.name for p in out.iterdir()) == [".polywear-files", "report.html"]  # a.png of run 1 is gone
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # no temporary folders left


def test_cli_overwrites_atomically(tmp_path):
    out = tmp_path / "curve.nc"
    code, _, err = run_main(["friction", "curve", "--points", "11", "--out", str(out)])
    assert code == 0, err
    first = out.stat().st_ino
    code, _, err = run_main(["friction", "curve", "--points", "21", "--out", str(out)])
    assert code == 0, err
    assert out.stat().st_ino != first  # a new file renamed over the old one, not rewritten in place
    assert sorted(p.name for p in tmp_path.iterdir()) == ["curve.nc"]


# -- Ctrl-C ----------------------------------------------------------------------------------
def _cpu_seconds(pid: int) -> float:
    """User + system CPU time of a process [s] (Linux /proc)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _children(pid: int) -> list[int]:
    return [int(c) for c in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]


def _interrupt_after(args: list[str], cwd: Path, cpu_s: float = 0.0, children: int = 0, group: bool = False,
                     sig: int = signal.SIGINT):
    """Run ``polywear *args``, wait until it computes (``cpu_s`` of CPU time used and
    ``children`` child processes running: past the imports, whatever the machine's load),
    then send ``sig`` (to the process group if ``group``, as a terminal's Ctrl-C does);
    (exit code, stdout, stderr)."""
    proc = subprocess.Popen([str(POLYWEAR), *args], cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=group)
    deadline = time.monotonic() + 120.0
    while not (_cpu_seconds(proc.pid) >= cpu_s and len(_children(proc.pid)) >= children):
        assert proc.poll() is None, "the command ended before it could be interrupted"
        assert time.monotonic() < deadline, "the command did not start computing"
        time.sleep(0.1)
    time.sleep(0.5)
    assert proc.poll() is None, "the command ended before it could be interrupted"
    if group:
        os.killpg(proc.pid, sig)
    else:
        proc.send_signal(sig)
    out, err = proc.communicate(timeout=60)
    return proc.returncode, out, err


def _assert_interrupted(code, out, err, folder: Path, expected: set[str], sig: int = signal.SIGINT):
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == {signal.SIGINT: 130, signal.SIGTERM: 143}[sig], err
    assert lines[-1] == {signal.SIGINT: "interrupted", signal.SIGTERM: "terminated"}[sig], err
    assert "Traceback" not in err, err
    assert {p.name for p in folder.iterdir()} == expected  # no partial or temporary file


@pytest.mark.slow
def test_ctrl_c_in_compiled_integration(tmp_path):
    """SIGINT while numba's integrator runs: exit 130, one line, no file (it used to be a
    SystemError traceback, a segmentation fault, or exit 0 with the file written)."""
    code, out, err = _interrupt_after(["simulate", "--duration", "60", "--out", "run.nc", "-q"], tmp_path, cpu_s=2.0)
    _assert_interrupted(code, out, err, tmp_path, set())
    assert err.strip() == "interrupted"


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_ctrl_c_while_the_command_line_starts(tmp_path, sig):
    """SIGINT (SIGTERM) during the imports (before main() runs): still one line and exit 130 (143)."""
    proc = subprocess.Popen([str(POLYWEAR), "stability", "-q"], cwd=tmp_path, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    # Python itself starts in about 20 ms of CPU time; importing typer, click, rich and
    # the package takes several times longer: 60 ms falls inside those imports
    deadline = time.monotonic() + 30.0
    while _cpu_seconds(proc.pid) < 0.06:
        assert proc.poll() is None and time.monotonic() < deadline
        time.sleep(0.002)
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=60)
    _assert_interrupted(proc.returncode, out, err, tmp_path, set(), sig)


def test_sigterm_while_computing(tmp_path):
    """SIGTERM (what ``timeout``, CI runners and ``kill`` send) once the command computes:
    exit 143, one line, no file."""
    code, out, err = _interrupt_after(["simulate", "--duration", "60", "--out", "run.nc", "-q"], tmp_path,
                                      cpu_s=2.0, sig=signal.SIGTERM)
    _assert_interrupted(code, out, err, tmp_path, set(), signal.SIGTERM)
    assert err.strip() == "terminated"


@pytest.mark.slow
def test_ctrl_c_with_worker_processes(tmp_path):
    """Ctrl-C to the whole process group during a study on local worker processes."""
    code, out, err = _interrupt_after(
        ["study", "-q", "-w", "2", "-s", "study.outputs=bifurcation", "-s", "study.n_base=64", "--out", "s.nc"],
        tmp_path, children=2, group=True)
    _assert_interrupted(code, out, err, tmp_path, set())


@pytest.mark.slow
def test_ctrl_c_keeps_the_previous_report(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "report.html").write_text("previous run")
    code, _, err = _interrupt_after(["report", "-q", "--out", "out"], tmp_path, cpu_s=3.0)
    _assert_interrupted(code, "", err, tmp_path, {"out"})
    assert sorted(p.name for p in out.iterdir()) == ["report.html"]
    assert (out / "report.html").read_text() == "previous run"


@pytest.mark.slow
def test_sigterm_keeps_the_previous_report_and_the_users_files(tmp_path):
    """A report, notes.txt and analysis/ of the user's beside it; a rerun killed with
    SIGTERM leaves all byte-identical, clears a killed run's partial folder (its process
    has ended) and leaves none of its own; a complete rerun keeps the user's files."""
    out = tmp_path / "out"
    code, _, err = run_main(["report", "-q", "--out", str(out), "--speed-range", "40", "80"])
    assert code == 0, err
    (out / "notes.txt").write_text("mine")
    (out / "analysis").mkdir()
    (out / "analysis" / "fit.py").write_text("mine too")
    before = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    (tmp_path / f".out.new-{dead.pid}-x1y2z3").mkdir()  # left by a run killed with SIGKILL
    code, _, err = _interrupt_after(["report", "-q", "--out", "out"], tmp_path, cpu_s=3.0, sig=signal.SIGTERM)
    _assert_interrupted(code, "", err, tmp_path, {"out"}, signal.SIGTERM)
    assert {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()} == before
    code, _, err = run_main(["report", "-q", "--out", str(out), "--speed-range", "40", "80"])
    assert code == 0, err
    assert (out / "notes.txt").read_text() == "mine" and (out / "analysis" / "fit.py").read_text() == "mine too"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


# -- numeric limits --------------------------------------------------------------------------
@pytest.mark.parametrize("args, fragment", [
    (["bifurcation", "--speed-range", "20", "inf"], "--speed-range"),
    (["bifurcation", "--speed-range", "20", "nan"], "--speed-range"),
    (["bifurcation", "--n-speeds", "1e8"], "--n-speeds"),
    (["bifurcation", "--n-speeds", "100000000"], "--n-speeds"),
    (["bifurcation", "--ntst", "100000000"], "--ntst"),
    (["stability", "--speed-range", "1", "1e9"], "--speed-range"),
    (["stability", "--n-speeds", "100000000"], "--n-speeds"),
    (["simulate", "--duration", "1e9"], "--duration"),
    (["simulate", "--duration", "inf"], "--duration"),
    (["simulate", "--rtol", "1e-300"], "--rtol"),
    (["simulate", "--speed", "2000"], "--speed"),
    (["simulate", "-s", "operating.speed_kmh=2000"], "operating.speed_kmh"),
    (["excitation", "--duration", "1e9"], "--duration"),
    (["map", "--range", "0", "inf"], "--range"),
    (["sensitivity", "--step", "inf"], "--step"),
    (["design", "--max-change", "1e300"], "--max-change"),
    (["friction", "curve", "--points", "1000000000"], "--points"),
    (["friction", "curve", "--v-max", "inf"], "--v-max"),
    (["study", "-s", "study.n_base=1073741824"], "study.n_base"),
    (["study", "-s", "study.speed_range_kmh=[20, 1e9]"], "study.speed_range_kmh"),
    (["params", "show", "-s", "operating.toe_deg=nan"], "operating.toe_deg"),
])
def test_impossible_numbers_are_one_line_exit_2(args, fragment):
    _one_line_error(*run_main(args), fragment)


def test_same_speed_limit_from_an_option_and_from_the_config(tmp_path):
    from polywear.cli.common import MAX_SPEED_KMH
    from polywear.params.tables import MAX_SPEED_KMH as PARAMS_MAX_SPEED_KMH

    assert MAX_SPEED_KMH == PARAMS_MAX_SPEED_KMH
    over = f"{MAX_SPEED_KMH * 1.001:g}"
    _one_line_error(*run_main(["simulate", "--speed", over]), "--speed")
    config = tmp_path / "fast.toml"
    config.write_text(f"[operating]\nspeed_kmh = {over}\n")
    _one_line_error(*run_main(["simulate", "-c", str(config)]), "speed_kmh")
    config.write_text(f"[study]\nspeed_range_kmh = [20.0, {over}]\n")
    _one_line_error(*run_main(["study", "-c", str(config)]), "speed_range_kmh")
    _one_line_error(*run_main(["bifurcation", "--speed-range", "20", over]), "--speed-range")


@pytest.mark.parametrize("content", [bytes(range(256)), b"\x00\x01 not toml \xff", b"[operating\nspeed_kmh = 1"])
def test_unreadable_config_is_one_line_exit_2(tmp_path, content):
    config = tmp_path / "bad.toml"
    config.write_bytes(content)
    _one_line_error(*run_main(["params", "show", "-c", str(config)]), str(config))


# -- help text -------------------------------------------------------------------------------
def test_help_keeps_units_and_has_no_bool_metavars():
    code, out, _ = run_main(["bifurcation", "--help"])
    assert code == 0 and "[km/h]" in out
    code, out, _ = run_main(["friction", "curve", "--help"])
    assert code == 0 and "[m/s]" in out
    for path, _ in _leaf_commands():
        code, out, err = run_main([*path, "--help"])
        assert code == 0, (path, err)
        assert "<bool>" not in out, path


def test_usage_errors_are_one_line():
    _one_line_error(*run_main(["bifurcation", "--no-such-option"]), "--no-such-option")
    _one_line_error(*run_main(["simulate", "--duration", "abc"]), "--duration")
    code, out, err = run_main(["friction"])  # a group without a command: its help, not an "error"
    assert code == 2 and (out + err).startswith("Usage: ") and "friction [OPTIONS] COMMAND" in out + err
    assert "error" not in err


# -- stdout / stderr / -q --------------------------------------------------------------------
def test_every_command_takes_quiet():
    missing = [" ".join(path) for path, cmd in _leaf_commands() if "-q" not in _options(cmd)]
    assert not missing, f"commands without -q: {missing}"


@pytest.mark.parametrize("args", [
    ["params", "show"],
    ["friction", "curve", "--points", "11"],
    ["stability", "--n-speeds", "50"],
    ["simulate", "--duration", "0.05"],
])
def test_results_on_stdout_notes_on_stderr(args, tmp_path):
    code, out, err = run_main([*args, "--json", "-q"])
    assert code == 0, err
    json.loads(out)
    assert err == ""
    code, out, err = run_main([*args, "-q"])
    assert code == 0 and out.strip() and err == "", err
    plot = tmp_path / "f.png"
    if args[0] != "params":
        code, out, err = run_main([*args, "--plot", str(plot)])
        assert code == 0 and out.strip() and plot.stat().st_size > 0
        assert f"wrote {plot}" in err  # the real file name written, on stderr


def test_simulate_says_no_oscillation_for_a_decaying_motion():
    """Below the first Hopf speed the disturbance decays to rounding level within 3 s: the
    outcome is the equilibrium, not a 'transient' at the frequency of rounding noise."""
    code, out, err = run_main(["simulate", "--speed", "30", "--duration", "3", "--json", "-q"])
    assert code == 0, err
    summary = json.loads(out)
    assert summary["outcome"] == "equilibrium"
    code, out, err = run_main(["simulate", "--speed", "30", "--duration", "3", "-q"])
    assert "no oscillation" in out and "Hz" not in out


def test_simulate_unsettled_motion_is_not_given_an_amplitude():
    """Safe car, 1 s: the slow decay has no whole cycle yet; say so instead of 'amplitude nan mm'."""
    code, out, err = run_main(["simulate", "-s", "operating.toe_deg=0.05", "-q"])
    assert code == 0 and "not settled" in out and "nan" not in out


# -- study --scheduler -----------------------------------------------------------------------
def test_unreachable_scheduler_fails_within_the_connect_timeout():
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # closed again: nothing listens there
    start = time.monotonic()
    code, out, err = run_main(["study", "-q", "--scheduler", f"tcp://127.0.0.1:{port}", "--connect-timeout", "1"])
    elapsed = time.monotonic() - start
    _one_line_error(code, out, err, str(port))
    assert "within 1 s" in err
    assert elapsed < 30.0  # generous: dask's default connect timeout alone would be 30 s


# -- bootstrap -------------------------------------------------------------------------------
@pytest.mark.skipif(shutil.which("bash") is None, reason="needs bash")
def test_bootstrap_installs_only_what_is_missing(tmp_path):
    """scripts/bootstrap.sh against a fake virtualenv whose python logs its calls."""
    (tmp_path / "scripts").mkdir()
    shutil.copy(REPO / "scripts" / "bootstrap.sh", tmp_path / "scripts")
    shutil.copy(REPO / "pyproject.toml", tmp_path)
    venv_bin = tmp_path / ".venv" / "bin"
    venv_bin.mkdir(parents=True)
    log = tmp_path / "pip.log"
    (venv_bin / "python").write_text(f'#!/bin/sh\necho "$*" >> {log}\n')
    (venv_bin / "python").chmod(0o755)

    def bootstrap(*extras):
        subprocess.run(["bash", str(tmp_path / "scripts" / "bootstrap.sh"), *extras], check=True,
                       capture_output=True)
        return log.read_text().splitlines() if log.exists() else []

    assert len(bootstrap("test")) == 1  # first time: install with the test extra
    assert len(bootstrap()) == 1  # run.sh after test.sh: nothing to do, no pip call (offline)
    assert len(bootstrap("test")) == 1
    calls = bootstrap("docs")  # a new extra: installed together with the old one
    assert len(calls) == 2 and calls[-1].endswith("[docs,test]")
    with open(tmp_path / "pyproject.toml", "a") as fh:
        fh.write("\n# changed\n")
    calls = bootstrap()
    assert len(calls) == 3 and calls[-1].endswith("[docs,test]")
