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


def simulated_wear_change(params, speed_kmh: float, order: int) -> complex:
    """Per-revolution relative change dW_n/W_n of harmonic ``order`` by brute force: the
    coupled model simulated (rtol 1e-10) with that harmonic worn to 1 um, past its slowest
    transient (14 e-folds), and the harmonic written over the next two revolutions; no
    linear algebra, the wear map's independent check."""
    from polywear.models import model_for
    from polywear.models.profile import coupled_model, patch_sinc, profile_vector
    from polywear.solvers.integrate import integrate
    from polywear.wear.law import friction_power, written_harmonics
    from polywear.wear.map import load_to_power

    base = model_for(params)
    coupled = coupled_model(base)
    V, R = speed_kmh / 3.6, params.operating.rolling_radius_m
    u0, A, *_ = load_to_power(base, base.pack(params), V)
    decay = -np.max(np.linalg.eigvals(A).real)
    cos_coef = np.zeros(order)
    cos_coef[-1] = patch_sinc([order], params.tire.contact_length_m, R)[0] * 1e-6
    p = profile_vector(base, params, V, cos_coef, np.zeros(order))
    T = 2 * math.pi * R / V
    settle = math.ceil(14.0 / decay / T) * T
    run = integrate(coupled, np.append(u0, 0.0), V, p, settle + 2 * T, rtol=1e-10, atol=1e-14, dense_from=settle)
    t = settle + np.arange(2 * 64 * order + 1) * (T / (64 * order))
    u = run.dense(t)
    dW, _ = written_harmonics(t, friction_power(coupled, u, V, p), u[:, -1], [order], params)
    return complex(dW[0] / 2 / 1e-6)
