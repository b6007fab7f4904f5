"""Measured friction data: CSV files (steady points, loops), shipped samples, synthetic points.

The CSV formats are described in docs/friction.md.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..params import Friction
from ..physics.lugre import steady_friction
from .curve import _steady_args

__all__ = [
    "FrictionDataError",
    "VELOCITY_COLUMN",
    "FRICTION_COLUMN",
    "FREQUENCY_COLUMN",
    "TIME_COLUMN",
    "LOOP_COLUMNS",
    "read_steady_csv",
    "read_loops_csv",
    "synthetic_steady_data",
    "sample_path",
]


VELOCITY_COLUMN = "sliding_velocity_m_per_s"
FRICTION_COLUMN = "friction_coefficient"


class FrictionDataError(InputError):
    """Measured friction data cannot be used (one line naming the file, row and problem)."""


FREQUENCY_COLUMN = "frequency_hz"
TIME_COLUMN = "time_s"
LOOP_COLUMNS = (FREQUENCY_COLUMN, TIME_COLUMN, VELOCITY_COLUMN, FRICTION_COLUMN)
_SAMPLES = {"steady": "friction_sample.csv", "loops": "friction_loops_sample.csv"}


def _read_csv_columns(path: str | Path, columns: tuple[str, ...]) -> tuple[list[np.ndarray], list[int]]:
    """Numeric ``columns`` of a CSV file with a header row; also each row's line number."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise FrictionDataError(f"{path}: cannot read ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise FrictionDataError(f"{path}: not a text (CSV) file") from None
    rows = [(n, line) for n, line in enumerate(text.splitlines(), 1) if line.strip() and not line.lstrip().startswith("#")]
    if not rows:
        raise FrictionDataError(f"{path}: empty")
    header_line, header = rows[0][0], [c.strip() for c in next(csv.reader([rows[0][1]]))]
    missing = [c for c in columns if c not in header]
    if missing:
        raise FrictionDataError(
            f"{path} line {header_line}: missing column(s) {', '.join(missing)} "
            f"(header must name {', '.join(columns)}; found {', '.join(header)})"
        )
    index = [header.index(c) for c in columns]
    values: list[list[float]] = [[] for _ in columns]
    for n, line in rows[1:]:
        cells = next(csv.reader([line]))
        if len(cells) != len(header):
            raise FrictionDataError(f"{path} line {n}: {len(cells)} fields, header has {len(header)}")
        for name, i, out in zip(columns, index, values):
            try:
                value = float(cells[i])
            except ValueError:
                raise FrictionDataError(f"{path} line {n}: {name} = {cells[i].strip()!r} is not a number") from None
            if not math.isfinite(value):
                raise FrictionDataError(f"{path} line {n}: {name} = {cells[i].strip()!r} is not finite")
            out.append(value)
    return [np.array(col) for col in values], [n for n, _ in rows[1:]]


def read_steady_csv(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Measured steady points (velocity [m/s], mu [-]) from a CSV file.

    The first row is a header that names the columns ``sliding_velocity_m_per_s``
    [m/s] and ``friction_coefficient`` [-] (in any order; other columns are ignored;
    lines starting with ``#`` are comments). Raises :class:`FrictionDataError` naming
    the file, line and problem.
    """
    (v, mu), lines = _read_csv_columns(path, (VELOCITY_COLUMN, FRICTION_COLUMN))
    if np.any(v == 0.0):
        n = lines[int(np.argmax(v == 0.0))]
        raise FrictionDataError(f"{path} line {n}: {VELOCITY_COLUMN} = 0, where steady friction is not defined")
    return v, mu


def read_loops_csv(path: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Measured loops (frequency [Hz], time [s], velocity [m/s], mu [-]) from a CSV file.

    Like :func:`read_steady_csv`, with the columns ``frequency_hz``, ``time_s``,
    ``sliding_velocity_m_per_s`` and ``friction_coefficient``.
    """
    (f, t, v, mu), lines = _read_csv_columns(path, LOOP_COLUMNS)
    if np.any(f <= 0.0):
        n = lines[int(np.argmax(f <= 0.0))]
        raise FrictionDataError(f"{path} line {n}: {FREQUENCY_COLUMN} must be > 0")
    return f, t, v, mu


def synthetic_steady_data(friction: Friction, velocity, noise_sd: float, seed: int) -> np.ndarray:
    """Steady friction at ``velocity`` [m/s] plus Gaussian noise of s.d. ``noise_sd`` [-].

    Noise from ``numpy.random.default_rng(seed)``; used for the shipped sample and tests.
    """
    v = np.asarray(velocity, dtype=float)
    rng = np.random.default_rng(seed)
    return steady_friction(v, *_steady_args(friction)) + rng.normal(0.0, noise_sd, v.shape)


def sample_path(kind: str = "steady") -> Path:
    """Path of the shipped sample data, ``"steady"`` points or ``"loops"`` (docs/friction.md)."""
    from importlib.resources import files

    if kind not in _SAMPLES:
        raise ValueError(f"kind = {kind!r}: one of {', '.join(_SAMPLES)}")
    return Path(str(files("polywear").joinpath("data", _SAMPLES[kind])))
