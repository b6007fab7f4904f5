"""Linear stability of the steady rolling state along a speed range.

The equilibrium ``u_eq(V)`` of the model is computed at each speed and the
eigenvalues of its Jacobian decide stability. Hopf points (a complex pair crossing
the imaginary axis) are bracketed on a speed grid and located by Brent's method on
the real part of the tracked eigenvalue to ``xtol`` [m/s]; their criticality comes
from the first Lyapunov coefficient (Kuznetsov, *Elements of Applied Bifurcation
Theory*, eq. 3.20), computed with exact (complex-step) second derivatives and a
difference of those for the third.

Speeds are km/h at the interface, m/s inside.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import brentq

from ..errors import NumericalError
from ..models import model_for
from ..results import Result, with_deprecated_keys
from ..params import Params
from ..settings import check_count, check_positive
from ..units import DEFAULT_SPEED_RANGE_KMH, STABILITY_SPEED_RANGE_KMH, kmh_to_ms, ms_to_kmh
from .derivatives import bilinear, jac_directional, rhs_directional, trilinear
from .points import Criticality, PointKind, SpecialPoint

__all__ = [
    "HopfPoint",
    "StabilityResult",
    "StabilitySettings",
    "equilibrium_eigenvalues",
    "locate_hopf",
    "first_lyapunov_coefficient",
    "critical_eigenvalue_derivative",
    "stability",
    "fast_linear_band",
]


@dataclass(frozen=True)
class StabilitySettings:
    """Numerical settings of :func:`stability`."""

    n_speeds: int = 400
    """Grid points for bracketing (at least 3); a pair of crossings closer than the grid
    spacing can be missed."""
    xtol_ms: float = 1e-10
    """Tolerance of the located crossing speeds [m/s]."""

    def __post_init__(self) -> None:
        check_count(self, "n_speeds", minimum=3)
        check_positive(self, "xtol_ms")


@dataclass(frozen=True)
class HopfPoint:
    """A Hopf point of the equilibrium branch.

    ``q`` and ``w`` are right and left critical eigenvectors with ``J q = i omega q``,
    ``w^H J = i omega w^H``, ``|q| = 1`` and ``w^H q = 1``. ``dre_dspeed`` is
    d Re(lambda)/dV [1/m] (> 0: the pair crosses into the right half plane with
    increasing speed). ``first_lyapunov_coefficient`` is l1 (< 0: supercritical,
    soft; > 0: subcritical, hard).
    """

    speed_ms: float
    """Speed of the Hopf point [m/s] (``speed_kmh`` in km/h)."""
    omega: float  # [rad/s]
    u: np.ndarray
    q: np.ndarray
    w: np.ndarray
    dre_dspeed: float
    first_lyapunov_coefficient: float
    mode: str

    @property
    def speed_kmh(self) -> float:
        return ms_to_kmh(self.speed_ms)

    @property
    def frequency_hz(self) -> float:
        return self.omega / (2.0 * np.pi)

    @property
    def criticality(self) -> Criticality:
        """Soft (supercritical, l1 < 0) or hard (subcritical)."""
        return Criticality.SOFT if self.first_lyapunov_coefficient < 0.0 else Criticality.HARD

    def special_point(self) -> SpecialPoint:
        """This Hopf point as a :class:`~polywear.dynamics.points.SpecialPoint` (kind HB)."""
        return SpecialPoint(PointKind.HOPF, self.speed_kmh, self.frequency_hz, criticality=self.criticality)

    def summary(self) -> dict:
        return {
            "speed_kmh": self.speed_kmh,
            "frequency_hz": self.frequency_hz,
            "criticality": self.criticality,
            "first_lyapunov_coefficient": self.first_lyapunov_coefficient,
            "crossing": "destabilizing" if self.dre_dspeed > 0 else "stabilizing",
            "mode": self.mode,
        }


def equilibrium_eigenvalues(model, p, speeds_ms) -> tuple[np.ndarray, np.ndarray]:
    """Equilibria ``(n_speeds, n)`` and Jacobian eigenvalues ``(n_speeds, n)`` at ``speeds_ms`` [m/s]
    (the Jacobians stacked into one LAPACK call: the same eigenvalues as one call each)."""
    speeds = np.atleast_1d(np.asarray(speeds_ms, dtype=float))
    states = np.empty((len(speeds), model.n))
    jacobians = np.empty((len(speeds), model.n, model.n))
    for i, V in enumerate(speeds):
        states[i] = model.equilibrium(V, p)
        jacobians[i] = model.jacobian(states[i], V, p)
    return states, np.linalg.eigvals(jacobians).astype(complex, copy=False)


def _n_unstable(eigenvalues: np.ndarray) -> np.ndarray:
    return np.sum(eigenvalues.real > 0.0, axis=-1)


def _eigen_nearest(model, p, V, target: complex):
    """Equilibrium, Jacobian, and the eigenpair nearest ``target`` at speed V."""
    u = model.equilibrium(V, p)
    J = model.jacobian(u, V, p)
    vals, vecs = np.linalg.eig(J)
    i = int(np.argmin(np.abs(vals - target)))
    return u, J, vals[i], vecs[:, i]


def mode_label(model, p, q: np.ndarray) -> str:
    """Name of the coordinate that carries most of the mode's potential energy."""
    best, label = -1.0, ""
    for state, stiffness_slot in model.coordinates:
        k = p[model.param_names.index(stiffness_slot)]
        energy = k * abs(q[model.index(state)]) ** 2
        if energy > best:
            best, label = energy, state
    return label


def locate_hopf(model, p, V_lo: float, V_hi: float, lam_lo: complex, lam_hi: complex, xtol=1e-10):
    """Hopf point of the mode whose eigenvalue goes from ``lam_lo`` at V_lo to ``lam_hi`` at V_hi."""

    def tracked(V):
        s = (V - V_lo) / (V_hi - V_lo)
        return _eigen_nearest(model, p, V, lam_lo + s * (lam_hi - lam_lo))

    V = brentq(lambda v: tracked(v)[2].real, V_lo, V_hi, xtol=xtol, rtol=4 * np.finfo(float).eps)
    u, J, lam, q = tracked(V)
    omega = abs(lam.imag)
    if lam.imag < 0:
        q = q.conj()
    q = q / np.linalg.norm(q)
    lvals, lvecs = np.linalg.eig(J.T)
    w = lvecs[:, int(np.argmin(np.abs(lvals + 1j * omega)))]  # J^T w = -i omega w <=> w^H J = i omega w^H
    w = w / np.vdot(w, q).conj()  # w^H q = 1
    dre = critical_eigenvalue_derivative(model, u, V, p, q, w, dV=1.0).real
    l1 = first_lyapunov_coefficient(model, u, V, p, q, w, omega, J)
    return HopfPoint(V, omega, u, q, w, dre, l1, mode_label(model, p, q))


def critical_eigenvalue_derivative(model, u, V, p, q, w, dV=0.0, dp=None) -> complex:
    """Total derivative of the critical eigenvalue along (dV, dp), equilibrium shift included.

    ``dlambda = w^H (J_u du + J_V dV + J_p dp) q / (w^H q)`` with ``du = -J^{-1} (f_V dV + f_p dp)``.
    """
    J = model.jacobian(u, V, p)
    f_theta = rhs_directional(model, u, V, p, dV=dV, dp=dp)
    du = -np.linalg.solve(J, f_theta)
    dJ = jac_directional(model, u, V, p, du=du, dV=dV, dp=dp)
    return np.vdot(w, dJ @ q) / np.vdot(w, q)


def first_lyapunov_coefficient(model, u, V, p, q, w, omega, J) -> float:
    """First Lyapunov coefficient l1 (Kuznetsov 2004, eq. 3.20) [units of 1/(time*|q|^2)].

    ``q``: ``J q = i omega q``, ``|q| = 1``; ``w``: ``w^H J = i omega w^H``, ``w^H q = 1``.
    """
    n = len(u)
    qb = q.conj()
    b_qq = bilinear(model, u, V, p, q, q)
    b_qqb = bilinear(model, u, V, p, q, qb)
    c_qqqb = trilinear(model, u, V, p, q, q, qb)
    r1 = np.linalg.solve(J, b_qqb)
    r2 = np.linalg.solve(2j * omega * np.eye(n) - J, b_qq)
    terms = c_qqqb - 2.0 * bilinear(model, u, V, p, q, r1) + bilinear(model, u, V, p, qb, r2)
    return float(np.vdot(w, terms).real / (2.0 * omega))


RENAMED_KEYS = {"linear_band_kmh": "unstable_intervals_kmh"}
"""New -> old keys of :meth:`StabilityResult.summary` (the old ones go in the next release)."""


@dataclass
class StabilityResult(Result):
    """Eigenvalues of the equilibrium along speed, Hopf points and unstable intervals."""

    params: Params
    speeds_kmh: np.ndarray
    eigenvalues: np.ndarray  # (n_speeds, n) [1/s]
    equilibria: np.ndarray  # (n_speeds, n)
    hopf_points: list[HopfPoint]
    real_crossings_kmh: list[float]
    """Speeds where a real eigenvalue crosses zero (static divergence / fold of equilibria)."""
    linear_band_kmh: list[tuple[float, float]]
    """Speed intervals where steady rolling is unstable [km/h]."""
    state_names: tuple[str, ...]
    settings: dict = field(default_factory=dict)
    alignment_deg: np.ndarray | None = None
    """(n_speeds, 2) running toe and camber [deg] of the equilibria, for models whose
    alignment comes out of the equilibrium solve (axle4dof); None otherwise."""

    def open_ends(self) -> list[str]:
        """Ends of the analysed range (``"lower"``, ``"upper"``) where steady rolling is
        unstable: there an interval of ``linear_band_kmh`` ends at the range, not at an onset."""
        lo, hi = float(self.speeds_kmh[0]), float(self.speeds_kmh[-1])
        return [end for end, v in (("lower", lo), ("upper", hi))
                if any(v in (a, b) for a, b in self.linear_band_kmh)]

    def summary(self) -> dict:
        """The JSON summary of ``polywear stability``."""
        out = {
            "model": self.params.model,
            "hopf_speeds_kmh": [h.speed_kmh for h in self.hopf_points],
            "hopf_frequencies_hz": [h.frequency_hz for h in self.hopf_points],
            "linear_band_kmh": [list(iv) for iv in self.linear_band_kmh],
            "hopf_points": [h.summary() for h in self.hopf_points],
            "real_eigenvalue_crossings_kmh": list(self.real_crossings_kmh),
            "linear_band_open_ends": self.open_ends(),
        }
        out = with_deprecated_keys(out, RENAMED_KEYS)
        if self.alignment_deg is not None:
            op = self.params.operating.speed_kmh
            at = [float(np.interp(op, self.speeds_kmh, self.alignment_deg[:, k])) for k in (0, 1)]
            out["running_alignment"] = {
                "speed_kmh": op,
                "toe_deg": at[0],
                "camber_deg": at[1],
                "toe_range_deg": [float(self.alignment_deg[:, 0].min()), float(self.alignment_deg[:, 0].max())],
                "camber_range_deg": [float(self.alignment_deg[:, 1].min()), float(self.alignment_deg[:, 1].max())],
            }
        return out

    def _dataset(self):
        """xarray Dataset: eigenvalues (real, imag) and equilibria against speed."""
        import xarray as xr

        ds = xr.Dataset(
            {
                "eigenvalue_real": (("speed_kmh", "index"), self.eigenvalues.real, {"units": "1/s"}),
                "eigenvalue_imag": (("speed_kmh", "index"), self.eigenvalues.imag, {"units": "rad/s"}),
                "equilibrium": (("speed_kmh", "state"), self.equilibria),
            },
            coords={"speed_kmh": self.speeds_kmh, "state": list(self.state_names)},
            attrs={
                "hopf_speeds_kmh": [h.speed_kmh for h in self.hopf_points],
                "hopf_frequencies_hz": [h.frequency_hz for h in self.hopf_points],
                **{k: str(v) for k, v in self.settings.items()},
            },
        )
        return ds

    def plot(self, ax=None):
        """Real parts of the eigenvalues against speed; Hopf points marked, the operating
        speed (``params.operating.speed_kmh``) as a vertical line. Returns artists."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(7, 4))
        re = self.eigenvalues.real
        order = np.argsort(-re, axis=1)
        re_sorted = np.take_along_axis(re, order, axis=1)
        artists = []
        for j in range(re_sorted.shape[1]):
            artists += ax.plot(self.speeds_kmh, re_sorted[:, j], lw=1.0, color=f"C{j % 10}")
        artists.append(ax.axhline(0.0, color="k", lw=0.8))
        for lo, hi in self.linear_band_kmh:
            artists.append(ax.axvspan(lo, hi, color="tab:red", alpha=0.12))
        for v in self.real_crossings_kmh:
            artists += ax.plot([v], [0.0], "D", color="tab:purple")
        for h in self.hopf_points:
            artists += ax.plot([h.speed_kmh], [0.0], "o", color="tab:red")
            artists.append(
                ax.annotate(
                    f"H {h.speed_kmh:.1f} km/h\n{h.frequency_hz:.0f} Hz, {h.criticality}",
                    (h.speed_kmh, 0.0), textcoords="offset points", xytext=(4, 8), fontsize=8,
                )
            )
        finite = re_sorted[:, : min(3, re_sorted.shape[1])]
        lo, hi = np.nanmin(finite), np.nanmax(finite)
        pad = 0.1 * (hi - lo + 1e-12)
        ax.set_ylim(lo - pad, hi + pad)
        speed = self.params.operating.speed_kmh
        artists.append(ax.axvline(speed, color="tab:green", ls="-.", lw=1.5, label=f"operating speed {speed:g} km/h"))
        ax.legend(loc="lower left", fontsize=8)
        ax.set_xlabel("speed [km/h]")
        ax.set_ylabel("Re(eigenvalue) [1/s]")
        ax.set_title(f"{self.params.model}: stability of steady rolling (red: unstable)")
        return artists


def stability(
    params: Params,
    speed_range_kmh: tuple[float, float] = STABILITY_SPEED_RANGE_KMH,
    settings: StabilitySettings = StabilitySettings(),
) -> StabilityResult:
    """Linear stability of steady rolling along speed (``polywear stability``, ``pw.stability``).

    The equilibrium and its Jacobian eigenvalues are computed on a speed grid; every
    change in the number of unstable eigenvalues between grid points is located by
    Brent's method: a complex pair gives a Hopf point (frequency, first Lyapunov
    coefficient, mode), a real eigenvalue a static-divergence speed.

    Parameters
    ----------
    params : Params
        The parameter set (model, operating point, tread, friction, axle, tire).
    speed_range_kmh : (float, float)
        Lowest and highest speed [km/h], ``0 < low < high``.
    settings : StabilitySettings
        Grid points for bracketing and tolerance of the located speeds.

    Returns
    -------
    StabilityResult
        Eigenvalues [1/s] against speed, Hopf points, unstable intervals [km/h];
        ``summary()`` is what ``polywear stability --json`` prints.

    Raises
    ------
    ValueError
        If the speed range is invalid.
    """
    lo, hi = (float(v) for v in speed_range_kmh)
    if not (0.0 < lo < hi):
        raise ValueError(f"speed range {lo} {hi}: need 0 < low < high [km/h]")
    model = model_for(params)
    p = model.pack(params)
    speeds_kmh, states, eig = _refined_grid(model, p, np.linspace(lo, hi, settings.n_speeds))
    speeds = kmh_to_ms(speeds_kmh)
    unstable = _n_unstable(eig)
    hopfs: list[HopfPoint] = []
    reals: list[float] = []
    for i in np.flatnonzero(np.diff(unstable) != 0):
        h, r = _hopf_in_bracket(model, p, speeds[i], speeds[i + 1], eig[i], eig[i + 1], settings.xtol_ms)
        hopfs += h
        reals += r
    hopfs.sort(key=lambda h: h.speed_ms)
    real_kmh = sorted(ms_to_kmh(v) for v in reals)
    intervals = _unstable_intervals(model, p, speeds_kmh, [h.speed_kmh for h in hopfs] + real_kmh)
    alignment = getattr(model.kernels, "running_alignment", None)
    return StabilityResult(
        params=params,
        speeds_kmh=speeds_kmh,
        eigenvalues=eig,
        equilibria=states,
        hopf_points=hopfs,
        real_crossings_kmh=real_kmh,
        linear_band_kmh=intervals,
        state_names=model.state_names,
        settings={"n_speeds": settings.n_speeds, "xtol_ms": settings.xtol_ms},
        alignment_deg=None if alignment is None else np.degrees([alignment(u, p) for u in states]),
    )


REFINE_POINTS = 16
"""Speeds added across a grid point where a band may hide between neighbours."""
REFINE_ROUNDS = 8
"""Refinement rounds at most (each shrinks the spacing there by about REFINE_POINTS / 2)."""


def _hidden_bands(speeds_kmh: np.ndarray, eig: np.ndarray) -> list[int]:
    """Grid points where an unstable (or stable) band may lie between the neighbours.

    The k-th largest real part of the eigenvalues is continuous in speed. Where it has a
    local extremum at a grid point and keeps its sign there and at both neighbours, it
    could still cross zero twice between the neighbours if it is steep enough: with
    slopes up to ``L`` (twice the steeper of the two secants), the extreme value between
    ``x[i-1]`` and ``x[i+1]`` can reach ``(y[i-1] + y[i+1] +- L (x[i+1] - x[i-1])) / 2``.
    Those points are returned; the grid is refined around them.
    """
    real = np.sort(eig.real, axis=1)
    y0, y1, y2 = real[:-2], real[1:-1], real[2:]  # (grid point i - 1, i, i + 1) x eigenvalue
    x = np.asarray(speeds_kmh)[:, None]
    extremum = (y0 * y1 > 0) & (y1 * y2 > 0) & ((y1 - y0) * (y2 - y1) < 0)  # no sign change (located anyway)
    steepest = 2.0 * np.maximum(np.abs(y1 - y0) / (x[1:-1] - x[:-2]), np.abs(y2 - y1) / (x[2:] - x[1:-1]))
    reach = 0.5 * (y0 + y2 - np.sign(y1) * steepest * (x[2:] - x[:-2]))  # towards zero
    return [int(i) + 1 for i in np.flatnonzero(np.any(extremum & (np.sign(reach) != np.sign(y1)), axis=1))]


def _refined_grid(model, p, speeds_kmh: np.ndarray):
    """Equilibria and eigenvalues on ``speeds_kmh``, refined where a band could fall
    between grid points (:func:`_hidden_bands`): (speeds [km/h], states, eigenvalues)."""
    states, eig = equilibrium_eigenvalues(model, p, kmh_to_ms(speeds_kmh))
    for _ in range(REFINE_ROUNDS):
        suspects = _hidden_bands(speeds_kmh, eig)
        if not suspects:
            break
        extra = np.unique(np.concatenate([
            np.linspace(speeds_kmh[i - 1], speeds_kmh[i + 1], REFINE_POINTS + 2)[1:-1] for i in suspects
        ]))
        extra = extra[~np.isin(extra, speeds_kmh)]
        new_states, new_eig = equilibrium_eigenvalues(model, p, kmh_to_ms(extra))
        order = np.argsort(np.concatenate([speeds_kmh, extra]), kind="stable")
        speeds_kmh = np.concatenate([speeds_kmh, extra])[order]
        states = np.concatenate([states, new_states])[order]
        eig = np.concatenate([eig, new_eig])[order]
    return speeds_kmh, states, eig


def _hopf_in_bracket(model, p, V_lo, V_hi, eig_lo, eig_hi, xtol) -> tuple[list[HopfPoint], list[float]]:
    """Hopf points and real-eigenvalue crossings [m/s] between two grid speeds (the bracket
    is refined if several modes cross or the eigenvalues cannot be matched)."""
    crossing = _crossing_pairs(eig_lo, eig_hi)
    if crossing is None:  # ambiguous: split the bracket
        V_mid = 0.5 * (V_lo + V_hi)
        if V_hi - V_lo < 1e-6:
            raise NumericalError(f"cannot separate eigenvalue crossings near {ms_to_kmh(V_lo):.6f} km/h")
        _, eig_mid = equilibrium_eigenvalues(model, p, [V_mid])
        h1, r1 = _hopf_in_bracket(model, p, V_lo, V_mid, eig_lo, eig_mid[0], xtol)
        h2, r2 = _hopf_in_bracket(model, p, V_mid, V_hi, eig_mid[0], eig_hi, xtol)
        return h1 + h2, r1 + r2
    pairs, reals = crossing
    hopfs = [locate_hopf(model, p, V_lo, V_hi, a, b, xtol) for a, b in pairs]
    return hopfs, [_locate_real_crossing(model, p, V_lo, V_hi, a, b, xtol) for a, b in reals]


def _locate_real_crossing(model, p, V_lo, V_hi, lam_lo, lam_hi, xtol) -> float:
    """Speed [m/s] where a real eigenvalue (tracked from lam_lo to lam_hi) passes through zero:
    a static (divergence) instability or a fold of equilibria."""

    def tracked(V):
        s = (V - V_lo) / (V_hi - V_lo)
        return _eigen_nearest(model, p, V, lam_lo + s * (lam_hi - lam_lo))[2].real

    return float(brentq(tracked, V_lo, V_hi, xtol=xtol, rtol=4 * np.finfo(float).eps))


def _crossing_pairs(eig_lo: np.ndarray, eig_hi: np.ndarray):
    """Matched eigenvalues whose real part changes sign: ``(pairs, reals)`` with the
    complex pairs (Im > 0) and the real eigenvalues that cross zero.

    Eigenvalues are matched by nearest distance; returns None when the matching is
    ambiguous or a complex pair turns real within the bracket (then it is refined).
    """
    from scipy.optimize import linear_sum_assignment

    cost = np.abs(eig_lo[:, None] - eig_hi[None, :])
    rows, cols = linear_sum_assignment(cost)
    pairs, reals = [], []
    for r, c in zip(rows, cols):
        a, b = eig_lo[r], eig_hi[c]
        if np.sign(a.real) != np.sign(b.real):
            if a.imag > 0 and b.imag > 0:
                pairs.append((a, b))
            elif a.imag == 0 and b.imag == 0:
                reals.append((a, b))
            elif a.imag == 0 or b.imag == 0:
                return None
    # every crossing pair has a conjugate partner; the sign count must match
    n_change = np.sum(eig_hi.real > 0) - np.sum(eig_lo.real > 0)
    signed = sum(2 if b.real > 0 else -2 for _, b in pairs) + sum(1 if b.real > 0 else -1 for _, b in reals)
    return (pairs, reals) if signed == n_change else None


def _unstable_intervals(model, p, speeds_kmh, edges_kmh) -> list[tuple[float, float]]:
    """Speed intervals [km/h] where the equilibrium has an eigenvalue with Re > 0.

    Between consecutive crossings (Hopf or real) the number of unstable eigenvalues is
    constant; it is evaluated at the middle of each piece.
    """
    edges = sorted(edges_kmh)
    points = [float(speeds_kmh[0]), *edges, float(speeds_kmh[-1])]
    intervals: list[tuple[float, float]] = []
    for a, b in zip(points[:-1], points[1:]):
        if b <= a:
            continue
        _, eig_mid = equilibrium_eigenvalues(model, p, [kmh_to_ms(0.5 * (a + b))])
        if _n_unstable(eig_mid)[0] > 0:
            if intervals and intervals[-1][1] == a:
                intervals[-1] = (intervals[-1][0], b)
            else:
                intervals.append((a, b))
    return intervals


# -- the linear band alone, fast: a coarse grid and Brent ------------------------------------
def _growth_rates(model, p, speeds) -> np.ndarray:
    """Largest real part of the equilibrium's eigenvalues at each speed [1/s] (one LAPACK call)."""
    J = np.empty((len(speeds), model.n, model.n))
    for k, V in enumerate(speeds):
        model.kernels.jac(model.equilibrium(V, p), float(V), p, J[k])
    return np.linalg.eigvals(J).real.max(axis=1)


def fast_linear_band(
    params: Params, speed_range_kmh=DEFAULT_SPEED_RANGE_KMH, n_grid: int = 48, xtol_ms: float = 1e-9
) -> list[tuple[float, float]]:
    """Speed intervals [km/h] where steady rolling is unstable (the linear band), fast.

    The largest real part ``r(V)`` of the equilibrium eigenvalues is sampled on
    ``n_grid`` speeds; every sign change is refined by Brent's method to ``xtol_ms``
    [m/s]. Where ``r`` has a negative local maximum (or positive local minimum) on the
    grid (the range ends included), a bounded scalar search decides whether it crosses
    zero between the grid points, so a band narrower than the grid step is not missed. The ends of an
    interval are Hopf speeds (or, where a real eigenvalue crosses zero, that speed),
    or the range ends where the band reaches them.
    """
    from scipy.optimize import brentq, minimize_scalar

    model = model_for(params)
    p = model.pack(params)
    lo, hi = (kmh_to_ms(v) for v in speed_range_kmh)
    speeds = np.linspace(lo, hi, n_grid)
    r = _growth_rates(model, p, speeds)

    def rate(V):
        return _growth_rates(model, p, (V,))[0]

    def root(a, b):
        return brentq(rate, a, b, xtol=xtol_ms, rtol=4 * np.finfo(float).eps)

    crossings = [root(speeds[i], speeds[i + 1]) for i in np.flatnonzero((r[:-1] > 0) != (r[1:] > 0))]
    for i in range(n_grid):  # the two ends too: a band inside the first or last grid step
        a, b = max(i - 1, 0), min(i + 1, n_grid - 1)
        window = r[a : b + 1]
        peak = r[i] >= window.max() and r[i] <= 0.0
        trough = r[i] <= window.min() and r[i] > 0.0
        if not (peak or trough):
            continue
        sign = -1.0 if peak else 1.0
        best = minimize_scalar(lambda V: sign * rate(V), bounds=(speeds[a], speeds[b]), method="bounded",
                               options={"xatol": xtol_ms * 1e3})
        if (rate(best.x) > 0.0) == peak:
            crossings += [root(speeds[a], best.x), root(best.x, speeds[b])]
    edges = [lo, *sorted(crossings), hi]
    unstable = r[0] > 0.0
    intervals = []
    for a, b in zip(edges[:-1], edges[1:]):
        if unstable and b > a:
            intervals.append((ms_to_kmh(a), ms_to_kmh(b)))
        unstable = not unstable
    return intervals
