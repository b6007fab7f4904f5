"""One distance step of the wear evolution (:mod:`polywear.wear.evolution`): the writes of
the step's windows as rates, the profile's update over the step, and the predictor,
corrector and error estimate of the error control.

The coherent writes are ``dW/dN = a W + b + c W_m/|W_m| + t (W_m/|W_m|)^j`` (:func:`step_rates`):
``a`` the growth of the speeds that are not locked, ``b`` the fixed writes of the locked ones
(and the unlocked ones' writes on harmonics too small to give a rate),
``c`` a locked vibration's write at its locking order m, which keeps its direction to W_m,
and ``t`` its writes at the multiples j m, which turn j times as fast. :func:`update_profile`
integrates that over the step, exactly where it can (``docs/wear.md``, "How the fast
evolution works", points 7 and 11).
"""

from __future__ import annotations

import math

import numpy as np

from .windows import WindowWear

__all__ = ["update_profile", "turning_orders", "pinned_step", "step_rates", "predict", "corrected", "curvature",
           "step_error",
           "MAX_CHANGE", "MAX_EXPONENT", "PROPORTIONAL_FLOOR"]

MAX_CHANGE = 0.3
"""A distance step is shortened so that the change of the profile stays below this
fraction of its largest harmonic (fast growth after locking is resolved, not jumped
over) [-]: the whole change where the tread vibrates, only the part added rather than
integrated exactly where rolling is steady (there the exponential update is exact)."""
PROPORTIONAL_FLOOR = 1e-6
"""An unlocked window's write at a harmonic below this fraction of the profile's largest is
a forcing, not a rate ``S_n / W_n`` [-]: axle4dof at 110 km/h (vibrating at order 8.500,
order 1 passing through zero at 7e-13 m, 6e-9 of the largest) wrote 1.2e-13 m per
revolution there, a "growth" of 0.16 per revolution that, applied to the step's own
W_1 of 1.7e-6 m, wrote 0.015 mm on order 1 in a step of 0.2 km (docs/wear.md, point 13)."""
MAX_EXPONENT = 3.0
"""Largest exponent |N S_n / W_n| integrated exactly in one step; above, the write is added [-],
unless the harmonic decays (Re < -MAX_EXPONENT: exact at any exponent; added, a decay by
x = -10 flipped the harmonic and grew it ninefold, and the change limit held the steps of
fleet car 11, whose drifting vibration wears order 8 away, near 60 km; docs/wear.md)."""
_GAUSS = np.polynomial.legendre.leggauss(16)
_NODES, _WEIGHTS = 0.5 * (_GAUSS[0] + 1.0), 0.5 * _GAUSS[1]
"""16-point Gauss-Legendre nodes and weights on [0, 1] for the turn of a pinned harmonic (:func:`pinned_step`)."""


def update_profile(W: np.ndarray, x: np.ndarray, forcing: np.ndarray, pinned: np.ndarray | None = None,
                   turning: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """W after a step (see module notes) and the part of the change that was added rather
    than integrated exactly. ``x``: exponents ``a N`` of the writes proportional to W (the
    speeds not locked); ``forcing``: writes ``b N`` [m] that do not depend on W (the locked
    speeds'); ``pinned``: writes ``c N`` [m] of locked vibrations at their locking order,
    whose direction keeps to that of W there (``dW/dN = c W/|W|``, :func:`pinned_step`);
    ``turning``: their writes ``t N`` [m] at the multiples j m of that order, relative to
    the direction of W_m to the power j (:func:`turning_orders`): they turn j times as fast
    as W_m, whose turn over the step is taken as uniform.
    dW/dN = a W + b is integrated exactly, ``W e^x + forcing (e^x - 1)/x``."""
    rms = math.sqrt(0.5 * float(np.sum(np.abs(W) ** 2)))
    pinned = np.zeros_like(W) if pinned is None else pinned
    turning = np.zeros_like(W) if turning is None else turning
    along = pinned * np.exp(1j * np.angle(W))  # the pinned writes in the direction of W
    multiples = turning_orders(pinned)
    forcing = forcing.copy()
    for n, (m, j) in multiples.items():  # at the start of the step, in the direction of W_m^j
        forcing[n] += turning[n] * np.exp(1j * j * np.angle(W[m]))
    out = W + x * W + forcing + along
    added = out - W
    big = np.abs(W) > 1e-6 * rms
    ok = big & ((np.abs(x) <= MAX_EXPONENT) | (x.real < -MAX_EXPONENT))  # a decay is exact at any exponent
    growth = np.exp(x[ok])
    small = np.abs(x[ok]) < 1e-12
    phi = np.where(small, 1.0, (growth - 1.0) / np.where(small, 1.0, x[ok]))  # (e^x - 1)/x
    out[ok] = W[ok] * growth + forcing[ok] * phi + along[ok]
    added[ok] = forcing[ok] * phi + along[ok]
    turns = {}
    for n in np.flatnonzero(ok & (pinned != 0)):
        pinned_end = pinned_step(W[n], x[n], pinned[n])
        if pinned_end is not None:  # else the pinned write all but erases W_n: added
            turned, turns[n] = pinned_end
            out[n] += turned - W[n] * np.exp(x[n]) - along[n]
            added[n] -= along[n]
    for n, (m, j) in multiples.items():
        if not ok[n] or m not in turns or turning[n] == 0:
            continue
        # dW_n/ds = x_n W_n + f e^(i j turn s): W_n e^x + f e^x phi(i j turn - x), phi(z) = (e^z - 1)/z
        start = turning[n] * np.exp(1j * j * np.angle(W[m]))
        fixed = start * _phi(x[n])
        out[n] += start * np.exp(x[n]) * _phi(1j * j * turns[m] - x[n]) - fixed
        added[n] -= fixed
    return out, added


def _phi(z: complex) -> complex:
    """``(e^z - 1)/z`` (1 at z = 0)."""
    return 1.0 if abs(z) < 1e-12 else complex(np.expm1(z) / z)


def turning_orders(pinned: np.ndarray) -> dict[int, tuple[int, int]]:
    """Harmonic index n -> (m, j) for the multiples n + 1 = j (m + 1), j >= 2, of the locking
    orders (indices m where ``pinned`` is not zero), the smallest locking order first; a
    multiple that is itself a locking order, or already taken, is left out. A vibration
    locked at order m is periodic in 1/m of a revolution, so what it writes by itself lies
    on these harmonics, and it moves with its phase, which keeps to W_m: its write at
    j m turns j times as fast as W_m (docs/wear.md, point 11)."""
    K = pinned.size
    locking = [int(m) for m in np.flatnonzero(pinned)]
    out: dict[int, tuple[int, int]] = {}
    for m in locking:
        for j in range(2, K // (m + 1) + 1):
            n = j * (m + 1) - 1
            if n not in out and n not in locking:
                out[n] = (m, j)
    return out


def pinned_step(W: complex, x: complex, c: complex) -> tuple[complex, float] | None:
    """``W`` after a step of ``dW/ds = x W + c W/|W|``, s in [0, 1], and its turn [rad]: in
    polar form ``rho' = Re(x) rho + Re(c)`` (exact: ``rho0 e^(ks) + Re(c) (e^(ks) - 1)/k``,
    k = Re x) and ``alpha' = Im(x) + Im(c)/rho`` (16-point Gauss-Legendre over the step, rho
    smooth and monotone). None where rho falls below a tenth of its start (the write erases W)."""
    rho0, k = abs(W), x.real
    grow = np.exp(k * _NODES)
    rho = rho0 * grow + c.real * (_NODES if abs(k) < 1e-12 else (grow - 1.0) / k)
    end = rho0 * math.exp(k) + c.real * (1.0 if abs(k) < 1e-12 else math.expm1(k) / k)
    if end <= 0.1 * rho0 or float(np.min(rho)) <= 0.1 * rho0:
        return None
    turn = x.imag + c.imag * float(np.sum(_WEIGHTS / rho))
    return end * np.exp(1j * (np.angle(W) + turn)), turn


def step_error(W_new, W_pred) -> float:
    """Error estimate of a step [-]: the largest difference of a harmonic between the second-
    and the first-order profile, relative to the largest harmonic (sizes and phases: a locked
    pattern turns around the tire as it deepens)."""
    return float(np.max(np.abs(W_new - W_pred))) / max(float(np.max(np.abs(W_new))), 1e-30)


def _unlocked(win: WindowWear) -> bool:
    """A window whose coherent writes are proportional to the profile: the tread vibrates
    without locking, or rolls steadily."""
    return not (win.locked and math.isfinite(win.order))


def _proportional(win: WindowWear) -> np.ndarray:
    """Harmonics (K,) bool whose write an unlocked window gives as proportional to the profile
    there: where W_n is at least PROPORTIONAL_FLOOR of the largest harmonic. Below it the
    write is what the other harmonics force there (a vibration at order 8.5 mixing W_9 and
    W_8 writes on order 1), and its ratio to a W_n near zero is no growth rate."""
    return np.abs(win.profile) >= PROPORTIONAL_FLOOR * float(np.max(np.abs(win.profile)))


def _exponents(win: WindowWear, proportional: np.ndarray) -> np.ndarray:
    """Coherent growth per revolution ``S_n / W_n`` (K,) of an unlocked window (0 where W_n is
    not ``proportional``, :func:`_proportional`)."""
    ok = proportional & (win.profile != 0)
    return np.where(ok, win.coherent / np.where(ok, win.profile, 1), 0)


def step_rates(wins, n_revs, turning: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Coherent writes of a step's windows as ``dW/dstep = x W + b + c W/|W| + t (W_m/|W_m|)^j``:
    ``x`` (K,) the summed exponents ``N S_n / W_n`` of the speeds not locked (their write is
    proportional to the profile they ran with); ``c`` (K,) [m] at the locking order m =
    round(nu) of a locked speed its write ``N S_m`` turned into the direction of W_m (the
    locked vibration keeps its phase to W_m, so its write there turns with W_m: a pattern
    worn across W_m travels around the tire, :func:`_locking_index`); ``t`` (K,) [m] its
    writes at the multiples j m, relative to the direction of W_m to the power j
    (:func:`turning_orders`; with ``turning`` False they stay in ``b``); ``b`` (K,) [m]
    the other writes ``N S`` of the locked ones, and those of the unlocked ones on harmonics
    too small to give a rate (:func:`_proportional`)."""
    K = wins[0].coherent.size
    x, b, c, t = (np.zeros(K, dtype=complex) for _ in range(4))
    locked = []
    for n, w in zip(n_revs, wins):
        if _unlocked(w):
            proportional = _proportional(w)
            x = x + n * _exponents(w, proportional)
            b = b + n * np.where(proportional, 0, w.coherent)
            continue
        b = b + n * w.coherent
        m = _locking_index(w)
        if m is not None:
            c[m] += n * w.coherent[m] * np.exp(-1j * np.angle(w.profile[m]))
            b[m] -= n * w.coherent[m]
            locked.append((n, w, m))
    if turning:
        for k, (m, j) in turning_orders(c).items():
            for n, w, m_w in locked:
                if m_w == m:
                    t[k] += n * w.coherent[k] * np.exp(-1j * j * np.angle(w.profile[m]))
                    b[k] -= n * w.coherent[k]
    return x, b, c, t


def _locking_index(win: WindowWear) -> int | None:
    """Index of the locking order m = round(nu) of a locked window, whose write there keeps to
    the direction of W_m (None: no such order, or W_m below 1e-6 of the profile's largest
    harmonic, where the write is the pattern's own and does not turn with it)."""
    m = round(win.order) - 1
    if not 0 <= m < win.profile.size:
        return None
    return m if abs(win.profile[m]) > 1e-6 * float(np.max(np.abs(win.profile))) else None


def predict(W, wins, h, cycle, R):
    """Profile after a step of ``h`` [km] with the writes of the windows at its start (first
    order), the step shortened while the change exceeds MAX_CHANGE; returns the profile,
    the step and the revolutions per speed."""
    for _ in range(8):
        n_revs = [share * h * 1000.0 / (2.0 * math.pi * R) for _, share in cycle]
        W_new, added = update_profile(W, *step_rates(wins, n_revs))
        drifting_total = sum(w.written(n) - n * w.coherent for n, w in zip(n_revs, wins))
        W_new = W_new + drifting_total
        # what is not integrated exactly (the growth x W and the turn of a pinned write are,
        # while x and c hold; the error estimate of the step tells when they do not)
        change = float(np.max(np.abs(added + drifting_total))) / max(float(np.max(np.abs(W))), 1e-30)
        if change <= MAX_CHANGE:
            break
        h *= 0.8 * MAX_CHANGE / change
    return W_new, h, n_revs


def corrected(W, wins, n_revs, ends, W_pred, before=None, ratio: float = 1.0):
    """Profile after the step with the mean of the writes at its start (``wins``, at W) and at
    its end (``ends``, run at the predicted ``W_pred``): the trapezoid rule, second order;
    with the windows at the start of the step ``before`` (``ratio``: this step over that
    one), the exponents get the trapezoid's curvature term (:func:`curvature`)."""
    start, end = step_rates(wins, n_revs), step_rates(ends, n_revs)
    if not np.array_equal(start[2] != 0, end[2] != 0):  # locked at other orders at its two ends
        start, end = step_rates(wins, n_revs, turning=False), step_rates(ends, n_revs, turning=False)
    x, b, c, t = (0.5 * (a + z) for a, z in zip(start, end))
    if before is not None:
        x = x + curvature(step_rates(before, n_revs)[0], start[0], end[0], ratio,
                          [_unlocked(w) for w in before] == [_unlocked(w) for w in wins] == [_unlocked(w) for w in ends])
    drifting_total = sum(w.written(n) - n * w.coherent for n, w in zip(n_revs, wins))
    return update_profile(W, x, b, c, t)[0] + drifting_total


def curvature(x_before, x_start, x_end, ratio: float, same_speeds_unlocked: bool = True) -> np.ndarray:
    """The curvature term of the trapezoid rule for the exponents (K,) of a step: with the
    exponents ``x`` over this step's revolutions at the start of the step before, at the start
    and at the end of this one, ``ratio`` = h / h_before, the quadratic through the three
    integrates to the trapezoid minus ``ratio/(6 (1 + ratio)) ((x_end - x_start) - ratio
    (x_start - x_before))`` (-(x_end - 2 x_start + x_before)/12 at equal steps), the
    trapezoid's own error -h^3 x''/12. The error estimate of the step (first against second
    order) does not see it, and over the 5-7 e-folds of an unlocked growth it added up to
    1 % of the harmonic (docs/wear.md, point 14). Zero on harmonics without an exponent at
    one of the three, and everywhere where the speeds that are not locked differ among them
    (``same_speeds_unlocked`` False)."""
    if not same_speeds_unlocked:
        return np.zeros_like(x_start)
    ok = (x_before != 0) & (x_start != 0) & (x_end != 0)
    term = -ratio / (6.0 * (1.0 + ratio)) * ((x_end - x_start) - ratio * (x_start - x_before))
    return np.where(ok, term, 0)
