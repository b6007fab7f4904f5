"""Whether one car meets the wear criterion of the wear design (:mod:`polywear.wear.design`):
by the linear wear map (the seeded roughness grown over the drive cycle at the map's
share-weighted rates, exact while rolling is stable at every cycle speed) or by the
nonlinear evolution over the target distance (:func:`~polywear.wear.evolution.wear_evolution`).
The design's searches judge every probe, a car with one key changed, here
(:func:`meets_criterion`)."""

from __future__ import annotations

import math
from enum import StrEnum

import numpy as np

from ..dynamics.sensitivity import perturbed
from ..params import Params
from .evolution import (EvolutionResult, EvolutionSettings, StepBudgetError, initial_roughness, peak_to_valley,
                        wear_evolution)
from .map import wear_map

__all__ = ["CLEARLY_VISIBLE", "Judge", "cycle_rates", "cycle_growth", "linear_depth_mm", "evolved_from",
           "evolved_over", "meets_criterion", "outcome_text"]

CLEARLY_VISIBLE = 2.0
"""A probe with stable rolling at every cycle speed whose linear-map depth at the target
exceeds this many visible depths fails without an evolution (the nonlinear evolution
follows the linear one while the profile is small) [-]."""


class Judge(StrEnum):
    """What judges a wear design option (the value is its text in JSON and on the command line)."""

    AUTO = "auto"
    """The evolution with a target distance where the nominal tread vibrates at a cycle
    speed, else the map (a result records the one it used)."""
    MAP = "map"
    """The linear wear map (exact while rolling is stable at every cycle speed)."""
    EVOLUTION = "evolution"
    """The nonlinear evolution over the target distance (every probe an evolution: minutes)."""


def cycle_rates(params: Params, cycle=None) -> np.ndarray | None:
    """Complex rate per km of every order over the cycle, ``sum_i share_i ln(1 + dW/W)_i``
    times revolutions per km (real part: growth, imaginary: turn); None if steady rolling
    is unstable at a cycle speed."""
    cycle = tuple(cycle) if cycle is not None else params.wear.cycle_shares()
    m = wear_map(params, [v for v, _ in cycle])
    if not m.rolling_stable.all():
        return None
    shares = np.array([s for _, s in cycle])
    return (shares @ np.log1p(m.relative_change)) * m.revolutions_per_km


def cycle_growth(params: Params, cycle=None) -> tuple[float, int, bool]:
    """(max_n g_n [e-folds per 1000 km], its order, every cycle speed rolling-stable)."""
    rates = cycle_rates(params, cycle)
    if rates is None:
        return math.inf, 0, False
    k = int(np.argmax(rates.real))
    return float(rates.real[k] * 1000.0), k + 1, True


def linear_depth_mm(params: Params, distance_km: float, cycle=None) -> float:
    """Peak-to-valley depth [mm] after ``distance_km`` of the seeded roughness grown by the
    linear map (exact while the profile is small and rolling stable; inf if it is not)."""
    rates = cycle_rates(params, cycle)
    if rates is None:
        return math.inf
    W = initial_roughness(params) * np.exp(rates * distance_km)
    return peak_to_valley(W, params.wear.profile_points) * 1e3


def outcome_text(evolved: dict) -> str:
    """An evolution of :func:`evolved_over` in words."""
    if evolved.get("undecided"):
        return f"undecided (over its budget at {evolved['distance_km']:,.0f} km)"
    return ("no visible polygon" if evolved["visible_km"] is None
            else f"visible after {evolved['visible_km']:,.0f} km")


def evolved_over(params: Params, target_km: float, cycle, settings: EvolutionSettings, workers: int | None = None) -> dict:
    """The evolution over ``target_km`` [km] on ``cycle`` (``workers`` as in
    :func:`~polywear.wear.evolution.wear_evolution`): the distance it reached [km] (less
    than ``target_km`` only with ``until_visible``), its depth there [mm], the visible
    distance [km] (None: not within it) and the dominant order there; or, where it stopped
    at its step or work budget, ``undecided`` True with the distance it had reached."""
    try:
        worn = wear_evolution(params, target_km, cycle, settings, workers=workers)
    except StepBudgetError as exc:
        return {"distance_km": exc.done_km, "depth_mm": None, "visible_km": None, "dominant_order": None,
                "undecided": True}
    return {"distance_km": float(worn.distance_km[-1]), "depth_mm": float(worn.depth_mm[-1]),
            "visible_km": worn.visible_km, "dominant_order": int(worn.dominant_order[-1])}


def evolved_from(worn: EvolutionResult, target_km: float, cycle) -> dict:
    """:func:`evolved_over` of an evolution already run (the report's on the drive cycle), which
    must be over ``target_km`` [km] on ``cycle``."""
    if tuple(worn.cycle) != tuple(cycle) or not math.isclose(float(worn.distance_km[-1]), target_km, rel_tol=1e-9):
        raise ValueError(f"wear_design: the nominal evolution given ran {float(worn.distance_km[-1]):g} km on "
                         f"{worn.cycle}: need {target_km:g} km on {cycle}")
    return {"distance_km": target_km, "depth_mm": float(worn.depth_mm[-1]), "visible_km": worn.visible_km,
            "dominant_order": int(worn.dominant_order[-1])}


def meets_criterion(params: Params, key: str, nominal: float, factor: float, cycle, target_km: float | None,
                    judge: Judge = Judge.MAP, settings: EvolutionSettings = EvolutionSettings(),
                    workers: int | None = None):
    """(criterion met, growth [e-folds per 1000 km], order, the evolution or None) with
    ``key`` at ``nominal * factor``; None where it cannot be evaluated. An evolution stopped
    at its budget does not meet it (``undecided`` in the evolution)."""
    try:
        changed = perturbed(params, key, nominal * factor)
    except ValueError:
        return None
    visible = params.wear.visible_depth_mm
    evolved = None
    try:
        g, order, stable = cycle_growth(changed, cycle)
        if target_km is None:
            ok = stable and g <= 0.0
        elif judge == "map":
            ok = stable and linear_depth_mm(changed, target_km, cycle) < visible
        elif stable and linear_depth_mm(changed, target_km, cycle) > CLEARLY_VISIBLE * visible:
            ok = False
        else:
            evolved = evolved_over(changed, target_km, cycle, settings, workers)
            ok = evolved["visible_km"] is None and not evolved.get("undecided")
            order = evolved["dominant_order"]
    except (ValueError, RuntimeError, ArithmeticError, np.linalg.LinAlgError):
        return None
    return ok, g, order, evolved
