"""Wear indicators of a self-excited vibration (docs/model.md section 5).

For a limit cycle at speed V:

* SEV frequency ``f = 1/T`` [Hz];
* polygon order ``n = f / f_rot`` with ``f_rot = V / (2 pi R_e)``, and its distance to
  the nearest integer (a polygon locks in when the tread meets its own wear pattern
  in phase, i.e. near an integer);
* RMS tread acceleration ``a_rms`` [m/s^2] over the period (the lateral acceleration of
  the tread coordinate x);
* mean frictional power ``P = <F v_r>`` [W] over the period, and the steady-rolling value
  ``P_0 = F_0 v_r0`` at the same speed;
* wear-rate index ``W = P / P_0`` [-]: Schallamach's abrasion law (abraded volume
  proportional to frictional work) normalized by steady rolling, so ``W = 1`` means SEV
  changes the *mean* abrasion rate not at all and ``W = 1.3`` means 30 % faster;
* uneven-wear index ``U = rms(F v_r - P) / P_0`` [-]: the fluctuation of the frictional
  power over the vibration period relative to steady rolling. Local abrasion follows
  the local frictional work, so this fluctuation, repeated ``n`` times per wheel turn,
  is what writes the polygon; ``U = 0`` without SEV.

Lupker's observation that wear grows nonlinearly with vibration acceleration is
carried by ``a_rms``, reported beside the indices; the indices have no tuned constants.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..results import with_deprecated_keys
from ..units import frequency_order, ms_to_kmh

__all__ = ["WearIndicators", "wear_indicators"]

RENAMED_KEYS = {"frequency_order": "polygon_order", "frequency_order_offset": "polygon_order_offset"}
"""New -> old keys of :meth:`WearIndicators.summary` (the old ones go in the next release)."""


@dataclass(frozen=True)
class WearIndicators:
    speed_kmh: float
    frequency_hz: float
    frequency_order: float
    """f / f_rot of the cycle, a ratio [-]."""
    frequency_order_offset: float
    """Distance of the frequency order to the nearest whole number of sides [-]."""
    rms_acceleration: float  # [m/s^2]
    frictional_power_w: float
    steady_frictional_power_w: float
    wear_index: float
    uneven_wear_index: float

    def summary(self) -> dict:
        return with_deprecated_keys({k: float(v) for k, v in self.__dict__.items()}, RENAMED_KEYS)


def wear_indicators(model, p, orbit, rolling_radius_m: float, samples: int = 2048) -> WearIndicators:
    """Wear indicators of a periodic orbit (``solvers.collocation.PeriodicOrbit``)."""
    V = orbit.speed
    tau = np.arange(samples) / samples
    u = orbit.evaluate(tau)
    aux = model.diagnostics(u, V, p)
    names = model.aux_names
    v_r = aux[:, names.index("sliding_velocity")]
    force = aux[:, names.index("friction_force")]
    accel = np.array([model.f(ui, V, p)[model.index("xdot")] for ui in u])
    u_eq = model.equilibrium(V, p)
    steady = model.diagnostics(u_eq, V, p)
    p0 = float(steady[names.index("friction_force")] * steady[names.index("sliding_velocity")])
    power = float(np.mean(force * v_r))
    f = 1.0 / orbit.period
    n = frequency_order(f, V, rolling_radius_m)
    return WearIndicators(
        speed_kmh=ms_to_kmh(V),
        frequency_hz=f,
        frequency_order=n,
        frequency_order_offset=abs(n - round(n)),
        rms_acceleration=float(np.sqrt(np.mean(accel**2))),
        frictional_power_w=power,
        steady_frictional_power_w=p0,
        wear_index=power / p0 if p0 else float("nan"),
        uneven_wear_index=float(np.sqrt(np.mean((force * v_r - power) ** 2)) / p0) if p0 else float("nan"),
    )
