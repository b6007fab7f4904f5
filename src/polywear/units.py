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
    "order_rays",
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


RAY_LABEL_GAP_IN = (0.32, 0.14)
"""Least distance [inch] between the anchors of two order-ray labels: along the top edge
(the labels' width) and along the right edge (their height)."""


def order_rays(ax, orders, rolling_radius_m: float, speed_range_kmh, top_hz: float, first=(), **line_kw) -> list:
    """Wheel-order rays ``n V / (2 pi R)`` [Hz] over ``speed_range_kmh`` [km/h] below
    ``top_hz`` [Hz] onto ``ax``, each labelled ``n=..`` inside the axes where it leaves them
    (right or top edge). A ray is drawn only if its label keeps :data:`RAY_LABEL_GAP_IN`
    from every label already placed (``first`` orders first, then multiples of 10, of 5,
    then the others, ascending), so every drawn ray is labelled and no two labels overlap.
    Returns the orders drawn."""
    lo, hi = (float(v) for v in speed_range_kmh)
    fig = ax.figure
    box = ax.get_position()
    width, height = box.width * fig.get_figwidth(), box.height * fig.get_figheight()  # axes size [inch]
    candidates = [n for n in first if n in orders] + sorted(
        (n for n in orders if n not in first), key=lambda n: (n % 10 != 0, n % 5 != 0, n))
    placed: list[tuple[str, float]] = []  # (edge, position along it [inch])
    drawn = []
    kw = {"color": "w", "lw": 0.5, "alpha": 0.5, **line_kw}
    for n in candidates:
        if order_frequency_hz(n, lo, rolling_radius_m) >= top_hz:
            continue
        f_end = float(order_frequency_hz(n, hi, rolling_radius_m))
        if f_end <= top_hz:
            edge, where, xy, align = "right", (1.0 - f_end / top_hz) * height, (hi, f_end), ("right", "center")
        else:
            v_exit = top_hz / float(order_frequency_hz(n, 1.0, rolling_radius_m))
            edge, where, xy, align = "top", (v_exit - lo) / (hi - lo) * width, (v_exit, top_hz), ("center", "top")
        # along the perimeter: the top edge from the left, then the right edge from the top
        s = where if edge == "top" else width + where
        if any(abs(s - (p if e == "top" else width + p)) < RAY_LABEL_GAP_IN[e == "right" and edge == "right"]
               for e, p in placed):
            continue
        placed.append((edge, where))
        drawn.append(n)
        ax.plot([lo, xy[0]], [float(order_frequency_hz(n, lo, rolling_radius_m)), xy[1]], **kw)
        ax.annotate(f"n={n:g}", xy, xytext=(-2, 0) if edge == "right" else (0, -2), textcoords="offset points",
                    ha=align[0], va=align[1], fontsize=7, color="k",
                    bbox={"boxstyle": "round,pad=0.1", "fc": "w", "ec": "none", "alpha": 0.75}, zorder=6)
    return sorted(drawn)
