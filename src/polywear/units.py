"""Speed limits, default speed ranges, unit conversions, wheel rotation and unit tables, in one place.

Plain Python at import (only :mod:`math`; numpy is imported when a conversion is called), so
the command line may import it without slowing ``polywear --help``; the functions accept
floats or numpy arrays alike.
"""

from __future__ import annotations

import math

__all__ = [
    "MAX_SPEED_KMH",
    "DEFAULT_SPEED_RANGE_KMH",
    "DEFAULT_OPERATING_RANGE_KMH",
    "STABILITY_SPEED_RANGE_KMH",
    "FLEET_SPEED_RANGE_KMH",
    "KMH",
    "KMH_PER_MS",
    "kmh_to_ms",
    "ms_to_kmh",
    "wheel_circumference_m",
    "wheel_rotation_frequency_hz",
    "frequency_order",
    "plot_scale",
]

MAX_SPEED_KMH = 1000.0
"""Highest speed any key or option accepts [km/h]."""

DEFAULT_SPEED_RANGE_KMH: tuple[float, float] = (20.0, 300.0)
"""Speeds searched by default by the analyses of cycles and wear (bifurcation, report, wear map,
design, sensitivities, stability maps, studies) [km/h]. From 20 km/h up, the tread mode
(130-150 Hz at the defaults) lies within the default 60 polygon orders of the wear map
(150 Hz is order 51 at 20 km/h, 204 at 5 km/h); the diagram uses the same range so that
``bifurcation`` and ``report`` draw the same one."""

DEFAULT_OPERATING_RANGE_KMH: tuple[float, float] = (80.0, 130.0)
"""Operating speeds of a study's largest-amplitude output by default [km/h]."""

STABILITY_SPEED_RANGE_KMH: tuple[float, float] = (5.0, 300.0)
"""Speeds of the linear analyses of steady rolling (``stability``, ``calibrate``) by default [km/h]:
eigenvalues only, no cycle and no wear order to resolve, so they start near standstill, where a
measured run-up starts and a linear onset below 20 km/h would otherwise go unseen."""

FLEET_SPEED_RANGE_KMH: tuple[float, float] = (10.0, 600.0)
"""Speeds of a fleet study by default (``fleet``, ``[fleet] speed_range_kmh``) [km/h]: the cars
spread over wide parameter ranges, and a bifurcation speed beyond the range is censored
(``n_at_range_end``) in the quantiles, so the range is wider than one car's."""


KMH_PER_MS = 3.6
"""1 m/s in km/h."""

KMH = 1.0 / KMH_PER_MS
"""1 km/h in m/s."""


def kmh_to_ms(v_kmh):
    """Speed km/h -> m/s: a float for a scalar, an array for a sequence or an array."""
    import numpy as np  # here, not at import: see the module docstring

    return np.asarray(v_kmh) * KMH if np.ndim(v_kmh) else float(v_kmh) * KMH


def ms_to_kmh(v_ms):
    """Speed m/s -> km/h: a float for a scalar, an array for a sequence or an array."""
    import numpy as np  # here, not at import: see the module docstring

    return np.asarray(v_ms) * KMH_PER_MS if np.ndim(v_ms) else float(v_ms) * KMH_PER_MS


def wheel_circumference_m(rolling_radius_m):
    """Rolling circumference ``2 pi R_e`` [m] of a wheel of rolling radius R_e [m]."""
    return 2.0 * math.pi * rolling_radius_m


def wheel_rotation_frequency_hz(speed_ms, rolling_radius_m):
    """Wheel rotation frequency ``V / (2 pi R_e)`` [Hz] at speed V [m/s], rolling radius R_e [m]."""
    return speed_ms / wheel_circumference_m(rolling_radius_m)


def order_frequency_hz(order, speed_kmh, rolling_radius_m):
    """Frequency ``n V / (2 pi R_e)`` [Hz] of wheel order n at vehicle speed V [km/h]."""
    import numpy as np  # here, not at import: see the module docstring

    return wheel_rotation_frequency_hz(kmh_to_ms(order * np.asarray(speed_kmh)), rolling_radius_m)


def frequency_order(frequency_hz, speed_ms, rolling_radius_m):
    """Frequency order ``f / f_rot = f 2 pi R_e / V``, a ratio (dimensionless, not a whole number of sides),
    of a frequency f [Hz] at speed V [m/s].

    Linear in f, so it also turns a derivative of f into one of n (at fixed V, R_e).
    """
    return frequency_hz / wheel_rotation_frequency_hz(speed_ms, rolling_radius_m)


_PLOT_UNITS = {"m": (1e3, "mm"), "rad": (1e3, "mrad")}


def plot_scale(unit: str) -> tuple[float, str]:
    """(factor, unit) for plotting a quantity of SI ``unit``: m -> mm, rad -> mrad, else as is."""
    return _PLOT_UNITS.get(unit, (1.0, unit))
