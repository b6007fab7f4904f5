"""The least change of one parameter that meets a criterion: a geometric grid, then bisection.

Multiplicative changes ``p = p0 * f`` are tried in both directions (more and less of the
parameter) on a geometric grid of ``grid`` steps from 1 to ``max_factor`` (and 1 to
``1 / max_factor``); the first grid step that meets the criterion is refined by bisection
in ``ln f`` to ``refine`` between it and the step before. The smaller change (in
``|ln f|``) of the two directions is kept. The criterion must hold beyond its least change
along each direction (a grid step can pass over a window where it holds).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TypeVar

import numpy as np

__all__ = ["least_factor"]

T = TypeVar("T")


def least_factor(meets: Callable[[float], T | None], max_factor: float, grid: int = 24,
                 refine: float = 0.01) -> tuple[float, T] | None:
    """(least factor f [-], what ``meets(f)`` returned there), or None if no factor within
    ``1 / max_factor .. max_factor`` meets the criterion.

    ``meets(f)`` is None where the criterion fails (or cannot be evaluated), anything else
    where it holds. ``grid``: grid steps per direction [-]; ``refine``: accuracy of the
    bisection in ``ln f`` [-] (0.01: 1 %).
    """
    best = None
    for sign in (1.0, -1.0):
        previous = 1.0
        for f in np.exp(sign * np.linspace(0.0, math.log(max_factor), grid + 1)[1:]):
            hit = meets(float(f))
            if hit is None:
                previous = float(f)
                continue
            lo, hi = math.log(previous), math.log(float(f))
            while abs(hi - lo) > refine:
                mid = 0.5 * (lo + hi)
                probe = meets(math.exp(mid))
                if probe is not None:
                    hi, hit = mid, probe
                else:
                    lo = mid
            factor = math.exp(hi)
            if best is None or abs(math.log(factor)) < abs(math.log(best[0])):
                best = (factor, hit)
            break
    return best
