"""Shared pieces of the command-line interface: options, parameter loading, output.

An option that several commands take is defined once, here: as an ``Annotated`` alias
(``SpeedRangeOpt``, ``BackendOpt``, ...) or, for the options nearly every command takes,
as an option group declared by one parameter, ``inputs: Inputs = Inputs()`` (``--config``,
``--set``) and ``outputs: Outputs = Outputs("what --out writes", suffixes)`` (``--json``,
``--plot``, ``--out``, ``--quiet``); :func:`add_shared_options` expands the groups in place
and adds ``--tir``. The groups also carry the shared command bodies: ``inputs.load()``,
``outputs.check()``, ``outputs.progress(...)``, ``outputs.write(...)``, ``outputs.show(...)``.

Heavy libraries are imported inside the commands, never at module level, so that
``polywear --help`` stays fast.
"""

from __future__ import annotations

import json
import math
import tempfile
from abc import ABC, abstractmethod
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import Annotated, Any, Callable, Iterator, Optional

import typer

from ..units import MAX_SPEED_KMH

ConfigOpt = Annotated[
    Optional[Path],
    typer.Option("--config", "-c", help="TOML parameter file (defaults for missing keys)."),
]
SetOpt = Annotated[
    Optional[list[str]],
    typer.Option("--set", "-s", help="Override a key: table.key=value (repeatable)."),
]
JsonOpt = Annotated[bool, typer.Option("--json", help="Print the summary as JSON on stdout.")]
PlotOpt = Annotated[Optional[Path], typer.Option("--plot", help="Write a figure (png, pdf, svg).")]


def out_option(help: str) -> Any:
    """The ``--out/-o FILE`` option, with ``help`` saying what the command writes there."""
    return Annotated[Optional[Path], typer.Option("--out", "-o", help=help)]


QuietOpt = Annotated[bool, typer.Option("--quiet", "-q", help="No progress output or notes on stderr.")]
SpeedRangeOpt = Annotated[
    tuple[float, float], typer.Option("--speed-range", help="Lowest and highest speed [km/h].")
]
"""``--speed-range LOW HIGH`` [km/h]; default ``DEFAULT_SPEED_RANGE_KMH``, check with :func:`check_speed_range`."""
OperatingRangeOpt = Annotated[
    Optional[tuple[float, float]],
    typer.Option("--operating-range", help="Speeds to keep free of SEV [km/h] (default: operating speed -30/+20)."),
]
"""``--operating-range LOW HIGH`` [km/h]; None: ``dynamics.design.default_operating_range``."""
TirOpt = Annotated[
    Optional[Path],
    typer.Option("--tir", help="Tyre property file (.tir, Magic Formula): its values come before --config/--set."),
]


class Backend(str, Enum):
    """Where the runs of a study or a fleet go: local processes, this process, or Dask."""

    processes = "processes"
    serial = "serial"
    dask = "dask"


BackendOpt = Annotated[
    Optional[Backend],
    typer.Option("--backend", help="processes (default), serial, or dask (implied by --scheduler)."),
]
SchedulerOpt = Annotated[
    Optional[str], typer.Option("--scheduler", help="Dask scheduler address, e.g. tcp://10.0.0.5:8786.")
]
WorkersOpt = Annotated[
    Optional[int], typer.Option("--workers", "-w", min=1, help="Local worker processes (default: all CPUs).")
]

PLOT_SUFFIXES = (".png", ".pdf", ".svg", ".svgz", ".eps", ".ps", ".jpg", ".jpeg", ".tif", ".tiff", ".webp")
"""File types ``--plot`` writes (matplotlib's Agg, PDF, SVG and PS backends)."""
MAX_GRID_POINTS = 20_000
"""Most speeds of a stability grid or sweep a command accepts (20 000 eigen-solves: seconds)."""


class UserError(Exception):
    """Bad input from the user: reported as one line, exit code 2, no traceback."""


_TIR_PATH: ContextVar[Path | None] = ContextVar("tir_path", default=None)
"""The ``--tir`` file of the running command (set by :func:`with_shared_options`)."""


def tir_path() -> Path | None:
    """The ``--tir`` file of the running command (None without one)."""
    return _TIR_PATH.get()


def load(config: Path | None, sets: list[str] | None):
    """Resolved, validated parameters: defaults, the ``--tir`` file of the running command
    (if any), the TOML file, then ``--set`` overrides."""
    tir = _TIR_PATH.get()
    if tir is not None:
        from ..measured.tir import load_with_tir

        return load_with_tir(tir, config, sets or ()).params
    from ..params import load_params

    return load_params(config, sets or ())


def load_with_study(config: Path | None, sets: list[str] | None):
    """(parameters, study specification): ``--set study.key=value`` overrides go to the
    study (the ``[study]`` table of the TOML file), the others to :func:`load`."""
    from ..params import STUDY_TABLE, load_study

    study_sets = [item for item in sets or () if item.split("=", 1)[0].strip().split(".", 1)[0] == STUDY_TABLE]
    params = load(config, [item for item in sets or () if item not in study_sets])
    return params, load_study(config, study_sets)


class OptionGroup(ABC):
    """Options that travel together. A command declares them as one parameter whose default
    is the group (a frozen dataclass, its fields named like the options);
    :func:`with_shared_options` puts the options in that place of its --help and hands the
    command their values as one such object."""

    @abstractmethod
    def options(self) -> list[tuple[str, Any, Any]]:
        """(parameter name, typer annotation, default) of each option, in --help order."""


@dataclass(frozen=True)
class Inputs(OptionGroup):
    """Where a command's parameters come from, ``inputs: Inputs = Inputs()``: ``--config
    FILE`` and ``--set table.key=value`` (``--tir FILE``, last in --help, is added by
    :func:`with_shared_options`)."""

    config: Path | None = None
    set_: list[str] | None = None

    def options(self) -> list[tuple[str, Any, Any]]:
        return [("config", ConfigOpt, None), ("set_", SetOpt, None)]

    def load(self):
        """The resolved, validated parameters (:func:`load`)."""
        return load(self.config, self.set_)

    def load_with_study(self):
        """(parameters, study specification) (:func:`load_with_study`)."""
        return load_with_study(self.config, self.set_)


@dataclass(frozen=True)
class Outputs(OptionGroup):
    """How a command answers, ``outputs: Outputs = Outputs(...)``: ``--json``, ``--plot FILE``,
    ``--out FILE`` and ``--quiet``, the default saying which it takes; when the command
    runs, their values and what it does with them."""

    out_help: str | None = None
    """Help of ``--out FILE``: what the command writes there (None: no ``--out``)."""
    suffixes: tuple[str, ...] = ()
    """File types ``--out`` writes."""
    takes_plot: bool = True
    """Whether the command takes ``--plot FILE``."""
    json_: bool = False
    plot: Path | None = None
    out: Path | None = None
    quiet: bool = False

    def options(self) -> list[tuple[str, Any, Any]]:
        return [
            ("json_", JsonOpt, False),
            *([("plot", PlotOpt, None)] if self.takes_plot else []),
            *([("out", out_option(self.out_help), None)] if self.out_help else []),
            ("quiet", QuietOpt, False),
        ]

    def check(self) -> None:
        """``--out``, then ``--plot``, checked before any computation (:func:`output_file`)."""
        output_file(self.out, "--out", self.suffixes)
        output_file(self.plot, "--plot", PLOT_SUFFIXES)

    def note(self, message: str) -> None:
        """A status line on stderr, unless ``--quiet`` (:func:`info`)."""
        info(message, self.quiet)

    def progress(self, description: str):
        """A progress bar for the block, unless ``--quiet`` (:func:`progress`)."""
        return progress(description, enabled=not self.quiet)

    def write(self, save: Callable[[Path], Any] | None = None, make_figure: Callable[[], Any] | None = None) -> None:
        """``save(tmp)`` to ``--out``, then the figure of ``make_figure()`` to ``--plot``, each
        when the option is given (``make_figure`` None: no figure to draw; :func:`write_output`,
        :func:`write_figure`)."""
        if self.out and save is not None:
            write_output(self.out, save, self.quiet)
        if self.plot and make_figure is not None:
            write_figure(self.plot, make_figure, self.quiet)

    def show(self, summary: Any, print_text: Callable[[Any], None]) -> None:
        """``summary`` as JSON on stdout with ``--json`` (:func:`emit_json`), else as text by
        ``print_text(summary)``."""
        if self.json_:
            emit_json(summary)
        else:
            print_text(summary)


NETCDF_OUTPUTS = Outputs("Write the result (netCDF .nc).", (".nc",))
"""``--json``, ``--plot`` and ``--out`` of a result written as netCDF, ``--quiet``."""


def with_shared_options(command: Callable) -> Callable:
    """``command`` with the options shared by several commands in its signature, so that
    each is defined once, here: every parameter whose default is an :class:`OptionGroup`
    replaced, in place, by the group's options (the command receives their values as one
    group object), and, last, ``--tir FILE`` (applied by :func:`load`) if it takes
    ``--config`` and has no ``tir`` parameter of its own."""
    import dataclasses
    import functools
    import inspect

    sig = inspect.signature(command, eval_str=True)  # once per command: most of the start-up cost here
    groups = {p.name: p.default for p in sig.parameters.values() if isinstance(p.default, OptionGroup)}
    parameters = []
    for p in sig.parameters.values():
        if p.name in groups:
            options = groups[p.name].options()
            parameters += [inspect.Parameter(n, p.kind, default=d, annotation=a) for n, a, d in options]
        else:
            parameters.append(p)
    names = {p.name for p in parameters}
    takes_tir = "config" in names and "tir" not in names
    if not groups and not takes_tir:
        return command
    if takes_tir:
        parameters.append(inspect.Parameter("tir", inspect.Parameter.KEYWORD_ONLY, default=None, annotation=TirOpt))

    @functools.wraps(command)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        for name, group in groups.items():
            values = {option: kwargs.pop(option) for option, _, _ in group.options()}
            kwargs[name] = dataclasses.replace(group, **values)
        if not takes_tir:
            return command(*args, **kwargs)
        token = _TIR_PATH.set(kwargs.pop("tir", None))
        try:
            return command(*args, **kwargs)
        finally:
            _TIR_PATH.reset(token)

    wrapper.__signature__ = sig.replace(parameters=parameters)  # type: ignore[attr-defined]
    wrapper.__annotations__ = {p.name: p.annotation for p in parameters}
    return wrapper


def add_shared_options(app: typer.Typer) -> None:
    """:func:`with_shared_options` for every command of ``app`` and its sub-applications."""
    for command in app.registered_commands:
        command.callback = with_shared_options(command.callback)
    for group in app.registered_groups:
        add_shared_options(group.typer_instance)


def check_speed_range(pair: tuple[float, float] | None, option: str = "--speed-range") -> tuple[float, float] | None:
    """``(low, high)`` checked: finite, 0 < low < high <= MAX_SPEED_KMH [km/h] (None passes)."""
    if pair is None:
        return None
    lo, hi = pair
    if not (math.isfinite(lo) and math.isfinite(hi) and 0.0 < lo < hi <= MAX_SPEED_KMH):
        raise UserError(f"{option} {lo:g} {hi:g}: need 0 < low < high <= {MAX_SPEED_KMH:g} [km/h]")
    return float(lo), float(hi)


def check_param_keys(keys, option: str = "--param", example: str = "operating.toe_deg") -> None:
    """Each key a numeric configuration key or ``adhesion_scale``; else one line naming the first other."""
    from ..keys import ADHESION_SCALE, study_keys

    known = study_keys()
    for key in keys:
        if key not in known:
            raise UserError(f"{option} {key}: not a numeric parameter key (e.g. {example}, {ADHESION_SCALE})")


def check_count(value: int | None, option: str, low: int, high: int) -> int | None:
    """An integer option checked against ``low <= value <= high`` (None passes)."""
    if value is not None and not low <= value <= high:
        raise UserError(f"{option} {value}: must be between {low} and {high}")
    return value


def chosen_backend(backend: Backend | None, scheduler: str | None, connect_timeout_s: float) -> str:
    """The backend ``--backend``/``--scheduler`` ask for (dask if only a scheduler is given),
    checked; a Dask scheduler is probed once, failing within ``connect_timeout_s`` [s]."""
    chosen = backend.value if backend else ("dask" if scheduler else "processes")
    if chosen == "dask" and not scheduler:
        raise UserError("--backend dask: give --scheduler tcp://host:port")
    if scheduler and chosen != "dask":
        raise UserError(f"--scheduler needs the dask backend, not {chosen}")
    if chosen == "dask":
        from distributed import Client

        try:
            with Client(scheduler, timeout=f"{connect_timeout_s}s"):
                pass
        except (OSError, ValueError, TypeError) as exc:  # unreachable, timed out, malformed address
            raise UserError(
                f"cannot reach the Dask scheduler {scheduler} within {connect_timeout_s:g} s: {exc}"
            ) from None
    return chosen


def dask_connect_timeout(seconds: float | None):
    """Dask's connect timeout set to ``seconds`` [s] for the block (nothing when None)."""
    from contextlib import nullcontext

    if seconds is None:
        return nullcontext()
    import dask

    return dask.config.set({"distributed.comm.timeouts.connect": f"{seconds}s"})


def output_file(path: Path | None, option: str, suffixes: tuple[str, ...]) -> Path | None:
    """Check, before any computation, that ``path`` can be written as one of ``suffixes``.

    Refused with one line (exit 2): an unknown extension, an existing directory, a
    missing parent directory, a parent that is a file, or a location that cannot be
    written. Returns ``path`` unchanged (None passes).
    """
    if path is None:
        return None
    if path.suffix.lower() not in suffixes:
        raise UserError(f"{option} {path}: unknown extension {path.suffix or '(none)'!r}, "
                        f"expected {', '.join(suffixes)}")
    if path.is_dir():
        raise UserError(f"{option} {path}: is a directory, expected a file name")
    _writable_directory(path.parent, f"{option} {path}")
    return path


def output_folder(path: Path, option: str, marker: str) -> Path:
    """Check a results folder before any computation: a folder (or nothing yet) in a
    writable directory, and, if it holds files, one this command wrote (it has ``marker``):
    a folder of other files is never touched (refused, naming them)."""
    if path.exists():
        if not path.is_dir():
            raise UserError(f"{option} {path}: is a file, expected a folder")
        entries = sorted(p.name for p in path.iterdir())
        if entries and not (path / marker).exists():
            shown = ", ".join(entries[:5]) + (f" and {len(entries) - 5} more" if len(entries) > 5 else "")
            raise UserError(f"{option} {path}: folder holds other files ({shown}; no {marker}); "
                            "give a new or empty folder")
    _writable_directory(path.parent, f"{option} {path}")
    return path


def _writable_directory(directory: Path, what: str) -> None:
    where = directory if str(directory) else Path(".")
    if not where.exists():
        raise UserError(f"{what}: directory {where} does not exist")
    if not where.is_dir():
        raise UserError(f"{what}: {where} is not a directory")
    try:  # the real test (permissions, read-only file systems, root)
        with tempfile.TemporaryFile(dir=where):
            pass
    except OSError as exc:
        raise UserError(f"{what}: cannot write in {where} ({exc.strerror})") from None


def write_output(path: Path, write: Callable[[Path], Any], quiet: bool = False) -> None:
    """``write(tmp)`` to a temporary file next to ``path``, renamed onto it when complete."""
    from ..io import atomic_path

    with atomic_path(path) as tmp:
        write(tmp)
    info(f"wrote {path}", quiet)


def save_text(text: str) -> Callable[[Path], Any]:
    """A ``save(path)`` for :func:`write_output` that writes ``text`` (UTF-8)."""
    return lambda path: path.write_text(text, encoding="utf-8")


def emit_json(payload: Any) -> None:
    """Write a JSON summary to stdout (numpy scalars and arrays converted)."""
    typer.echo(json.dumps(payload, indent=2, default=_jsonable, allow_nan=False))


@contextmanager
def user_errors(*kinds: type[Exception], prefix: str = "") -> Iterator[None]:
    """An exception of ``kinds`` raised in the block (bad input found by the library)
    becomes a :class:`UserError`: one line ``prefix`` + message, exit 2."""
    try:
        yield
    except kinds as exc:
        raise UserError(f"{prefix}{exc}") from None


def _jsonable(obj: Any) -> Any:
    import numpy as np

    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"not JSON serializable: {type(obj).__name__}")


def info(message: str, quiet: bool = False) -> None:
    """A status line on stderr (stdout is kept clean for --json)."""
    if not quiet:
        typer.echo(message, err=True)


def status_lines(prefix: str, quiet: bool = False) -> Callable[[float, float | None, str], None]:
    """A progress callback (:mod:`polywear.progress`) that writes each message as a status
    line on stderr (:func:`info`): for long stages rather than many small steps."""

    def show(done: float, total: float | None, message: str = "") -> None:
        if message:
            info(f"{prefix}{message} ...", quiet)

    return show


@contextmanager
def progress(description: str, enabled: bool = True) -> Iterator[Any]:
    """A rich progress bar on stderr (a terminal only: logs stay clean).

    Yields a progress callback ``update(done, total, message)`` (the library's convention,
    :mod:`polywear.progress`) to pass as ``progress=`` to an entry point: the bar shows
    ``done/total`` (``done`` alone while the total is unknown) and the latest message.
    """
    from rich.console import Console

    from ..progress import report

    console = Console(stderr=True)
    if not (enabled and console.is_terminal):
        yield report(None)
        return
    from rich.progress import BarColumn, Progress, ProgressColumn, TextColumn, TimeElapsedColumn, TimeRemainingColumn
    from rich.text import Text

    class Count(ProgressColumn):
        def render(self, task) -> Text:
            total = "" if task.total is None else f"/{task.total:.0f}"
            return Text(f"{task.completed:.0f}{total}")

    columns = [TextColumn("[progress.description]{task.description}"), BarColumn(), Count(), TimeElapsedColumn(),
               TimeRemainingColumn()]
    with Progress(*columns, console=console, transient=True) as bar:
        task = bar.add_task(description, total=None)

        def update(done: float, total: float | None, message: str = "") -> None:
            if message:
                bar.update(task, completed=done, total=total, description=f"{description}: {message}")
            else:  # keep the last message
                bar.update(task, completed=done, total=total)

        yield update


def save_figure(make_figure) -> Callable[[Path], Any]:
    """A ``save(path)`` that builds a figure with ``make_figure()`` on the Agg backend,
    writes it to ``path`` and closes it."""

    def save(path: Path) -> None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig = make_figure()
        try:
            fig.savefig(path, dpi=150, bbox_inches="tight")
        finally:
            plt.close(fig)

    return save


def write_figure(path: Path, make_figure, quiet: bool = False) -> None:
    """Build a figure with ``make_figure()`` on the Agg backend, write it to ``path``, close it."""
    write_output(path, save_figure(make_figure), quiet)


def one_axes(draw, figsize=(8.0, 4.5)):
    """A figure with one axes drawn by ``draw(ax)`` (e.g. a result's ``.plot``)."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=figsize)
    draw(ax)
    return fig
