"""The static (Stribeck) friction curve of the LuGre model, and what the other modules share.

Forces are per unit normal load (friction coefficients); velocities are the sliding
velocity of the road relative to the tread [m/s] (docs/model.md, "LuGre friction").
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..params import Friction
from ..params.files import _toml_value
from ..physics.lugre import steady_friction, steady_friction_slope
from ..results import Result

__all__ = ["STEADY_PARAMETERS", "SteadyCurve", "falling_branch", "steady_curve"]


STEADY_PARAMETERS = (
    "mu_static",
    "mu_coulomb",
    "stribeck_velocity_m_per_s",
    "stribeck_exponent",
    "sigma2_s_per_m",
)
"""Keys of ``[friction]`` that the steady curve depends on (and that can be fitted)."""


def _steady_args(friction: Friction) -> tuple[float, float, float, float, float]:
    """(sigma2, mu_s, mu_c, v_s, delta) in the order of the lugre steady_* functions."""
    f = friction
    return (f.sigma2_s_per_m, f.mu_static, f.mu_coulomb, f.stribeck_velocity_m_per_s, f.stribeck_exponent)


def _friction_toml(friction: Friction, notes: dict[str, str] | None = None) -> str:
    """The ``[friction]`` table of a parameter file, with optional comments per key."""
    notes = notes or {}
    lines = ["[friction]"]
    for name in type(friction).model_fields:
        entry = f"{name} = {_toml_value(getattr(friction, name))}"  # words (contact) and integers too
        lines.append(f"{entry:<42} # {notes[name]}" if name in notes else entry)
    return "\n".join(lines) + "\n"


def _axes(ax):
    if ax is None:
        import matplotlib.pyplot as plt

        _, ax = plt.subplots(figsize=(6.4, 4.4))
    return ax


# -- static curve --------------------------------------------------------------------------


def falling_branch(friction: Friction) -> tuple[float, float] | None:
    """Sliding speeds ``(v_lo, v_hi)`` [m/s] between which d mu_ss/dv < 0 (v > 0).

    On this branch friction acts as negative damping. ``v_hi`` is ``inf`` when
    sigma2 = 0; ``None`` if the viscous term outweighs the Stribeck drop everywhere.
    """
    from scipy.optimize import brentq

    sigma2, mu_s, mu_c, v_s, delta = _steady_args(friction)

    def slope(v):
        return float(steady_friction_slope(v, sigma2, mu_s, mu_c, v_s, delta))

    # |dG/dv| peaks where (v/v_s)^delta = (delta - 1)/delta (at v -> 0+ for delta = 1)
    v_peak = v_s * ((delta - 1.0) / delta) ** (1.0 / delta)
    if mu_s == mu_c or slope(v_peak) >= 0.0:
        return None
    v_lo = 0.0 if sigma2 == 0.0 or v_peak == 0.0 else brentq(slope, 0.0, v_peak, xtol=1e-15, rtol=1e-13)
    if sigma2 == 0.0:
        return v_lo, math.inf
    v_hi = max(2.0 * v_peak, v_s)
    while slope(v_hi) < 0.0:
        v_hi *= 2.0
    return v_lo, brentq(slope, v_peak, v_hi, xtol=1e-15, rtol=1e-13)


@dataclass(frozen=True, eq=False)
class SteadyCurve(Result):
    """Static (Stribeck) friction curve mu_ss(v) = sgn(v) G(v) + sigma2 v."""

    friction: Friction
    velocity: np.ndarray
    """Sliding velocity [m/s]."""
    mu: np.ndarray
    """Steady friction coefficient [-]."""

    @property
    def falling_branch(self) -> tuple[float, float] | None:
        """See :func:`falling_branch`."""
        return falling_branch(self.friction)

    def summary(self) -> dict[str, Any]:
        """mu_s, mu_c, the falling branch [m/s] and the velocity range [m/s]."""
        branch = self.falling_branch
        return {
            "mu_static": self.friction.mu_static,
            "mu_coulomb": self.friction.mu_coulomb,
            "falling_branch_m_per_s": [x if math.isfinite(x) else None for x in branch] if branch else None,
            "velocity_range_m_per_s": [float(self.velocity.min()), float(self.velocity.max())],
        }

    def _dataset(self):
        """xarray Dataset: mu against velocity, with the friction parameters as TOML."""
        import xarray as xr

        return xr.Dataset(
            {"mu": ("velocity", self.mu, {"long_name": "steady friction coefficient", "units": "1"})},
            coords={"velocity": ("velocity", self.velocity, {"long_name": "sliding velocity", "units": "m/s"})},
            attrs={"title": "LuGre static friction curve", "friction_toml": _friction_toml(self.friction)},
        )

    def plot(self, ax=None, **kwargs):
        """Draw mu_ss against v; returns the line artists."""
        ax = _axes(ax)
        kwargs.setdefault("color", "k")
        kwargs.setdefault("label", "static curve")
        lines = ax.plot(self.velocity, self.mu, **kwargs)
        ax.set_xlabel("sliding velocity $v_r$ [m/s]")
        ax.set_ylabel(r"friction coefficient $F/N$ [-]")
        ax.grid(True, alpha=0.3)
        return lines


def steady_curve(friction: Friction, velocity) -> SteadyCurve:
    """Static friction curve of ``friction`` at the sliding velocities ``velocity`` [m/s]."""
    v = np.atleast_1d(np.asarray(velocity, dtype=float))
    if not np.all(np.isfinite(v)):
        raise ValueError("velocity: must be finite")
    return SteadyCurve(friction, v, steady_friction(v, *_steady_args(friction)))
