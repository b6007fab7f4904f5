"""Property-based test of every ``polywear`` command with random option and config values.

The commands and their options are read from the typer application itself, so a new
command or option is fuzzed without touching this file. Two properties:

* with at least one bad input among random ones (a NaN/inf/text/unknown ``--set``, an
  unreadable or ill-typed config file, an unwritable output path), every command fails
  with exit code 2 and one line ``error: ...`` on stderr, no traceback, before computing
  anything (so the run stays fast), and writes no file;
* cheap commands with random values, valid or not: exit 0 or 2, never a traceback, no
  partial file left.

The exit code 130 (Ctrl-C) is tested with real signals in test_cli_robustness.py.
Examples per property: 40 by default (about half a minute in all); ``POLYWEAR_FUZZ_EXAMPLES=2000`` for a longer run.
"""

from __future__ import annotations

import enum
import os
import types
import typing
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from .cli_runner import run_main

EXAMPLES = int(os.environ.get("POLYWEAR_FUZZ_EXAMPLES", "40"))
FUZZ = settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.too_slow])

# -- the commands, read from the application -----------------------------------------------


def _commands() -> dict[str, list]:
    """{"sub command": [click parameters]} for every leaf command."""
    import typer

    from polywear.cli.app import app

    found: dict[str, list] = {}

    def walk(cmd, path):
        if hasattr(cmd, "commands"):
            for name, sub in cmd.commands.items():
                walk(sub, [*path, name])
        else:
            found[" ".join(path)] = [p for p in cmd.params if p.name != "help"]

    walk(typer.main.get_command(app), [])
    return found


COMMANDS = _commands()


def _kind(param) -> tuple[str, typing.Any]:
    """(kind, detail) of a parameter from its annotation: flag, float, int, path, text, choice."""
    annotation = param.type_descriptor.annotation
    origin = typing.get_origin(annotation)
    if origin in (typing.Union, types.UnionType):
        annotation = next(a for a in typing.get_args(annotation) if a is not type(None))
        origin = typing.get_origin(annotation)
    if origin in (list, tuple):
        annotation = typing.get_args(annotation)[0]
    if annotation is bool:
        return "flag", None
    if isinstance(annotation, type) and issubclass(annotation, enum.Enum):
        return "choice", [m.value for m in annotation]
    if annotation in (float, int):
        return annotation.__name__, None
    if annotation is Path:
        return "path", None
    return "text", None


# -- random values ---------------------------------------------------------------------------
NUMBERS = st.one_of(
    st.sampled_from(["nan", "inf", "-inf", "1e308", "-1e308", "1e-308", "0", "-1", "1e8", "3", "0.5", "120"]),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-10**12, 10**12).map(str),
)
TEXT = st.one_of(st.sampled_from(["", "abc", "[1, 2]", "{a = 1}", "true", "=", "x=y=z", "\x00"]),
                 st.text(max_size=12))


def _keys() -> list[str]:
    from polywear.params import flat_items, load_params

    return [key for key, _, _ in flat_items(load_params())]


KEYS = _keys()
BAD_VALUES = st.sampled_from(["nan", "inf", "-inf", "1e999", '"text"', "[1, 2]", "{a = 1}", "", "abc"])


def _paths(folder: Path):
    """Output or input paths: writable, and every kind of bad one."""
    return st.sampled_from([
        folder / "ok.nc", folder / "ok.png", folder / "ok.csv", folder / "ok.json", folder / "ok.toml",
        folder / "missing" / "x.nc", folder / "a_file" / "x.png", folder / "a_dir", folder / "x.unknown",
        folder / "binary.toml", Path("/proc/polywear-fuzz.nc"),
    ]).map(str)


def _option_values(draw, params, folder: Path) -> list[str]:
    """Random arguments for a random subset of ``params``."""
    args: list[str] = []
    for param in params:
        if not draw(st.booleans()):
            continue
        kind, detail = _kind(param)
        if param.param_type_name == "argument":
            args += [draw(_paths(folder))]
            continue
        option = param.opts[0]
        if kind == "flag":
            args += [option]
            continue
        value = {
            "float": NUMBERS, "int": NUMBERS, "path": _paths(folder), "text": TEXT,
            "choice": st.one_of(st.sampled_from(detail or ["x"]), TEXT),
        }[kind]
        if option in ("--set", "-s"):
            value = st.builds(lambda k, v: f"{k}={v}", st.sampled_from(KEYS), st.one_of(NUMBERS, TEXT))
        args += [option, *(draw(value) for _ in range(max(param.nargs, 1)))]
    return args


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    """Inputs the fuzzer points at: a file where a folder is expected, a folder, binary data."""
    folder = tmp_path_factory.mktemp("fuzz")
    (folder / "a_file").write_text("x")
    (folder / "a_dir").mkdir()
    (folder / "binary.toml").write_bytes(bytes(range(256)))
    (folder / "typed.toml").write_text('[operating]\nspeed_kmh = "fast"\n')
    (folder / "unknown.toml").write_text("[no_such_table]\nx = 1\n")
    return folder


FIXTURES = {"a_file", "a_dir", "binary.toml", "typed.toml", "unknown.toml"}


def _no_files_written(folder: Path) -> None:
    """Nothing but the fixtures: no result and no partial or temporary file."""
    extra = sorted(p.name for p in folder.iterdir() if p.name not in FIXTURES)
    assert extra == [], extra
    assert list((folder / "a_dir").iterdir()) == []


def _bad_input(draw, name: str, params, folder: Path) -> list[str]:
    """One input that must be refused, fitting what the command takes."""
    opts = {o for p in params for o in getattr(p, "opts", [])}
    kinds = []
    if "--set" in opts:
        kinds += ["bad value", "unknown key"]
    if "--config" in opts:
        kinds += ["bad config"]
    outputs = [o for o in ("--out", "--plot", "--csv") if o in opts]
    if outputs:
        kinds += ["bad output"]
    kind = draw(st.sampled_from(kinds)) if kinds else "bad argument"
    if kind == "bad value":
        return ["--set", f"{draw(st.sampled_from(KEYS))}={draw(BAD_VALUES)}"]
    if kind == "unknown key":
        return ["--set", f"{draw(st.sampled_from(['no.such_key', 'operating.speed', 'tread']))}=1"]
    if kind == "bad config":
        config = draw(st.sampled_from(["binary.toml", "typed.toml", "unknown.toml", "a_dir", "missing.toml"]))
        return ["--config", str(folder / config)]
    if kind == "bad output":
        bad = draw(st.sampled_from(["missing/x.png", "a_file/x.png", "x.unknown"]))
        return [draw(st.sampled_from(outputs)), str(folder / bad)]
    return [str(folder / "missing" / "x.toml")]


def _without_outputs_and_config(params):
    """Random values for everything but the options that name files (the bad one decides)."""
    return [p for p in params if not set(getattr(p, "opts", [])) & {"--out", "-o", "--plot", "--csv", "--config"}
            and p.param_type_name != "argument"]


@FUZZ
@given(data=st.data(), name=st.sampled_from(sorted(COMMANDS)))
def test_bad_input_is_one_line_exit_2_and_writes_nothing(folder, data, name):
    params = COMMANDS[name]
    args = _option_values(data.draw, _without_outputs_and_config(params), folder)
    bad = _bad_input(data.draw, name, params, folder)
    arguments = [p for p in params if p.param_type_name == "argument"]
    if arguments and bad[0].startswith("-"):
        # commands that read an input file: give them a missing one, which is also refused
        args = [str(folder / "missing" / "input.csv"), *args]
    code, out, err = run_main([*name.split(), *args, *bad])
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2, (name, args, bad, code, err[-2000:])
    assert len(lines) == 1 and lines[0].startswith("error: "), (name, args, bad, err[-2000:])
    assert "Traceback" not in err and out == ""
    _no_files_written(folder)


CHEAP = ["params show", "params init", "friction curve"]
"""Commands cheap enough to run to the end with random valid values (milliseconds)."""


@FUZZ
@given(data=st.data(), name=st.sampled_from(CHEAP))
def test_cheap_commands_exit_0_or_2_without_traceback(folder, data, name):
    params = COMMANDS[name]
    args = _option_values(data.draw, params, folder)
    if name == "params init" and not any(not a.startswith("-") for a in args):
        args = [str(folder / "ok.toml"), *args]
    code, out, err = run_main([*name.split(), *args])
    assert code in (0, 2), (name, args, code, err[-2000:])
    assert "Traceback" not in err, (name, args, err[-2000:])
    if code == 2:
        lines = [line for line in err.splitlines() if line.strip()]
        assert len(lines) == 1 and lines[0].startswith("error: "), (name, args, err)
    leftovers = [p.name for p in folder.iterdir() if ".part" in p.name or p.name.startswith(".")]
    assert leftovers == [], leftovers
    for written in set(folder.iterdir()) - {folder / f for f in FIXTURES}:
        written.unlink()
