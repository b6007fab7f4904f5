"""Validation shared by the frozen settings dataclasses.

Every numerical-options object of the library (``ContinuationSettings``, ``MapSettings``,
``StabilitySettings``, ``SimulationSettings``, ``WearMapSettings``, ``WearDesignSettings``,
``AutoSettings``, ...) is a frozen dataclass
that checks its fields in ``__post_init__`` with these helpers, so that a bad value fails
on construction with a ``ValueError`` naming the class and the field. Frozen dataclasses
are hashable and picklable: settings travel to worker processes unchanged.
"""

from __future__ import annotations

import math
from typing import Any

__all__ = ["check_count", "check_fraction", "check_order", "check_positive"]


def _fail(obj: Any, name: str, value: Any, need: str) -> ValueError:
    return ValueError(f"{type(obj).__name__}: {name} = {value!r}: {need}")


def check_positive(obj: Any, *names: str, finite: bool = True) -> None:
    """Each named field is a real number > 0 (and finite unless ``finite=False``)."""
    for name in names:
        value = getattr(obj, name)
        ok = isinstance(value, (int, float)) and not isinstance(value, bool) and value > 0.0
        if not ok or (finite and not math.isfinite(value)):
            raise _fail(obj, name, value, "must be positive" + (" and finite" if finite else ""))


def check_count(obj: Any, *names: str, minimum: int = 1, maximum: int | None = None) -> None:
    """Each named field is an integer >= ``minimum`` (and <= ``maximum`` if given)."""
    for name in names:
        value = getattr(obj, name)
        if not isinstance(value, int) or isinstance(value, bool) or value < minimum or (
                maximum is not None and value > maximum):
            need = f"from {minimum} to {maximum}" if maximum is not None else f">= {minimum}"
            raise _fail(obj, name, value, f"must be an integer {need}")


def check_fraction(obj: Any, name: str, closed_low: bool = False) -> None:
    """The named field lies in (0, 1] (in [0, 1] with ``closed_low=True``)."""
    value = getattr(obj, name)
    low_ok = value >= 0.0 if closed_low else value > 0.0
    if not (isinstance(value, (int, float)) and low_ok and value <= 1.0):
        raise _fail(obj, name, value, f"must lie in {'[' if closed_low else '('}0, 1]")


def check_order(obj: Any, *names: str) -> None:
    """The named fields are non-decreasing in the order given (e.g. ds_min <= ds <= ds_max)."""
    values = [getattr(obj, name) for name in names]
    if any(a > b for a, b in zip(values, values[1:])):
        got = ", ".join(f"{n} = {v!r}" for n, v in zip(names, values))
        raise ValueError(f"{type(obj).__name__}: need {' <= '.join(names)} (got {got})")
