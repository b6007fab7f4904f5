"""The problems handed to AUTO-07p (:mod:`polywear.validation.auto07p`): each model's
equations in AUTO's form and units, and AUTO's constants.

AUTO works in scaled units so that every unknown is of order one and its relative
tolerances mean the same for every state: time in ms, lengths in mm, angles in mrad, so
rates come out in mm/ms = m/s and mrad/ms = rad/s and the period in ms; the vehicle
speed ``V`` [m/s] is PAR(1). ``tread1dof``'s equations are written out here again,
independently of its numba kernels, for bifpy to trace and compile; ``axle4dof`` reaches
AUTO through callbacks into its compiled kernels (:data:`AUTO_MODELS`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import partial
from typing import Callable

import numpy as np

from ..models import get_model
from ..models.base import Model
from ..models.tread1dof import MODEL
from ..settings import check_count, check_order, check_positive

__all__ = ["AutoSettings", "AutoModel", "AUTO_MODELS", "STATE_UNIT", "AXLE4DOF_STATE_UNIT", "TIME_UNIT_S",
           "SPEED_INDEX", "auto_rhs", "auto_jacobian", "kernel_rhs", "kernel_jacobian", "starting_point"]

TIME_UNIT_S = 1.0e-3
"""AUTO's time unit [s] (1 ms)."""
STATE_UNIT = (1.0e-3, 1.0e-3 / TIME_UNIT_S, 1.0e-3)
"""SI value of one AUTO unit of each ``tread1dof`` state (x [mm], x' [mm/ms = m/s], z [mm])."""
AXLE4DOF_STATE_UNIT = (1.0e-3,) * 4 + (1.0e-3 / TIME_UNIT_S,) * 4 + (1.0e-3,)
"""SI value of one AUTO unit of each ``axle4dof`` state: alpha, beta, gamma [mrad], x [mm],
their rates [mrad/ms = rad/s, mm/ms = m/s], z [mm]."""
_RATE_FACTOR = tuple(TIME_UNIT_S / unit for unit in STATE_UNIT)
"""d(scaled state)/d(scaled time) per unit of the SI rate d(state)/dt."""

SPEED_INDEX = 1
"""AUTO's PAR index (1-based) of the vehicle speed V [m/s]."""


@dataclass(frozen=True)
class AutoSettings:
    """AUTO-07p constants for :func:`model_diagram` (names as in AUTO's manual).

    The defaults (those of ``tread1dof``; ``AUTO_MODELS[name].settings`` per model) were
    chosen by the refinement study in docs/validation_auto07p.md: doubling ``ntst``,
    tightening the tolerances tenfold and halving the steps moves the Hopf speeds, fold
    and operating-speed amplitude by far less than 1e-4.
    """

    ntst: int = 40
    """Mesh intervals per orbit (adapted along the branch, IAD = 3)."""
    ncol: int = 4
    """Collocation points per mesh interval."""
    epsl: float = 1e-8
    """Newton tolerance on the parameters (relative)."""
    epsu: float = 1e-8
    """Newton tolerance on the solution (relative; states are O(1) in AUTO's units)."""
    epss: float = 1e-6
    """Tolerance locating special points (HB, LP, BP, UZ)."""
    ds: float = 0.01
    """First pseudo-arclength step."""
    dsmin: float = 1e-6
    """Smallest step before AUTO gives up."""
    dsmax_equilibrium: float = 2.0
    """Largest step on the equilibrium branch (V in m/s, states in mm)."""
    dsmax_cycles: float = 2.0
    """Largest step on a branch of periodic orbits."""
    nmx: int = 5000
    """Largest number of steps per branch."""
    samples_per_interval: int = 16
    """Points per mesh interval searched for the extrema of the collocation polynomial
    (then polished by Newton steps; the stored orbit has ``ncol + 1`` per interval)."""
    transpile: bool = True
    """Compile the model to a native AUTO executable (True) or call back into Python."""

    def __post_init__(self) -> None:
        # out-of-range constants make AUTO run away rather than fail: refuse them here
        check_count(self, "ncol", minimum=2)
        if self.ncol > 7:
            raise ValueError(f"AutoSettings: ncol = {self.ncol}: AUTO-07p supports 2 to 7 collocation points")
        check_count(self, "ntst", "samples_per_interval", minimum=2)
        check_count(self, "nmx")
        check_positive(self, "epsl", "epsu", "epss", "ds", "dsmin", "dsmax_equilibrium", "dsmax_cycles")
        check_order(self, "dsmin", "ds", "dsmax_equilibrium")
        check_order(self, "dsmin", "ds", "dsmax_cycles")

    def refined(self) -> AutoSettings:
        """Twice the mesh intervals, tolerances / 10, steps / 2 (for refinement studies)."""
        return replace(
            self,
            ntst=2 * self.ntst,
            epsl=self.epsl / 10,
            epsu=self.epsu / 10,
            epss=self.epss / 10,
            ds=self.ds / 2,
            dsmax_equilibrium=self.dsmax_equilibrium / 2,
            dsmax_cycles=self.dsmax_cycles / 2,
            nmx=2 * self.nmx,
        )


def _coefficients(p) -> dict[str, float]:
    """Named SI parameters of ``tread1dof`` from its packed vector ``p``."""
    coeff = dict(zip(MODEL.param_names, (float(v) for v in p)))
    coeff["sin_toe"] = math.sin(coeff["toe"])
    return coeff


def _lugre_terms(u, speed, c):
    """SI state and LuGre terms at AUTO state ``u`` (mm, m/s, mm) and speed [m/s].

    Written with ``abs`` and ``np.exp`` only, so bifpy can trace it symbolically.
    """
    x = u[0] * STATE_UNIT[0]
    xdot = u[1] * STATE_UNIT[1]
    z = u[2] * STATE_UNIT[2]
    slide = speed * c["sin_toe"] - xdot  # v_r [m/s]
    ratio = abs(slide) / c["v_s"]
    decay = np.exp(-(ratio ** c["delta"]))
    g = c["mu_c"] + (c["mu_s"] - c["mu_c"]) * decay  # Stribeck curve G(v_r)
    zdot = slide - c["sigma0"] * abs(slide) * z / g
    force = c["N"] * (c["sigma0"] * z + c["sigma1"] * zdot + c["sigma2"] * slide)
    return x, xdot, z, slide, ratio, decay, g, zdot, force


def auto_rhs(p):
    """AUTO's FUNC for ``tread1dof`` with parameter vector ``p``: ``func(u, par)``.

    ``u`` = (x [mm], x' [m/s], z [mm]), ``par[0]`` = V [m/s]; returns du/dT with T in
    ms (docs/model.md section 3 in these units).
    """
    c = _coefficients(p)

    def func(u, par):
        x, xdot, _, _, _, _, _, zdot, force = _lugre_terms(u, par[0], c)
        xddot = (force - c["c"] * xdot - c["k"] * x) / c["m"]
        return [_RATE_FACTOR[0] * xdot, _RATE_FACTOR[1] * xddot, _RATE_FACTOR[2] * zdot]

    return func


def auto_jacobian(p, icu):
    """AUTO's analytic Jacobian of :func:`auto_rhs`: ``jac(u, par) -> (d/du, d/dPAR(icu))``.

    Hand-derived (bifpy's automatic derivative of ``abs`` prints invalid Fortran in
    bifpy 0.3.0 with sympy 1.14); tested against finite differences and the kernel's.
    Columns of PAR indices other than the speed are zero (the period is AUTO's own).
    """
    c = _coefficients(p)

    def jac(u, par):
        _, _, z, slide, ratio, decay, g, _, _ = _lugre_terms(u, par[0], c)
        sgn = slide / abs(slide)  # the model is not differentiable at v_r = 0 itself
        dg = -(c["mu_s"] - c["mu_c"]) * decay * c["delta"] * ratio ** (c["delta"] - 1.0) * sgn / c["v_s"]
        dzdot_dslide = 1.0 - c["sigma0"] * z * (sgn * g - abs(slide) * dg) / (g * g)
        dzdot_dz = -c["sigma0"] * abs(slide) / g
        dforce_dslide = c["N"] * (c["sigma1"] * dzdot_dslide + c["sigma2"])
        dforce_dz = c["N"] * (c["sigma0"] + c["sigma1"] * dzdot_dz)
        m = c["m"]
        # SI: d(x', x'', z')/d(x, x', z), with d v_r/d x' = -1, and d/dV (d v_r/dV = sin toe)
        d_state_si = [
            [0.0, 1.0, 0.0],
            [-c["k"] / m, (-c["c"] - dforce_dslide) / m, dforce_dz / m],
            [0.0, -dzdot_dslide, dzdot_dz],
        ]
        d_speed_si = [0.0, dforce_dslide * c["sin_toe"] / m, dzdot_dslide * c["sin_toe"]]
        d_state = [
            [_RATE_FACTOR[i] * d_state_si[i][j] * STATE_UNIT[j] for j in range(3)] for i in range(3)
        ]
        d_par = [
            [_RATE_FACTOR[i] * d_speed_si[i] if index == SPEED_INDEX else 0.0 for index in icu]
            for i in range(3)
        ]
        return d_state, d_par

    return jac


def kernel_rhs(model: Model, p, state_unit):
    """AUTO's FUNC from a model's compiled kernel: ``func(u, par)`` = du/dT in AUTO's units.

    ``u`` is the state in units of ``state_unit`` (SI value of one unit per state),
    ``par[0]`` = V [m/s], T in ms; ``model.f`` does the work.
    """
    unit = np.asarray(state_unit, dtype=float)
    rate = TIME_UNIT_S / unit
    p = np.asarray(p, dtype=float)

    def func(u, par):
        return rate * model.f(unit * u, par[0], p)

    return func


def kernel_jacobian(model: Model, p, state_unit, icu):
    """AUTO's analytic Jacobian of :func:`kernel_rhs`: ``jac(u, par) -> (d/du, d/dPAR(icu))``
    from ``model.jacobian`` and ``model.df_dspeed`` (columns of other PAR indices are 0)."""
    unit = np.asarray(state_unit, dtype=float)
    rate = TIME_UNIT_S / unit
    scale = rate[:, None] * unit[None, :]
    p = np.asarray(p, dtype=float)
    speed_columns = [k for k, index in enumerate(icu) if index == SPEED_INDEX]

    def jac(u, par):
        u_si = unit * u
        d_state = scale * model.jacobian(u_si, par[0], p)
        d_par = np.zeros((len(unit), len(icu)))
        d_par[:, speed_columns] = (rate * model.df_dspeed(u_si, par[0], p))[:, None]
        return d_state, d_par

    return jac


@dataclass(frozen=True)
class AutoModel:
    """How one model's equations reach AUTO-07p, in which units, with which defaults."""

    name: str
    state_unit: tuple[float, ...]
    """SI value of one AUTO unit of each state."""
    units: str
    """The units in words (for the result)."""
    settings: AutoSettings
    """Default AUTO constants (chosen by a refinement study)."""
    written_out: Callable[[np.ndarray], tuple[Callable, Callable]] | None = None
    """Equations written out for bifpy's tracer, ``p -> (func, jacobian_for)``, or None:
    the model's compiled kernels through callbacks (:func:`kernel_rhs`)."""

    @property
    def model(self) -> Model:
        return get_model(self.name)

    @property
    def traceable(self) -> bool:
        """bifpy can compile the equations natively (``transpile=True``)."""
        return self.written_out is not None

    def equations(self, p) -> tuple[Callable, Callable]:
        """``(func(u, par), jacobian_for(icu) -> jac(u, par))`` at parameter vector ``p``."""
        if self.written_out is not None:
            return self.written_out(p)
        model = self.model
        return kernel_rhs(model, p, self.state_unit), partial(kernel_jacobian, model, p, self.state_unit)


def _tread1dof_written_out(p):
    return auto_rhs(p), partial(auto_jacobian, p)


AUTO_MODELS = {
    "tread1dof": AutoModel(
        name="tread1dof",
        state_unit=STATE_UNIT,
        units="AUTO works in mm (x, z), m/s (x'), ms (time); results here are SI",
        settings=AutoSettings(),
        written_out=_tread1dof_written_out,
    ),
    "axle4dof": AutoModel(
        name="axle4dof",
        state_unit=AXLE4DOF_STATE_UNIT,
        units="AUTO works in mrad (angles), mm (x, z), rad/s and m/s (rates), ms (time); "
        "results here are SI",
        settings=AutoSettings(transpile=False),
    ),
}
"""The models AUTO-07p can compute, by name."""


def starting_point(u_eq, speed, state_unit):
    """AUTO's STPNT: the equilibrium ``u_eq`` (SI) at ``speed`` [m/s]."""
    scaled = np.asarray(u_eq, dtype=float) / np.asarray(state_unit)

    def stpnt(u, par, t):
        par[0] = speed
        u[:] = scaled

    return stpnt
