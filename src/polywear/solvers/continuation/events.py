"""Period doubling (PD) and torus (Neimark-Sacker, NS) points between two points of a branch.

:func:`_multiplier_events` tells from the counts of Floquet multipliers outside the unit
circle which kinds of crossing lie between two points; :func:`_locate_crossing` locates
one on the branch by root finding in the arclength on a test function of the
multipliers (:func:`_pd_test`, or the modulus of the crossing complex pair), or by
bisection on the counts where no single crossing can be followed.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .branch import BranchPoint
from .stepper import _align_to_kinks, _secant_in_bracket, _Step

__all__ = ["CROSSING_ITERATIONS"]


def _nontrivial(multipliers: np.ndarray) -> np.ndarray:
    """The Floquet multipliers without the trivial one (the one nearest 1)."""
    return np.delete(multipliers, int(np.argmin(np.abs(multipliers - 1.0))))


def _event_counts(point: BranchPoint) -> dict[str, int]:
    """Multipliers outside the unit circle (trivial one excluded): real negative ("PD"), complex
    ("NS"), real positive ("+1")."""
    mu = [complex(z) for z in point.multipliers.tolist()]  # a few numbers: plain Python is faster
    trivial = min(range(len(mu)), key=lambda k: abs(mu[k] - 1.0))
    counts = {"PD": 0, "NS": 0, "+1": 0}
    for k, z in enumerate(mu):
        if k != trivial and abs(z) > 1.0:
            if not abs(z.imag) < 1e-8 * abs(z):
                counts["NS"] += 1
            elif z.real != 0.0:
                counts["PD" if z.real < 0 else "+1"] += 1
    return counts


def _multiplier_events(a: BranchPoint, b: BranchPoint) -> list[str]:
    """Period doubling (PD) and torus (NS) crossings between two consecutive points."""
    ca, cb = _event_counts(a), _event_counts(b)
    return [label for label in ("PD", "NS") if ca[label] != cb[label]]


def _pd_test(multipliers: np.ndarray) -> float:
    """Test function of period doubling: the product of ``(mu + 1) / (|mu| + 1)`` over the
    non-trivial multipliers. Each factor lies in [-1, 1] and a complex pair gives
    ``|mu + 1|^2 / (|mu| + 1)^2 > 0``, so it is continuous along the branch (also where two
    real multipliers meet and become a complex pair) and changes sign exactly where a real
    multiplier crosses -1; its sign is (-1)^(number of real multipliers below -1)."""
    mu = _nontrivial(multipliers)
    return float(np.real(np.prod((mu + 1.0) / (np.abs(mu) + 1.0))))


def _pd_residual(multipliers: np.ndarray) -> float:
    """Distance of the non-trivial multiplier nearest -1 from -1."""
    return float(np.min(np.abs(_nontrivial(multipliers) + 1.0)))


def _upper(multipliers: np.ndarray) -> np.ndarray:
    """The non-trivial multipliers with imaginary part >= 0 (one of each complex pair)."""
    mu = _nontrivial(multipliers)
    return mu[mu.imag >= 0.0]


def _ns_pair(a: np.ndarray, b: np.ndarray) -> tuple[complex, complex] | None:
    """The complex multiplier pair that crosses the unit circle between two points with
    multipliers ``a`` and ``b``: complex multipliers (upper half plane), one at each point,
    each the other's nearest there, with moduli on opposite sides of 1 (the closest such
    match); None if there is none (e.g. the count of complex multipliers outside the circle
    changed only because two real ones outside met and became a complex pair)."""
    ua, ub = _upper(a), _upper(b)
    matches = []
    for za in ua[np.abs(ua.imag) >= 1e-8 * np.abs(ua)]:
        zb = ub[np.argmin(np.abs(ub - za))]
        back = ua[np.argmin(np.abs(ua - zb))]
        if back == za and abs(zb.imag) >= 1e-8 * abs(zb) and (abs(za) - 1.0) * (abs(zb) - 1.0) < 0.0:
            matches.append((abs(za - zb), za, zb))
    return min(matches, key=lambda m: m[0])[1:] if matches else None


def _collisions_only(a: BranchPoint, b: BranchPoint) -> bool:
    """True if the change of the counts of multipliers outside the unit circle between two
    points is accounted for by real multipliers crossing +1 or -1 singly (where the parity of
    those counts changed), with the rest only pairs of real multipliers outside meeting and
    becoming a complex pair outside, or the reverse (which is no bifurcation)."""
    ca, cb = _event_counts(a), _event_counts(b)
    total = sum(cb.values()) - sum(ca.values())
    single = [(cb[k] - ca[k]) % 2 for k in ("PD", "+1")]
    return any(total == da + db for da in ((-1, 1) if single[0] else (0,))
               for db in ((-1, 1) if single[1] else (0,)))


def _locate_crossing(start: _Step, ds: float, prev: BranchPoint, point: BranchPoint,
                     label: str) -> BranchPoint | None:
    """The PD or NS point between ``prev`` (arclength 0 from the start X0) and ``point`` (arclength ds).

    PD: root in the arclength of :func:`_pd_test`, which changes sign where a real multiplier
    crosses -1. NS: root of ``|mu| - 1`` of the complex pair that crosses (:func:`_ns_pair`),
    followed from iterate to iterate as the multiplier nearest the value interpolated
    between the bracket's ends. Both by :func:`_crossing_in_bracket`, to
    ``settings.crossing_tol`` on the multiplier. Where the count of such multipliers
    outside the circle changed without such a crossing: None if the counts changed only by
    real pairs outside meeting and becoming complex ones or the reverse
    (:func:`_collisions_only`: no bifurcation), else bisection in the arclength on the count
    (:func:`_bisect_crossing`, several crossings in one step).
    """
    if label == "PD":
        if np.sign(_pd_test(prev.multipliers)) != np.sign(_pd_test(point.multipliers)):
            return _crossing_in_bracket(start, ds, prev, point, label, _pd_value)
    else:
        pair = _ns_pair(prev.multipliers, point.multipliers)
        if pair is not None:
            return _crossing_in_bracket(start, ds, prev, point, label, _ns_value, pair)
    return None if _collisions_only(prev, point) else _bisect_crossing(start, ds, prev, point, label)


def _pd_value(multipliers: np.ndarray, guess: complex) -> tuple[float, complex, float]:
    """(test function, followed multiplier, residual) of period doubling (``guess`` unused)."""
    return _pd_test(multipliers), -1.0, _pd_residual(multipliers)


def _ns_value(multipliers: np.ndarray, guess: complex) -> tuple[float, complex, float]:
    """(|mu| - 1, mu, ||mu| - 1|) of the multiplier in the upper half plane nearest ``guess``."""
    upper = _upper(multipliers)
    z = complex(upper[np.argmin(np.abs(upper - guess))])
    return abs(z) - 1.0, z, abs(abs(z) - 1.0)


CROSSING_ITERATIONS = 30
"""Largest number of correctors of one PD/NS location (:func:`_crossing_in_bracket`)."""


def _crossing_in_bracket(start: _Step, ds: float, prev: BranchPoint, point: BranchPoint, label: str,
                         value: Callable[[np.ndarray, complex], tuple[float, complex, float]],
                         pair: tuple[complex, complex] = (-1.0, -1.0)) -> BranchPoint:
    """Illinois (regula falsi that halves the value at an end kept twice in a row; bisection
    where a step would leave the bracket) in the arclength s from X0 for the root of a test
    function of the multipliers, between ``prev`` (s = 0) and ``point`` (s = ds).

    ``value(multipliers, guess)`` gives the test function, the multiplier followed (the one
    nearest ``guess``, interpolated linearly in s between the bracket's ends ``pair``) and
    the residual (distance of the multiplier from the crossing). Stops when the residual is
    below ``settings.crossing_tol``, after :data:`CROSSING_ITERATIONS` correctors or when the
    bracket is down to rounding. Returns the point with the smallest residual, labelled:
    on the crossing to the tolerance, not a point past it (its stability is marginal);
    ``point`` if the first corrector fails.
    """
    stepper, X0, t0, phase_ref = start
    tol = stepper.settings.crossing_tol
    (g_0, z_0, _), (g_1, z_1, _) = value(prev.multipliers, pair[0]), value(point.multipliers, pair[1])
    ends: list[tuple[float, float, complex]] = [(0.0, g_0, z_0), (ds, g_1, z_1)]  # (s, test function, multiplier)
    best, best_residual, replaced = point, np.inf, -1
    for _ in range(CROSSING_ITERATIONS):
        (s_a, g_a, z_a), (s_b, g_b, z_b) = ends
        s = _secant_in_bracket((s_a, g_a), (s_b, g_b), s_a, s_b)
        out = stepper.correct(X0, t0, s, phase_ref)
        solved_on = stepper
        if out is not None and stepper.settings.align_kinks:  # as the branch's points: kinks on mesh points
            solved_on, *_, out = _align_to_kinks(start, s, out)
        if out is None:
            break
        X, t, iterations, multipliers = out
        g, z, residual = value(multipliers, z_a + (s - s_a) / (s_b - s_a) * (z_b - z_a))
        if residual < best_residual:
            best, best_residual = BranchPoint(solved_on.coll.unpack(X), multipliers, t, iterations), residual
        if residual < tol:
            break
        side = 0 if np.sign(g) == np.sign(g_a) else 1
        ends[side] = (s, g, z)
        if side == replaced:  # the same end replaced twice in a row: halve the other's value (Illinois)
            s_kept, g_kept, z_kept = ends[1 - side]
            ends[1 - side] = (s_kept, 0.5 * g_kept, z_kept)
        replaced = side
        if abs(ends[1][0] - ends[0][0]) <= 1e-12 * abs(ds):
            break
    return BranchPoint(best.orbit, best.multipliers, best.tangent, best.newton_iterations, label)


def _bisect_crossing(start: _Step, ds: float, prev: BranchPoint, point: BranchPoint, label: str,
                     rtol: float = 1e-3) -> BranchPoint:
    """Bisection in the arclength on the count of ``label`` multipliers outside the unit circle,
    to ``rtol * ds`` (where no single crossing can be followed): the first point past the
    first change of the count, labelled; ``point`` if a corrector fails."""
    stepper, X0, t0, phase_ref = start
    before = _event_counts(prev)[label]
    s_a, s_b, best = 0.0, ds, point
    while abs(s_b - s_a) > rtol * abs(ds):
        s = 0.5 * (s_a + s_b)
        out = stepper.correct(X0, t0, s, phase_ref)
        if out is None:
            break
        X, t, iterations, multipliers = out
        trial = BranchPoint(stepper.coll.unpack(X), multipliers, t, iterations)
        if _event_counts(trial)[label] == before:
            s_a = s
        else:
            s_b, best = s, trial
    return BranchPoint(best.orbit, best.multipliers, best.tangent, best.newton_iterations, label)
