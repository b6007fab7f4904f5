"""Independent closed forms used as test oracles (docs/model.md section 3)."""

import math

import numpy as np
from scipy.optimize import brentq


def characteristic_polynomial(V, p):
    """Coefficients (highest power first) of the tread1dof cubic at the equilibrium, docs/model.md section 3."""
    m, k, c, n_load, toe, s0, s1, s2, mu_s, mu_c, v_s, delta = p
    v0 = V * math.sin(toe)
    e = math.exp(-abs(v0 / v_s) ** delta)
    g0 = mu_c + (mu_s - mu_c) * e
    dg0 = -(mu_s - mu_c) * e * delta * abs(v0 / v_s) ** (delta - 1) * math.copysign(1.0, v0) / v_s
    a = s0 * v0 / g0
    b = v0 * dg0 / g0
    return np.array([m, c + m * a + n_load * (s1 * b + s2), k + c * a + n_load * (s0 * b + s2 * a), k * a])


def routh_hurwitz_hopf_speeds(p, lo, hi, n=2000):
    """Speeds [m/s] where a2 a1 - a3 a0 of the cubic changes sign with a1/a3 > 0: the Hopf
    condition (a zero with a1/a3 <= 0 is a neutral saddle, real roots +-r, not a Hopf point)."""

    def delta(V):
        a3, a2, a1, a0 = characteristic_polynomial(V, p)
        return a2 * a1 - a3 * a0

    grid = np.linspace(lo, hi, n)
    vals = np.array([delta(v) for v in grid])
    roots = []
    for i in np.flatnonzero(np.sign(vals[:-1]) != np.sign(vals[1:])):
        root = brentq(delta, grid[i], grid[i + 1], xtol=1e-14, rtol=1e-15)
        a3, _, a1, _ = characteristic_polynomial(root, p)
        if a1 / a3 > 0.0:
            roots.append(root)
    return roots


def complex_step_jacobian(model, u, V, p, h=1e-30):
    """Jacobian d f / d u and speed derivative d f / d V of ``model.f`` at ``(u, V, p)`` by
    complex steps (exact to round-off for a real-analytic right-hand side)."""
    pc = np.asarray(p).astype(complex)
    jac = np.array([model.f(u + 1j * h * e, V, pc).imag / h for e in np.eye(model.n)]).T
    return jac, model.f(u + 0j, V + 1j * h, pc).imag / h
