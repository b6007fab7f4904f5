"""Measured run-ups and coast-downs as a Campbell map, with automatic SEV detection.

A run (time, vehicle or wheel speed, one or more acceleration channels) becomes a
spectrogram per channel (Hann windows, ``scipy.signal.spectrogram``), each time slice
placed at its mean speed: the Campbell map. On it:

* **Features.** Spectral peaks that stand ``peak_db`` above the slice's spectral floor (medians
  over blocks of ``FLOOR_BINS`` frequency bins, interpolated) are linked from slice to slice into
  ridges. A ridge is classified by the
  slope of ``ln f`` against ``ln V``: about 1, an *order-tracking* feature (a worn polygon,
  an imbalance: ``f = n V / (2 pi R)``, with its order ``n``); about 0, a
  *constant-frequency* feature (SEV, or a structural mode excited by the road).
* **SEV** is a constant-frequency feature that switches on within the run and stands
  ``sev_db`` above the floor. Its onset and offset speeds come from the envelope of the
  band-passed signal (``|hilbert|``, smoothed over 10 periods, wheel orders removed): the
  last upward crossing of the floor + ``ONSET_DB`` before the SEV is developed, and the
  first downward crossing after it; uncertainty: half the speed between the crossings
  6 dB lower and higher. Its
  frequency at onset from the phase of the analytic signal over the first second
  (uncertainty from the scatter of the phase fit), its amplitude as sqrt(2) x RMS of the
  band over the developed part (uncertainty: scatter over 1 s blocks).
* **Ramp delay.** A run-up passes a slowly moving Hopf point late: the amplitude needs
  time to grow from the disturbance level to the detection threshold. :func:`ramp_delay`
  simulates the model along the measured ramp through its nearest Hopf point, the tread
  kicked by random displacements of ``disturbance_m`` every 20 ms, and runs the same
  detector on the simulated tread acceleration: delay = ``V_onset,sim - V_Hopf``, the mean
  over ``RAMP_SEEDS`` seeds. The measured onset is corrected by it; its uncertainty adds
  the scatter over the seeds and half the spread of the delays for kicks 10x smaller and
  10x larger (the disturbance of a real road is not known).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..params import ParameterError, Params
from ..results import Result
from ..settings import check_fraction, check_positive
from ..units import KMH_PER_MS, kmh_to_ms, ms_to_kmh, polygon_order, wheel_rotation_frequency_hz

__all__ = [
    "MeasurementError",
    "Run",
    "CampbellResult",
    "CampbellSettings",
    "read_run",
    "campbell",
    "ramp_delay",
    "order_frequency_hz",
]


class MeasurementError(InputError, ParameterError):
    """A measurement file cannot be read or used (one line)."""


_TIME_UNITS = {"s": 1.0, "sec": 1.0, "second": 1.0, "seconds": 1.0, "ms": 1e-3}
_SPEED_UNITS = {"km/h": 1.0, "kmh": 1.0, "kph": 1.0, "m/s": KMH_PER_MS, "mph": 1.609344}
_WHEEL_UNITS = {"rad/s": 1.0, "rpm": 2.0 * math.pi / 60.0, "1/min": 2.0 * math.pi / 60.0}
_HEADER = re.compile(r"^\s*(.*?)\s*[\[(]\s*([^\])]*?)\s*[\])]\s*$")


@dataclass(frozen=True)
class CampbellSettings:
    """Numerical settings of :func:`campbell` (spectrogram, feature detection, ramp simulation)."""

    window_s: float = 0.5
    """Spectrogram window [s] (frequency resolution 1/window_s)."""
    overlap: float = 0.75
    """Overlap of consecutive windows [-], in [0, 1)."""
    f_range_hz: tuple[float, float] | None = None
    """Frequencies searched for features [Hz]; default 10 Hz to 0.4 fs."""
    peak_db: float = 15.0
    """Peak prominence over the bin's median level [dB]."""
    sev_db: float = 20.0
    """Level SEV must reach over the bin's median level [dB]."""
    disturbance_m: float = 1e-6
    """Tread disturbance of the ramp simulation [m] (see :func:`ramp_delay`)."""

    def __post_init__(self) -> None:
        check_positive(self, "window_s", "peak_db", "sev_db", "disturbance_m")
        check_fraction(self, "overlap", closed_low=True)
        if self.overlap >= 1.0:
            raise ValueError(f"CampbellSettings: overlap = {self.overlap!r}: must lie in [0, 1)")
        if self.f_range_hz is not None:
            lo, hi = self.f_range_hz
            if not (math.isfinite(lo) and math.isfinite(hi) and 0.0 <= lo < hi):
                raise ValueError(f"CampbellSettings: f_range_hz = {self.f_range_hz!r}: need 0 <= low < high [Hz]")


def order_frequency_hz(order: float, speed_kmh, radius_m: float):
    """Frequency of wheel order n at vehicle speed V: ``n V / (2 pi R)`` [Hz]."""
    return wheel_rotation_frequency_hz(kmh_to_ms(order * np.asarray(speed_kmh)), radius_m)


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


# -- features -----------------------------------------------------------------------------
@dataclass
class _Ridge:
    segments: list[int]
    freqs: list[float]
    levels: list[float]


_GAP = 4
"""Slices a ridge may miss and still continue."""
FLOOR_BINS = 51
"""Width of the frequency blocks whose medians give each slice's spectral floor (narrow
peaks do not move it; a coloured background does)."""


def _spectral_floor(level_db: np.ndarray) -> np.ndarray:
    """Each slice's floor [dB]: medians over blocks of ``FLOOR_BINS`` frequency bins,
    linearly interpolated between the block centres (a running median at a fraction of
    its cost; narrow peaks do not move it)."""
    n_f = level_db.shape[0]
    n_blocks = max(1, n_f // FLOOR_BINS)
    edges = np.linspace(0, n_f, n_blocks + 1).astype(int)
    medians = np.array([np.median(level_db[a:b], axis=0) for a, b in zip(edges[:-1], edges[1:])])
    if n_blocks == 1:
        return np.broadcast_to(medians[0], level_db.shape)
    centres = 0.5 * (edges[:-1] + edges[1:] - 1)
    rows = np.arange(n_f)
    j = np.clip(np.searchsorted(centres, rows) - 1, 0, n_blocks - 2)
    w = np.clip((rows - centres[j]) / (centres[j + 1] - centres[j]), 0.0, 1.0)[:, None]
    return (1.0 - w) * medians[j] + w * medians[j + 1]


def _slope(x: np.ndarray, y: np.ndarray) -> float:
    """Least-squares slope of y against x (0 if x does not vary)."""
    dx = x - x.mean()
    sxx = float(dx @ dx)
    return float(dx @ (y - y.mean())) / sxx if sxx > 1e-18 else 0.0


def _predicted(ridge: _Ridge, speed: float, speeds) -> tuple[float, ...]:
    """Where the ridge's next peak is expected at ``speed``: along its own trend of
    ln f against ln V once it has 4 points, else as a constant or as an order."""
    f_last, v_last = ridge.freqs[-1], speeds[ridge.segments[-1]]
    if len(ridge.segments) >= 4:
        slope = _slope(np.log(speeds[ridge.segments[-6:]]), np.log(ridge.freqs[-6:]))
        return (f_last * (speed / v_last) ** slope,)
    return (f_last, f_last * speed / v_last)


def _track(freqs, level_db, peak_db, f_lo, f_hi, speeds) -> list[_Ridge]:
    """Peaks per slice (level above the slice's floor) linked into ridges that follow
    their own trend (so an order line crossing a constant-frequency feature does not
    join it)."""
    from scipy.signal import find_peaks

    df = freqs[1] - freqs[0]
    band = (freqs >= f_lo) & (freqs <= f_hi)
    active: list[_Ridge] = []
    done: list[_Ridge] = []
    for k in range(level_db.shape[1]):
        if speeds[k] <= 0.0:  # standing still: no wheel order, no speed trend to follow
            continue
        column = np.where(band, level_db[:, k], -np.inf)
        peaks, props = find_peaks(column, height=peak_db, distance=3)
        # a peak of the spectrum, not of its cut: the band's edge bins (the flank of a line
        # just outside the band) count only where they top their neighbours outside it
        full = level_db[:, k]
        real = (full[np.maximum(peaks - 1, 0)] < full[peaks]) & (full[np.minimum(peaks + 1, len(full) - 1)] < full[peaks])
        peaks, props = peaks[real], {"peak_heights": props["peak_heights"][real]}
        fpk = []  # parabolic interpolation of the peak frequency
        for i in peaks:
            a, b, c = level_db[i - 1, k], level_db[i, k], level_db[min(i + 1, len(freqs) - 1), k]
            denom = a - 2 * b + c
            fpk.append(freqs[i] + (0.5 * (a - c) / denom * df if denom < 0 else 0.0))
        used = set()
        expected = {id(r): _predicted(r, speeds[k], speeds) for r in active} if len(fpk) else {}
        for f, h in sorted(zip(fpk, props["peak_heights"]), key=lambda fh: -fh[1]):
            best, miss = None, math.inf
            for r in active:
                if id(r) in used or id(r) not in expected or k - r.segments[-1] > _GAP:
                    continue
                off = min(abs(g - f) for g in expected[id(r)])
                if off <= max(2.0 * df, 0.015 * f) and off < miss:
                    best, miss = r, off
            if best is None:
                best = _Ridge([], [], [])
                active.append(best)
            best.segments.append(k)
            best.freqs.append(float(f))
            best.levels.append(float(h))
            used.add(id(best))
        still = []
        for r in active:
            (still if k - r.segments[-1] <= _GAP else done).append(r)
        active = still
    return done + active


def _split(ridge: _Ridge, speeds, min_segments: int) -> list[_Ridge]:
    """A ridge cut where its trend of ln f against ln V changes (an order line that ran
    into a constant-frequency feature where their peaks merged), recursively."""
    n = len(ridge.segments)
    if n < 2 * min_segments:
        return [ridge]
    x, y = np.log(speeds[ridge.segments]), np.log(ridge.freqs)
    # residual sum of squares and slope of the line fit to points [a, b), from prefix sums
    c = [np.concatenate([[0.0], np.cumsum(v)]) for v in (np.ones(n), x, y, x * x, x * y, y * y)]

    def fit(a, b):
        m, sx, sy, sxx, sxy, syy = (v[b] - v[a] for v in c)
        vxx, vxy, vyy = sxx - sx * sx / m, sxy - sx * sy / m, syy - sy * sy / m
        if vxx <= 1e-18:
            return 0.0, max(vyy, 0.0)
        return vxy / vxx, max(vyy - vxy * vxy / vxx, 0.0)

    whole = fit(0, n)[1]
    best = None
    for i in range(min_segments, n - min_segments + 1):
        (s1, r1), (s2, r2) = fit(0, i), fit(i, n)
        if abs(s1 - s2) > 0.5 and r1 + r2 < 0.25 * whole and (best is None or r1 + r2 < best[1]):
            best = (i, r1 + r2)
    if best is None:
        return [ridge]
    i = best[0]
    parts = (_Ridge(ridge.segments[:i], ridge.freqs[:i], ridge.levels[:i]),
             _Ridge(ridge.segments[i:], ridge.freqs[i:], ridge.levels[i:]))
    return [piece for part in parts for piece in _split(part, speeds, min_segments)]


def _fundamental(strongest, candidates):
    """The lowest candidate of which ``strongest`` is a harmonic (a strongly nonlinear cycle
    can put more power into 2f or 3f than into f), overlapping it in time; else itself."""
    f0 = np.median(strongest[1].freqs)
    span = set(strongest[1].segments)
    below = [(f, r) for f, r in candidates if np.median(r.freqs) < 0.75 * f0 and span & set(r.segments)
             and abs(f0 / np.median(r.freqs) - round(f0 / np.median(r.freqs))) < 0.03 * f0 / np.median(r.freqs)]
    return min(below, key=lambda fr: np.median(fr[1].freqs)) if below else strongest


def _no_evidence(ridge: _Ridge, speeds, envelope: dict | None, sev_db: float, df: float) -> str | None:
    """Why a constant-frequency feature that starts or ends within the run is not SEV,
    None if it is: a self-excited line switches on (off) with speed, so the band's
    envelope must stand ``sev_db`` below the feature's plateau before (after) it, on each
    side that the run covers, and the feature must span enough speed that a wheel order
    would have moved by two frequency bins ``df`` [Hz]."""
    v = speeds[ridge.segments]
    if np.median(ridge.freqs) * (v.max() / v.min() - 1.0) < 2.0 * df:
        return (f"spans too little speed ({v.min():.0f}-{v.max():.0f} km/h) to be told from a wheel order, "
                "which would move by less than two frequency bins")
    if envelope is None:
        return "the run holds no stretch beside it to compare its level with"
    sides = {side: db for side, db in envelope["switch_db"].items() if db is not None}
    if not sides:
        return "developed over the whole run (hidden in part): it does not switch on or off"
    weak = [f"{db:.1f} dB above the band's level {side} it" for side, db in sides.items() if db < sev_db]
    if weak:
        return (f"does not switch on or off: its plateau stands only {' and '.join(weak)} (SEV: {sev_db:g} dB), "
                "a mode or line present all along")
    return None


def _classify(ridge: _Ridge, speeds, radius_m, min_segments) -> dict | None:
    if len(ridge.segments) < min_segments:
        return None
    v = speeds[ridge.segments]
    f = np.array(ridge.freqs)
    feature = {
        "speed_from_kmh": float(v.min()), "speed_to_kmh": float(v.max()),
        "frequency_from_hz": float(f.min()), "frequency_to_hz": float(f.max()),
        "level_db": float(np.max(ridge.levels)), "slices": len(ridge.segments),
    }
    if v.max() / v.min() < 1.05:
        feature.update(kind="unclassified", slope=None, reason="speed changes too little along it")
        return feature
    slope = float(np.polyfit(np.log(v), np.log(f), 1)[0])
    feature["slope"] = slope
    if abs(slope - 1.0) < 0.25:
        feature.update(kind="order", order=float(np.median(polygon_order(f, kmh_to_ms(v), radius_m))))
    elif abs(slope) < 0.5:  # an SEV cycle's frequency drifts with speed (slopes up to about 0.3 seen)
        feature["kind"] = "constant_frequency"
    else:
        feature["kind"] = "unclassified"
    return feature


# -- envelope onset ------------------------------------------------------------------------
def _envelope(x, fs, f0, bandwidth):
    from scipy.signal import butter, hilbert, sosfiltfilt

    lo, hi = max(f0 - bandwidth, 1.0), min(f0 + bandwidth, 0.45 * fs)
    sos = butter(4, [lo, hi], btype="bandpass", fs=fs, output="sos")
    y = sosfiltfilt(sos, x - np.mean(x))
    analytic = hilbert(y)
    n = max(1, int(round(10.0 * fs / f0)))
    env = np.convolve(np.abs(analytic), np.ones(n) / n, mode="same")
    return y, analytic, env


def _remove_orders(x, speed_kmh, fs, orders, radius_m, bandwidth_hz=1.0):
    """``x`` without the order-tracking components ``orders`` (wheel orders, float).

    Each order is demodulated along its own phase ``2 pi n int V/(2 pi R) dt``, low-passed
    to ``bandwidth_hz`` and subtracted (order tracking in the manner of a Vold-Kalman
    filter, with a Butterworth low-pass): what follows the wheel is removed, what keeps its
    frequency while the speed changes stays.
    """
    from scipy.signal import butter, sosfiltfilt

    sos = butter(2, bandwidth_hz, fs=fs, output="sos")
    out = np.asarray(x, dtype=float) - np.mean(x)
    base = 2.0 * math.pi * np.cumsum(order_frequency_hz(1.0, speed_kmh, radius_m)) / fs
    for n in orders:
        rotor = np.exp(-1j * n * base)
        slow = sosfiltfilt(sos, out * rotor)
        out = out - 2.0 * np.real(slow * np.conj(rotor))
    return out


def _crossing(env, start, stop, level, backward):
    """Index where ``env`` crosses ``level`` going outwards from the developed part."""
    idx = range(start, -1, -1) if backward else range(stop, len(env))
    for i in idx:
        if env[i] < level:
            return i
    return None


def _onset_offset(t, speed, env, on_index, off_index, floor, rise_db):
    """Onset/offset speeds where the envelope crosses ``floor`` + ``rise_db``; uncertainty:
    half the speed between the crossings 6 dB lower and higher."""
    out = {}
    for name, backward in (("onset", True), ("offset", False)):
        hits = [_crossing(env, on_index, off_index, floor * 10 ** (db / 20), backward)
                for db in (rise_db - 6.0, rise_db, rise_db + 6.0)]
        if hits[1] is None:
            out[name] = None
            continue
        spread = [speed[i] for i in hits if i is not None]
        out[name] = {"speed_kmh": float(speed[hits[1]]), "time_s": float(t[hits[1]]),
                     "uncertainty_kmh": float(0.5 * (max(spread) - min(spread))), "threshold_db": rise_db}
    return out


RAMP_SEEDS = 3
HOPF_MISMATCH_KMH = 5.0
"""A model whose Hopf point lies further than this [km/h] from the ramp-corrected onset
describes another tyre: the correction is flagged and gives no calibration observation."""
"""Simulated ramps (seeds of the kicks) averaged for the delay."""
ONSET_DB = 30.0
"""The onset is where the band envelope last rises through the floor + 30 dB (or 3/4 of
the way from floor to plateau in dB, if that is less) before the SEV is developed (half
its 90th percentile): high enough that the growth of the kicked response as the Hopf
point approaches (its damping goes to zero) does not count as onset."""
FLOOR_WINDOW_KMH = (15.0, 5.0)
"""The floor of the SEV band is the lower quartile of the envelope from 15 to 5 km/h before the SEV is
developed (the same window in a measurement and in the ramp simulation)."""


SWITCH_MAX_DB = 120.0
"""Cap of :func:`_switch_db` (a band of exact zeros beside the feature)."""


BRIDGE_KMH = 5.0
"""Dips of the envelope below half its plateau over less speed than this [km/h] are
bridged: where an order line crosses the band, its removal takes a notch out of the SEV."""


def _developed(env, speed, plateau, inside) -> tuple[int, int] | None:
    """First and last index of the developed feature: from where the envelope first reaches
    half the ``plateau`` within ``inside`` to where it last does, extended outwards over
    every dip shorter than ``BRIDGE_KMH`` (a line cut by a crossing order is one line)."""
    high = np.flatnonzero(env >= 0.5 * plateau)  # NaN (the ends) is not
    within = high[inside[high]]
    if within.size == 0:
        return None
    cut = (np.diff(high) > 1) & (np.abs(np.diff(speed[high])) > BRIDGE_KMH)
    piece = np.concatenate([[0], np.cumsum(cut)])
    first_piece, last_piece = piece[np.searchsorted(high, within[0])], piece[np.searchsorted(high, within[-1])]
    return int(high[np.searchsorted(piece, first_piece)]), int(high[np.searchsorted(piece, last_piece, side="right") - 1])


def _switch_db(env, speed, plateau, on_index, off_index, fs, f0) -> dict:
    """How far [dB] the plateau stands above the band's envelope where the feature is not
    developed (from ``on_index`` to ``off_index``): within 15 km/h before it and after it,
    ``{"before": dB, "after": dB}`` (lower quartiles); a side with fewer than 20 periods of
    ``f0`` left in the run is None (the run does not cover it)."""
    need = max(16, int(20 * fs / f0))
    out = {}
    for side, idx, ref in (("before", np.arange(on_index), speed[on_index]),
                           ("after", np.arange(off_index + 1, len(env)), speed[off_index])):
        idx = idx[(np.abs(speed[idx] - ref) <= FLOOR_WINDOW_KMH[0]) & np.isfinite(env[idx])]
        if idx.size < need:
            out[side] = None
            continue
        level = float(np.percentile(env[idx], 25))
        out[side] = SWITCH_MAX_DB if level <= plateau * 10 ** (-SWITCH_MAX_DB / 20) else 20.0 * math.log10(plateau / level)
    return out


def _sev_from_envelope(t, speed, x, fs, f0, t_start, t_end):
    """Onset, offset, frequency and amplitude of a constant-frequency feature near ``f0``
    present from ``t_start`` to ``t_end``."""
    bandwidth = max(0.05 * f0, 5.0)
    y, analytic, env = _envelope(x, fs, f0, bandwidth)
    edge = int(round(fs / f0 * 20))  # filter and smoothing transients at the ends: no crossing there
    env = env.copy()
    env[:edge] = np.nan
    env[-edge:] = np.nan
    inside = (t >= t_start) & (t <= t_end)
    if not np.any(inside) or np.all(inside):
        return None
    plateau = float(np.nanpercentile(env[inside], 90))
    developed = _developed(env, speed, plateau, inside)
    if developed is None:
        return None
    on_index, off_index = developed
    before = np.arange(on_index)
    v_dev = speed[on_index]
    direction = math.copysign(1.0, v_dev - speed[0]) if on_index > 0 else 1.0
    distance = direction * (v_dev - speed[before])
    window = before[(distance <= FLOOR_WINDOW_KMH[0]) & (distance >= FLOOR_WINDOW_KMH[1])]
    window = window[np.isfinite(env[window])]
    if window.size < 16:
        window = np.flatnonzero(~inside & (t < t_start) & np.isfinite(env))
    switch = _switch_db(env, speed, plateau, on_index, off_index, fs, f0)
    if window.size >= 16:
        floor = float(np.percentile(env[window], 25))  # robust to an order line crossing the band
    elif switch["after"] is not None:  # developed from the run's start: the floor after it, for the offset
        floor = plateau * 10.0 ** (-switch["after"] / 20.0)
    else:
        return None
    rise_db = min(ONSET_DB, 0.75 * 20.0 * math.log10(plateau / floor)) if plateau > floor else 0.0
    result = _onset_offset(t, speed, env, on_index, off_index, floor, rise_db)
    result["floor"] = floor
    result["switch_db"] = switch
    # frequency at onset: slope of the unwrapped phase over one second after the onset
    start = np.searchsorted(t, result["onset"]["time_s"]) if result.get("onset") else on_index
    window = slice(start, min(start + int(fs), off_index + 1))
    phase = np.unwrap(np.angle(analytic[window]))
    tt = t[window]
    if tt.size > 64:
        slope = np.polyfit(tt, phase, 1)[0]
        quarters = [np.polyfit(a, b, 1)[0] for a, b in zip(np.array_split(tt, 4), np.array_split(phase, 4))]
        result["frequency_hz"] = float(slope / (2 * math.pi))
        # scatter of the four quarter-second estimates: noise and the drift with speed
        result["frequency_uncertainty_hz"] = float(np.std(quarters, ddof=1) / 2.0 / (2 * math.pi))
    developed_part = slice(on_index, off_index + 1)
    blocks = [y[i:i + int(fs)] for i in range(on_index, off_index + 1 - int(fs), int(fs))]
    rms = [math.sqrt(float(np.mean(b**2))) for b in blocks] or [math.sqrt(float(np.mean(y[developed_part] ** 2)))]
    result["amplitude"] = float(math.sqrt(2.0) * np.mean(rms))
    result["amplitude_uncertainty"] = float(math.sqrt(2.0) * np.std(rms)) if len(rms) > 1 else None
    return result


def ramp_delay(
    params: Params,
    hopf_speed_kmh: float,
    frequency_hz: float,
    rate_kmh_per_s: float,
    disturbance_m: float,
    band_hz: float | None = None,
    span_kmh: float = 20.0,
    seed: int = 0,
) -> tuple[float, float] | None:
    """Delay with which the onset detector sees SEV after a ramp passes a Hopf point.

    The model is simulated from 25 km/h before the Hopf speed to ``span_kmh`` after it
    (signed ``rate_kmh_per_s``: negative for a coast-down), its tread kicked by Gaussian
    displacements of ``disturbance_m`` every 20 ms (``seed``), and the tread acceleration
    goes through the same detector as a measurement, in the band around ``band_hz`` (the
    measured feature's frequency; default the Hopf frequency).

    Returns
    -------
    (delay_kmh, frequency_shift_hz) or None
        Detected onset minus the Hopf speed (in the ramp's direction), and the frequency
        the detector reports at that onset minus the Hopf frequency. None: no onset
        within the span.
    """
    from .runup import simulate_ramp

    direction = 1.0 if rate_kmh_per_s > 0 else -1.0
    start = hopf_speed_kmh - direction * (FLOOR_WINDOW_KMH[0] + 10.0)  # floor window and settling of the kicks
    end = hopf_speed_kmh + direction * span_kmh
    fs = max(8.0 * frequency_hz, 500.0)
    run = simulate_ramp(params, start, end, abs(rate_kmh_per_s), fs, perturbation_m=0.0, kick_m=disturbance_m,
                        seed=seed)
    t_hopf = abs(hopf_speed_kmh - start) / abs(rate_kmh_per_s)
    sev = _sev_from_envelope(run.t, run.speed_kmh, run.acceleration, fs, band_hz or frequency_hz, t_hopf,
                             run.t[-1] + 1.0)
    if sev is None or sev.get("onset") is None:
        return None
    return direction * (sev["onset"]["speed_kmh"] - hopf_speed_kmh), sev.get("frequency_hz", math.nan) - frequency_hz


# -- the analysis ----------------------------------------------------------------------------
@dataclass
class CampbellResult(Result):
    """Campbell map of a run, detected features, SEV and the model's prediction over it."""

    run: Run
    frequencies_hz: np.ndarray
    times_s: np.ndarray
    speeds_kmh: np.ndarray
    power_db: np.ndarray  # (channel, frequency, slice), channel-summed in [0] if several
    channel_names: list[str]
    features: list[dict]
    sev: dict | None
    prediction: dict
    radius_m: float
    settings: dict
    no_sev: str | None = None
    """Why no SEV was found (None when it was)."""

    def summary(self) -> dict:
        return {
            "source": self.run.source,
            "sample_rate_hz": self.run.sample_rate_hz,
            "speed_range_kmh": [float(self.run.speed_kmh.min()), float(self.run.speed_kmh.max())],
            "channels": {n: u for n, (_, u) in self.run.channels.items()},
            "features": self.features,
            "sev": self.sev,
            **({"no_sev": self.no_sev} if self.sev is None else {}),
            "prediction": self.prediction,
            "notes": self.run.notes,
        }

    def observations(self) -> list[dict]:
        """The SEV onset and frequency as calibration observations (``[[observation]]``
        entries of ``polywear calibrate``): only a ramp-corrected onset is a Hopf speed, and
        only one whose model's Hopf point lies within ``HOPF_MISMATCH_KMH`` of it."""
        onset = (self.sev or {}).get("onset") or {}
        index = onset.get("hopf_index")
        if onset.get("corrected_speed_kmh") is None or index not in (0, 1) or onset.get("warning"):
            return []
        prefix = ("first_hopf", "hopf") if index == 0 else ("second_hopf", "second_hopf")
        source = f"measure campbell {Path(self.run.source).name}"
        out = [{"quantity": f"{prefix[0]}_kmh", "value": onset["corrected_speed_kmh"],
                "sigma": onset["corrected_uncertainty_kmh"], "label": f"{source}: ramp-corrected SEV onset"}]
        if self.sev.get("corrected_frequency_hz") is not None:
            out.append({"quantity": f"{prefix[1]}_frequency_hz", "value": self.sev["corrected_frequency_hz"],
                        "sigma": max(self.sev["corrected_frequency_uncertainty_hz"], 1e-6),
                        "label": f"{source}: SEV frequency at onset, ramp-corrected"})
        return out

    def _dataset(self):
        """xarray Dataset: power [dB] over (channel, frequency_hz, time_s), speed per time."""
        import xarray as xr

        ds = xr.Dataset(
            {"power_db": (("channel", "frequency_hz", "time_s"), self.power_db)},
            coords={"channel": self.channel_names, "frequency_hz": self.frequencies_hz, "time_s": self.times_s,
                    "speed_kmh": ("time_s", self.speeds_kmh)},
            attrs={"source": self.run.source, "rolling_radius_m": self.radius_m,
                   **{k: str(v) for k, v in self.settings.items()}},
        )
        ds["power_db"].attrs["units"] = "dB (re 1 channel unit^2)"
        return ds

    def save(self, path) -> Path:
        """As :meth:`Result.save`; a netCDF (.nc) map gets the summary as JSON next to it (.json)."""
        import json

        from ..io import write_text

        path = super().save(path)
        if path.suffix.lower() == ".nc":
            write_text(path.with_suffix(".json"), json.dumps(self.summary(), indent=2, allow_nan=False))
        return path

    def plot(self, ax=None, channel: int = 0, orders: tuple[int, ...] = tuple(range(1, 31))):
        """Frequency against speed in dB, order rays, Hopf points, SEV band, detected SEV."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(8, 5))
        level = self.power_db[channel]
        order = np.argsort(self.speeds_kmh)
        mesh = ax.pcolormesh(self.speeds_kmh[order], self.frequencies_hz, level[:, order], shading="nearest",
                             cmap="magma", vmin=np.percentile(level, 5), vmax=np.max(level))
        plt.colorbar(mesh, ax=ax, label="power [dB]")
        v = np.linspace(self.speeds_kmh.min(), self.speeds_kmh.max(), 50)
        fmax = self.frequencies_hz[-1]
        for n in orders:
            f = order_frequency_hz(n, v, self.radius_m)
            if f[0] < fmax:
                ax.plot(v, f, color="w", lw=0.4, alpha=0.35)
        for lo, hi in self.prediction.get("sev_band_kmh", []):
            ax.axvspan(lo, hi, ymin=0.97, ymax=1.0, color="tab:cyan", label="predicted SEV band")
            for edge in (lo, hi):
                ax.axvline(edge, color="tab:cyan", lw=0.8, ls=":")
        for h in self.prediction.get("hopf_points", []):
            ax.plot(h["speed_kmh"], h["frequency_hz"], "c^", ms=7, label="predicted Hopf point")
        wear = self.prediction.get("wear_most_unstable_orders", [])
        if wear:
            ax.plot([w["speed_kmh"] for w in wear], [w["frequency_hz"] for w in wear], "o", mfc="none",
                    color="tab:olive", ms=4, label="wear map: fastest-growing order")
        if self.sev and self.sev.get("onset"):
            on = self.sev["onset"]
            ax.axvline(on["speed_kmh"], color="tab:green", ls="--", label="detected SEV onset")
            if on.get("corrected_speed_kmh") is not None:
                ax.axvline(on["corrected_speed_kmh"], color="tab:green", label="onset, ramp-corrected")
        handles, labels = ax.get_legend_handles_labels()
        unique = dict(zip(labels, handles))
        if unique:
            ax.legend(unique.values(), unique.keys(), fontsize=7, loc="upper left")
        ax.set_xlim(self.speeds_kmh.min(), self.speeds_kmh.max())
        ax.set_ylim(0, fmax)
        ax.set_xlabel("speed [km/h]")
        ax.set_ylabel("frequency [Hz]")
        return mesh


def _prediction(params: Params, speed_range, run_speeds_kmh) -> dict:
    """Hopf points and SEV band of the model; where steady rolling is stable, the wear
    map's fastest-growing polygon order at 25 speeds of the run (its frequency n V/(2 pi R))."""
    from ..dynamics.bifurcation import bifurcation
    from ..wear.map import wear_map

    diagram = bifurcation(params, speed_range)
    wear = wear_map(params, np.linspace(run_speeds_kmh.min(), run_speeds_kmh.max(), 25))
    return {
        "hopf_points": [h.summary() for h in diagram.hopf_points],
        "sev_band_kmh": [list(b) for b in diagram.sev_band_kmh],
        "linear_band_kmh": [list(b) for b in getattr(diagram, "linear_band_kmh", [])],
        "wear_most_unstable_orders": [
            {k: r[k] for k in ("speed_kmh", "order", "frequency_hz", "efold_km")}
            for r in wear.rows() if r["order"] is not None and r["efold_km"] is not None
        ],
    }


def campbell(
    run: Run,
    params: Params,
    settings: CampbellSettings = CampbellSettings(),
    predict: bool = True,
    correct_ramp: bool = True,
) -> CampbellResult:
    """Campbell map of ``run`` with features, SEV and (``predict``) the model's band over it.

    Parameters
    ----------
    run : Run
    params : Params
        The model's parameters: rolling radius for the order rays, the prediction and the
        ramp-delay simulation.
    settings : CampbellSettings
        Spectrogram window and overlap, frequencies searched, detection levels [dB] and
        the disturbance of the ramp simulation.
    predict : bool
        Hopf points and SEV band of the model (a continuation) and the wear map's
        fastest-growing orders over the map.
    correct_ramp : bool
        Simulate the ramp through the nearest destabilizing Hopf point and correct the onset.
    """
    from scipy.signal import spectrogram

    window_s, overlap, peak_db, sev_db = settings.window_s, settings.overlap, settings.peak_db, settings.sev_db

    fs = run.sample_rate_hz
    n = int(round(window_s * fs))
    if n < 16 or n > len(run.t) // 2:
        raise MeasurementError(f"window of {window_s} s is {n} samples: need 16 to half the run ({len(run.t)} samples)")
    f_lo, f_hi = settings.f_range_hz or (10.0, 0.4 * fs)
    power = []
    for x, _ in run.channels.values():
        freqs, times, sxx = spectrogram(x, fs, window="hann", nperseg=n, noverlap=int(overlap * n),
                                        detrend="constant", scaling="spectrum")
        power.append(sxx)
    total = np.sum(power, axis=0)
    tiny = np.finfo(float).tiny
    stack = [total] + power if len(power) > 1 else power
    power_db = 10.0 * np.log10(np.maximum(np.array(stack), tiny))
    speeds = np.interp(times, run.t, run.speed_kmh)
    level = power_db[0] - _spectral_floor(power_db[0])
    radius = params.operating.rolling_radius_m
    ridges = [piece for r in _track(freqs, level, peak_db, f_lo, f_hi, speeds) for piece in _split(r, speeds, 6)]
    classified = [(f, r) for r in ridges for f in [_classify(r, speeds, radius, 6)] if f is not None]
    for feature, _ in classified:
        feature["sev"] = False
    # SEV: constant frequency, strong, switching on or off within the run, with the evidence of it
    strong = [(f, r) for f, r in classified if f["kind"] == "constant_frequency" and f["level_db"] >= sev_db]
    candidates = [(f, r) for f, r in strong if r.segments[0] > 1 or r.segments[-1] < len(times) - 2]
    for f, r in strong:
        if (f, r) not in candidates:
            f["not_sev"] = "present over the whole run"
    orders = [f["order"] for f, _ in classified if f["kind"] == "order"]
    cleaned: dict[str, np.ndarray] = {}  # channel -> without the order features
    found = {}  # id(ridge) -> (channel, frequency, envelope analysis) of the candidates with evidence
    for feature, ridge in candidates:
        f0 = float(np.median(ridge.freqs))
        channel = max(run.channels, key=lambda name: float(np.sum(
            np.array(power[list(run.channels).index(name)])[np.abs(freqs - f0) < 2 * (freqs[1] - freqs[0])])))
        if channel not in cleaned:
            x = run.channels[channel][0]
            cleaned[channel] = _remove_orders(x, run.speed_kmh, fs, orders, radius) if orders else x
        t_start, t_end = times[ridge.segments[0]] - window_s / 2, times[ridge.segments[-1]] + window_s / 2
        envelope = _sev_from_envelope(run.t, run.speed_kmh, cleaned[channel], fs, f0, t_start, t_end)
        reason = _no_evidence(ridge, speeds, envelope, sev_db, freqs[1] - freqs[0])
        if reason:
            feature["not_sev"] = reason
        else:
            found[id(ridge)] = (channel, f0, envelope)
    evidenced = [(f, r) for f, r in candidates if id(r) in found]
    sev = None
    no_sev = None
    if evidenced:
        feature, ridge = _fundamental(max(evidenced, key=lambda fr: fr[0]["level_db"]), evidenced)
        feature["sev"] = True
        feature.pop("not_sev", None)
        for f, r in candidates:
            ratio = np.median(r.freqs) / np.median(ridge.freqs)
            if r is not ridge and round(ratio) >= 2 and abs(ratio - round(ratio)) < 0.03 * ratio:
                f["harmonic_of_sev"] = int(round(ratio))
        strongest, f0, sev = found[id(ridge)]
        if sev.get("onset") and "frequency_hz" in sev:
            # the frequency drifts with speed: an uncertain onset speed is an uncertain frequency
            drift = _slope(speeds[ridge.segments], np.array(ridge.freqs))
            sev["frequency_drift_hz_per_kmh"] = drift
            sev["frequency_uncertainty_hz"] = math.hypot(sev["frequency_uncertainty_hz"],
                                                         drift * sev["onset"]["uncertainty_kmh"])
        sev.update(channel=strongest, unit=run.channels[strongest][1], ridge_frequency_hz=f0,
                   orders_removed=orders,
                   frequency_range_hz=[feature["frequency_from_hz"], feature["frequency_to_hz"]])
    elif strong:
        no_sev = "no constant-frequency feature switches on or off within the run: " + "; ".join(
            f"{np.median(r.freqs):.1f} Hz ({f['speed_from_kmh']:.0f}-{f['speed_to_kmh']:.0f} km/h) {f['not_sev']}"
            for f, r in strong)
    else:
        no_sev = f"no constant-frequency feature stands {sev_db:g} dB above the floor"
    prediction = _prediction(params, (max(5.0, 0.5 * run.speed_kmh.min()), max(300.0, 1.2 * run.speed_kmh.max())),
                             run.speed_kmh) if predict else {}
    if sev is not None and sev.get("onset") and correct_ramp:
        _correct_onset(sev, run, params, settings.disturbance_m)
    features = sorted((f for f, _ in classified), key=lambda f: -f["level_db"])
    return CampbellResult(run, freqs, times, speeds, power_db,
                          (["sum"] if len(power) > 1 else []) + list(run.channels), features, sev, prediction,
                          radius, {"window_s": window_s, "overlap": overlap, "peak_db": peak_db, "sev_db": sev_db,
                                   "disturbance_m": settings.disturbance_m}, no_sev)


def _correct_onset(sev: dict, run: Run, params: Params, disturbance_m: float) -> None:
    """Ramp rate at the onset, the model's nearest destabilizing Hopf point, the delay."""
    from ..dynamics.stability import StabilitySettings, stability

    onset = sev["onset"]
    near = np.abs(run.t - onset["time_s"]) <= 2.0
    rate = float(np.polyfit(run.t[near], run.speed_kmh[near], 1)[0])
    onset["ramp_rate_kmh_per_s"] = rate
    if abs(rate) < 0.05:
        onset["correction"] = "not corrected: the speed is not ramping at the onset"
        return
    hopfs = stability(params, (5.0, max(300.0, 1.5 * run.speed_kmh.max())), StabilitySettings(n_speeds=300)).hopf_points
    entering = [h for h in hopfs if (h.dre_dspeed > 0) == (rate > 0)]
    if not entering:
        onset["correction"] = "not corrected: the model has no Hopf point entering instability in this direction"
        return
    hopf = min(entering, key=lambda h: abs(h.speed_kmh - onset["speed_kmh"]))
    runs = [(disturbance_m, seed) for seed in range(RAMP_SEEDS)] + [(disturbance_m / 10, 0), (disturbance_m * 10, 0)]
    delays = [ramp_delay(params, hopf.speed_kmh, hopf.frequency_hz, rate, d, band_hz=sev["ridge_frequency_hz"], seed=k)
              for d, k in runs]
    shifts = [d[1] for d in delays[:RAMP_SEEDS] if d is not None and math.isfinite(d[1])]
    delays = [None if d is None else d[0] for d in delays]
    same = [d for d in delays[:RAMP_SEEDS] if d is not None]
    if not same:
        onset["correction"] = "not corrected: the simulated ramp shows no onset within 20 km/h of the Hopf point"
        return
    delay = float(np.mean(same))
    scatter = float(np.std(same, ddof=1)) if len(same) > 1 else 0.0
    levels = [d for d in delays[RAMP_SEEDS:] if d is not None] + [delay]
    level_spread = 0.5 * (max(levels) - min(levels))
    if shifts and sev.get("frequency_hz") is not None:
        sev["frequency_shift_hz"] = float(np.mean(shifts))
        sev["corrected_frequency_hz"] = sev["frequency_hz"] - sev["frequency_shift_hz"]
        sev["corrected_frequency_uncertainty_hz"] = math.hypot(
            sev["frequency_uncertainty_hz"], float(np.std(shifts, ddof=1)) if len(shifts) > 1 else 0.0)
    onset.update(
        hopf_speed_kmh=hopf.speed_kmh,
        hopf_index=hopfs.index(hopf),
        ramp_delay_kmh=delay,
        ramp_delay_scatter_kmh=scatter,
        ramp_delay_by_disturbance_kmh={f"{d:.2g}": x for (d, _), x in zip(runs[RAMP_SEEDS:], delays[RAMP_SEEDS:])},
        corrected_speed_kmh=onset["speed_kmh"] - math.copysign(delay, rate),
        corrected_uncertainty_kmh=math.sqrt(onset["uncertainty_kmh"] ** 2 + scatter**2 + level_spread**2),
        correction=(f"ramp-corrected: the model, ramped at {rate:.3g} km/h/s through its Hopf point at "
                    f"{hopf.speed_kmh:.1f} km/h with tread kicks of {disturbance_m:g} m, shows SEV {delay:.1f} "
                    f"+- {scatter:.1f} km/h late ({RAMP_SEEDS} seeds; kicks x0.1 / x10 give "
                    + ", ".join("none" if x is None else f"{x:.1f}" for x in delays[RAMP_SEEDS:]) + " km/h)"),
    )
    off = abs(onset["corrected_speed_kmh"] - hopf.speed_kmh)
    if off > HOPF_MISMATCH_KMH:
        onset["warning"] = (f"the model's Hopf point ({hopf.speed_kmh:.1f} km/h) is {off:.1f} km/h from the "
                            f"ramp-corrected onset ({onset['corrected_speed_kmh']:.1f} km/h), more than "
                            f"{HOPF_MISMATCH_KMH:g} km/h: the model describes another tyre, and its delay may not "
                            "hold for this one; not a calibration observation (calibrate roughly first, e.g. "
                            "with the detected onset)")
