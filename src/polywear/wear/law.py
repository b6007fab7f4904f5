"""The energetic wear law and the bookkeeping of the worn profile.

Friction power ``P = F v_r`` [W] (clipped at 0: a bristle giving back stored elastic
energy wears nothing) wears rubber at ``k_e P`` [m^3/s], spread uniformly over the
contact patch ``A_c = 2a b_w``. The material at angle ``phi`` collects, while it is in
the patch, ``dw(phi) = (k_e / A_c) P dt``.

The profile is kept as complex harmonics ``W_n`` (n = 1..K) of the depth,
``w(phi) = w_mean + sum_n Re(W_n exp(i n phi))`` (``W_n = A_n - i B_n`` with the cosine
and sine coefficients of :func:`polywear.models.profile.harmonics_of`). A time history
of the power and of the patch angle ``phi_c(t)`` writes

    dW_n = (k_e / (pi R b_w)) sinc_n  integral P(t) exp(-i n phi_c(t)) dt
    dw_mean = (k_e / (2 pi R b_w)) integral P(t) dt

(the indicator of the patch, integrated over angle, gives ``(2a/R) sinc_n``).
"""

from __future__ import annotations

import math

import numpy as np

from ..models.profile import patch_sinc
from ..units import wheel_circumference_m

__all__ = ["energetic_rate", "written_harmonics", "profile_samples", "friction_power"]


def energetic_rate(params) -> float:
    """k_e [m^3/J] from ``wear.energetic_rate_mm3_per_j``."""
    return params.wear.energetic_rate_mm3_per_j * 1e-9


def friction_power(model, u, V, p) -> np.ndarray:
    """Friction power ``max(F v_r, 0)`` [W] at states ``u`` (..., n) of ``model``."""
    aux = model.diagnostics(u, V, p)
    names = model.aux_names
    power = aux[..., names.index("friction_force")] * aux[..., names.index("sliding_velocity")]
    return np.maximum(power, 0.0)


def written_harmonics(t, power, angle, orders, params) -> tuple[np.ndarray, float]:
    """Depth written by a sampled time history: ``(dW_n [m] for n in orders, dw_mean [m])``.

    ``t`` [s] uniform samples, ``power`` [W] and ``angle`` = phi_c [rad] at them; the
    integrals are trapezoidal sums (exact for the sampled band-limited history when the
    window is whole revolutions and the sampling resolves ``max(orders)`` times the
    rotation and the power's own frequencies).
    """
    t = np.asarray(t, dtype=float)
    weights = np.full(t.size, t[1] - t[0])
    weights[0] *= 0.5
    weights[-1] *= 0.5
    R = params.operating.rolling_radius_m
    b_w = params.tire.tread_width_m
    k_e = energetic_rate(params)
    orders = np.asarray(orders)
    wp = weights * np.asarray(power, dtype=float)
    phase = np.exp(-1j * np.outer(orders, np.asarray(angle, dtype=float)))
    integral = phase @ wp
    sinc = patch_sinc(orders, params.tire.contact_length_m, R)
    dW = (k_e / (math.pi * R * b_w)) * sinc * integral
    mean = k_e / (wheel_circumference_m(R) * b_w) * float(wp.sum())
    return dW, mean


def profile_samples(W: np.ndarray, points: int, mean: float = 0.0) -> np.ndarray:
    """Depth ``w(phi_j)`` [m] at ``phi_j = 2 pi j / points`` from harmonics ``W_n``, n = 1..K."""
    spectrum = np.zeros(points // 2 + 1, dtype=complex)
    spectrum[1 : W.size + 1] = W * (points / 2.0)
    return np.fft.irfft(spectrum, n=points) + mean
