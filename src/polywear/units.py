"""Speed limits, default speed ranges, unit conversions and unit tables, in one place.

Plain Python (only :mod:`math`), so the command line may import it without slowing
``polywear --help``; the functions accept floats or numpy arrays alike.
"""

from __future__ import annotations

__all__ = [
    "MAX_SPEED_KMH",
    "DEFAULT_SPEED_RANGE_KMH",
    "DEFAULT_OPERATING_RANGE_KMH",
]

MAX_SPEED_KMH = 1000.0
"""Highest speed any key or option accepts [km/h]."""

DEFAULT_SPEED_RANGE_KMH: tuple[float, float] = (20.0, 300.0)
"""Speeds searched by default (diagrams, maps, sensitivities, studies, CLI) [km/h]."""

DEFAULT_OPERATING_RANGE_KMH: tuple[float, float] = (80.0, 130.0)
"""Operating speeds of a study's largest-amplitude output by default [km/h]."""
