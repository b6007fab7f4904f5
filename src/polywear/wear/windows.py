"""The simulated window of the wear evolution: what the coupled model writes per revolution.

At one speed the coupled model (profile -> load, :mod:`polywear.models.profile`) runs with
the current profile, from a given state, for a settling time, then for ``M`` whole
revolutions. Each revolution ``k`` writes harmonics ``D_k`` (a DFT of the sampled
friction power, :func:`_per_revolution`). The dominant frequency of the tread velocity
gives the vibration's order ``nu = f / f_rot``; the writes are split by least squares
(tapered, :func:`_taper`) with the known ratios ``r_j = exp(+-2 pi i j nu)`` into ``D_k = S + sum_j C_j r_j^k``
(:func:`_split`): S is written in the same place every revolution, the C_j drift
(``docs/wear.md``). A vibration is locked when its order is an integer to within
``LOCK_TOLERANCE`` or when its phase relative to the tire settles (``SETTLED_PHASE``).
Where the phase slips by whole periods while the strongest line sits at the integer
order, the order is the mean one (:func:`_slipping_order`).

The profile's load is tabulated over the contact angle (:func:`table_points` points,
:func:`~polywear.models.profile.profile_vector`) instead of summed over all harmonics in
every right-hand side, and the order estimate refines the line of an unpadded spectrum
with a compiled sum.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..models import model_for
from ..models.profile import coupled_model, patch_sinc, profile_vector
from ..params import Params
from ..solvers.integrate import integrate
from .law import energetic_rate, friction_power

__all__ = ["WindowWear", "window_wear", "continued", "coherence", "table_points", "LOCK_TOLERANCE", "SETTLED_PHASE",
           "SEPARATED_BEATS", "FITTED_LINES", "NEAR_SPAN", "MAX_WINDOW",
           "LONG_WINDOW"]

LOCK_TOLERANCE = 1e-6
"""A vibration whose order is this close to an integer is locked [-]."""
SETTLED_PHASE = 0.01
"""A vibration is also locked when its phase relative to the tire settles: the drift of
its phase at the nearest integer order over the last quarter of the window, continued at
the rate it decays from the quarter before, adds up to less than this [cycles]."""
VIBRATION_RMS = 0.01
"""The tread vibrates (self-excited) when the RMS of its velocity fluctuation exceeds this
[m/s]: 10 um at 150 Hz, far above the response to a worn profile of a tenth of a
millimetre and far below the SEV of a vibrating tire (0.1-0.3 m/s)."""
RESOLVABLE = 0.25
"""A drifting line is separated in a window of M revolutions when eps M >= this [-]."""
SIDEBANDS = 2
"""Harmonics j of the vibration whose drifting writes are separated (j = +-1..+-SIDEBANDS):
the window is lengthened for them, and a line too slow to fit gets a reference run."""
FITTED_LINES = 3
"""Harmonics j = SIDEBANDS+1..FITTED_LINES are also fitted as drifting where the window
resolves them (eps_j M >= RESOLVABLE), without lengthening the window [-]: at 110 km/h
(axle4dof, nu = 8.344) the third, at order 25.03, turns by half a period over 16
revolutions; counted as coherent it put 64 % of its drifting write into S_25, three times
the profile's own, scattering from window to window (docs/wear.md)."""
SEPARATED_BEATS = 3.0
"""A window separates the vibration's line from its nearest integer order when the pattern
turns by at least this many periods over it (eps M >= this) [-]: the Hann main lobe is 2
bins wide, so a shorter window mixes the line with the profile's locked response at that
order; the order estimate and the coherent write then depend on where the window starts."""
NEAR_SPAN = 2
"""A line j > SIDEBANDS is fitted on the harmonics m - NEAR_SPAN..m + NEAR_SPAN around its
nearest one m = round(j nu): a revolution's DFT puts a fraction of about eps_j / |n - j nu|
of its write on harmonic n (3 % on each neighbour at eps_j = 0.03) [-]."""
MAX_WINDOW = 64
"""Most revolutions a window is lengthened to for SEPARATED_BEATS [-], the look after which a
vibration closer to an integer order (eps < SEPARATED_BEATS / MAX_WINDOW) gets a longer
window: ``SEPARATED_BEATS / eps`` where its line turns by one to SEPARATED_BEATS periods
over MAX_WINDOW, ``LONG_WINDOW`` where it turns by less than a period."""
LONG_WINDOW = 1024
"""Most revolutions a window is lengthened to for SEPARATED_BEATS where the vibration drifts
by less than one period over MAX_WINDOW (eps MAX_WINDOW < 1) [-]: such a line cannot be
told from the profile's response at its integer order, and 64-revolution windows at the
same profile scattered its coherent write S_m / W_m by more than its size, signs included
(fleet car 11 at 110 km/h, order 8.0035: -7.7e-5 to +7.0e-5 per revolution), against
+-0.6 % over 800 revolutions (docs/wear.md). Lines with eps >= 3 / LONG_WINDOW are separated."""
_RTOL = 1e-5
"""Relative tolerance of the window's integration [-] (the coherent writes move by at most
2e-3 of the largest from 1e-8, near locking at 80 km/h; the evolution costs 0.7x that at
1e-6 and its answers move by 0.01 %: docs/wear.md)."""
_ATOL_FRACTION = 1e-9
"""Absolute tolerance of each state, as a fraction of its size in steady rolling [-]."""
SAMPLES_PER_ORDER = 16
"""Samples of the friction power per revolution per order K [-] (and at least 8000 per
second): at 16 the writes are within 2e-6 (coherent) and 3e-5 (drifting) of the largest
from those at 128 on windows at 80, 110 and 120 km/h; 32 before (docs/wear.md, point 8)."""


def table_points(orders: int) -> int:
    """Points of the load table over the contact angle for ``orders`` harmonics: a power of
    two, at least 64 per order and 4096 (interpolation error of the highest order below
    ``(2 pi / 64)^4 / 384 = 2.4e-7`` of its size, ``polywear.models.profile``)."""
    return max(4096, 1 << math.ceil(math.log2(64 * max(orders, 1))))


def coherence(eps: float, revolutions: float) -> float:
    """``|sin(pi eps M)/(M sin pi eps)|``: the fraction of M coherent writes that a
    pattern drifting by ``eps`` of a period per revolution keeps after M revolutions."""
    s = math.sin(math.pi * eps)
    if abs(s) < 1e-15:
        return 1.0
    return abs(math.sin(math.pi * eps * revolutions) / (revolutions * s))


def _window_sum(x: np.ndarray):
    """Sum of a window's samples, the same in every process: numpy's own pairwise sum.

    A BLAS dot product (``np.dot``) of a long vector splits the sum over BLAS threads,
    so its rounding depends on the thread count, which is fixed when BLAS loads and
    follows ``OPENBLAS_NUM_THREADS``/``OMP_NUM_THREADS``; a worker process started later
    (a fleet's or a study's) may get another count than this process (e.g. after
    ``distributed.LocalCluster`` set those variables to 1 here) and a different window."""
    return np.sum(x)


def _dominant_order(t, signal, f_rot: float) -> float:
    """Order nu = f / f_rot of the dominant spectral line of ``signal``: the largest bin of
    the Hann-windowed spectrum, refined to the maximum of ``|sum x_j exp(-2 pi i f t_j)|``
    within one bin either side (the main lobe, two bins wide, is unimodal there)."""
    x = signal - signal.mean()
    dt = t[1] - t[0]
    n = x.size
    from scipy.fft import next_fast_len

    size = next_fast_len(n, real=True)  # zero-padded to a length FFTs like (n itself can be nearly prime)
    xw = x * np.hanning(n)  # low leakage: neighbouring lines one order away barely bias the peak
    spectrum = np.abs(np.fft.rfft(xw, size))
    k = int(np.argmax(spectrum[1:])) + 1
    from scipy.optimize import minimize_scalar

    df = 1.0 / (size * dt)
    best = minimize_scalar(lambda f: -_line_amplitude(xw, f * dt), bounds=((k - 1) * df, (k + 1) * df),
                           method="bounded", options={"xatol": 1e-10 * k * df})
    return float(best.x) / f_rot


@njit(cache=True)
def _line_amplitude(x, cycles_per_sample: float) -> float:
    """``|sum_j x_j exp(-2 pi i c j)|`` (c cycles per sample), summed in order: the same
    rounding in every process (no BLAS, whose thread count can differ in worker processes)."""
    turn = np.exp(-2j * np.pi * cycles_per_sample)
    rotor = 1.0 + 0.0j
    acc = 0.0 + 0.0j
    for j in range(x.size):
        acc += x[j] * rotor
        rotor *= turn
        if j % 1024 == 1023:  # renormalize: the recurrence drifts by rounding
            rotor = np.exp(-2j * np.pi * cycles_per_sample * (j + 1))
    return abs(acc)


@dataclass
class WindowWear:
    """What one simulated window writes per revolution, split into coherent and drifting parts."""

    coherent: np.ndarray
    """S_n (K,) written in the same place every revolution [m per revolution]"""
    drifting: np.ndarray
    """C_j (2J, K) drifting parts at revolution 0 of the window [m]"""
    ratios: np.ndarray
    """r_j (2J,) turn of each drifting part per revolution"""
    mean_per_rev: float
    """uniform wear per revolution [m]"""
    revolutions: int
    order: float
    """order nu of the dominant vibration (NaN if none)"""
    locked: bool
    end_state: np.ndarray
    energy_per_rev: float
    """friction energy per revolution [J]"""
    profile: np.ndarray
    """the harmonics W_n the window ran with [m]"""

    def rescaled(self, W: np.ndarray) -> WindowWear:
        """This steady-rolling window's writes for the profile ``W``: in the linear regime each
        harmonic's coherent write is proportional to it (the rates S_n / W_n are the map's)."""
        rates = np.where(self.profile != 0, self.coherent / np.where(self.profile != 0, self.profile, 1), 0)
        return WindowWear(coherent=rates * W, drifting=self.drifting[:0], ratios=self.ratios[:0],
                          mean_per_rev=self.mean_per_rev, revolutions=self.revolutions, order=self.order,
                          locked=False, end_state=self.end_state, energy_per_rev=self.energy_per_rev, profile=W.copy())

    def written(self, revolutions: float) -> np.ndarray:
        """Harmonics written over ``revolutions`` following the window [m] (coherent + drifting)."""
        out = revolutions * self.coherent
        for r, c in zip(self.ratios, self.drifting):
            geometric = (1.0 - r ** revolutions) / (1.0 - r)
            out = out + c * r ** self.revolutions * geometric
        return out


def continued(state, window: WindowWear, profile: np.ndarray) -> np.ndarray:
    """``state`` (coupled model, the end of ``window``) restarted on the profile ``profile``
    (harmonics [m]) worn since: a locked vibration keeps its phase to the profile's harmonic
    W_m at its order m (a pattern worn across W_m turns W_m, and the vibration with it), so
    the contact angle is turned back by ``arg(profile_m / W_m) / m`` and the next window starts
    where continuous rolling would have the vibration (the profile's forced response settles
    within the window's settling time). Unchanged where the window is not locked."""
    out = np.array(state, dtype=float)
    m = round(window.order) if window.locked and math.isfinite(window.order) else 0
    if 1 <= m <= profile.size and window.profile[m - 1] != 0 and profile[m - 1] != 0:
        out[-1] -= float(np.angle(profile[m - 1] / window.profile[m - 1])) / m
    return out


def window_wear(params: Params, V: float, W: np.ndarray, state, settle_s: float, revolutions: int = 8,
                base=None, max_revolutions: int | None = None) -> WindowWear:
    """Simulate ``settle_s`` [s] then ``revolutions`` at speed V [m/s] with profile ``W``
    from ``state`` (coupled-model state) and split what each revolution writes.

    With ``max_revolutions``, a window too short to separate the vibration from its nearest
    integer order (``eps * revolutions < SEPARATED_BEATS``) is run again from the same state,
    ``ceil(SEPARATED_BEATS / eps)`` revolutions long: first at most ``max_revolutions``, then,
    after a look that long, as long as the vibration's own line needs where it turns by at
    least a period over it; where it turns by less, that window is run on from its end,
    settled, for up to LONG_WINDOW revolutions (:func:`_separating_window`; a shorter
    window's order is too coarse to ask for it: during a pull into locking 16 revolutions
    put the line within 1/64 of order 9 where 1 024 found it at 8.76)."""
    base = base or model_for(params)
    coupled = coupled_model(base)
    R = params.operating.rolling_radius_m
    K = W.size
    sinc = patch_sinc(np.arange(1, K + 1), params.tire.contact_length_m, R)
    p = profile_vector(base, params, V, sinc * W.real, -sinc * W.imag, table_points(K))
    T = 2.0 * math.pi * R / V
    state = np.array(state, dtype=float)
    state[-1] = math.fmod(state[-1], 2.0 * math.pi)
    scale = np.maximum(np.abs(base.equilibrium(V, base.pack(params))), 1e-6)
    atol = np.append(_ATOL_FRACTION * scale, 1e-9)
    t_end = settle_s + revolutions * T
    run = integrate(coupled, state, V, p, t_end, rtol=_RTOL, atol=atol, dense_from=settle_s)
    per_rev = max(SAMPLES_PER_ORDER * K, int(T * 8000.0))
    t = settle_s + np.arange(revolutions * per_rev + 1) * (T / per_rev)
    t[-1] = min(t[-1], t_end)
    u = run.dense(t)
    power = friction_power(coupled, u, V, p)
    D, mean = _per_revolution(t, power, u[:, -1], per_rev, revolutions, params, K)
    xdot = u[:, base.index("xdot")]
    vibrating = float(np.std(xdot)) > VIBRATION_RMS
    nu = _dominant_order(t, xdot, 1.0 / T) if vibrating else math.nan
    eps = _detuning(nu) if vibrating else []
    # the phase per revolution is followed without aliasing while it turns by less than 1/4 cycle;
    # a window longer than MAX_WINDOW (LONG_WINDOW) over which the line turns by less than
    # SETTLED_PHASE is as settled as a shorter window's phase is required to be
    phase = _tire_phase(xdot, u[:, -1], round(nu), per_rev, revolutions) if vibrating and eps[0] < 0.25 else None
    locked = vibrating and (eps[0] < LOCK_TOLERANCE or (revolutions > MAX_WINDOW and eps[0] * revolutions < SETTLED_PHASE)
                            or (phase is not None and _remaining_drift(phase) < SETTLED_PHASE))
    if phase is not None and not locked and eps[0] * revolutions < 1.0:
        nu = _slipping_order(phase, round(nu), nu)
        eps = _detuning(nu)
    if locked:  # everything the window writes is written in the same place every revolution
        eps = [0.0] * SIDEBANDS
    if max_revolutions is not None and vibrating and not locked and revolutions <= max_revolutions:
        needed = max(_separating_window(eps, max_revolutions), _resolving_window(nu, max_revolutions))
        if needed > max_revolutions and revolutions < max_revolutions:
            needed = max_revolutions  # a shorter look first: its order is only known to 1/revolutions
        elif needed > max_revolutions and eps[0] * revolutions < 1.0:  # LONG_WINDOW, after a look that long
            return _long_window(params, V, W, run.u_end, base, max_revolutions)
        if needed > revolutions:
            return window_wear(params, V, W, state, settle_s, needed, base, max_revolutions)
    slow = _slow_orders(nu, eps, revolutions, K)
    reference = None
    if slow:  # the same window without those harmonics: what the vibration writes there by itself
        W_ref = np.array(W)
        W_ref[[m - 1 for m in slow]] = 0.0
        p_ref = profile_vector(base, params, V, sinc * W_ref.real, -sinc * W_ref.imag, table_points(K))
        run_ref = integrate(coupled, state, V, p_ref, t_end, rtol=_RTOL, atol=atol, dense_from=settle_s)
        u_ref = run_ref.dense(t)
        reference = _per_revolution(t, friction_power(coupled, u_ref, V, p_ref), u_ref[:, -1], per_rev, revolutions,
                                    params, K)[0]
    coherent, drifting, ratios = _split(D, nu, eps + _fitted_beyond(nu, eps, revolutions), revolutions, reference)
    energy = float(_window_sum(power[:-1] * np.diff(t))) / revolutions
    return WindowWear(coherent=coherent, drifting=drifting, ratios=ratios, mean_per_rev=mean,
                      revolutions=revolutions, order=nu, locked=bool(locked), end_state=run.u_end.copy(),
                      energy_per_rev=energy, profile=np.array(W))


def _long_window(params: Params, V: float, W: np.ndarray, state, base, shortest: int) -> WindowWear:
    """A window run on from ``state`` (settled) at a line that turns by less than a period over
    ``shortest`` revolutions: first ``4 shortest`` revolutions, which end it where the line
    locks or is separated (a pull into locking mostly locks there), then lengthened by
    :func:`_separating_window`, each look from where the last ended, up to LONG_WINDOW."""
    revolutions = 4 * shortest
    while True:
        win = window_wear(params, V, W, state, 0.0, revolutions, base)
        drifting = math.isfinite(win.order) and not win.locked
        needed = _separating_window(_detuning(win.order), shortest) if drifting else 0
        if needed <= revolutions or revolutions >= LONG_WINDOW:
            return win
        state, revolutions = win.end_state, needed


def _tire_phase(signal, angle, order: int, per_rev: int, revolutions: int) -> np.ndarray:
    """Phase [cycles] of ``signal``'s line at integer ``order`` relative to the tire, per
    revolution (unwrapped): constant where the vibration is locked to the tire, turning by
    eps per revolution where it drifts."""
    rot = signal[: revolutions * per_rev] * np.exp(-1j * order * angle[: revolutions * per_rev])
    return np.unwrap(np.angle(rot.reshape(revolutions, per_rev).sum(axis=1))) / (2.0 * math.pi)


def _slipping_order(phase: np.ndarray, m: int, nu: float) -> float:
    """The vibration's mean order where its phase relative to the tire turns by at least a
    period against the integer order ``m`` over the window (else ``nu``): ``m`` plus the
    least-squares slope of the phase [cycles per revolution]; asked where the strongest
    line lies within a bin of ``m`` (``eps M < 1``). A vibration just outside its locking range dwells near one
    phase and slips by a period now and then (axle4dof at 120 km/h on the default cycle:
    about once every 16 revolutions); its spectrum is a comb at ``m + k/T`` whose strongest
    line is the dwell's, at ``m``, and not the mean frequency ``m + 1/T``. Split with the
    mean order, the dwell's write is the coherent one and the comb's lines k = +-1, +-2
    the drifting ones. A slip faster than half a period per revolution is not followed
    (the per-revolution phase aliases); such a window keeps ``nu``."""
    k = np.arange(phase.size)
    slope = float(np.polyfit(k, phase, 1)[0])
    return m + slope if abs(slope) * phase.size >= 1.0 else nu


def _remaining_drift(phase: np.ndarray) -> float:
    """Phase drift [cycles] from the start of the window's last quarter on, if it keeps
    decaying geometrically at the rate from the quarter before to the last (inf if it does
    not decay): how far a settling phase has still to go."""
    q = max(phase.size // 4, 1)
    last = abs(phase[-1] - phase[-1 - q])
    before = abs(phase[-1 - q] - phase[-1 - 2 * q]) if phase.size > 2 * q else math.inf
    return last / (1.0 - last / before) if last < before else math.inf


def _detuning(nu: float) -> list[float]:
    """Distance eps_j of j nu to the nearest integer, j = 1..SIDEBANDS."""
    return [abs(j * nu - round(j * nu)) for j in range(1, SIDEBANDS + 1)]


def _fitted_beyond(nu: float, eps, revolutions: int) -> list[float]:
    """Detuning of the lines j = SIDEBANDS+1..FITTED_LINES that the window resolves (0: not
    fitted, left in the coherent write; none where the vibration is locked or absent)."""
    if not eps or max(eps) == 0.0:
        return []
    far = [abs(j * nu - round(j * nu)) for j in range(SIDEBANDS + 1, FITTED_LINES + 1)]
    return [e if e * revolutions >= RESOLVABLE else 0.0 for e in far]


def _separating_window(eps, longest: int = MAX_WINDOW) -> int:
    """Revolutions that separate every drifting line j nu from its nearest integer order
    (``eps_j M >= SEPARATED_BEATS``; lines locked to within LOCK_TOLERANCE are not drifting;
    0 if none drifts), at most ``longest``, or at most LONG_WINDOW where the vibration's own
    line (j = 1) turns by less than a period over ``longest`` revolutions. Where it turns by
    one to SEPARATED_BEATS periods, the window is as long as that line needs (at most
    ``SEPARATED_BEATS / eps_1 < 3 longest``): 64-revolution windows at order 7.98 (tread1dof,
    toe 0.53 deg, 120 km/h) scattered S_8 / W_8 by 40 % from window to window, 150 revolutions
    by 1.5 % (docs/wear.md). The other lines keep ``longest`` (the second line near an integer
    order, axle4dof at 80 km/h at order 9.5016, asked for 962 revolutions and cost that cycle
    2.9 times its CPU time)."""
    drifting = [e for e in eps if e >= LOCK_TOLERANCE]
    if not drifting:
        return 0
    every = math.ceil(SEPARATED_BEATS / min(drifting))
    if LOCK_TOLERANCE <= eps[0] and eps[0] * longest < 1.0:
        return min(max(LONG_WINDOW, longest), every)
    own = math.ceil(SEPARATED_BEATS / eps[0]) if eps[0] >= LOCK_TOLERANCE else 0
    return max(min(longest, every), own)


def _resolving_window(nu: float, longest: int = MAX_WINDOW) -> int:
    """Revolutions over which the lines j = SIDEBANDS+1..FITTED_LINES of a vibration at order
    ``nu`` turn by RESOLVABLE of a period, so that they are fitted as drifting (0 if none
    needs it; a line too slow for ``longest`` revolutions, or locked, stays in the coherent
    write). Left in it, such a line scatters from window to window with where the window
    starts: fleet car 23 (110 km/h, order 8.670, its third line 0.010 off order 26) held
    its steps at ~150 km for 31 000 km, its error estimate set by order 26 in every step."""
    far = [abs(j * nu - round(j * nu)) for j in range(SIDEBANDS + 1, FITTED_LINES + 1)]
    slow = [e for e in far if LOCK_TOLERANCE <= e and e * longest >= RESOLVABLE]
    return max((math.ceil(RESOLVABLE / e) for e in slow), default=0)


def _slow_orders(nu, eps, revolutions, K) -> list[int]:
    """Harmonics m = round(j nu) of drifting lines too slow to separate in the window."""
    return sorted({int(round(j * nu)) for j in range(1, len(eps) + 1)
                   if LOCK_TOLERANCE <= eps[j - 1] and eps[j - 1] * revolutions < RESOLVABLE
                   and 1 <= round(j * nu) <= K})


def _taper(M: int) -> np.ndarray:
    """Weights (M, 1) of the least squares of :func:`_split`: the square root of a Hann taper
    over the window's M revolutions, ``sin(pi (k + 1/2) / M)``. Untapered, the slow
    modulation of a strong drifting line (its sidebands a few thousandths of an order away,
    ten times the coherent write of a small harmonic) leaks into the coherent write by about
    1/M, and S_n / W_n scattered by 3 % from window to window; tapered, by 0.2 % (tread
    damping 60 N s/m at 80 km/h, docs/wear.md, point 14)."""
    return np.sin(math.pi * (np.arange(M) + 0.5) / M)[:, None]


def _split(D, nu, eps, revolutions, reference=None):
    """Coherent part S (K,), drifting parts C (R, K) and their ratios r (R,) of the
    per-revolution writes D (M, K) of a vibration at order nu (see module notes).

    A line whose pattern turns by at least RESOLVABLE of a period over the window is
    separated by least squares with its known ratio. A slower one cannot be told apart
    from a coherent write within the window; it writes essentially on its nearest
    harmonic m = round(j nu) only. With ``reference``, the writes of the same window run
    without the profile's harmonic m, the vibration's own write at m is the reference's
    (drifting, turning by r per revolution, bounded over the step by 1/|sin(pi eps)|) and
    the difference is the profile's coherent feedback. Without it, the whole write at m
    is counted as drifting. Lines j > SIDEBANDS (``eps`` longer than SIDEBANDS; resolved
    ones only) are fitted, with their ratio r_j, only on the harmonics within NEAR_SPAN of
    their nearest one, where a revolution's DFT puts their write: fitted on every harmonic,
    their columns, close to the coherent one, would degrade S everywhere. Where lines are
    fitted, the least squares are weighted by :func:`_taper`."""
    M, K = D.shape
    k = np.arange(M)
    fast, slow, near = [], [], []
    for j in range(1, len(eps) + 1):
        if eps[j - 1] < LOCK_TOLERANCE:
            continue
        (near if j > SIDEBANDS else fast if eps[j - 1] * M >= RESOLVABLE else slow).append(j)
    ratios = [np.exp(sign * 2j * math.pi * j * nu) for j in fast for sign in (1, -1)]
    A = np.column_stack([np.ones(M)] + [r ** k for r in ratios])
    taper = _taper(M) if fast or near else np.ones((M, 1))
    coef = np.linalg.lstsq(A * taper, D * taper, rcond=None)[0]
    coherent, drifting = coef[0].copy(), [c for c in coef[1:]]
    taken = {int(round(j * nu)) for j in slow}
    for j in near:
        orders = [m for m in range(int(round(j * nu)) - NEAR_SPAN, int(round(j * nu)) + NEAR_SPAN + 1)
                  if 1 <= m <= K and m not in taken]
        if not orders:
            continue
        taken.update(orders)
        r = np.exp(2j * math.pi * j * nu)
        idx = np.array(orders) - 1
        coef_m = np.linalg.lstsq(np.column_stack([A, r ** k]) * taper, D[:, idx] * taper, rcond=None)[0]
        coherent[idx] = coef_m[0]
        for other, c_m in zip(drifting, coef_m[1:-1]):
            other[idx] = c_m
        c = np.zeros(K, dtype=complex)
        c[idx] = coef_m[-1]
        drifting.append(c)
        ratios.append(r)
    for j in slow:
        m = int(round(j * nu))
        if not 1 <= m <= K:
            continue
        r = np.exp(2j * math.pi * j * nu)
        c = np.zeros(K, dtype=complex)
        own = D[:, m - 1] if reference is None else reference[:, m - 1]
        c[m - 1] = np.mean(own * r ** -k)
        coherent[m - 1] = 0.0 if reference is None else np.mean(D[:, m - 1] - reference[:, m - 1])
        for other in drifting:
            other[m - 1] = 0.0
        drifting.append(c)
        ratios.append(r)
    return coherent, np.array(drifting).reshape(len(drifting), K), np.array(ratios)


def _per_revolution(t, power, angle, per_rev, revolutions, params, K):
    """Harmonics written in each revolution (revolutions, K) and the mean wear per revolution.

    The contact angle advances uniformly (phi_c' = V/R), so the samples of one revolution
    sit at phi_0 + 2 pi j / per_rev and the projection of :func:`~.wear_law.written_harmonics`
    is a DFT of the trapezoid-weighted power (the closing sample folds onto j = 0)."""
    dt = t[1] - t[0]
    D = np.empty((revolutions, K), dtype=complex)
    mean = 0.0
    R, b_w = params.operating.rolling_radius_m, params.tire.tread_width_m
    k_e = energetic_rate(params)
    sinc = patch_sinc(np.arange(1, K + 1), params.tire.contact_length_m, R)
    for k in range(revolutions):
        seg = power[k * per_rev : (k + 1) * per_rev + 1] * dt
        folded = seg[:-1].copy()
        folded[0] = 0.5 * (seg[0] + seg[-1])
        spectrum = np.fft.rfft(folded)[1 : K + 1]
        phi0 = angle[k * per_rev]
        integral = spectrum * np.exp(-1j * np.arange(1, K + 1) * phi0)
        D[k] = (k_e / (math.pi * R * b_w)) * sinc * integral
        mean += k_e / (2.0 * math.pi * R * b_w) * float(folded.sum()) / revolutions
    return D, mean


def _settle_times(base, params, V: float) -> tuple[float, float, bool]:
    """(first, next) settling times [s] and whether steady rolling is unstable (the tread
    vibrates). The first window starts at steady rolling: its settling follows the slowest
    decay or growth rate of steady rolling (a vibration grows at its rate). The next ones
    start where the last window ended, on the attractor: they wait only for the slowest
    decaying mode (8 e-folds, at least 4 revolutions); a barely unstable mode's small
    growth rate is not a decay toward the vibration (axle4dof at 80 km/h: 0.9/s, while a
    perturbed vibration settles at about 11/s, docs/wear.md)."""
    p = base.pack(params)
    q = base.prepared(V, p)
    lam = np.linalg.eigvals(base.jacobian(base.equilibrium(V, q), V, q))
    rate = max(float(np.min(np.abs(lam.real))), 1.0)
    decaying = -lam.real[lam.real < 0.0]
    decay = max(float(np.min(decaying)), 1.0) if decaying.size else rate
    T = 2.0 * math.pi * params.operating.rolling_radius_m / V
    first = min(max(30.0 / rate, 0.5), 6.0)
    return first, min(first, max(4.0 * T, 8.0 / decay)), bool(np.max(lam.real) > 0.0)
