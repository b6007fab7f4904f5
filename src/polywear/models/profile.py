"""A worn tread profile coupled into the normal load of either model.

The contact patch (length ``2a``) sees the patch average of the worn depth
``w(phi)`` around the tire at the material angle ``phi_c`` of its centre:
``w_c = sum_n sinc_n (A_n cos n phi_c + B_n sin n phi_c)`` with
``sinc_n = sin(n a/R)/(n a/R)`` (the mean depth is left out: uniform wear changes no
load). A worn spot unloads the tire like a lifted contact point, so the static load
``N0`` of the model is replaced by the time-varying

    N0 - k_z w_c - c_z dw_c/dt

(``k_z``, ``c_z``: tire vertical stiffness and damping). In ``axle4dof`` the kernel then
subtracts ``k_z dz_C + c_z z_C'`` of the axle motion and clamps the total at ``N >= 0``;
in ``tread1dof`` (rim held) this load is the whole normal load and is clamped here.
With the patch contact (``tread1dof+patch``, :mod:`polywear.models.patch`) it is the
patch's total load ``N``, clamped here, which the elements share in the proportions of
the pressure distribution: the patch average enters the load as for the point contact,
and the wear law spreads the friction power over the patch the same way
(docs/patch_contact.md section 5 gives the reasons).
The spring preloads of ``axle4dof`` stay those of the nominal ``N0`` (they are set on
the car, not by the profile): the base vector is always *prepared* at the speed.

The rolling angle ``phi_c`` is one more state, ``phi_c' = V/R``, so the coupled model
is autonomous like the others and runs through the same integrators. Its parameter
vector (built by :func:`profile_vector`) is a header, the harmonics, a table, then the
base model's vector:

    [model flag, index of N0, R, k_z, c_z, K, L, A'_1..A'_K, B'_1..B'_K,
     w_c(theta_j), w_c'(theta_j), w_c''(theta_j) (j < L), p_base...]

with ``A'_n = sinc_n A_n``, ``B'_n = sinc_n B_n`` [m] (already patch-averaged). With
every harmonic zero the load is ``N0 + 0.0 = N0`` exactly, so rhs, Jacobian and
diagnostics of the base states are bit for bit those of the base model.

With ``L = 0`` every call sums the K harmonics. With ``L > 0`` (``table_points``) the
patch-averaged depth and its first two angle derivatives are tabulated once at
``theta_j = 2 pi j / L`` (exact samples of the series, by FFT) and each call
interpolates: ``w_c`` cubic Hermite from ``(w_c, w_c')``, ``w_c'`` from
``(w_c', w_c'')``; the angle derivatives of the load are those of the interpolants, so
the Jacobian stays exact for the interpolated rhs. Interpolation error of harmonic n:
``(2 pi n / L)^4 / 384`` of its size (6e-7 for n = 60, L = 4096): a call costs a few
flops instead of K sine-cosine recurrences.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
from numba import njit

from . import axle4dof_kernels as _axle
from . import axle4dof_patch_kernels as _axle_patch
from . import patch as _patch
from . import tread1dof as _tread
from .base import Model

__all__ = ["coupled_model", "profile_vector", "patch_sinc", "harmonics_of", "PHASE_STATE"]

PHASE_STATE = "contact_angle"
"""Name of the added state: material angle phi_c at the centre of the patch [rad]."""

_FLAG, _IN0, _R, _KZ, _CZ, _NH, _NT = range(7)
_HEAD = 7
_CSTEP = 1e-20
"""Complex step [N] for the load derivative of the base rhs (exact to rounding)."""
_FLAGS = {"tread1dof": 0, "axle4dof": 1, "tread1dof+patch": 2, "axle4dof+patch": 3}
_AXLE_FLAGS = (1, 3)
"""Models whose kernels clamp the load themselves (the load there includes the axle's motion)."""


def patch_sinc(orders, contact_length_m: float, radius_m: float) -> np.ndarray:
    """Patch-average factor ``sinc_n = sin(n a/R)/(n a/R)`` of harmonic order(s) n [-]."""
    x = np.asarray(orders, dtype=float) * (0.5 * contact_length_m / radius_m)
    return np.sinc(x / np.pi)


def harmonics_of(profile: np.ndarray, max_order: int) -> tuple[np.ndarray, np.ndarray]:
    """Cosine and sine coefficients ``A_n, B_n`` (n = 1..max_order) of samples of
    ``w(phi)`` at ``phi_j = 2 pi j / len(profile)`` [profile units]."""
    m = len(profile)
    c = np.fft.rfft(profile)[1 : max_order + 1] * (2.0 / m)
    return c.real.copy(), -c.imag.copy()


# -- kernels ------------------------------------------------------------------------------
@njit(cache=True, error_model="numpy")
def _base_rhs(flag, u, V, p, out):
    if flag == 0:
        _tread.rhs(u, V, p, out)
    elif flag == 1:
        _axle.rhs(u, V, p, out)
    elif flag == 2:
        _patch.rhs(u, V, p, out)
    else:
        _axle_patch.rhs(u, V, p, out)


@njit(cache=True, error_model="numpy")
def _base_jac(flag, u, V, p, out):
    if flag == 0:
        _tread.jac(u, V, p, out)
    elif flag == 1:
        _axle.jac(u, V, p, out)
    elif flag == 2:
        _patch.jac(u, V, p, out)
    else:
        _axle_patch.jac(u, V, p, out)


@njit(cache=True, error_model="numpy")
def _base_dfdv(flag, u, V, p, out):
    if flag == 0:
        _tread.dfdv(u, V, p, out)
    elif flag == 1:
        _axle.dfdv(u, V, p, out)
    elif flag == 2:
        _patch.dfdv(u, V, p, out)
    else:
        _axle_patch.dfdv(u, V, p, out)


@njit(cache=True, error_model="numpy")
def _base_rhs_jac_dfdv(flag, u, V, p, f, J, fv):
    if flag == 0:
        _tread.rhs_jac_dfdv(u, V, p, f, J, fv)
    elif flag == 1:
        _axle.rhs_jac_dfdv(u, V, p, f, J, fv)
    elif flag == 2:
        _patch.rhs_jac_dfdv(u, V, p, f, J, fv)
    else:
        _axle_patch.rhs_jac_dfdv(u, V, p, f, J, fv)


@njit(cache=True, error_model="numpy")
def _base_aux(flag, u, V, p, out):
    if flag == 0:
        _tread.aux(u, V, p, out)
    elif flag == 1:
        _axle.aux(u, V, p, out)
    elif flag == 2:
        _patch.aux(u, V, p, out)
    else:
        _axle_patch.aux(u, V, p, out)


@njit(cache=True, error_model="numpy")
def _base_start(p) -> int:
    """Index of the base model's vector in ``p``: after header, harmonics and table."""
    return _HEAD + 2 * int(p[_NH].real) + 3 * int(p[_NT].real)


@njit(cache=True, error_model="numpy")
def _tabulated(theta, p, column):
    """Cubic Hermite interpolant of table ``column`` (0: w_c, 1: w_c') with the next column
    as its derivative, and the interpolant's own derivative, at angle theta [rad]."""
    k = int(p[_NH].real)
    size = int(p[_NT].real)
    step = 2.0 * np.pi / size
    x = theta / step
    cell = np.floor(x.real)
    t = x - cell  # in [0, 1); complex under a complex step in theta
    i = int(cell) % size
    j = (i + 1) % size
    start = _HEAD + 2 * k + column * size
    f0, f1 = p[start + i], p[start + j]
    d0, d1 = step * p[start + size + i], step * p[start + size + j]
    t2 = t * t
    value = (2.0 * t2 * t - 3.0 * t2 + 1.0) * f0 + (t2 * t - 2.0 * t2 + t) * d0 \
        + (3.0 * t2 - 2.0 * t2 * t) * f1 + (t2 * t - t2) * d1
    slope = ((6.0 * t2 - 6.0 * t) * (f0 - f1) + (3.0 * t2 - 4.0 * t + 1.0) * d0 + (3.0 * t2 - 2.0 * t) * d1) / step
    return value, slope


@njit(cache=True, error_model="numpy")
def _profile_load(theta, V, p):
    """Load change dN [N], d(dN)/dphi_c [N/rad] and d(dN)/dV [N s/m] at angle theta."""
    k = int(p[_NH].real)
    omega = V / p[_R]
    if p[_NT].real > 0.0:
        w, w_slope = _tabulated(theta, p, 0)
        dw, dw_slope = _tabulated(theta, p, 1)
        dn = -p[_KZ] * w - p[_CZ] * omega * dw
        return dn, -p[_KZ] * w_slope - p[_CZ] * omega * dw_slope, -p[_CZ] * dw / p[_R]
    c1 = np.cos(theta)
    s1 = np.sin(theta)
    cn, sn = c1, s1
    w = 0.0 * c1
    dw = 0.0 * c1  # dw_c/dphi
    d2w = 0.0 * c1  # d2w_c/dphi2
    for j in range(k):
        n = j + 1.0
        a = p[_HEAD + j]
        b = p[_HEAD + k + j]
        w += a * cn + b * sn
        dw += n * (b * cn - a * sn)
        d2w -= n * n * (a * cn + b * sn)
        cn, sn = cn * c1 - sn * s1, sn * c1 + cn * s1
    dn = -p[_KZ] * w - p[_CZ] * omega * dw
    dn_dtheta = -p[_KZ] * dw - p[_CZ] * omega * d2w
    dn_dv = -p[_CZ] * dw / p[_R]
    return dn, dn_dtheta, dn_dv


@njit(cache=True, error_model="numpy")
def _loaded(u, V, p):
    """The base vector with the profile's load, and whether the input was clamped."""
    n = u.size - 1
    q = p[_base_start(p) :].copy()
    i0 = int(p[_IN0].real)
    dn, dn_dtheta, dn_dv = _profile_load(u[n], V, p)
    load = q[i0] + dn
    clamped = int(p[_FLAG].real) not in _AXLE_FLAGS and load.real < 0.0
    q[i0] = 0.0 * load if clamped else load
    return q, clamped, dn_dtheta, dn_dv


@njit(cache=True, error_model="numpy")
def _load_in_place(u, V, p):
    """:func:`_loaded` without the copy (the hot path: rhs and diagnostics, 2-3x cheaper):
    the profile's load is written into ``p``'s base vector, returned as a view, with the
    index written and the nominal value the caller puts back after the base kernel. Not for
    a ``p`` shared between threads (the integrator releases the GIL): each simulation has
    its own vector (:func:`profile_vector` builds one per window)."""
    n = u.size - 1
    start = _base_start(p)
    i = start + int(p[_IN0].real)
    nominal = p[i]
    load = nominal + _profile_load(u[n], V, p)[0]
    p[i] = 0.0 * load if int(p[_FLAG].real) not in _AXLE_FLAGS and load.real < 0.0 else load
    return p[start:], i, nominal


@njit(cache=True, error_model="numpy")
def _df_dload(flag, u, V, q, i0, out):
    """Derivative of the base rhs with respect to the static load q[i0] (complex step)."""
    n = out.size
    uc = np.empty(n, dtype=np.complex128)
    for i in range(n):
        uc[i] = u[i]
    qc = q.astype(np.complex128)
    qc[i0] += 1j * _CSTEP
    oc = np.empty(n, dtype=np.complex128)
    _base_rhs(flag, uc, V + 0j, qc, oc)
    for i in range(n):
        out[i] = oc[i].imag / _CSTEP


@njit(cache=True, error_model="numpy")
def rhs(u, V, p, out):
    """du/dt: the base model's at the profile's load, and phi_c' = V/R."""
    n = u.size - 1
    q, i, nominal = _load_in_place(u, V, p)
    _base_rhs(int(p[_FLAG].real), u[:n], V, q, out[:n])
    p[i] = nominal
    out[n] = V / p[_R]


@njit(cache=True, error_model="numpy")
def _jac_phase(n, col, dn_dtheta, out):
    """Column and row of phi_c in df/du: the load's column ``col`` (d base rhs / dN) times dN/dphi_c."""
    for i in range(n):
        out[i, n] = col[i] * dn_dtheta
        out[n, i] = 0.0
    out[n, n] = 0.0


@njit(cache=True, error_model="numpy")
def _add_load_speed_term(n, col, dn_dv, out):
    """Add the load's column ``col`` (d base rhs / dN) times dN/dV [N s/m] to df/dV."""
    for i in range(n):
        out[i] += col[i] * dn_dv


@njit(cache=True, error_model="numpy")
def jac(u, V, p, out):
    """df/du, with the column of phi_c through the load."""
    n = u.size - 1
    q, clamped, dn_dtheta, _ = _loaded(u, V, p)
    flag = int(p[_FLAG])
    _base_jac(flag, u[:n], V, q, out[:n, :n])
    col = np.zeros(n)
    if not clamped and dn_dtheta != 0.0:
        _df_dload(flag, u[:n], V, q, int(p[_IN0]), col)
    _jac_phase(n, col, dn_dtheta, out)


@njit(cache=True, error_model="numpy")
def dfdv(u, V, p, out):
    """df/dV [per m/s]: the base model's, the load's (through phi_c' in dw_c/dt), 1/R.

    For ``axle4dof`` the base term differentiates the running preloads at the loaded
    ``N0 + dN`` instead of the nominal ``N0`` (a relative error of order dN/N0 in that
    term); the wear analysis runs at fixed speeds and never uses this kernel."""
    n = u.size - 1
    q, clamped, _, dn_dv = _loaded(u, V, p)
    flag = int(p[_FLAG])
    _base_dfdv(flag, u[:n], V, q, out[:n])
    if not clamped and dn_dv != 0.0:
        col = np.zeros(n)
        _df_dload(flag, u[:n], V, q, int(p[_IN0]), col)
        _add_load_speed_term(n, col, dn_dv, out)
    out[n] = 1.0 / p[_R]


@njit(cache=True, error_model="numpy")
def rhs_jac_dfdv(u, V, p, f, J, fv):
    """:func:`rhs`, :func:`jac` and :func:`dfdv` into f, J and fv at once, bit for bit
    theirs: the load, the base model and the load's column evaluated once."""
    n = u.size - 1
    q, clamped, dn_dtheta, dn_dv = _loaded(u, V, p)
    flag = int(p[_FLAG].real)
    _base_rhs_jac_dfdv(flag, u[:n], V, q, f[:n], J[:n, :n], fv[:n])
    f[n] = V / p[_R]
    col = np.zeros(n)
    if not clamped and (dn_dtheta != 0.0 or dn_dv != 0.0):
        _df_dload(flag, u[:n], V, q, int(p[_IN0]), col)
    _jac_phase(n, col if dn_dtheta != 0.0 else np.zeros(n), dn_dtheta, J)
    if not clamped and dn_dv != 0.0:
        _add_load_speed_term(n, col, dn_dv, fv)
    fv[n] = 1.0 / p[_R]


@njit(cache=True, error_model="numpy")
def aux(u, V, p, out):
    """The base model's diagnostics at the profile's load."""
    n = u.size - 1
    q, i, nominal = _load_in_place(u, V, p)
    _base_aux(int(p[_FLAG].real), u[:n], V, q, out)
    p[i] = nominal


# -- the model object ---------------------------------------------------------------------
def profile_vector(base: Model, params, V: float, a_patch=(), b_patch=(), table_points: int = 0) -> np.ndarray:
    """Parameter vector of :func:`coupled_model` ``(base)`` at speed ``V`` [m/s].

    ``a_patch``, ``b_patch``: patch-averaged cosine/sine harmonics n = 1..K of the worn
    depth [m] (``sinc_n`` times the profile's, see :func:`patch_sinc`); empty = no wear.
    ``table_points``: 0 sums the harmonics in every call; L > 2K tabulates the depth over
    the angle at L points and interpolates (module notes).
    """
    a = np.asarray(a_patch, dtype=float).ravel()
    b = np.asarray(b_patch, dtype=float).ravel()
    if a.shape != b.shape:
        raise ValueError(f"profile harmonics: {a.size} cosine but {b.size} sine coefficients")
    p_base = base.prepared(float(V), base.pack(params))
    head = [
        float(_FLAGS[base.name]),
        float(base.param_names.index("N0" if base.name.startswith("axle4dof") else "N")),
        params.operating.rolling_radius_m,
        params.tire.vertical_stiffness_n_per_m,
        params.tire.vertical_damping_ns_per_m,
        float(a.size),
        float(table_points),
    ]
    return np.concatenate((head, a, b, _table(a, b, table_points), p_base))


def _table(a: np.ndarray, b: np.ndarray, size: int) -> np.ndarray:
    """``w_c, w_c', w_c''`` [m, m/rad, m/rad^2] of the harmonics ``a, b`` at ``2 pi j / size``
    (exact samples of the trigonometric series, by inverse FFT)."""
    if size == 0:
        return np.empty(0)
    if size <= 2 * a.size:
        raise ValueError(f"table_points = {size}: must be above twice the {a.size} harmonics")
    n = np.arange(1, a.size + 1)
    spectrum = np.zeros(size // 2 + 1, dtype=complex)
    columns = []
    for power in range(3):
        spectrum[1 : a.size + 1] = (1j * n) ** power * (a - 1j * b) * (0.5 * size)
        columns.append(np.fft.irfft(spectrum, size))
    return np.concatenate(columns)


def _prepare_factory(base: Model):
    def prepare(V, p):
        """Re-cache the base model's speed-only quantities for speed ``V`` [m/s]."""
        start = _HEAD + 2 * int(p[_NH]) + 3 * int(p[_NT])
        out = np.array(p, dtype=float)
        out[start:] = base.prepared(float(V), out[start:])
        return out

    return prepare


def _equilibrium_factory(base: Model):
    def equilibrium(V, p):
        """Steady rolling of the unworn tire (base equilibrium) at phi_c = 0."""
        start = _HEAD + 2 * int(p[_NH]) + 3 * int(p[_NT])
        return np.append(base.equilibrium(V, np.asarray(p, dtype=float)[start:]), 0.0)

    return equilibrium


_COUPLED: dict[Model, Model] = {}
"""Per base model (the patch has one per element count and pressure)."""


def coupled_model(base: Model) -> Model:
    """The profile-coupled version of ``base`` (states of ``base`` plus ``contact_angle``).

    Build its parameter vector with :func:`profile_vector` (``Model.pack`` does not apply).
    """
    if base.name not in _FLAGS:
        from ..params import ParameterError

        raise ParameterError(f"{base.name}: no worn-profile coupling (models with one: {', '.join(_FLAGS)})")
    if base not in _COUPLED:
        kernels = SimpleNamespace(
            rhs=rhs, jac=jac, dfdv=dfdv, rhs_jac_dfdv=rhs_jac_dfdv, aux=aux,
            equilibrium=_equilibrium_factory(base), prepare=_prepare_factory(base),
        )
        _COUPLED[base] = Model(
            name=f"{base.name}+profile",
            state_names=base.state_names + (PHASE_STATE,),
            state_units=base.state_units + ("rad",),
            aux_names=base.aux_names,
            slots=(),
            kernels=kernels,
            coordinates=base.coordinates,
        )
    return _COUPLED[base]
