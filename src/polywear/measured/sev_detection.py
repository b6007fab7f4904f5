"""SEV in a measured or simulated run: ridges of the Campbell map, their classification
(order-tracking or constant-frequency), the evidence that a line switches on and off, its
onset and offset from the band envelope, and the ramp delay of a Hopf point.

The methods are described in :mod:`polywear.measured.campbell`, which puts them together.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..params import Params
from ..results import with_deprecated_keys
from ..units import frequency_order, kmh_to_ms, order_frequency_hz


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


def spectral_floor(level_db: np.ndarray) -> np.ndarray:
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


def log_slope(x: np.ndarray, y: np.ndarray) -> float:
    """Least-squares slope of y against x (0 if x does not vary)."""
    dx = x - x.mean()
    sxx = float(dx @ dx)
    return float(dx @ (y - y.mean())) / sxx if sxx > 1e-18 else 0.0


def _predicted(ridge: _Ridge, speed: float, speeds) -> tuple[float, ...]:
    """Where the ridge's next peak is expected at ``speed``: along its own trend of
    ln f against ln V once it has 4 points, else as a constant or as an order."""
    f_last, v_last = ridge.freqs[-1], speeds[ridge.segments[-1]]
    if len(ridge.segments) >= 4:
        slope = log_slope(np.log(speeds[ridge.segments[-6:]]), np.log(ridge.freqs[-6:]))
        return (f_last * (speed / v_last) ** slope,)
    return (f_last, f_last * speed / v_last)


def track_ridges(freqs, level_db, peak_db, f_lo, f_hi, speeds) -> list[_Ridge]:
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


def split_ridge(ridge: _Ridge, speeds, min_segments: int) -> list[_Ridge]:
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
    return [piece for part in parts for piece in split_ridge(part, speeds, min_segments)]


def fundamental(strongest, candidates):
    """The lowest candidate of which ``strongest`` is a harmonic (a strongly nonlinear cycle
    can put more power into 2f or 3f than into f), overlapping it in time; else itself."""
    f0 = np.median(strongest[1].freqs)
    span = set(strongest[1].segments)
    below = [(f, r) for f, r in candidates if np.median(r.freqs) < 0.75 * f0 and span & set(r.segments)
             and abs(f0 / np.median(r.freqs) - round(f0 / np.median(r.freqs))) < 0.03 * f0 / np.median(r.freqs)]
    return min(below, key=lambda fr: np.median(fr[1].freqs)) if below else strongest


def no_evidence(ridge: _Ridge, speeds, envelope: dict | None, sev_db: float, df: float) -> str | None:
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


def classify_ridge(ridge: _Ridge, speeds, radius_m, min_segments) -> dict | None:
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
        feature.update(kind="order", frequency_order=float(np.median(frequency_order(f, kmh_to_ms(v), radius_m))))
        feature = with_deprecated_keys(feature, {"frequency_order": "order"})  # "order" until the next release
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


def remove_orders(x, speed_kmh, fs, orders, radius_m, bandwidth_hz=1.0):
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


def sev_from_envelope(t, speed, x, fs, f0, t_start, t_end):
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
    sev = sev_from_envelope(run.t, run.speed_kmh, run.acceleration, fs, band_hz or frequency_hz, t_hopf,
                             run.t[-1] + 1.0)
    if sev is None or sev.get("onset") is None:
        return None
    return direction * (sev["onset"]["speed_kmh"] - hopf_speed_kmh), sev.get("frequency_hz", math.nan) - frequency_hz
