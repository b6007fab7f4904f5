"""Measured runs in: a run-up or coast-down from CSV or MDF4, with its columns found, units
converted and checked (time unit, speed sign and direction, sample rate, constant speed).

CSV: one header line with units in brackets or parentheses (``time [s]``, ``speed
[km/h]``, ``acc_y [m/s^2]``), delimiter found from the header. MDF4 (``.mf4``, extra
``measure``): channels by name. The result is a :class:`Run` on a uniform time grid.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..params import ParameterError
from ..units import KMH_PER_MS, ms_to_kmh


class MeasurementError(InputError, ParameterError):
    """A measurement file cannot be read or used (one line)."""


_TIME_UNITS = {"s": 1.0, "sec": 1.0, "second": 1.0, "seconds": 1.0, "ms": 1e-3}
_SPEED_UNITS = {"km/h": 1.0, "kmh": 1.0, "kph": 1.0, "m/s": KMH_PER_MS, "mph": 1.609344}
_WHEEL_UNITS = {"rad/s": 1.0, "rpm": 2.0 * math.pi / 60.0, "1/min": 2.0 * math.pi / 60.0}
_HEADER = re.compile(r"^\s*(.*?)\s*[\[(]\s*([^\])]*?)\s*[\])]\s*$")




@dataclass
class Run:
    """A measured run: ``t`` [s] (uniform), ``speed_kmh``, channels name -> (samples, unit)."""

    source: str
    t: np.ndarray
    speed_kmh: np.ndarray
    channels: dict[str, tuple[np.ndarray, str]]
    notes: list[str] = field(default_factory=list)

    @property
    def sample_rate_hz(self) -> float:
        return 1.0 / float(np.median(np.diff(self.t)))


def _split_header(name: str) -> tuple[str, str]:
    match = _HEADER.match(str(name))
    return (match.group(1), match.group(2).strip()) if match else (str(name).strip(), "")


def _columns_from_csv(path: Path):
    import pandas as pd

    try:
        with open(path, encoding="utf-8", errors="replace") as fh:
            header = next((line for line in fh if line.strip() and not line.startswith("#")), "")
        sep = max((",", ";", "\t"), key=header.count) if any(c in header for c in ",;\t") else r"\s+"
        frame = pd.read_csv(path, sep=sep, comment="#", engine="c" if len(sep) == 1 else "python")
    except (OSError, UnicodeDecodeError, pd.errors.ParserError, pd.errors.EmptyDataError) as exc:
        raise MeasurementError(f"{path}: not a readable CSV run ({type(exc).__name__}: {str(exc).splitlines()[0]})") \
            from None
    out = {}
    for column in frame.columns:
        values = pd.to_numeric(frame[column], errors="coerce").to_numpy(dtype=float)
        name, unit = _split_header(column)
        out[name] = (values, unit)
    return out


def _columns_from_mdf(path: Path):
    try:
        from asammdf import MDF
    except ImportError:
        raise MeasurementError(
            f"{path}: reading MDF files needs the optional extra: pip install 'polywear[measure]' (asammdf)"
        ) from None
    mdf = MDF(str(path))
    frame = mdf.to_dataframe(time_from_zero=True)
    out = {"time": (frame.index.to_numpy(dtype=float), "s")}
    for column in frame.columns:
        try:
            unit = mdf.get(column).unit or ""
        except Exception:  # noqa: BLE001 - asammdf raises several kinds for ambiguous names
            unit = ""
        out[str(column)] = (frame[column].to_numpy(dtype=float), unit)
    return out


def _pick(columns: dict, wanted: str | None, pattern: str, what: str, path: Path) -> str:
    if wanted is not None:
        if wanted not in columns:
            raise MeasurementError(f"{path}: no column {wanted!r} (columns: {', '.join(columns)})")
        return wanted
    found = [c for c in columns if re.search(pattern, c, re.I)]
    if not found:
        raise MeasurementError(f"{path}: no {what} column found (name it e.g. '{what} [unit]', or give --{what}-column)")
    return found[0]


SAMPLE_RATE_HZ = (50.0, 1e6)
"""Plausible sample rates of a vibration measurement [Hz]; outside them the time unit is off."""
MAX_RAMP_KMH_PER_S = 100.0
"""Fastest plausible mean speed change of a run [km/h/s] (about 3 g; a car brakes at 1 g)."""
STANDSTILL_JITTER_KMH = 1.0
"""Negative speeds down to this [km/h] in a run of positive ones are noise at standstill."""


def _check_time_unit(path, name, unit, rate_hz, duration_s, speed_kmh) -> None:
    """A sample rate or a speed change no vehicle measurement has: the time unit is off
    (by 1000, s for ms or the reverse): one line that says so."""
    other = "ms" if _TIME_UNITS[unit.lower()] == 1.0 else "s"
    hint = f"is the time in {other} rather than {unit}? (header: '{name} [{other}]')"
    if not SAMPLE_RATE_HZ[0] <= rate_hz <= SAMPLE_RATE_HZ[1]:
        raise MeasurementError(f"{path}: time column {name!r} [{unit}] gives a sample rate of {rate_hz:.4g} Hz, "
                               f"outside {SAMPLE_RATE_HZ[0]:g} Hz to {SAMPLE_RATE_HZ[1]:g} Hz: {hint}")
    ramp = float(np.ptp(speed_kmh)) / duration_s
    if ramp > MAX_RAMP_KMH_PER_S:
        raise MeasurementError(f"{path}: the speed changes by {np.ptp(speed_kmh):.4g} km/h in {duration_s:.4g} s "
                               f"({ramp:.4g} km/h/s, more than a vehicle can): {hint}")


def _check_speed(path, name, speed_kmh) -> list[str]:
    """Notes on the speed column: negative throughout (taken as its magnitude), a
    standstill's negative jitter, no change (not a run-up); an error where it changes sign."""
    notes = []
    low, high = float(speed_kmh.min()), float(speed_kmh.max())
    if high <= 0.0 and low < 0.0:
        notes.append(f"speed column {name!r} is negative throughout: taken as its magnitude (a logger's sign "
                     "convention for the direction of travel)")
        low, high = -high, -low
    elif low < -STANDSTILL_JITTER_KMH:
        raise MeasurementError(f"{path}: speed column {name!r} changes sign ({low:.4g} to {high:.4g} km/h): a run "
                               "goes one way; give the speed's magnitude")
    elif low < 0.0:
        notes.append(f"speed column {name!r}: negative values down to {low:.3g} km/h at standstill taken as their "
                     "magnitude")
        low = 0.0
    if high - low < max(2.0, 0.05 * high):
        notes.append(f"the speed stays within {low:.4g}-{high:.4g} km/h: not a run-up or coast-down (order and "
                     "constant-frequency features cannot be told apart, and SEV cannot be seen switching on)")
    return notes


def read_run(
    path: str | Path,
    time_column: str | None = None,
    speed_column: str | None = None,
    channels: list[str] | tuple[str, ...] = (),
    rolling_radius_m: float | None = None,
) -> Run:
    """Read a run from CSV (units in the header: ``time [s]``, ``speed [km/h]``, ...) or MDF4.

    Time in s or ms; vehicle speed in km/h, m/s or mph, or wheel speed in rad/s or rpm
    (converted with ``rolling_radius_m``). Channels: the named ones, else every other
    numeric column. Rows with a missing value are dropped; a non-uniform time base is
    interpolated onto a uniform one; a file whose time runs backwards throughout is
    reversed, and negative speeds (a logger's sign convention) are taken as their
    magnitude (each noted). Errors: time that runs backwards in part, a sample rate or
    speed change that no measurement has (a time unit off by 1000), a speed that
    changes sign.
    """
    path = Path(path)
    if not path.is_file():
        raise MeasurementError(f"{path}: no such file")
    columns = _columns_from_mdf(path) if path.suffix.lower() in (".mf4", ".mdf", ".dat") else _columns_from_csv(path)
    t_name = _pick(columns, time_column, r"^(t|time|zeit)\b", "time", path)
    v_name = _pick(columns, speed_column, r"speed|velocity|geschw|^v\b", "speed", path)
    t, t_unit = columns[t_name]
    v, v_unit = columns[v_name]
    if t_unit.lower() not in _TIME_UNITS:
        raise MeasurementError(f"{path}: time column {t_name!r} has unit {t_unit!r}: use s or ms in the header")
    unit = v_unit.lower()
    if unit in _SPEED_UNITS:
        speed = v * _SPEED_UNITS[unit]
    elif unit in _WHEEL_UNITS:
        if rolling_radius_m is None:
            raise MeasurementError(f"{path}: wheel speed in {v_unit} needs the rolling radius")
        speed = ms_to_kmh(v * _WHEEL_UNITS[unit] * rolling_radius_m)
    else:
        raise MeasurementError(f"{path}: speed column {v_name!r} has unit {v_unit!r}: "
                               f"use one of {', '.join([*_SPEED_UNITS, *_WHEEL_UNITS])}")
    names = list(channels) or [c for c in columns if c not in (t_name, v_name)]
    for name in names:
        if name not in columns:
            raise MeasurementError(f"{path}: no channel {name!r} (columns: {', '.join(columns)})")
    if not names:
        raise MeasurementError(f"{path}: no acceleration channel besides {t_name!r} and {v_name!r}")
    data = np.column_stack([t * _TIME_UNITS[t_unit.lower()], speed] + [columns[n][0] for n in names])
    good = np.all(np.isfinite(data), axis=1)
    notes = []
    if not np.all(good):
        notes.append(f"{int(np.sum(~good))} rows with missing or non-numeric values dropped")
    data = data[good]
    if len(data) < 64:
        raise MeasurementError(f"{path}: only {len(data)} usable rows")
    dt = np.diff(data[:, 0])
    if np.all(dt < 0):
        data = data[::-1]
        dt = -dt[::-1]
        notes.append(f"time column {t_name!r} runs backwards throughout: rows taken in reverse order")
    elif np.any(dt < 0):
        k = int(np.argmax(dt < 0))
        raise MeasurementError(f"{path}: time column {t_name!r} runs backwards from {data[k, 0]:g} s to "
                               f"{data[k + 1, 0]:g} s: sort or split the file (one run a file)")
    if not np.all(dt > 0):
        raise MeasurementError(f"{path}: time column {t_name!r} has repeated values")
    step = float(np.median(dt))
    _check_time_unit(path, t_name, t_unit, 1.0 / step, data[-1, 0] - data[0, 0], data[:, 1])
    notes += _check_speed(path, v_name, data[:, 1])
    data[:, 1] = np.abs(data[:, 1])
    if np.max(np.abs(dt - step)) > 0.01 * step:
        grid = np.arange(data[0, 0], data[-1, 0], step)
        data = np.column_stack([grid] + [np.interp(grid, data[:, 0], data[:, k]) for k in range(1, data.shape[1])])
        notes.append(f"non-uniform time base: interpolated onto {1 / step:.6g} Hz")
    return Run(str(path), data[:, 0] - data[0, 0], data[:, 1],
               {n: (data[:, 2 + i], columns[n][1]) for i, n in enumerate(names)}, notes)
