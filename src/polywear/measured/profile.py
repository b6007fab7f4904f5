"""Measured worn tires: tread depth or radius around the circumference, as a polygon spectrum.

Two file kinds (CSV, comma or semicolon):

- **long** profiles: one row per reading, columns ``angle`` and ``depth`` or ``radius``
  with their units in the header (``angle_deg``, ``angle [rad]``, ``depth_mm``,
  ``radius [m]``, ...), optional ``rib``, ``distance_km`` and ``position``; a depth gauge
  at 24-72 points or a laser scan of thousands;
- **harmonics** tables: ``order, amplitude_mm, phase_deg`` (what uniformity machines
  export), optional ``rib``, ``distance_km``, ``position``.

Each (position, rib, mileage) is one :class:`MeasuredProfile`. A long profile is fitted by
least squares with the Fourier series ``w(phi) = c_0 + sum Re(W_n e^{i n phi})``,
n = 1..K: uneven spacing, gaps and a missing 360 degree closure need nothing special, and
the covariance of the fit gives each order's standard error. Readings that stand more than
``OUTLIER_SIGMAS`` robust deviations off the fit (a stone in the groove) are dropped and
named. The worn depth is ``w = -depth`` (or ``-radius``): a harmonic's amplitude and the
peak-to-valley depth do not depend on the sign. Harmonics are [mm] throughout this module.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable

import numpy as np

from ..errors import InputError
from ..results import Result

__all__ = [
    "ProfileError",
    "MeasuredProfile",
    "MeasuredProfiles",
    "read_profiles",
    "fit_harmonics",
    "peak_to_valley_mm",
]

OUTLIER_SIGMAS = 5.0
"""A reading whose standardized residual is this many robust standard deviations (1.4826
MAD) off, and whose residual against the fit without it exceeds three resolution steps,
is an outlier."""
FLOOR_SIGMAS = 4.0
"""An order counts as measured when its amplitude exceeds this many standard errors: pure
noise passes it with probability exp(-8) = 3e-4 per order (Rayleigh tail)."""
MAX_CONDITION = 100.0
"""The highest order fitted is lowered until the fit's condition number is below this: a
gap in the readings leaves high orders undetermined (they could be anything inside it)."""
DEFAULT_MAX_ORDER = 30
"""Highest order fitted unless the caller says otherwise; also at most (0.75 N - 1)/2 for
N readings, so that a quarter of them is left to estimate the noise."""

LENGTH_UNITS_MM = {"mm": 1.0, "um": 1e-3, "µm": 1e-3, "m": 1e3, "cm": 10.0, "in": 25.4}
ANGLE_UNITS_DEG = {"deg": 1.0, "degree": 1.0, "degrees": 1.0, "rad": 180.0 / math.pi}
PLAUSIBLE_MM = {"depth": (0.0, 40.0), "radius": (150.0, 800.0)}
"""Readings outside these ranges [mm] are in another unit (a 7 mm depth given as 7000)."""


class ProfileError(InputError):
    """A profile file that cannot be read as a measured tire (one line, names the file)."""


@dataclass(frozen=True)
class MeasuredProfile:
    """One measured tire, rib and mileage: its polygon spectrum."""

    source: str
    position: str | None
    rib: str | None
    distance_km: float | None
    harmonics_mm: np.ndarray
    """(K,) complex W_n [mm], n = 1..K: ``w(phi) = sum Re(W_n e^{i n phi})``"""
    std_error_mm: np.ndarray
    """(K,) standard error of |W_n| [mm] (from the fit's covariance)"""
    angle_deg: np.ndarray | None = None
    """readings kept (long profiles) [deg]"""
    wear_mm: np.ndarray | None = None
    """worn depth at those angles, -depth or -radius, mean removed [mm]"""
    outliers_deg: tuple[float, ...] = ()
    notes: tuple[str, ...] = ()

    @property
    def orders(self) -> np.ndarray:
        return np.arange(1, self.harmonics_mm.size + 1)

    @property
    def amplitude_mm(self) -> np.ndarray:
        return np.abs(self.harmonics_mm)

    @property
    def floor_mm(self) -> np.ndarray:
        """Noise floor per order [mm]: amplitudes below it are not measured."""
        return FLOOR_SIGMAS * self.std_error_mm

    @property
    def significant(self) -> np.ndarray:
        return self.amplitude_mm > self.floor_mm

    @property
    def dominant_order(self) -> int | None:
        """Order of the largest amplitude above the floor (None: nothing above it)."""
        if not self.significant.any():
            return None
        return int(self.orders[np.argmax(np.where(self.significant, self.amplitude_mm, -1.0))])

    @property
    def peak_to_valley_mm(self) -> float:
        """Peak-to-valley of the profile made of the orders above the floor [mm] (the
        evolution's definition of "visible", without the measurement noise)."""
        return peak_to_valley_mm(np.where(self.significant, self.harmonics_mm, 0.0))

    @property
    def label(self) -> str:
        parts = [self.source]
        if self.position is not None:
            parts.append(f"position {self.position}")
        if self.rib is not None:
            parts.append(f"rib {self.rib}")
        if self.distance_km is not None:
            parts.append(f"{self.distance_km:g} km")
        return ", ".join(parts)

    def summary(self) -> dict:
        order = self.dominant_order
        return {
            "source": self.source, "position": self.position, "rib": self.rib, "distance_km": self.distance_km,
            "dominant_order": order,
            "dominant_amplitude_mm": None if order is None else float(self.amplitude_mm[order - 1]),
            "peak_to_valley_mm": self.peak_to_valley_mm,
            "orders": [{"order": int(n), "amplitude_mm": float(a), "std_error_mm": float(s)}
                       for n, a, s in zip(self.orders, self.amplitude_mm, self.std_error_mm)],
            "outliers_deg": list(self.outliers_deg), "notes": list(self.notes),
        }


def peak_to_valley_mm(harmonics_mm: np.ndarray, points: int = 720) -> float:
    """Peak-to-valley depth [mm] of the profile with harmonics W_n [mm], n = 1..K: sampled
    at ``points`` angles (at least 16 per period of the highest order), each extremum
    refined by the parabola through it and its neighbours."""
    W = np.asarray(harmonics_mm, dtype=complex)
    points = max(points, 16 * W.size)
    phi = 2.0 * np.pi * np.arange(points) / points
    w = np.real(np.exp(1j * np.outer(phi, np.arange(1, W.size + 1))) @ W)

    def vertex(i: int) -> float:
        a, b, c = w[i - 1], w[i], w[(i + 1) % points]
        curvature = a - 2.0 * b + c
        return float(b - 0.125 * (c - a) ** 2 / curvature) if curvature != 0.0 else float(b)

    return vertex(int(np.argmax(w))) - vertex(int(np.argmin(w)))


def _design(phi: np.ndarray, K: int) -> np.ndarray:
    """Columns 1, cos(n phi), sin(n phi), n = 1..K."""
    n = np.arange(1, K + 1)
    return np.hstack([np.ones((phi.size, 1)), np.cos(np.outer(phi, n)), np.sin(np.outer(phi, n))])


def fit_harmonics(angle_deg: np.ndarray, wear_mm: np.ndarray, max_order: int, resolution_mm: float = 0.0
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Least-squares Fourier fit of ``wear_mm`` at ``angle_deg``.

    Returns (W_n [mm] complex, n = 1..K; standard error of |W_n| [mm]; residuals [mm];
    sigma [mm], the reading noise: the residuals' RMS with the fit's degrees of freedom,
    at least the resolution's quantisation ``resolution/sqrt(12)``).
    """
    phi = np.radians(np.asarray(angle_deg, dtype=float))
    y = np.asarray(wear_mm, dtype=float)
    K = int(max_order)
    A = _design(phi, K)
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    residuals = y - A @ coef
    dof = y.size - A.shape[1]
    sigma = max(math.sqrt(float(residuals @ residuals) / dof) if dof > 0 else 0.0, resolution_mm / math.sqrt(12.0))
    a, b = coef[1 : K + 1], coef[K + 1 :]
    W = a - 1j * b  # a cos + b sin = Re((a - i b) e^{i phi})
    cov = np.linalg.pinv(A.T @ A) * sigma**2
    var_a, var_b = np.diag(cov)[1 : K + 1], np.diag(cov)[K + 1 :]
    std = np.sqrt(0.5 * (var_a + var_b))
    return W, std, residuals, sigma


def _deleted_residuals(angle_deg: np.ndarray, y: np.ndarray, K: int) -> tuple[np.ndarray, np.ndarray]:
    """Each reading's residual against the fit made without it, ``e_i / (1 - h_ii)`` [mm]
    (h: the hat matrix), and the residual standardized by its own spread,
    ``e_i / sqrt(1 - h_ii)``: a spike cannot hide by pulling the fit towards itself, and a
    reading at the edge of a gap is not taken for one."""
    A = _design(np.radians(angle_deg), K)
    Q, _ = np.linalg.qr(A)
    h = np.minimum(np.sum(Q**2, axis=1), 1.0 - 1e-12)
    e = y - Q @ (Q.T @ y)
    return e / (1.0 - h), e / np.sqrt(1.0 - h)


def _resolution(values: np.ndarray) -> float:
    """The step the readings are written in [their unit] (0.01 for 7.23, 7.31, ...)."""
    for decimals in range(0, 7):
        step = 10.0 ** -decimals
        if np.all(np.abs(values / step - np.round(values / step)) < 1e-6):
            return step
    return 0.0


def _profile_from_readings(source: str, key: tuple, angle: np.ndarray, wear: np.ndarray, resolution: float,
                           max_order: int) -> MeasuredProfile:
    """Fit one group of readings, dropping outliers (at most a tenth of them)."""
    position, rib, distance = key
    notes: list[str] = []
    K = min(max_order, int((0.75 * angle.size - 1) // 2))  # a quarter of the readings left to estimate the noise
    if K < 1:
        raise ProfileError(f"{source}: {_describe(key)}: {angle.size} readings; at least 6 are needed for a spectrum")
    phi = np.radians(angle)
    requested = K
    while K > 1 and np.linalg.cond(_design(phi, K)) > MAX_CONDITION:
        K -= 1
    if K < requested:
        gap = float(np.diff(np.concatenate([angle, [angle[0] + 360.0]])).max())
        notes.append(f"orders above {K} not fitted: the spacing of the readings (largest gap {gap:.0f} deg) leaves "
                     "them undetermined")
    keep = np.ones(angle.size, bool)
    outliers: list[float] = []
    # below the readings' quantisation, or their rounding as floats amplified by the fit's
    # condition (at most MAX_CONDITION), a residual is no outlier: a pure polygon written
    # at full precision lost 7 of its 72 readings to residuals of 1e-15 mm on an AVX-512
    # machine, whose robust deviation was rounding too
    floor = max(3.0 * resolution, MAX_CONDITION * np.finfo(float).eps * float(np.max(np.abs(wear))))
    while True:  # drop the worst reading while its deleted residual is an outlier
        idx = np.flatnonzero(keep)
        deleted, standardized = _deleted_residuals(angle[idx], wear[idx], K)
        scale = 1.4826 * float(np.median(np.abs(standardized)))
        worst = int(np.argmax(np.abs(standardized)))
        if (abs(standardized[worst]) <= OUTLIER_SIGMAS * scale or abs(deleted[worst]) <= floor
                or len(outliers) >= angle.size // 10):
            break
        outliers.append(float(angle[idx[worst]]))
        keep[idx[worst]] = False
    W, std, _, _ = fit_harmonics(angle[keep], wear[keep], K, resolution)
    if outliers:
        notes.append(f"{len(outliers)} reading(s) off the profile by more than {OUTLIER_SIGMAS:g} robust deviations "
                     f"left out (a stone in the groove?) at {', '.join(f'{a:g}' for a in sorted(outliers))} deg")
    kept_wear = wear[keep] - float(np.mean(wear[keep]))
    return MeasuredProfile(source, position, rib, distance, W, std, angle[keep], kept_wear, tuple(sorted(outliers)),
                           tuple(notes))


def _split_header(name: str) -> tuple[str, str | None]:
    """``depth_mm`` / ``depth [mm]`` / ``depth (mm)`` -> (``depth``, ``mm``)."""
    text = name.strip().lower()
    m = re.fullmatch(r"([a-z_ ]+?)\s*[\[(]\s*([a-zµ]+)\s*[\])]", text)
    if m:
        return m.group(1).strip().replace(" ", "_"), m.group(2)
    for unit in sorted({**LENGTH_UNITS_MM, **ANGLE_UNITS_DEG, "km": 1}, key=len, reverse=True):
        if text.endswith("_" + unit):
            return text[: -len(unit) - 1], unit
    return text, None


def _read_table(path: Path):
    import pandas as pd

    try:
        frame = pd.read_csv(path, sep=None, engine="python", comment="#")
    except (OSError, UnicodeDecodeError, pd.errors.ParserError, pd.errors.EmptyDataError, ValueError) as exc:
        raise ProfileError(f"{path}: cannot be read as CSV ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})") from None
    if frame.empty:
        raise ProfileError(f"{path}: no readings")
    return frame


def _column(frame, path: Path, names: tuple[str, ...]) -> tuple[str, str, str | None] | None:
    """(column, quantity, unit) of the first column whose name is one of ``names``."""
    for column in frame.columns:
        quantity, unit = _split_header(str(column))
        if quantity in names:
            return str(column), quantity, unit
    return None


def _numbers(frame, column: str, path: Path) -> np.ndarray:
    import pandas as pd

    values = pd.to_numeric(frame[column], errors="coerce").to_numpy(dtype=float)
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        raise ProfileError(f"{path}: column {column!r} row {int(bad[0]) + 2}: {frame[column].iloc[bad[0]]!r} is not a "
                           "finite number")
    return values


def _groups(frame, path: Path) -> tuple[list[tuple], np.ndarray]:
    """Group keys (position, rib, distance_km) per row."""
    cols = {}
    for name in ("position", "rib", "distance"):
        found = _column(frame, path, (name,) if name != "distance" else ("distance", "mileage"))
        cols[name] = found
    positions = frame[cols["position"][0]].astype(str).to_numpy() if cols["position"] else np.full(len(frame), None)
    ribs = frame[cols["rib"][0]].astype(str).to_numpy() if cols["rib"] else np.full(len(frame), None)
    if cols["distance"]:
        column, _, unit = cols["distance"]
        if unit not in (None, "km"):
            raise ProfileError(f"{path}: column {column!r}: distance in km, not {unit}")
        distances = _numbers(frame, column, path)
        if np.any(distances < 0):
            raise ProfileError(f"{path}: column {column!r}: a negative distance")
    else:
        distances = np.full(len(frame), np.nan)
    keys = [(p, r, None if not math.isfinite(d) else float(d)) for p, r, d in zip(positions, ribs, distances)]
    order = sorted(set(keys), key=lambda k: tuple("" if v is None else str(v) if not isinstance(v, float) else f"{v:020.3f}" for v in k))
    index = np.array([order.index(k) for k in keys])
    return order, index


def _read_long(path: Path, frame, value: tuple[str, str, str | None], unit: str | None, max_order: int
               ) -> list[MeasuredProfile]:
    angle_col = _column(frame, path, ("angle", "azimuth", "position_angle"))
    if angle_col is None:
        raise ProfileError(f"{path}: no angle column (expected e.g. angle_deg)")
    column, quantity, header_unit = value
    unit = unit or header_unit
    if unit is None:
        raise ProfileError(f"{path}: column {column!r} has no unit; write it in the header ({quantity}_mm) or give --unit")
    if unit not in LENGTH_UNITS_MM:
        raise ProfileError(f"{path}: column {column!r}: unknown length unit {unit!r} (one of {', '.join(LENGTH_UNITS_MM)})")
    angle_unit = angle_col[2] or "deg"
    if angle_unit not in ANGLE_UNITS_DEG:
        raise ProfileError(f"{path}: column {angle_col[0]!r}: unknown angle unit {angle_unit!r} (deg or rad)")
    raw = _numbers(frame, column, path)
    values = raw * LENGTH_UNITS_MM[unit]
    angle = _numbers(frame, angle_col[0], path) * ANGLE_UNITS_DEG[angle_unit]
    full_turn = 360.0
    if np.any(angle < 0) or np.any(angle > full_turn + 1e-9):
        bad = angle[(angle < 0) | (angle > full_turn + 1e-9)][0]
        raise ProfileError(f"{path}: angle {bad:g} deg is outside 0..360 deg (in radians? write angle_rad)")
    low, high = PLAUSIBLE_MM[quantity]
    outside = values[(values < low) | (values > high)]
    if outside.size:
        raise ProfileError(f"{path}: {quantity} {outside[0]:g} mm is not a tire's {quantity} ({low:g}-{high:g} mm): "
                           f"is column {column!r} in {unit}? (a wrong unit in the header or --unit)")
    keys, index = _groups(frame, path)
    resolution = _resolution(raw) * LENGTH_UNITS_MM[unit]
    profiles = []
    for g, key in enumerate(keys):
        rows = np.flatnonzero(index == g)
        a, v = angle[rows], values[rows]
        closed = a.size > 1 and np.isclose(a[-1], full_turn) and np.isclose(a[0], 0.0)
        if closed:  # the 360 degree reading closes the circle: the 0 degree reading again
            a, v, rows = a[:-1], v[:-1], rows[:-1]
        back = np.flatnonzero(np.diff(a) <= 0)
        if back.size:
            i = int(back[0]) + 1
            raise ProfileError(f"{path}: {_describe(key)}: angle {a[i]:g} deg at row {rows[i] + 2} is not above the one "
                               f"before ({a[i - 1]:g} deg); angles must rise around the tire (two tires mixed? add a "
                               "position, rib or distance_km column)")
        profiles.append(_profile_from_readings(path.name, key, a, -v, resolution, max_order))
    return profiles


def _describe(key: tuple) -> str:
    position, rib, distance = key
    parts = [f"position {position}" if position is not None else "", f"rib {rib}" if rib is not None else "",
             f"{distance:g} km" if distance is not None else ""]
    return ", ".join(p for p in parts if p) or "the profile"


def _read_harmonics(path: Path, frame, max_order: int) -> list[MeasuredProfile]:
    amp = _column(frame, path, ("amplitude",))
    phase = _column(frame, path, ("phase",))
    order_col = _column(frame, path, ("order", "harmonic"))
    unit = amp[2] if amp[2] in LENGTH_UNITS_MM else None
    if unit is None:
        raise ProfileError(f"{path}: column {amp[0]!r} needs a length unit (amplitude_mm)")
    orders = _numbers(frame, order_col[0], path)
    if np.any(orders < 1) or np.any(orders != np.round(orders)):
        raise ProfileError(f"{path}: orders must be whole numbers >= 1")
    amplitude = _numbers(frame, amp[0], path) * LENGTH_UNITS_MM[unit]
    if np.any(amplitude < 0):
        raise ProfileError(f"{path}: a negative amplitude")
    if np.any(amplitude > PLAUSIBLE_MM["depth"][1]):
        raise ProfileError(f"{path}: amplitude {amplitude.max():g} mm is not a tire's: is {amp[0]!r} in {unit}?")
    phi = _numbers(frame, phase[0], path) * ANGLE_UNITS_DEG[phase[2] or "deg"] if phase else np.zeros(len(frame))
    keys, index = _groups(frame, path)
    resolution = _resolution(amplitude / LENGTH_UNITS_MM[unit]) * LENGTH_UNITS_MM[unit]
    profiles = []
    for g, key in enumerate(keys):
        n = orders[index == g].astype(int)
        if np.unique(n).size != n.size:
            raise ProfileError(f"{path}: {_describe(key)}: an order is listed twice (two tires mixed?)")
        K = int(min(max(n.max(), 1), max(max_order, n.max())))
        W = np.zeros(K, complex)
        W[n - 1] = amplitude[index == g] * np.exp(1j * np.radians(phi[index == g]))
        std = np.full(K, max(resolution, 1e-9) / math.sqrt(12.0))
        profiles.append(MeasuredProfile(path.name, *key, W, std, notes=("harmonics as given; the noise floor is "
                                                                        "the amplitude's written resolution",)))
    return profiles


def read_profiles(paths: Iterable[str | Path], unit: str | None = None, max_order: int = DEFAULT_MAX_ORDER
                  ) -> MeasuredProfiles:
    """Measured profiles from CSV files (long profiles or harmonics tables).

    ``unit``: the length unit of the depth or radius column when the header has none
    (mm, um, m, cm, in); ``max_order``: the highest order fitted (also below half the
    readings of each group). Raises :class:`ProfileError` with one line naming the file.
    """
    if max_order < 1:
        raise ProfileError(f"max order {max_order}: must be at least 1")
    if unit is not None and unit not in LENGTH_UNITS_MM:
        raise ProfileError(f"--unit {unit!r}: one of {', '.join(LENGTH_UNITS_MM)}")
    profiles: list[MeasuredProfile] = []
    for p in [Path(p) for p in paths]:
        if not p.is_file():
            raise ProfileError(f"{p}: no such file")
        frame = _read_table(p)
        value = _column(frame, p, ("depth", "tread_depth")) or _column(frame, p, ("radius",))
        if value is not None:
            profiles += _read_long(p, frame, value, unit, max_order)
        elif _column(frame, p, ("amplitude",)) and _column(frame, p, ("order", "harmonic")):
            profiles += _read_harmonics(p, frame, max_order)
        else:
            raise ProfileError(f"{p}: neither a profile (angle_deg, depth_mm or radius_mm) nor a harmonics table "
                               f"(order, amplitude_mm, phase_deg); columns: {', '.join(map(str, frame.columns))}")
    return MeasuredProfiles(tuple(profiles))


@dataclass
class MeasuredProfiles(Result):
    """Measured profiles of one or more files: spectra, dominant orders, growth."""

    profiles: tuple[MeasuredProfile, ...]
    settings: dict = field(default_factory=dict)

    @property
    def tires(self) -> dict[tuple, list[MeasuredProfile]]:
        """(position, rib) -> its profiles, by mileage (None first)."""
        out: dict[tuple, list[MeasuredProfile]] = {}
        for p in self.profiles:
            out.setdefault((p.position, p.rib), []).append(p)
        for key in out:
            out[key].sort(key=lambda q: -1.0 if q.distance_km is None else q.distance_km)
        return out

    @property
    def dominant_order(self) -> int | None:
        """The dominant order of the latest mileage, over all tires and ribs (the order
        with the largest summed amplitude above the floor)."""
        latest = self.latest()
        if not latest:
            return None
        K = max(p.harmonics_mm.size for p in latest)
        total = np.zeros(K)
        for p in latest:
            total[: p.harmonics_mm.size] += np.where(p.significant, p.amplitude_mm, 0.0)
        return int(np.argmax(total)) + 1 if total.any() else None

    def latest(self) -> list[MeasuredProfile]:
        """The profile at the largest mileage of every tire and rib."""
        return [profiles[-1] for profiles in self.tires.values()]

    def growth(self) -> list[dict]:
        """Per tire and rib and pair of successive mileages: growth of each order measured
        at both [1/1000 km] (ln of the amplitude ratio per 1000 km)."""
        rows = []
        for (position, rib), profiles in self.tires.items():
            known = [p for p in profiles if p.distance_km is not None]
            for a, b in zip(known, known[1:]):
                span = (b.distance_km - a.distance_km) / 1000.0
                if span <= 0:
                    continue
                K = min(a.harmonics_mm.size, b.harmonics_mm.size)
                for n in range(1, K + 1):
                    if a.significant[n - 1] and b.significant[n - 1]:
                        rows.append({"position": position, "rib": rib, "from_km": a.distance_km, "to_km": b.distance_km,
                                     "order": n, "growth_per_1000km": math.log(b.amplitude_mm[n - 1] /
                                                                               a.amplitude_mm[n - 1]) / span})
        return rows

    def summary(self) -> dict:
        latest = self.latest()
        return {
            "dominant_order": self.dominant_order,
            "peak_to_valley_mm": max((p.peak_to_valley_mm for p in latest), default=None),
            "profiles": [p.summary() for p in self.profiles],
            "growth": self.growth(),
        }

    def _dataset(self):
        import xarray as xr

        K = max(p.harmonics_mm.size for p in self.profiles)
        amp = np.full((len(self.profiles), K), np.nan)
        err = np.full((len(self.profiles), K), np.nan)
        for i, p in enumerate(self.profiles):
            amp[i, : p.harmonics_mm.size] = p.amplitude_mm
            err[i, : p.harmonics_mm.size] = p.std_error_mm
        return xr.Dataset(
            {"amplitude_mm": (("profile", "order"), amp), "std_error_mm": (("profile", "order"), err),
             "distance_km": ("profile", [np.nan if p.distance_km is None else p.distance_km for p in self.profiles])},
            coords={"order": np.arange(1, K + 1), "profile": [p.label for p in self.profiles]})

    def plot(self, ax: Any = None, predicted_mm: np.ndarray | None = None, predicted_label: str = "predicted"):
        """The measured tires in polar form (worn depth, exaggerated around a base circle),
        the predicted profile beside them if given ([mm] at equally spaced angles)."""
        import matplotlib.pyplot as plt

        if ax is None:
            ax = plt.figure(figsize=(5.5, 5.5)).add_subplot(projection="polar")
        artists = []
        latest = self.latest()
        scale = max([p.peak_to_valley_mm for p in latest] + [float(np.ptp(predicted_mm)) if predicted_mm is not None
                                                            else 0.0, 1e-3])
        phi = np.linspace(0.0, 2 * np.pi, 721)
        for p in latest:
            w = np.real(np.exp(1j * np.outer(phi, p.orders)) @ np.where(p.significant, p.harmonics_mm, 0.0))
            artists += ax.plot(phi, 1.0 - w / scale, lw=1.2, label=p.label)
            if p.angle_deg is not None:
                artists.append(ax.scatter(np.radians(p.angle_deg), 1.0 - p.wear_mm / scale, s=6, alpha=0.5))
        if predicted_mm is not None:
            grid = np.linspace(0.0, 2 * np.pi, predicted_mm.size, endpoint=False)
            artists += ax.plot(np.append(grid, 2 * np.pi), 1.0 - np.append(predicted_mm, predicted_mm[0]) / scale,
                               "k--", lw=1.2, label=predicted_label)
        ax.set_ylim(0.0, 1.6)
        ax.set_yticks([])
        ax.set_title(f"worn profile (radial scale: 1 = {scale:.3g} mm peak-to-valley)", fontsize=9)
        ax.legend(loc="lower left", fontsize=7, bbox_to_anchor=(-0.1, -0.15))
        return artists
