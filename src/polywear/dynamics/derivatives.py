"""Exact derivatives of model kernels by the complex step.

For a real-analytic f, ``f(x + i h d) = f(x) + i h f'(x) d + O(h^2)``, so
``Im f(x + i h d) / h`` is the directional derivative to rounding error with no
subtractive cancellation; with ``h = 1e-150`` there is no step to choose. The kernels
accept complex arrays (``|v|`` and ``sgn v`` act on the real part), which makes the
derivatives exact wherever the sliding velocity is not zero.

Notation: ``u`` state, ``V`` speed [m/s], ``p`` kernel parameter vector.
"""

from __future__ import annotations

import numpy as np

H = 1e-150
"""Complex-step size (any tiny value gives the same result)."""


def rhs_directional(model, u, V, p, du=None, dV=0.0, dp=None) -> np.ndarray:
    """d/dε f(u + ε du, V + ε dV, p + ε dp) at ε = 0."""
    uc = np.asarray(u, dtype=complex) + (0 if du is None else 1j * H * np.asarray(du))
    pc = np.asarray(p, dtype=complex) + (0 if dp is None else 1j * H * np.asarray(dp))
    return model.f(uc, complex(V, H * dV), pc).imag / H


def jac_directional(model, u, V, p, du=None, dV=0.0, dp=None) -> np.ndarray:
    """d/dε J(u + ε du, V + ε dV, p + ε dp) at ε = 0 (J = df/du)."""
    uc = np.asarray(u, dtype=complex) + (0 if du is None else 1j * H * np.asarray(du))
    pc = np.asarray(p, dtype=complex) + (0 if dp is None else 1j * H * np.asarray(dp))
    return model.jacobian(uc, complex(V, H * dV), pc).imag / H


def bilinear(model, u, V, p, a, b) -> np.ndarray:
    """Second derivative B(a, b) = sum_jk d2f/du_j du_k a_j b_k (complex a, b allowed)."""
    a = np.asarray(a)
    b = np.asarray(b)

    def real_b(x, y):
        return jac_directional(model, u, V, p, du=x) @ y

    ar, ai = a.real, a.imag
    br, bi = b.real, b.imag
    out = real_b(ar, br).astype(complex)
    if np.any(ai) or np.any(bi):
        out += -real_b(ai, bi) + 1j * (real_b(ar, bi) + real_b(ai, br))
    return out


def trilinear(model, u, V, p, a, b, c, step=1e-5) -> np.ndarray:
    """Third derivative C(a, b, c): central difference of B(a, b) along c.

    ``c`` is split into real and imaginary parts; each part is scaled to unit norm for
    the difference, so the truncation error is O(step^2) relative.
    """
    c = np.asarray(c)
    out = np.zeros(len(u), dtype=complex)
    for part, weight in ((c.real, 1.0), (c.imag, 1j)):
        norm = np.linalg.norm(part)
        if norm == 0.0:
            continue
        d = part / norm * step
        plus = bilinear(model, np.asarray(u) + d, V, p, a, b)
        minus = bilinear(model, np.asarray(u) - d, V, p, a, b)
        out += weight * norm * (plus - minus) / (2.0 * step)
    return out
