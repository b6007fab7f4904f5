"""Pseudo-arclength building blocks shared by the continuations of this package.

The cycle continuation (:mod:`polywear.solvers.continuation`, unknowns: a collocated
orbit, its period and the speed) and the continuation of Hopf curves in a parameter
plane (:mod:`polywear.solvers.curve_continuation`, unknowns: speed and parameter) take
the same steps: predict along the unit tangent, correct by Newton on the equations plus
the arclength condition ``t0 . (y - y0) = ds``, orient the new tangent along the
direction of travel, and adapt the step length to the number of Newton iterations.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

import numpy as np

__all__ = ["correct", "oriented", "next_step"]

Extra = TypeVar("Extra")


def correct(
    newton_step: Callable[[np.ndarray], tuple[np.ndarray, Extra] | None],
    y0: np.ndarray,
    t0: np.ndarray,
    ds: float,
    max_newton: int,
    converged: Callable[[np.ndarray], bool],
) -> tuple[np.ndarray, Extra, int] | None:
    """Newton from the predictor ``y0 + ds t0``.

    ``newton_step(y)`` solves the bordered system (the equations and the arclength
    condition ``t0 . (y - y0) = ds`` in the caller's norm) at ``y`` and returns the
    correction with any by-product, or None when it cannot (singular, not finite).
    Returns ``(y, by-product of the last step, iterations)`` once ``converged(correction)``;
    None after ``max_newton`` iterations.
    """
    y = y0 + ds * t0
    for it in range(1, max_newton + 1):
        out = newton_step(y)
        if out is None:
            return None
        dy, extra = out
        y = y + dy
        if converged(dy):
            return y, extra, it
    return None


def oriented(t: np.ndarray, previous: np.ndarray, weights: np.ndarray | float = 1.0) -> np.ndarray:
    """``t`` or ``-t``, whichever points along ``previous`` in the inner product with ``weights``
    (the direction of travel is kept)."""
    return -t if t @ (weights * previous) < 0 else t


def next_step(ds: float, iterations: int, ds_max: float, grow: float, shrink_after: float = np.inf) -> float:
    """The next step length: ``grow`` times ``ds`` after a corrector that took at most 3
    iterations, the same up to ``shrink_after`` iterations, half beyond; at most ``ds_max``."""
    factor = grow if iterations <= 3 else 1.0 if iterations <= shrink_after else 0.5
    return min(ds_max, ds * factor)
