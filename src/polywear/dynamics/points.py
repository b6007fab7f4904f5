"""Special points of bifurcation diagrams, stability maps and the AUTO-07p reference, one type.

A :class:`SpecialPoint` is where the qualitative picture changes along a speed sweep
(one-parameter diagram) or along a curve of such points in the (speed, parameter)
plane (stability map). Its :class:`PointKind` values are the labels used in the JSON
output and in AUTO-07p's vocabulary (``HB``, ``LP``, ``PD``, ...). Speeds are km/h.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum

import numpy as np

__all__ = ["Criticality", "PointKind", "SpecialPoint"]


class PointKind(StrEnum):
    """What happens at a special point (the value is its label)."""

    HOPF = "HB"
    """Hopf point of steady rolling: a complex pair of eigenvalues crosses the imaginary axis."""
    LP = "LP"
    """Fold (limit point) of cycles: a stable and an unstable cycle merge."""
    PD = "PD"
    """Period doubling of a cycle (a Floquet multiplier crosses -1)."""
    NS = "NS"
    """Neimark-Sacker (torus) bifurcation of a cycle (a complex pair of multipliers leaves the unit circle; AUTO: TR)."""
    BP = "BP"
    """Branch point (AUTO-07p flags it where a cycle branch shrinks onto the equilibrium)."""
    DIV = "DIV"
    """A real eigenvalue of steady rolling crosses zero (static divergence starts or ends)."""
    GH = "GH"
    """Generalized Hopf (Bautin) point on a Hopf curve of a map: the first Lyapunov coefficient changes sign."""
    HOPF_TURN = "HT"
    """Turning point of a Hopf curve in the map's parameter: the two Hopf speeds of a band merge, the linear band closes."""


class Criticality(StrEnum):
    """How steady rolling loses stability at a Hopf point (the sign of the first Lyapunov coefficient l1)."""

    SOFT = "soft"
    """Supercritical (l1 < 0): a small stable cycle grows out of steady rolling (soft self-excitation)."""
    HARD = "hard"
    """Subcritical (l1 > 0): an unstable cycle ends there; a large disturbance starts SEV before it (hard)."""


@dataclass(frozen=True)
class SpecialPoint:
    """One special point: its kind, speed [km/h] and what is known there.

    ``amplitude`` is the half peak-to-peak amplitude of every state of the cycle there
    [state units: m, rad] (None where there is no cycle or it is not known); ``branch``
    the index of the cycle branch it lies on; ``value`` the parameter value of a
    stability map [key units] (None on a one-parameter diagram); ``criticality``
    :class:`Criticality` at a Hopf point; ``orbit`` the periodic orbit, where the
    point was located on one by continuation.
    """

    kind: PointKind
    speed_kmh: float
    frequency_hz: float | None = None
    """Frequency of the oscillation there [Hz] (None where none is known)."""
    amplitude: np.ndarray | None = field(default=None, compare=False)
    branch: int | None = None
    value: float | None = None
    criticality: Criticality | None = None
    orbit: object = field(default=None, repr=False, compare=False)

    @property
    def label(self) -> str:
        """The kind's label (``"HB"``, ``"LP"``, ...)."""
        return self.kind.value
