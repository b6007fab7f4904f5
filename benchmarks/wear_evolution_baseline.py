"""The nonlinear wear evolution as it was before the fast evolution (commit f5fff94):
the benchmark's baseline (``benchmarks/bench_wear.py``) and the reference of the test that
the fast evolution gives the same answer (``tests/test_wear_evolution.py``). Not a user
option: frozen, one process, fixed distance steps, every window simulated with the
profile load summed over all harmonics in each right-hand side.

Fast dynamics and slow wear alternate. For a distance step ``h``:

1. **Window.** At each speed of the cycle the coupled model runs with the current
   profile, from where the last window at that speed ended, until the transient has died
   out, then for ``M`` whole revolutions, each writing harmonics ``D_k``.
2. **Locking and coherence.** The dominant order ``nu`` of the tread velocity; the writes
   are fitted as ``D_k = S + sum_j C_j r_j^k``, ``r_j = exp(+-2 pi i j nu)``; locked
   (integer order, or a settling phase): all is coherent.
3. **Update.** Unlocked: ``W_n exp(N S_n / W_n)``; locked: ``W + N S`` with S
   extrapolated to the middle of the step; ``dW/dN = a W + b`` exactly on a cycle.
4. **Linear regime.** Steady rolling with a small profile reuses its window's rates.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from polywear.models import get_model
from polywear.units import kmh_to_ms
from polywear.models.profile import coupled_model, patch_sinc, profile_vector
from polywear.params import Params
from polywear.progress import Progress
from polywear.solvers.integrate import integrate
from polywear.wear.evolution import EvolutionResult, EvolutionSettings
from polywear.wear.law import energetic_rate, friction_power

__all__ = ["wear_evolution", "window_wear"]

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
MAX_CHANGE = 0.3
"""A distance step is shortened so that the change of the profile stays below this
fraction of its largest harmonic (fast growth after locking is resolved, not jumped
over) [-]: the whole change where the tread vibrates, only the part added rather than
integrated exactly where rolling is steady (there the exponential update is exact)."""
LINEAR_LOAD = 1e-3
"""While the profile can change the load by less than this fraction of N0, a speed where
rolling is steady is in the linear regime: its window is simulated once and its rates
S_n / W_n (those of the linear wear map) are reused [-]."""
MAX_EXPONENT = 3.0
"""Largest exponent |N S_n / W_n| integrated exactly in one step; above, the write is added [-]."""
RESOLVABLE = 0.25
"""A drifting line is separated in a window of M revolutions when eps M >= this [-]."""
SIDEBANDS = 2
"""Harmonics j of the vibration whose drifting writes are separated (j = +-1..+-SIDEBANDS)."""
SEPARATED_BEATS = 3.0
"""A window separates the vibration's line from its nearest integer order when the pattern
turns by at least this many periods over it (eps M >= this) [-]: the Hann main lobe is 2
bins wide, so a shorter window mixes the line with the profile's locked response at that
order; the order estimate and the coherent write then depend on where the window starts."""
MAX_WINDOW = 64
"""Most revolutions a window is lengthened to for SEPARATED_BEATS [-]; a vibration closer
to an integer order (eps < SEPARATED_BEATS / MAX_WINDOW) is only partly separated."""
_RTOL = 1e-8
_ATOL_FRACTION = 1e-9


def coherence(eps: float, revolutions: float) -> float:
    """``|sin(pi eps M)/(M sin pi eps)|``: the fraction of M coherent writes that a
    pattern drifting by ``eps`` of a period per revolution keeps after M revolutions."""
    s = math.sin(math.pi * eps)
    if abs(s) < 1e-15:
        return 1.0
    return abs(math.sin(math.pi * eps * revolutions) / (revolutions * s))


def initial_roughness(params: Params) -> np.ndarray:
    """Seeded random harmonics W_n [m], n = 1..max_order, of RMS ``initial_roughness_um``
    (complex normal, phases uniform; numpy SeedSequence(seed))."""
    K = params.wear.max_order
    rng = np.random.default_rng(np.random.SeedSequence(params.wear.seed))
    W = rng.standard_normal(K) + 1j * rng.standard_normal(K)
    rms = math.sqrt(0.5 * float(np.sum(np.abs(W) ** 2)))
    return W * (params.wear.initial_roughness_um * 1e-6 / rms)


def _window_sum(x: np.ndarray):
    """Sum of a window's samples, the same in every process: numpy's own pairwise sum.

    A BLAS dot product (``np.dot``) of a long vector splits the sum over BLAS threads,
    so its rounding depends on the thread count, which is fixed when BLAS loads and
    follows ``OPENBLAS_NUM_THREADS``/``OMP_NUM_THREADS``; a worker process started later
    (``wear_evolution(..., workers=N)``) may get another count than this process (e.g. after
    ``distributed.LocalCluster`` set those variables to 1 here) and a different window."""
    return np.sum(x)


def _dominant_order(t, signal, f_rot: float) -> float:
    """Order nu = f / f_rot of the dominant spectral line of ``signal``."""
    x = signal - signal.mean()
    dt = t[1] - t[0]
    n = x.size
    from scipy.fft import next_fast_len

    pad = next_fast_len(8 * n, real=True)  # a length FFTs like: 8 n itself can be nearly prime
    xw = x * np.hanning(n)  # low leakage: neighbouring lines one order away barely bias the peak
    spectrum = np.abs(np.fft.rfft(xw, pad))
    k = int(np.argmax(spectrum[1:])) + 1
    from scipy.optimize import minimize_scalar

    def minus_power(f):  # numpy's pairwise sum, not BLAS: see _window_sum
        return -abs(_window_sum(xw * np.exp(-2j * math.pi * f * t)))

    df = 1.0 / (pad * dt)
    best = minimize_scalar(minus_power, bracket=None, bounds=((k - 2) * df, (k + 2) * df), method="bounded",
                           options={"xatol": 1e-10 * k * df})
    return float(best.x) / f_rot


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


def window_wear(params: Params, V: float, W: np.ndarray, state, settle_s: float, revolutions: int = 8,
                base=None, max_revolutions: int | None = None) -> WindowWear:
    """Simulate ``settle_s`` [s] then ``revolutions`` at speed V [m/s] with profile ``W``
    from ``state`` (coupled-model state) and split what each revolution writes.

    With ``max_revolutions``, a window too short to separate the vibration from its nearest
    integer order (``eps * revolutions < SEPARATED_BEATS``) is run again from the same state,
    ``ceil(SEPARATED_BEATS / eps)`` revolutions long (at most ``max_revolutions``)."""
    base = base or get_model(params.model)
    coupled = coupled_model(base)
    R = params.operating.rolling_radius_m
    K = W.size
    sinc = patch_sinc(np.arange(1, K + 1), params.tire.contact_length_m, R)
    p = profile_vector(base, params, V, sinc * W.real, -sinc * W.imag)
    T = 2.0 * math.pi * R / V
    state = np.array(state, dtype=float)
    state[-1] = math.fmod(state[-1], 2.0 * math.pi)
    scale = np.maximum(np.abs(base.equilibrium(V, base.pack(params))), 1e-6)
    atol = np.append(_ATOL_FRACTION * scale, 1e-9)
    t_end = settle_s + revolutions * T
    run = integrate(coupled, state, V, p, t_end, rtol=_RTOL, atol=atol, dense_from=settle_s)
    per_rev = max(32 * K, int(T * 8000.0))
    t = settle_s + np.arange(revolutions * per_rev + 1) * (T / per_rev)
    t[-1] = min(t[-1], t_end)
    u = run.dense(t)
    power = friction_power(coupled, u, V, p)
    D, mean = _per_revolution(t, power, u[:, -1], per_rev, revolutions, params, K)
    xdot = u[:, base.index("xdot")]
    vibrating = float(np.std(xdot)) > VIBRATION_RMS
    nu = _dominant_order(t, xdot, 1.0 / T) if vibrating else math.nan
    eps = _detuning(nu) if vibrating else []
    # the phase per revolution is followed without aliasing while it turns by less than 1/4 cycle
    locked = vibrating and (eps[0] < LOCK_TOLERANCE or (
        eps[0] < 0.25 and _remaining_drift(_tire_phase(xdot, u[:, -1], round(nu), per_rev, revolutions))
        < SETTLED_PHASE))
    if locked:  # everything the window writes is written in the same place every revolution
        eps = [0.0] * SIDEBANDS
    if max_revolutions is not None and vibrating and not locked:
        needed = min(max_revolutions, _separating_window(eps))
        if needed > revolutions:
            return window_wear(params, V, W, state, settle_s, needed, base, max_revolutions)
    slow = _slow_orders(nu, eps, revolutions, K)
    reference = None
    if slow:  # the same window without those harmonics: what the vibration writes there by itself
        W_ref = np.array(W)
        W_ref[[m - 1 for m in slow]] = 0.0
        p_ref = profile_vector(base, params, V, sinc * W_ref.real, -sinc * W_ref.imag)
        run_ref = integrate(coupled, state, V, p_ref, t_end, rtol=_RTOL, atol=atol, dense_from=settle_s)
        u_ref = run_ref.dense(t)
        reference = _per_revolution(t, friction_power(coupled, u_ref, V, p_ref), u_ref[:, -1], per_rev, revolutions,
                                    params, K)[0]
    coherent, drifting, ratios = _split(D, nu, eps, revolutions, reference)
    energy = float(_window_sum(power[:-1] * np.diff(t))) / revolutions
    return WindowWear(coherent=coherent, drifting=drifting, ratios=ratios, mean_per_rev=mean,
                      revolutions=revolutions, order=nu, locked=bool(locked), end_state=run.u_end.copy(),
                      energy_per_rev=energy, profile=np.array(W))


def _tire_phase(signal, angle, order: int, per_rev: int, revolutions: int) -> np.ndarray:
    """Phase [cycles] of ``signal``'s line at integer ``order`` relative to the tire, per
    revolution (unwrapped): constant where the vibration is locked to the tire, turning by
    eps per revolution where it drifts."""
    rot = signal[: revolutions * per_rev] * np.exp(-1j * order * angle[: revolutions * per_rev])
    return np.unwrap(np.angle(rot.reshape(revolutions, per_rev).sum(axis=1))) / (2.0 * math.pi)


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


def _separating_window(eps) -> int:
    """Revolutions that separate every drifting line j nu from its nearest integer order
    (``eps_j M >= SEPARATED_BEATS``; lines locked to within LOCK_TOLERANCE are not drifting)."""
    drifting = [e for e in eps if e >= LOCK_TOLERANCE]
    return math.ceil(SEPARATED_BEATS / min(drifting)) if drifting else 0


def _slow_orders(nu, eps, revolutions, K) -> list[int]:
    """Harmonics m = round(j nu) of drifting lines too slow to separate in the window."""
    return sorted({int(round(j * nu)) for j in range(1, len(eps) + 1)
                   if LOCK_TOLERANCE <= eps[j - 1] and eps[j - 1] * revolutions < RESOLVABLE
                   and 1 <= round(j * nu) <= K})


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
    is counted as drifting."""
    M, K = D.shape
    k = np.arange(M)
    fast, slow = [], []
    for j in range(1, len(eps) + 1):
        if eps[j - 1] < LOCK_TOLERANCE:
            continue
        (fast if eps[j - 1] * M >= RESOLVABLE else slow).append(j)
    ratios = [np.exp(sign * 2j * math.pi * j * nu) for j in fast for sign in (1, -1)]
    A = np.column_stack([np.ones(M)] + [r ** k for r in ratios])
    coef = np.linalg.lstsq(A, D, rcond=None)[0]
    coherent, drifting = coef[0].copy(), [c for c in coef[1:]]
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
    """(first, next) settling times [s] from the slowest decay (or growth) rate of steady
    rolling, and whether steady rolling is unstable (the tread vibrates)."""
    p = base.pack(params)
    q = base.prepared(V, p)
    lam = np.linalg.eigvals(base.jacobian(base.equilibrium(V, q), V, q))
    rate = max(float(np.min(np.abs(lam.real))), 1.0)
    T = 2.0 * math.pi * params.operating.rolling_radius_m / V
    first = min(max(30.0 / rate, 0.5), 6.0)
    return first, min(first, max(4.0 * T, 8.0 / rate)), bool(np.max(lam.real) > 0.0)


def _update(W: np.ndarray, free: np.ndarray, forcing: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """W after a step (see module notes) and the part of the change that was added rather
    than integrated exactly. ``free``: coherent writes of the speeds not locked, proportional
    to W (rate a, ``x = free / W = a N``); ``forcing``: those of the locked speeds, a rate b
    that does not depend on W. dW/dN = a W + b is integrated exactly,
    ``W e^x + forcing (e^x - 1)/x``."""
    rms = math.sqrt(0.5 * float(np.sum(np.abs(W) ** 2)))
    out = W + free + forcing
    added = free + forcing
    big = np.abs(W) > 1e-6 * rms
    x = np.zeros_like(W)
    x[big] = free[big] / W[big]
    ok = big & (np.abs(x) <= MAX_EXPONENT)
    growth = np.exp(x[ok])
    small = np.abs(x[ok]) < 1e-12
    phi = np.where(small, 1.0, (growth - 1.0) / np.where(small, 1.0, x[ok]))  # (e^x - 1)/x
    out[ok] = W[ok] * growth + forcing[ok] * phi
    added[ok] = forcing[ok] * phi
    return out, added



def wear_evolution(params: Params, distance_km: float, cycle: Iterable[tuple[float, float]] | None = None,
           settings: EvolutionSettings = EvolutionSettings(), progress: Progress | None = None) -> EvolutionResult:
    """Worn profile from seeded roughness over ``distance_km`` [km] (fixed steps, one process)."""
    cycle = tuple(cycle) if cycle is not None else params.wear.cycle_shares()
    return _evolve(params, distance_km, cycle, settings.step_km, settings.revolutions, progress, None)


def _windows(pool, jobs, base, longest: int) -> list[WindowWear]:
    """:func:`window_wear` of every job ``(params, V, W, state, settle_s, revolutions)``."""
    return [window_wear(*job, base=base, max_revolutions=longest) for job in jobs]


def _evolve(params: Params, distance_km: float, cycle, step_km: float, revolutions: int, progress, pool
            ) -> EvolutionResult:
    """:func:`wear_evolution` on a given cycle, the windows of each step run by :func:`_windows`."""
    base = get_model(params.model)
    coupled = coupled_model(base)
    R = params.operating.rolling_radius_m
    k_e = energetic_rate(params)
    n_steps = max(1, math.ceil(distance_km / step_km - 1e-9))
    step = distance_km / n_steps
    W = initial_roughness(params)
    states, settles, windows = [], [], []
    for v_kmh, _ in cycle:
        V = float(kmh_to_ms(v_kmh))
        first, nxt, unstable = _settle_times(base, params, V)
        windows.append(revolutions if unstable else min(revolutions, 3))
        u0 = coupled.equilibrium(V, profile_vector(base, params, V))
        u0[base.index("x")] += 1e-5  # a small disturbance: steady rolling as a car drives
        states.append(u0)
        settles.append([first, nxt])
    shortest = list(windows)  # per speed; a vibrating window is lengthened up to `longest`
    longest = max(MAX_WINDOW, revolutions)
    history, means, energies, distance = [W.copy()], [0.0], [0.0], [0.0]
    orders_hist, locked_hist = [], []
    mean = energy = done = 0.0
    linear = [None] * len(cycle)  # per speed: the steady-rolling window whose rates S_n / W_n are reused
    last_locked = [None] * len(cycle)  # per speed: (coherent write, distance) of the last step's locked window
    sinc = patch_sinc(np.arange(1, W.size + 1), params.tire.contact_length_m, R)
    load_scale = LINEAR_LOAD * params.operating.vertical_load_n / params.tire.vertical_stiffness_n_per_m \
        if params.tire.vertical_stiffness_n_per_m > 0 else math.inf
    while done < distance_km * (1.0 - 1e-12):
        h = min(step, distance_km - done)
        wins = []
        small = float(np.sum(np.abs(sinc * W))) < load_scale  # |w_c| bounded by the sum of |sinc_n W_n|
        run = [j for j in range(len(cycle)) if not (small and linear[j] is not None)]
        jobs = [(params, float(kmh_to_ms(cycle[j][0])), W, states[j], settles[j][0], windows[j]) for j in run]
        simulated = dict(zip(run, _windows(pool, jobs, base, longest)))
        for j in range(len(cycle)):
            if j not in simulated:
                wins.append(linear[j].rescaled(W))
                continue
            win = simulated[j]
            if math.isfinite(win.order):  # the next window at this speed starts long enough
                drifting = 0 if win.locked else _separating_window(_detuning(win.order))
                windows[j] = max(shortest[j], min(longest, drifting))
            settles[j][0] = settles[j][1]
            states[j] = win.end_state
            linear[j] = win if (small and not math.isfinite(win.order)) else None
            wins.append(win)
        locked = [w.locked and math.isfinite(w.order) for w in wins]
        vibrating = any(math.isfinite(w.order) for w in wins)
        # locked in this step and the last: the write's change per km, for the step's mean write
        trend = [(w.coherent - last[0]) / (done - last[1]) if lk and last is not None else 0.0
                 for w, lk, last in zip(wins, locked, last_locked)]
        last_locked = [(w.coherent, done) if lk else None for w, lk in zip(wins, locked)]
        for _ in range(8):  # shorten the step where the profile would change by more than MAX_CHANGE
            n_revs = [share * h * 1000.0 / (2.0 * math.pi * R) for _, share in cycle]
            free = sum((n * w.coherent for n, w, lk in zip(n_revs, wins, locked) if not lk), np.zeros_like(W))
            forcing = sum((n * (w.coherent + 0.5 * h * d) for n, w, lk, d in zip(n_revs, wins, locked, trend) if lk),
                          np.zeros_like(W))
            drifting_total = sum(w.written(n) - n * w.coherent for n, w in zip(n_revs, wins))
            W_new, added = _update(W, free, forcing)
            W_new = W_new + drifting_total
            # vibrating: the coherent write is not exactly proportional to W (locking pulls), so the
            # whole change is limited; steady rolling: only what was not integrated exactly
            limited = (W_new - W) if vibrating else (added + drifting_total)
            change = float(np.max(np.abs(limited))) / max(float(np.max(np.abs(W))), 1e-30)
            if change <= MAX_CHANGE:
                break
            h *= 0.8 * MAX_CHANGE / change
        W = W_new
        done += h
        mean += sum(n * w.mean_per_rev for n, w in zip(n_revs, wins))
        energy += sum(n * w.energy_per_rev for n, w in zip(n_revs, wins))
        history.append(W.copy())
        means.append(mean)
        energies.append(energy)
        distance.append(done)
        orders_hist.append([w.order for w in wins])
        locked_hist.append([w.locked and math.isfinite(w.order) for w in wins])
        if progress is not None:
            progress(done, distance_km, "")
    distance = np.array(distance)
    steps = np.diff(distance)
    return EvolutionResult(params=params, distance_km=distance, harmonics=np.array(history),
                           mean_depth_m=np.array(means), cycle=cycle, vibration_order=np.array(orders_hist),
                           locked=np.array(locked_hist), friction_energy_j=np.array(energies),
                           settings={"step_km": step, "smallest_step_km": float(steps.min()),
                                     "revolutions": revolutions, "k_e_m3_per_j": k_e})
