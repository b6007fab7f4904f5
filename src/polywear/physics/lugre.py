"""LuGre tread-road friction, normalized by the normal load (docs/model.md section 2).

Scalar kernels are ``numba.njit`` functions that accept float or complex arguments
(complex arguments are used for complex-step derivatives, so the non-analytic
functions ``|v|`` and ``sgn v`` act on the real part only). Array helpers for
curves, loops and fitting follow.

Symbols: ``v`` sliding velocity of the road relative to the tread [m/s], ``z`` mean
bristle deflection [m], ``sigma0`` [1/m], ``sigma1`` [s/m], ``sigma2`` [s/m],
``mu_s``, ``mu_c`` [-], ``v_s`` [m/s], ``delta`` [-]. Forces are per unit normal load.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = [
    "real_abs",
    "real_sign",
    "stribeck",
    "stribeck_dv",
    "bristle_rate",
    "bristle_rate_partials",
    "bristle_decay_rate",
    "friction_coefficient",
    "steady_deflection",
    "steady_friction",
    "steady_friction_slope",
]


@njit(cache=True, error_model="numpy")
def real_abs(x):
    """|x| taken on the real part, analytic continuation for complex-step use."""
    return x if x.real >= 0.0 else -x


@njit(cache=True, error_model="numpy")
def real_sign(x):
    """sgn(Re x) as a float (0 at 0)."""
    r = x.real
    if r > 0.0:
        return 1.0
    if r < 0.0:
        return -1.0
    return 0.0


@njit(cache=True, error_model="numpy")
def stribeck(v, mu_s, mu_c, v_s, delta):
    """Stribeck curve G(v) = mu_c + (mu_s - mu_c) exp(-|v/v_s|^delta) [-]."""
    return mu_c + (mu_s - mu_c) * np.exp(-(real_abs(v / v_s) ** delta))


@njit(cache=True, error_model="numpy")
def stribeck_dv(v, mu_s, mu_c, v_s, delta):
    """dG/dv [s/m]; zero at v = 0 for delta > 1."""
    a = real_abs(v / v_s)
    if a.real == 0.0:
        return 0.0 * v
    return -(mu_s - mu_c) * np.exp(-(a**delta)) * delta * a ** (delta - 1.0) * real_sign(v) / v_s


@njit(cache=True, error_model="numpy")
def bristle_decay_rate(v, sigma0, g):
    """sigma0 |v| / G [1/s]: the rate at which the bristle forgets its deflection."""
    return sigma0 * real_abs(v) / g


@njit(cache=True, error_model="numpy")
def bristle_rate(v, z, sigma0, g):
    """dz/dt = v - sigma0 |v| z / G [m/s] for sliding velocity v and G = g."""
    return v - bristle_decay_rate(v, sigma0, g) * z


@njit(cache=True, error_model="numpy")
def bristle_rate_partials(v, z, sigma0, g, dg):
    """(d(dz/dt)/dv [-], d(dz/dt)/dz [1/s]) of :func:`bristle_rate`; ``dg`` = dG/dv at v."""
    dzd_dv = 1.0 - sigma0 * z * (real_sign(v) * g - real_abs(v) * dg) / (g * g)
    return dzd_dv, -bristle_decay_rate(v, sigma0, g)


@njit(cache=True, error_model="numpy")
def friction_coefficient(v, z, zdot, sigma0, sigma1, sigma2):
    """F/N = sigma0 z + sigma1 dz/dt + sigma2 v [-]."""
    return sigma0 * z + sigma1 * zdot + sigma2 * v


def steady_deflection(v, sigma0, mu_s, mu_c, v_s, delta):
    """Steady bristle deflection z_ss = sgn(v) G(v) / sigma0 [m] (array-valued)."""
    v = np.asarray(v, dtype=float)
    return np.sign(v) * _stribeck_array(v, mu_s, mu_c, v_s, delta) / sigma0


def steady_friction(v, sigma2, mu_s, mu_c, v_s, delta):
    """Steady friction coefficient mu_ss(v) = sgn(v) G(v) + sigma2 v [-] (array-valued)."""
    v = np.asarray(v, dtype=float)
    return np.sign(v) * _stribeck_array(v, mu_s, mu_c, v_s, delta) + sigma2 * v


def steady_friction_slope(v, sigma2, mu_s, mu_c, v_s, delta):
    """d mu_ss / dv [s/m] (v != 0); negative on the falling (Stribeck) branch."""
    v = np.asarray(v, dtype=float)
    a = np.abs(v / v_s)
    return -(mu_s - mu_c) * np.exp(-(a**delta)) * delta * a ** (delta - 1.0) / v_s + sigma2


def _stribeck_array(v, mu_s, mu_c, v_s, delta):
    return mu_c + (mu_s - mu_c) * np.exp(-np.abs(v / v_s) ** delta)
