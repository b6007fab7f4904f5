"""Linear wear stability: which polygon orders grow, how fast, at which speeds.

Around steady rolling, a worn harmonic ``w_n exp(i n phi)`` changes the load through
the patch average and so the friction power; the power writes wear back onto the same
harmonic. Per wheel revolution (``docs/wear.md``)

    dw_n / w_n = -(k_e / (V b_w)) sinc_n^2 (k_z + i n Omega c_z) H_PN(i n Omega),

``Omega = V/R``, ``H_PN(s) = C (s I - A)^-1 B + D`` the transfer function from the static
load to the friction power ``P = F v_r`` of the model linearized at its equilibrium:
``A`` the analytic Jacobian, ``B = df/dN0`` (spring preloads held), ``C = dP/du`` and
``D = dP/dN0``; B, C and D by complex steps of the compiled kernels (exact to
rounding). The multiplier ``lambda_n = 1 + dw_n/w_n`` gives the growth
``ln|lambda_n|`` per revolution and the drift of the pattern ``-arg(lambda_n)/n`` per
revolution (positive: the pattern moves toward increasing material angle, the way the
contact patch sweeps the tread). No simulation and no finite differences.

Where steady rolling is itself unstable (the linear band) the tread vibrates and this
analysis does not apply: such speeds are flagged ``rolling_stable = False``.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

import numpy as np
from numpy.typing import ArrayLike

from ..models import model_for
from ..results import Result
from ..models.profile import patch_sinc
from ..params import MAX_WEAR_ORDER, Params
from ..settings import check_count
from ..units import kmh_to_ms, order_rays, wheel_circumference_m, wheel_rotation_frequency_hz
from ..dynamics.stability import mode_label, stability
from .law import energetic_rate

__all__ = ["WearMap", "WearMapSettings", "wear_map", "load_to_power", "VIBRATING_NOTE"]

VIBRATING_NOTE = "vibrating: see evolution"
_CSTEP = 1e-20
"""Complex step, relative to the perturbed quantity's scale (exact to rounding)."""


@dataclass(frozen=True)
class WearMapSettings:
    """Numerical settings of :func:`wear_map` (``polywear wear map --max-order``)."""

    max_order: int | None = None
    """Highest polygon order of the map [-] (1 to ``MAX_WEAR_ORDER``); None: ``wear.max_order``
    of the parameters (the result records the order used)."""

    def __post_init__(self) -> None:
        if self.max_order is not None:
            check_count(self, "max_order", minimum=1, maximum=MAX_WEAR_ORDER)


def _load_slot(model) -> int:
    return model.param_names.index("N0" if "N0" in model.param_names else "N")


def _power(model, u, V, p) -> complex:
    """Friction power F v_r at one (possibly complex) state."""
    out = np.empty(len(model.aux_names), dtype=np.result_type(u, p, V))
    model.kernels.aux(u, V, p, out)
    names = model.aux_names
    return out[names.index("friction_force")] * out[names.index("sliding_velocity")]


def load_to_power(model, p, V: float):
    """Linearization at steady rolling: ``(u0, A, B, C, D)`` with ``p`` prepared at ``V``.

    ``A = df/du``, ``B = df/dN0``, ``C = dP/du``, ``D = dP/dN0`` (P = F v_r [W],
    N0 [N]); the spring preloads stay those of the nominal load.
    """
    q = model.prepared(V, np.asarray(p, dtype=float))
    u0 = model.equilibrium(V, q)
    A = model.jacobian(u0, V, q)
    i0 = _load_slot(model)
    h_n = _CSTEP * max(abs(q[i0]), 1.0)
    qc = q.astype(complex)
    qc[i0] += 1j * h_n
    uc = u0.astype(complex)
    Vc = complex(V)
    B = model.f(uc, Vc, qc).imag / h_n
    D = _power(model, uc, Vc, qc).imag / h_n
    qr = q.astype(complex)
    C = np.empty(model.n)
    for j in range(model.n):
        h = _CSTEP * max(abs(u0[j]), 1e-6)
        du = uc.copy()
        du[j] += 1j * h
        C[j] = _power(model, du, Vc, qr).imag / h
    return u0, A, B, C, D


@dataclass
class WearMap(Result):
    """Per-revolution wear multipliers over (speed, order) and what they mean."""

    params: Params
    speeds_kmh: np.ndarray
    """(S,) [km/h]"""
    orders: np.ndarray
    """(K,) polygon orders n = 1..max_order"""
    relative_change: np.ndarray
    """(S, K) complex dw_n/w_n per revolution [-]; NaN where rolling is unstable"""
    rolling_stable: np.ndarray
    """(S,) bool: steady rolling stable (the map applies)"""
    mode_frequency_hz: np.ndarray
    """(S,) damped frequency of the tread mode at each speed [Hz]"""
    mean_wear_mm_per_1000km: np.ndarray
    """(S,) uniform wear of steady rolling [mm per 1000 km]"""
    linear_band_kmh: list[tuple[float, float]]
    """Speed intervals where steady rolling is unstable [km/h], bounded by the located
    Hopf speeds (``dynamics.stability``) within the speeds of the map"""
    settings: WearMapSettings = WearMapSettings()
    """The settings of the map, ``max_order`` the highest order computed"""

    # -- derived quantities ---------------------------------------------------------------
    @property
    def revolutions_per_km(self) -> float:
        return wheel_rotation_frequency_hz(1000.0, self.params.operating.rolling_radius_m)  # per 1000 m

    @property
    def growth_per_rev(self) -> np.ndarray:
        """ln|1 + dw_n/w_n| per revolution [-] (S, K)."""
        d = self.relative_change
        return 0.5 * np.log1p(2.0 * d.real + np.abs(d) ** 2)

    @property
    def growth_per_1000km(self) -> np.ndarray:
        """e-folds per 1000 km (S, K); scales as k_e."""
        return self.growth_per_rev * self.revolutions_per_km * 1000.0

    @property
    def efold_km(self) -> np.ndarray:
        """Distance over which a growing order grows by e [km] (S, K); NaN where it decays."""
        g = self.growth_per_rev * self.revolutions_per_km
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(g > 0.0, 1.0 / g, np.nan)

    @property
    def drift_deg_per_rev(self) -> np.ndarray:
        """Drift of the pattern around the tire [deg per revolution] (S, K)."""
        d = self.relative_change
        return -np.degrees(np.arctan2(d.imag, 1.0 + d.real)) / self.orders

    @property
    def frequency_hz(self) -> np.ndarray:
        """n times the rotation frequency [Hz] (S, K)."""
        f_rot = wheel_rotation_frequency_hz(kmh_to_ms(self.speeds_kmh), self.params.operating.rolling_radius_m)
        return np.outer(f_rot, self.orders)

    def most_unstable(self) -> np.ndarray:
        """Index of the fastest-growing order per speed (-1 where rolling is unstable)."""
        g = np.where(self.rolling_stable[:, None], self.growth_per_rev, -np.inf)
        return np.where(self.rolling_stable, np.argmax(g, axis=1), -1)

    def rows(self, all_orders: bool = False) -> list[dict]:
        """JSON rows: per speed its most unstable order (or every order)."""
        efold, growth, drift, freq = self.efold_km, self.growth_per_1000km, self.drift_deg_per_rev, self.frequency_hz
        best = self.most_unstable()
        out = []
        for i, v in enumerate(self.speeds_kmh):
            if not self.rolling_stable[i]:
                out.append({"speed_kmh": float(v), "order": None, "frequency_hz": None, "growth_per_1000km": None,
                            "efold_km": None, "drift_deg_per_rev": None, "rolling_stable": False,
                            "note": VIBRATING_NOTE})
                continue
            for k in range(len(self.orders)) if all_orders else [best[i]]:
                out.append({
                    "speed_kmh": float(v),
                    "order": int(self.orders[k]),
                    "frequency_hz": float(freq[i, k]),
                    "growth_per_1000km": float(growth[i, k]),
                    "efold_km": None if math.isnan(efold[i, k]) else float(efold[i, k]),
                    "drift_deg_per_rev": float(drift[i, k]),
                    "rolling_stable": True,
                    "note": None,
                })
        return out

    def summary(self, all_orders: bool = False) -> dict:
        """The JSON summary of ``polywear wear map``."""
        return {
            "model": self.params.model,
            "energetic_rate_mm3_per_j": self.params.wear.energetic_rate_mm3_per_j,
            "distances_scale_as": "1/k_e",
            "linear_band_kmh": [list(b) for b in self.linear_band_kmh],
            "rows": self.rows(all_orders),
        }

    def to_dataframe(self):
        """pandas DataFrame: :meth:`rows` of every order (what ``wear map --csv`` writes)."""
        import pandas as pd

        return pd.DataFrame(self.rows(all_orders=True))

    def _dataset(self):
        """xarray Dataset over (speed_kmh, order)."""
        import xarray as xr

        dims = ("speed_kmh", "order")
        return xr.Dataset(
            {
                "relative_change_real": (dims, self.relative_change.real, {"units": "1 per revolution"}),
                "relative_change_imag": (dims, self.relative_change.imag, {"units": "1 per revolution"}),
                "growth_per_1000km": (dims, self.growth_per_1000km, {"units": "e-folds per 1000 km"}),
                "efold_km": (dims, self.efold_km, {"units": "km", "note": "scales as 1/k_e"}),
                "drift_deg_per_rev": (dims, self.drift_deg_per_rev, {"units": "deg per revolution"}),
                "frequency_hz": (dims, self.frequency_hz, {"units": "Hz"}),
                "rolling_stable": ("speed_kmh", self.rolling_stable.astype(np.int8)),
                "mode_frequency_hz": ("speed_kmh", self.mode_frequency_hz, {"units": "Hz"}),
                "mean_wear_mm_per_1000km": ("speed_kmh", self.mean_wear_mm_per_1000km),
            },
            coords={"speed_kmh": self.speeds_kmh, "order": self.orders},
            attrs={k: str(v) for k, v in asdict(self.settings).items()},
        )

    def plot(self, ax=None, sev_band_kmh: tuple[float, float] | None = None, rays=(5, 10, 15, 20, 30, 40, 60)):
        """Campbell-style map: speed on x, frequency n f_rot on y, growth per 1000 km
        coloured per (speed, order); wheel-order rays, the tread mode, the linear band
        (and the SEV band if given) shaded. Returns the artists."""
        import matplotlib.pyplot as plt
        from matplotlib.colors import TwoSlopeNorm

        if ax is None:
            _, ax = plt.subplots(figsize=(8, 5))
        g = np.where(self.rolling_stable[:, None], self.growth_per_1000km, np.nan)
        finite = g[np.isfinite(g)]
        lim = float(np.max(np.abs(finite))) if finite.size else 1.0
        freq = self.frequency_hz
        # cell corners: speeds half-way between grid speeds, orders n -+ 1/2 along each column
        v = self.speeds_kmh
        v_edges = np.concatenate(([v[0]], 0.5 * (v[1:] + v[:-1]), [v[-1]])) if v.size > 1 else np.array([v[0] - 0.5, v[0] + 0.5])
        f_rot_edges = wheel_rotation_frequency_hz(kmh_to_ms(v_edges), self.params.operating.rolling_radius_m)
        order_edges = np.concatenate((self.orders - 0.5, [self.orders[-1] + 0.5]))
        X = np.repeat(v_edges[:, None], order_edges.size, axis=1)
        Y = np.outer(f_rot_edges, order_edges)
        mesh = ax.pcolormesh(X, Y, g, cmap="RdBu_r", norm=TwoSlopeNorm(0.0, -lim, lim) if lim > 0 else None,
                             shading="flat")
        artists = [mesh]
        cbar = ax.figure.colorbar(mesh, ax=ax)
        cbar.set_label("growth [e-folds per 1000 km] (scales as k_e)")
        for lo, hi in self.linear_band_kmh:
            artists.append(ax.axvspan(lo, hi, color="0.6", alpha=0.45, label="linear band: vibrating, see evolution"))
        if sev_band_kmh is not None:
            artists.append(ax.axvspan(*sev_band_kmh, fill=False, hatch="//", edgecolor="tab:orange", lw=0.0,
                                      label="SEV band"))
        top = min(float(np.nanmax(freq)), 1.6 * float(np.nanmax(self.mode_frequency_hz)))
        ax.set_ylim(0.0, top)  # every ray drawn is labelled, no two labels overlap (units.order_rays)
        order_rays(ax, [n for n in rays if n <= self.orders[-1]], self.params.operating.rolling_radius_m,
                   (float(v[0]), float(v[-1])), top, color="0.25", lw=0.6, alpha=1.0)
        artists += ax.plot(self.speeds_kmh, self.mode_frequency_hz, color="k", lw=1.6, ls="--", label="tread mode")
        best = self.most_unstable()
        ok = best >= 0
        artists += ax.plot(self.speeds_kmh[ok], freq[ok, best[ok]], "o", ms=2.5, color="tab:red",
                           label="most unstable order")
        ax.set_xlabel("speed [km/h]")
        ax.set_ylabel("frequency n f_rot [Hz]  (rays: polygon order n)")
        ax.set_ylim(0.0, top)
        ax.set_title(f"{self.params.model}: wear-stability map (red grows, blue heals)")
        handles, labels = ax.get_legend_handles_labels()
        unique = dict(zip(labels, handles))
        ax.legend(unique.values(), unique.keys(), fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=3)
        return artists


def _tread_mode_frequency(model, p, A) -> float:
    """Damped frequency [Hz] of the least damped oscillatory mode carried by the tread."""
    vals, vecs = np.linalg.eig(A)
    best = (math.inf, math.nan)
    for k, lam in enumerate(vals):
        if lam.imag > 0.0 and mode_label(model, p, vecs[:, k]) == "x":
            damping = -lam.real / abs(lam)
            best = min(best, (damping, lam.imag / (2.0 * math.pi)))
    return best[1]


def wear_map(params: Params, speeds_kmh: ArrayLike, settings: WearMapSettings = WearMapSettings()) -> WearMap:
    """The linear wear-stability map at the given speeds [km/h] for orders 1 to
    ``settings.max_order`` (:class:`WearMapSettings`; default ``wear.max_order``)."""
    if not isinstance(settings, WearMapSettings):
        raise TypeError(f"wear_map: settings = {settings!r}: a WearMapSettings (the highest order is "
                        "WearMapSettings(max_order=...))")
    speeds_kmh = np.atleast_1d(np.asarray(speeds_kmh, dtype=float))
    K = params.wear.max_order if settings.max_order is None else settings.max_order
    model = model_for(params)
    p = model.pack(params)
    orders = np.arange(1, K + 1)
    R = params.operating.rolling_radius_m
    k_z, c_z = params.tire.vertical_stiffness_n_per_m, params.tire.vertical_damping_ns_per_m
    k_e, b_w = energetic_rate(params), params.tire.tread_width_m
    sinc2 = patch_sinc(orders, params.tire.contact_length_m, R) ** 2
    change = np.full((len(speeds_kmh), K), np.nan + 0j)
    stable = np.zeros(len(speeds_kmh), dtype=bool)
    mode_f = np.full(len(speeds_kmh), np.nan)
    mean_wear = np.full(len(speeds_kmh), np.nan)
    eye = np.eye(model.n)
    for i, V in enumerate(kmh_to_ms(speeds_kmh)):
        u0, A, B, C, D = load_to_power(model, p, V)
        mode_f[i] = _tread_mode_frequency(model, p, A)
        p0 = max(float(_power(model, u0, V, model.prepared(V, p)).real), 0.0)
        mean_wear[i] = k_e * p0 / (V * b_w) * 1e6 / wheel_circumference_m(R) * 1e3  # m/rev -> mm/1000 km
        stable[i] = bool(np.max(np.linalg.eigvals(A).real) < 0.0)
        if not stable[i]:
            continue
        s = 1j * orders * (V / R)
        X = np.linalg.solve(s[:, None, None] * eye - A, np.broadcast_to(B, (K, model.n))[..., None])[..., 0]
        H = X @ C + D
        change[i] = -(k_e / (V * b_w)) * sinc2 * (k_z + s * c_z) * H
    lo, hi = float(speeds_kmh.min()), float(speeds_kmh.max())
    bands = stability(params, (lo, hi)).linear_band_kmh if hi > lo else (
        [] if stable[0] else [(lo, hi)])
    return WearMap(params=params, speeds_kmh=speeds_kmh, orders=orders, relative_change=change,
                   rolling_stable=stable, mode_frequency_hz=mode_f, mean_wear_mm_per_1000km=mean_wear,
                   linear_band_kmh=[(float(a), float(b)) for a, b in bands],
                   settings=replace(settings, max_order=K))
