"""Property-based test of every ``polywear`` command with random option and config values.

The commands and their options are read from the typer application itself, so a new
command or option is fuzzed without touching this file. Two properties:

* with at least one bad input among random ones (a NaN/inf/text/unknown ``--set``, an
  unreadable or ill-typed config file, an unwritable output path), every command fails
  with exit code 2 and one line ``error: ...`` on stderr, no traceback, before computing
  anything (so the run stays fast), and writes no file;
* cheap commands with random values, valid or not: exit 0 or 2, never a traceback, no
  partial file left;
* a value of a numeric key just past, or far past, its plausibility bound (the key
  registry, docs/model.md section 6): exit 2, one line naming the key, on every command
  that takes ``--set``;
* every kind of input file (a .tir file, a friction CSV, an observation file, a fleet
  spec) with one number replaced by an extreme one, or the whole file by a bad one:
  exit 0, 2 or 130, no traceback, no NaN or Infinity in the JSON, no partial file, and
  at most ``CALL_CPU_S`` of CPU per call.

The exit code 130 (Ctrl-C) is tested with real signals in test_cli_robustness.py.
Examples per property: 40 by default (a few minutes in all); ``POLYWEAR_FUZZ_EXAMPLES=2000`` for a longer
run (benchmarks/bench_fuzz.py).
"""

from __future__ import annotations

import enum
import os
import types
import typing
from pathlib import Path

import pytest
from hypothesis import HealthCheck, Phase, assume, given, settings
from hypothesis import strategies as st

from .cli_runner import run_main

EXAMPLES = int(os.environ.get("POLYWEAR_FUZZ_EXAMPLES", "40"))
FUZZ = settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.too_slow],
                **({} if os.environ.get("POLYWEAR_FUZZ_SHRINK", "1") == "1" else
                   {"phases": [Phase.explicit, Phase.reuse, Phase.generate]}))
CALL_LOG = os.environ.get("POLYWEAR_FUZZ_LOG")
"""A file to which every call's CPU time [s] and arguments are appended (benchmarks/bench_fuzz.py)."""
CALL_CPU_S = float(os.environ.get("POLYWEAR_FUZZ_CALL_CPU_S", "120"))
"""Most CPU time one fuzzed call may take [s] (this process); it is stopped there."""
WALL_PER_CPU = 10.0
"""A call is also stopped after ``WALL_PER_CPU * CALL_CPU_S`` of wall time (a call that
waits without computing, on a loaded machine) [-]."""


class CallTooSlow(BaseException):
    """A fuzzed call stopped at its time limit (not an Exception: the command cannot catch it)."""


def _run(args: list[str], note: str = "") -> tuple[int, str, str]:
    """``run_main(args)`` stopped after ``CALL_CPU_S`` of CPU (or ``WALL_PER_CPU`` times that of
    wall time) with :class:`CallTooSlow` naming the arguments and ``note`` (what was put in an
    input file): a call that hangs fails the property with its example instead of hanging the run."""
    import signal
    import time

    message = (f"over {CALL_CPU_S:g} s CPU or {WALL_PER_CPU * CALL_CPU_S:g} s wall: "
               f"polywear {' '.join(args)} {note}")
    fired = []

    def stop(signum, frame):
        # armed again: a raise that lands where Python only prints it (a garbage-collection
        # callback, a __del__) is swallowed there; the next one lands in the call
        fired.append(signum)
        signal.setitimer(signal.ITIMER_PROF, 0.05)
        signal.setitimer(signal.ITIMER_REAL, 0.5)
        raise CallTooSlow(message)

    previous = {s: signal.signal(s, stop) for s in (signal.SIGPROF, signal.SIGALRM)}
    start = time.process_time()
    signal.setitimer(signal.ITIMER_PROF, CALL_CPU_S)
    signal.setitimer(signal.ITIMER_REAL, WALL_PER_CPU * CALL_CPU_S)
    try:
        return run_main(args)
    except Exception as error:
        if fired:
            # the stop landed in compiled code that turned it into another error (seen once in
            # CI: numba's unboxing of a first-class function builds `sig` by unpickling and calls
            # _get_wrapper_address(func, sig) without checking it; a pending stop leaves it NULL,
            # which Python reads as a missing argument: "TypeError: ... missing ... 'sig'")
            raise CallTooSlow(message) from error
        raise
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0.0)
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        for s, handler in previous.items():
            signal.signal(s, handler)
        if CALL_LOG:
            with open(CALL_LOG, "a") as log:
                log.write(f"{time.process_time() - start:.3f}\t{args!r} {note}\n")


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
    code, out, err = _run([*name.split(), *args, *bad])
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2, (name, args, bad, code, err[-2000:])
    assert len(lines) == 1 and lines[0].startswith("error: "), (name, args, bad, err[-2000:])
    assert "Traceback" not in err and out == ""
    _no_files_written(folder)


def test_a_call_past_the_time_limit_is_stopped_naming_it(monkeypatch):
    """The harness's own limit: a call that computes longer than ``CALL_CPU_S`` is stopped
    with its arguments (here a limit of 0.05 s against an axle4dof bifurcation diagram of
    ~0.7 s CPU once compiled; a warm stability run of 400 speeds, 0.04 s, was too short)."""
    monkeypatch.setitem(globals(), "CALL_CPU_S", 0.05)
    with pytest.raises(CallTooSlow, match=r"over 0.05 s CPU .*polywear bifurcation --set model=axle4dof"):
        _run(["bifurcation", "--set", "model=axle4dof", "--json", "-q"])


CHEAP = ["params show", "params init", "friction curve"]
"""Commands cheap enough to run to the end with random valid values (milliseconds)."""


@FUZZ
@given(data=st.data(), name=st.sampled_from(CHEAP))
def test_cheap_commands_exit_0_or_2_without_traceback(folder, data, name):
    params = COMMANDS[name]
    args = _option_values(data.draw, params, folder)
    if name == "params init" and not any(not a.startswith("-") for a in args):
        args = [str(folder / "ok.toml"), *args]
    code, out, err = _run([*name.split(), *args])
    assert code in (0, 2), (name, args, code, err[-2000:])
    assert "Traceback" not in err, (name, args, err[-2000:])
    if code == 2:
        lines = [line for line in err.splitlines() if line.strip()]
        assert len(lines) == 1 and lines[0].startswith("error: "), (name, args, err)
    leftovers = [p.name for p in folder.iterdir() if ".part" in p.name or p.name.startswith(".")]
    assert leftovers == [], leftovers
    for written in set(folder.iterdir()) - {folder / f for f in FIXTURES}:
        written.unlink()


# -- plausibility bounds of every numeric key ---------------------------------------------------
def _past_bounds() -> list[tuple[str, str]]:
    """(key, value) just past and far past every finite bound of the key registry."""
    import math

    from polywear.keys import KEYS

    out = []
    for key, info in KEYS.items():
        if info.kind != "stored":
            continue
        for bound, inclusive, sign in ((info.lower, info.lower_inclusive, -1.0), (info.upper, info.upper_inclusive, 1.0)):
            if not math.isfinite(bound):
                continue
            step = max(abs(bound), 1.0) * (1e-6 if inclusive else 0.0)
            just = bound + sign * step if inclusive else bound
            if info.integer:
                just = bound + sign * (1 if inclusive else 0)
            out += [(key, repr(int(just) if info.integer else float(just))),
                    (key, repr(int(bound + sign * 10 ** 9) if info.integer else float(bound + sign * 1e12)))]
    return out


PAST_BOUNDS = _past_bounds()
WITH_SET = sorted(name for name, params in COMMANDS.items() if any("--set" in getattr(p, "opts", []) for p in params))


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> dict[str, list[str]]:
    """Valid inputs of the commands that need one (command -> arguments), so that the bad
    key, not a missing file, is what is refused; commands with no valid input here get a
    missing file (their message then names the file)."""
    folder = tmp_path_factory.mktemp("inputs")
    (folder / "obs.toml").write_text(OBSERVATIONS)
    (folder / "fleet.toml").write_text(FLEET)
    return {"calibrate": ["--observed", str(folder / "obs.toml"), "--vary", "friction.mu_static"],
            "fleet": ["--spec", str(folder / "fleet.toml")],
            "params from-tir": [str(DATA / "mf62_example.tir")],
            "friction fit": ["--sample"], "friction fit-loops": ["--sample"]}


@FUZZ
@given(name=st.sampled_from(WITH_SET), case=st.sampled_from(PAST_BOUNDS))
def test_a_value_past_its_bound_is_refused_naming_the_key(folder, inputs, name, case):
    key, value = case
    arguments = [p for p in COMMANDS[name] if p.param_type_name == "argument"]
    args = inputs.get(name, [str(folder / "missing" / "input.csv")] if arguments else [])
    code, out, err = _run([*name.split(), *args, "--set", f"{key}={value}"])
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2 and out == "", (name, key, value, code, err[-2000:])
    assert len(lines) == 1 and lines[0].startswith("error: ") and "Traceback" not in err, (name, err)
    named = key in lines[0] or (name not in inputs and arguments and "input.csv" in lines[0])
    assert named, (name, key, value, lines[0])
    _no_files_written(folder)


# -- every kind of input file, good and bad --------------------------------------------------
DATA = Path(__file__).parent / "data"
OBSERVATIONS = ('[[observation]]\nquantity = "first_hopf_kmh"\nvalue = 58.1\nsigma = 1.0\n\n'
                '[[observation]]\nquantity = "friction_mu"\nvalue = 0.7\nsigma = 0.02\nat_sliding_speed_m_per_s = 0.2\n')
FLEET_CARS = 50
"""Most cars a fuzzed fleet spec may ask for: a larger valid ``samples`` is a request for
that many cars, minutes to hours of work by design (60001 cars: stopped at 30 s of CPU
by the call limit of benchmarks/bench_fuzz.py), not an input to be refused fast; the
values past its bounds (0, over 1e7, fractions, text) are still fuzzed."""
FLEET = ('[fleet]\nsamples = 2\n[[fleet.parameter]]\nkey = "operating.toe_deg"\ndistribution = "uniform"\n'
         'low = 0.45\nhigh = 0.55\n[[fleet.usage]]\nspeed_kmh = 100\nshare = 1\n')


def _input_kinds() -> dict[str, tuple[str, list[str]]]:
    """Kind -> (a valid file's text, the command that reads it; ``{file}`` stands for the path)."""
    from polywear.friction import sample_path

    return {
        "tir": (DATA.joinpath("mf62_example.tir").read_text(), ["params", "from-tir", "{file}", "--json", "-q"]),
        "tir option": (DATA.joinpath("mf62_example.tir").read_text(),
                       ["stability", "--tir", "{file}", "--n-speeds", "20", "--json", "-q"]),
        "friction csv": (sample_path("steady").read_text(), ["friction", "fit", "{file}", "--json", "-q"]),
        "observations": (OBSERVATIONS, ["calibrate", "--observed", "{file}", "--vary", "friction.mu_static",
                                        "--no-profile", "--json", "-q"]),
        "fleet spec": (FLEET, ["fleet", "--spec", "{file}", "--backend", "serial", "--json", "-q"]),
    }


INPUT_KINDS = _input_kinds()
NUMBER_IN_TEXT = r"(?<![A-Za-z_0-9.])-?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?"
EXTREME = st.one_of(st.sampled_from(["0", "-0", "-1", "1e308", "-1e308", "1e-308", "1e9", "-1e9", "nan", "inf",
                                     "1e999", "5", "3.5", "60001", "0.1"]),
                    st.floats(allow_nan=False, allow_infinity=False).map(repr))
BAD_FILES = [b"", bytes(range(256)), b"\xef\xbb\xbf", b"x = \n", b"[[[", "ä=ü\n".encode("latin-1")]


def _many_cars(value: str) -> bool:
    """Whether ``value`` is a valid ``fleet.samples`` above :data:`FLEET_CARS` (a whole number up to 1e7)."""
    try:
        number = float(value)
    except ValueError:
        return False
    return FLEET_CARS < number <= 1e7 and number == int(number)


def _no_nan_json(text: str) -> None:
    """The output parses as strict JSON: NaN and Infinity are refused."""
    import json

    def refuse(constant):
        raise AssertionError(f"{constant} in the JSON")

    json.loads(text, parse_constant=refuse)


@FUZZ
@given(data=st.data(), kind=st.sampled_from(sorted(INPUT_KINDS)))
def test_every_input_file_kind_with_extreme_or_bad_content(folder, data, kind):
    import re

    text, command = INPUT_KINDS[kind]
    path = folder / "input.fuzz"
    if data.draw(st.booleans(), label="bad file"):
        content = data.draw(st.sampled_from(BAD_FILES), label="content")
        path.write_bytes(content)
        note = f"(file: {content[:20]!r})"
    else:
        numbers = list(re.finditer(NUMBER_IN_TEXT, text))
        hit = numbers[data.draw(st.integers(0, len(numbers) - 1), label="number")]
        value = data.draw(EXTREME, label="value")
        if kind == "fleet spec" and text[:hit.start()].endswith("samples = "):
            assume(not _many_cars(value))
        path.write_text(text[:hit.start()] + value + text[hit.end():])
        line = text[:hit.end()].rsplit("\n", 1)[-1]
        note = f"(file: {line!r} with {hit.group()} -> {value})"
    out_file = folder / "out.json"
    args = [a.replace("{file}", str(path)) for a in command]
    if kind in ("friction csv", "observations"):
        args += ["--out", str(out_file)]
    try:
        code, out, err = _run(args, note)
    finally:
        path.unlink()
    assert code in (0, 2, 130), (kind, args, code, err[-2000:])
    assert "Traceback" not in err, (kind, err[-2000:])
    if code == 0:
        _no_nan_json(out)
        if out_file.exists():
            _no_nan_json(out_file.read_text())
    else:
        lines = [line for line in err.splitlines() if line.strip() and not line.startswith("warning: ")]
        assert lines and lines[-1].startswith("error: "), (kind, err[-2000:])
        assert not out_file.exists()
    out_file.unlink(missing_ok=True)
    _no_files_written(folder)
