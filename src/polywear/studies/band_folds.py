"""Single folds of a car followed in the parameters from a pilot reference, each deciding one
piece of the SEV band a study needs (the edges path, :mod:`.edges`, then skips that branch).

- :func:`top_fold`: the fold that ends the band above a hard last Hopf point.
- :func:`gap_fold`: the first fold of the third Hopf point's branch, which bounds the band
  in the gap between the two intervals of the linear band (Hopf criticalities
  :data:`GAP_FOLD_CRITICALITY`).

Each is the fast path's fold following (:meth:`~polywear.studies.fast_band.FastBand.follow_fold`)
from the nearest reference that has that fold; ``solver`` is the
:class:`~polywear.studies.fast_band.FastBand` whose references and settings are used.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..models import model_for
from ..params import Params
from ..units import ms_to_kmh
from .band import LABEL_TOL_KMH, Band, Fallback, FallbackReason, _distance, _Fallback

__all__ = ["GAP_FOLD_CRITICALITY", "GapFold", "TopFold", "gap_fold", "top_fold"]


@dataclass(frozen=True)
class TopFold:
    """The top of a SEV band from :func:`top_fold`: the last Hopf point (hard) and
    the fold above it where the stable cycles of the last hard region end [km/h], and the
    fold's tread amplitude [m]."""

    hopf_kmh: float
    fold_kmh: float
    amplitude_x_m: float


@dataclass(frozen=True)
class GapFold:
    """The band in the gap between the two intervals of the linear band from
    :func:`gap_fold`: the second and third Hopf points and the first fold of the
    third's branch below it [km/h], and the fold's tread amplitude [m]."""

    second_hopf_kmh: float
    hopf_kmh: float
    fold_kmh: float
    amplitude_x_m: float


def _top_fold_index(diagram, band: Band) -> int | None:
    """Index of the fold that ends ``band`` (of ``diagram``) above its last Hopf point, a hard
    one, with the last hard region from that point to the fold; None if there is none, a
    branch failed or a real eigenvalue crosses."""
    if (not band.hopf_kmh or band.hopf_criticality[-1] != "hard" or not band.hard_regions_kmh
            or diagram.stability.real_crossings_kmh or any(info["failed"] for info in diagram.branch_info)):
        return None
    top = band.sev_band_kmh[-1][1]
    j = next((k for k, v in enumerate(band.folds_kmh) if abs(v - top) <= LABEL_TOL_KMH), None)
    a, b = band.hard_regions_kmh[-1]
    if j is None or abs(a - band.hopf_kmh[-1]) > LABEL_TOL_KMH or abs(b - top) > LABEL_TOL_KMH:
        return None
    return j


GAP_FOLD_CRITICALITY = ("hard", "soft", "hard", "hard")
"""Hopf criticalities of the cars whose gap between the two intervals of the linear band is
taken from the first fold of the third Hopf point's branch (:func:`gap_fold`)."""


def _gap_fold_index(diagram, band: Band, folds) -> int | None:
    """Index into ``folds`` (the LP points of ``diagram``'s branches, in order) of the first fold
    ``F`` of the branch from the third of four Hopf points (:data:`GAP_FOLD_CRITICALITY`) when
    it decides the band in the gap: ``F`` between the first and that Hopf point, no PD or NS
    point on the branch until it is back above that point's speed, and the SEV band's
    interval through [max(F, second Hopf point), third Hopf point] starting there; None
    otherwise, or where a branch failed or a real eigenvalue crosses."""
    if (tuple(band.hopf_criticality) != GAP_FOLD_CRITICALITY or diagram.stability.real_crossings_kmh
            or any(info["failed"] for info in diagram.branch_info)):
        return None
    second, third = band.hopf_kmh[1], band.hopf_kmh[2]
    b = next((k for k, info in enumerate(diagram.branch_info)
              if abs(info["from_hopf_kmh"] - third) <= LABEL_TOL_KMH), None)
    if b is None:
        return None
    branch = diagram.branches[b]
    lp = next(((point, k) for label, point, k in branch.special if label == "LP"), None)
    if lp is None or not band.hopf_kmh[0] < ms_to_kmh(lp[0].orbit.speed) < third:
        return None
    fold, k_fold = lp[0], lp[1]
    speeds = [ms_to_kmh(pt.orbit.speed) for pt in branch.points]
    back = next((k for k in range(k_fold + 1, len(speeds)) if speeds[k] >= third), len(speeds))
    if any(label in ("PD", "NS") and k <= back for label, _, k in branch.special):
        return None
    low = max(ms_to_kmh(fold.orbit.speed), second)
    piece = next(((a, c) for a, c in band.sev_band_kmh if a - LABEL_TOL_KMH <= low and third <= c), None)
    if piece is None or (low > second and abs(piece[0] - low) > LABEL_TOL_KMH):
        return None
    return next(j for j, f in enumerate(folds) if f is fold)


def top_fold(solver, params: Params) -> TopFold | Fallback:
    """The fold that ends the SEV band of ``params`` above its last Hopf point, a hard one,
    followed in the parameters from the nearest reference that has such a fold
    (:attr:`BandReference.top_fold`, any Hopf signature, usable or not), as the fast
    path follows folds; or why not (no such Hopf point or reference, the fold not
    followed, its amplitude below ``min_fold_amplitude`` of the reference's, or not
    between that Hopf point and the range's upper end)."""
    linear = _linear(solver, params)
    if isinstance(linear, Fallback):
        return linear
    model, p, stab = linear
    if not stab.hopf_points or stab.hopf_points[-1].criticality != "hard":
        return Fallback(FallbackReason.HOPF_SIGNATURE, "the last Hopf point is not a hard one")
    refs = [r for r in solver.references if r.p.shape == p.shape and r.top_fold is not None]
    if not refs:
        return Fallback(FallbackReason.NO_REFERENCE, "no reference with a fold above a hard last Hopf point")
    ref = min(refs, key=lambda r: _distance(p, r.p))
    j = ref.top_fold
    try:
        point = solver.follow_fold(model, p, ref, j)
    except _Fallback as exc:
        return exc.fallback
    amplitude = float(point.orbit.amplitude()[model.index("x")])
    if amplitude < solver.min_fold_amplitude * ref.band.fold_amplitude_x_m[j]:
        return Fallback(FallbackReason.FOLD_AMPLITUDE, f"top fold: amplitude {amplitude:.3g} m, below "
                        f"{solver.min_fold_amplitude} of the reference's")
    hopf, fold = stab.hopf_points[-1].speed_kmh, ms_to_kmh(point.orbit.speed)
    if not hopf < fold < solver.speed_range_kmh[1]:
        return Fallback(FallbackReason.ORDER_CHANGED if fold <= hopf else FallbackReason.FOLD_OUT_OF_RANGE,
                        f"top fold at {fold:.2f} km/h, not between the last Hopf point ({hopf:.2f} km/h) "
                        f"and {solver.speed_range_kmh[1]:g} km/h")
    return TopFold(hopf, fold, amplitude)

def _linear(solver, params: Params):
    """``(model, packed parameters, stability)`` of the car for :func:`top_fold` and
    :func:`gap_fold`, or the :class:`Fallback` where stability fails or a real
    eigenvalue crosses."""
    from ..dynamics.stability import StabilitySettings, stability

    model = model_for(params)
    p = model.pack(params)
    try:
        stab = stability(params, solver.speed_range_kmh, StabilitySettings(n_speeds=solver.n_grid))
    except RuntimeError as exc:
        return Fallback(FallbackReason.STABILITY_FAILED, f"stability: {exc}")
    if stab.real_crossings_kmh:
        return Fallback(FallbackReason.REAL_CROSSING, "real eigenvalue crossing")
    return model, p, stab

def gap_fold(solver, params: Params) -> GapFold | Fallback:
    """The band in the gap between the two intervals of the linear band of a car with
    four Hopf points of criticalities :data:`GAP_FOLD_CRITICALITY`: the first fold ``F``
    of the third Hopf point's branch followed in the parameters from the nearest
    reference of the same criticalities that has it (:attr:`BandReference.gap_fold`,
    usable or not), as :func:`top_fold` follows the top; the piece of the band is
    [max(F, second Hopf point), third Hopf point]. Or why not (other criticalities, no
    such reference, the fold not followed, its amplitude below ``min_fold_amplitude`` of
    the reference's, or not between the first and the third Hopf point)."""
    linear = _linear(solver, params)
    if isinstance(linear, Fallback):
        return linear
    model, p, stab = linear
    criticality = tuple(h.criticality for h in stab.hopf_points)
    if criticality != GAP_FOLD_CRITICALITY:
        return Fallback(FallbackReason.HOPF_SIGNATURE, f"Hopf points {tuple(str(c) for c in criticality)}, "
                        f"not {GAP_FOLD_CRITICALITY}")
    refs = [r for r in solver.references if r.p.shape == p.shape and r.gap_fold is not None]
    if not refs:
        return Fallback(FallbackReason.NO_REFERENCE, "no reference with the third Hopf point's fold")
    ref = min(refs, key=lambda r: _distance(p, r.p))
    j = ref.gap_fold
    try:
        point = solver.follow_fold(model, p, ref, j)
    except _Fallback as exc:
        return exc.fallback
    ix = model.index("x")
    amplitude, ref_amplitude = float(point.orbit.amplitude()[ix]), float(ref.folds[j].orbit.amplitude()[ix])
    if amplitude < solver.min_fold_amplitude * ref_amplitude:
        return Fallback(FallbackReason.FOLD_AMPLITUDE, f"gap fold: amplitude {amplitude:.3g} m, below "
                        f"{solver.min_fold_amplitude} of the reference's")
    first, second, third = (h.speed_kmh for h in stab.hopf_points[:3])
    fold = ms_to_kmh(point.orbit.speed)
    if not first < fold < third:
        return Fallback(FallbackReason.ORDER_CHANGED, f"gap fold at {fold:.2f} km/h, not between the first "
                        f"({first:.2f} km/h) and the third Hopf point ({third:.2f} km/h)")
    return GapFold(second, third, fold, amplitude)
