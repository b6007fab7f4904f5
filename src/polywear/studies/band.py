"""The band of one parameter set and why the fast path did not apply: what every path of
studies and fleets returns (:class:`Band`), with the full diagram's band
(:func:`band_from_diagram`) and the fast path's fallback reasons."""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np

from ..results import Result, with_deprecated_keys

__all__ = ["Band", "BandPath", "Fallback", "FallbackReason", "LABEL_TOL_KMH", "band_from_diagram"]

LABEL_TOL_KMH = 1e-9
"""Largest distance [km/h] between a band end and the special point it is labelled with."""


class BandPath(str, Enum):
    """Which path gave a :class:`Band` (compares equal to its value: ``"fast"``, ``"full"``)."""

    FAST = "fast"
    FULL = "full"


class FallbackReason(str, Enum):
    """Why a sample took the full continuation (``Band.reason``; its value is a short tag)."""

    NO_REFERENCE = "no_reference"
    """No reference for this model (parameter vector of another length)."""
    REFERENCE_UNUSABLE = "reference_unusable"
    """Every reference with the sample's Hopf points has a PD/NS bifurcation, a real
    crossing, a failed branch or a band end that is not a label."""
    STABILITY_FAILED = "stability_failed"
    """The eigenvalue analysis of the steady state failed."""
    REAL_CROSSING = "real_crossing"
    """A real eigenvalue crosses zero in the speed range."""
    HOPF_SIGNATURE = "hopf_signature"
    """No reference has the sample's number and criticalities of Hopf points (a band
    opens or closes, a Bautin point is crossed)."""
    NARROW_BAND = "narrow_band"
    """A narrow band lies between two grid speeds."""
    FOLD_NOT_FOLLOWED = "fold_not_followed"
    """A fold could not be followed from the reference to the sample."""
    FOLD_AMPLITUDE = "fold_amplitude"
    """A fold's amplitude fell below ``min_fold_amplitude`` of the reference's (Bautin point near)."""
    FOLD_OUT_OF_RANGE = "fold_out_of_range"
    """A fold left the speed range."""
    ORDER_CHANGED = "order_changed"
    """The order of the Hopf and fold speeds differs from the reference's."""
    AMPLITUDE_CYCLE = "amplitude_cycle"
    """No stable cycle found at a chosen speed, neither from the reference's nor along the
    sample's branch from the nearest end of its stable interval."""


@dataclass(frozen=True)
class Band(Result):
    """Bifurcation speeds [km/h], bands [km/h] and amplitudes [m] of one parameter set.

    ``amplitude_x_m[i]`` is the largest tread amplitude (half peak-to-peak of ``x``) of a
    stable cycle at the i-th chosen speed (0 where there is none). ``path`` is
    :class:`BandPath` (``"fast"`` or ``"full"``); ``reason`` is the :class:`FallbackReason`
    when the fast path was tried and did not apply (None otherwise), ``detail`` its message.
    """

    hopf_kmh: tuple[float, ...]
    hopf_criticality: tuple[str, ...]
    folds_kmh: tuple[float, ...]
    fold_amplitude_x_m: tuple[float, ...]
    linear_band_kmh: tuple[tuple[float, float], ...]
    sev_band_kmh: tuple[tuple[float, float], ...]
    hard_regions_kmh: tuple[tuple[float, float], ...]
    amplitude_speeds_kmh: tuple[float, ...] = ()
    amplitude_x_m: tuple[float, ...] = ()
    path: BandPath = BandPath.FULL
    reason: FallbackReason | None = None
    detail: str = ""
    gaps_after_pd_ns_kmh: tuple[tuple[float, float], ...] = ()
    """Gaps of the SEV band [km/h] that start or end at a period doubling or torus
    bifurcation with steady rolling stable, where the motion past it may persist (full path
    only: ``BifurcationDiagram.gaps_after_pd_ns_kmh``, by :func:`~polywear.dynamics.diagram.sev_band`;
    the fast path's references have none)."""

    def _dataset(self):
        """Hopf points, folds and amplitudes [m] along their own dimensions; bands [km/h] as (n, 2)."""
        import xarray as xr

        def bands(b):
            return np.array(b, dtype=float).reshape(-1, 2)

        return xr.Dataset(
            {
                "hopf_kmh": ("hopf", np.array(self.hopf_kmh, dtype=float), {"units": "km/h"}),
                "hopf_criticality": ("hopf", np.array(self.hopf_criticality, dtype=str)),
                "folds_kmh": ("fold", np.array(self.folds_kmh, dtype=float), {"units": "km/h"}),
                "fold_amplitude_x": ("fold", np.array(self.fold_amplitude_x_m, dtype=float), {"units": "m"}),
                "amplitude_x": ("amplitude_speed_kmh", np.array(self.amplitude_x_m, dtype=float), {"units": "m"}),
                "linear_band_kmh": (("linear_band", "end"), bands(self.linear_band_kmh), {"units": "km/h"}),
                "sev_band_kmh": (("sev_band", "end"), bands(self.sev_band_kmh), {"units": "km/h"}),
                "hard_regions_kmh": (("hard_region", "end"), bands(self.hard_regions_kmh), {"units": "km/h"}),
                "gaps_after_pd_ns_kmh": (("gap", "end"), bands(self.gaps_after_pd_ns_kmh), {"units": "km/h"}),
            },
            coords={"amplitude_speed_kmh": np.array(self.amplitude_speeds_kmh, dtype=float), "end": ["low", "high"]},
            attrs={"path": str(self.summary()["path"]), "reason": str(self.summary()["reason"] or "")},
        )

    def plot(self, ax=None):
        """SEV band shaded, Hopf points and folds on the speed axis, amplitudes [mm]. Returns artists."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(7, 3))
        artists = [ax.axvspan(lo, hi, color="tab:orange", alpha=0.15) for lo, hi in self.sev_band_kmh]
        artists += ax.plot(self.hopf_kmh, [0.0] * len(self.hopf_kmh), "o", color="tab:red", label="Hopf")
        artists += ax.plot(self.folds_kmh, np.array(self.fold_amplitude_x_m) * 1e3, "s", color="k", label="fold")
        artists += ax.plot(self.amplitude_speeds_kmh, np.array(self.amplitude_x_m) * 1e3, "^", color="tab:blue",
                           label="stable cycle")
        ax.set_xlabel("speed [km/h]")
        ax.set_ylabel("amplitude x [mm]")
        ax.set_title(f"SEV band ({self.summary()['path']} path)", fontsize=10)
        ax.legend(fontsize=8)
        return artists

    @property
    def first_bifurcation_speed_kmh(self) -> float:
        """Lowest speed of the SEV band (NaN without a band)."""
        return self.sev_band_kmh[0][0] if self.sev_band_kmh else np.nan

    @property
    def second_bifurcation_speed_kmh(self) -> float:
        """Highest speed of the SEV band (NaN without a band)."""
        return self.sev_band_kmh[-1][1] if self.sev_band_kmh else np.nan

    def summary(self) -> dict:
        """The band as JSON; tread amplitudes in mm (the attributes hold them in m)."""
        return with_deprecated_keys({
            "hopf_kmh": list(self.hopf_kmh),
            "hopf_criticality": list(self.hopf_criticality),
            "folds_kmh": list(self.folds_kmh),
            "fold_amplitude_x_mm": [1e3 * a for a in self.fold_amplitude_x_m],
            "linear_band_kmh": [list(b) for b in self.linear_band_kmh],
            "sev_band_kmh": [list(b) for b in self.sev_band_kmh],
            "hard_regions_kmh": [list(b) for b in self.hard_regions_kmh],
            "gaps_after_pd_ns_kmh": [list(b) for b in self.gaps_after_pd_ns_kmh],
            "amplitude_speeds_kmh": list(self.amplitude_speeds_kmh),
            "amplitude_x_mm": [1e3 * a for a in self.amplitude_x_m],
            "path": self.path.value,
            "reason": None if self.reason is None else self.reason.value,
            "detail": self.detail,
        }, {"fold_amplitude_x_mm": ("fold_amplitude_x_m", 1e-3), "amplitude_x_mm": ("amplitude_x_m", 1e-3)})


def _stable_amplitude(cycles, ix: int) -> float:
    """Largest amplitude of state ``ix`` among the stable cycles (0 if none)."""
    return max((float(c.amplitude[ix]) for c in cycles if c.stable), default=0.0)


def band_from_diagram(diagram, amplitude_speeds_kmh=(), fallback=None) -> Band:
    """The :class:`Band` of a full bifurcation diagram (amplitudes by Newton at each speed);
    ``fallback`` (a :class:`Fallback`) when the fast path was tried first."""
    ix = diagram.state_names.index("x")
    speeds = tuple(float(v) for v in amplitude_speeds_kmh)
    return Band(
        hopf_kmh=tuple(h.speed_kmh for h in diagram.hopf_points),
        hopf_criticality=tuple(h.criticality for h in diagram.hopf_points),
        folds_kmh=tuple(f.speed_kmh for f in diagram.folds),
        fold_amplitude_x_m=tuple(float(f.amplitude[ix]) for f in diagram.folds),
        linear_band_kmh=tuple(tuple(b) for b in diagram.linear_band_kmh),
        sev_band_kmh=tuple(tuple(b) for b in diagram.sev_band_kmh),
        hard_regions_kmh=tuple(tuple(b) for b in diagram.hard_regions_kmh),
        amplitude_speeds_kmh=speeds,
        amplitude_x_m=tuple(_stable_amplitude(diagram.cycles_at(v), ix) for v in speeds),
        path=BandPath.FULL,
        reason=None if fallback is None else fallback.reason,
        detail="" if fallback is None else fallback.detail,
        gaps_after_pd_ns_kmh=tuple(tuple(g) for g in diagram.gaps_after_pd_ns_kmh),
    )


@dataclass(frozen=True)
class Fallback:
    """Why the fast path does not apply to a sample: the typed reason and a message."""

    reason: FallbackReason
    detail: str = ""


class _Fallback(Exception):
    """The fast path does not apply to this sample (``reason``; the message says more)."""

    def __init__(self, reason: FallbackReason, detail: str):
        super().__init__(detail)
        self.fallback = Fallback(reason, detail)


def _difference(p: np.ndarray, p_ref: np.ndarray) -> np.ndarray:
    """``p - p_ref``, zero in slots that are not parameters (NaN: a model's per-speed cache)."""
    both = np.isfinite(p) & np.isfinite(p_ref)
    return np.where(both, p - np.where(both, p_ref, 0.0), 0.0)


def _distance(p: np.ndarray, p_ref: np.ndarray) -> float:
    """Squared relative distance [-] of two kernel parameter vectors (the nearest reference)."""
    return float(np.sum((_difference(p, p_ref) / (np.abs(p_ref) + 1e-12)) ** 2))
