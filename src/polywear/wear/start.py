"""Where the wear evolution starts at each speed: steady rolling, or the large vibration.

``start="rest"`` (the default): steady rolling with a small disturbance, as a car drives.
``start="cycle"``: at a speed where steady rolling is stable but a large stable cycle
coexists with it (a hard region of the bifurcation diagram, hard self-excitation), the
tread starts on that cycle, as after a pothole that kicked it beyond the unstable cycle
(the trigger amplitude); at the other speeds it starts from rest (where rolling is
unstable the vibration grows from rest by itself). ``docs/wear.md``.
"""

from __future__ import annotations

import numpy as np

from ..models import model_for
from ..params import Params
from ..units import DEFAULT_SPEED_RANGE_KMH, kmh_to_ms

__all__ = ["STARTS", "cycle_start_states", "start_states"]

STARTS = ("rest", "cycle")
"""Start states of :func:`~polywear.wear.evolution.wear_evolution` at each speed."""


def cycle_start_states(params: Params, speeds_kmh, diagram=None) -> dict[float, np.ndarray]:
    """Per speed [km/h] of ``speeds_kmh`` where steady rolling is stable and a stable cycle
    exists: a state of the base model on the largest stable cycle (its collocation orbit at
    phase 0). Speeds without one are left out.

    ``diagram``: the :class:`~polywear.dynamics.diagram.BifurcationDiagram` to take the
    cycles from (default: computed over the default speed range widened to hold the speeds,
    about a second)."""
    if diagram is None:
        from ..dynamics.bifurcation import bifurcation

        lo, hi = DEFAULT_SPEED_RANGE_KMH
        diagram = bifurcation(params, (min(lo, min(speeds_kmh)), max(hi, max(speeds_kmh))))
    model = model_for(params)
    p = model.pack(params)
    out = {}
    for v in speeds_kmh:
        if not any(a <= v <= b for a, b in diagram.hard_regions_kmh):
            continue
        V = float(kmh_to_ms(v))
        if np.any(np.linalg.eigvals(model.jacobian(model.equilibrium(V, p), V, p)).real > 0.0):
            continue  # rolling unstable: not hard
        stable = [c for c in diagram.cycles_at(v) if c.stable]
        if stable:
            out[v] = np.asarray(stable[-1].orbit.evaluate(0.0)[0], dtype=float)
    return out


def start_states(params: Params, cycle, start: str) -> dict[float, np.ndarray]:
    """The base-model start states per cycle speed [km/h] that differ from rest for
    ``start`` (:data:`STARTS`): none for ``"rest"``; for ``"cycle"`` those of
    :func:`cycle_start_states`, a ValueError if no cycle speed has one (the evolution from
    rest is then the only one)."""
    if start not in STARTS:
        raise ValueError(f"start = {start!r}: must be one of {', '.join(STARTS)}")
    if start == "rest":
        return {}
    speeds = [v for v, _ in cycle]
    states = cycle_start_states(params, speeds)
    if not states:
        raise ValueError(f"start = 'cycle': at none of the speeds {', '.join(f'{v:g}' for v in speeds)} km/h does a "
                         "stable cycle coexist with stable steady rolling (no hard self-excitation there): the "
                         "evolution from rest is the only one")
    return states
