"""Speed intervals ``[(low, high), ...]`` [km/h]: runs of a grid, union, difference.

The SEV band, the linear band, the hard-excitation band and the bands of a stability
map are unions of closed speed intervals; these helpers build and combine them.
"""

from __future__ import annotations

__all__ = ["runs_of", "union", "subtract"]

Interval = tuple[float, float]


def runs_of(speeds, flags) -> list[Interval]:
    """Intervals [first, last] of consecutive grid ``speeds`` where ``flags`` holds."""
    out, start = [], None
    for v, f in zip(speeds, flags):
        if f and start is None:
            start = v
        if f:
            last = v
        if not f and start is not None:
            out.append((float(start), float(last)))
            start = None
    if start is not None:
        out.append((float(start), float(last)))
    return out


def union(intervals, gap: float = 0.0) -> list[Interval]:
    """Sorted union of closed intervals; intervals less than ``gap`` apart are joined too."""
    out: list[Interval] = []
    for lo, hi in sorted(intervals):
        if out and lo <= out[-1][1] + gap:
            out[-1] = (out[-1][0], max(out[-1][1], hi))
        else:
            out.append((lo, hi))
    return out


def subtract(a, b, min_width: float = 1e-9) -> list[Interval]:
    """Intervals of ``a`` not covered by ``b`` (both unions of closed intervals); pieces
    no wider than ``min_width`` are dropped."""
    out = []
    for lo, hi in a:
        pieces = [(lo, hi)]
        for blo, bhi in b:
            nxt = []
            for plo, phi in pieces:
                if bhi <= plo or blo >= phi:
                    nxt.append((plo, phi))
                    continue
                if plo < blo:
                    nxt.append((plo, blo))
                if bhi < phi:
                    nxt.append((bhi, phi))
            pieces = nxt
        out += [p for p in pieces if p[1] - p[0] > min_width]
    return out
