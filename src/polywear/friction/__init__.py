"""LuGre friction on its own: static curve, hysteresis loops, fitting to measurements.

The paper's Fig. 1 shows the friction coefficient of the LuGre model against a
sinusoidal sliding velocity: at low frequency the loop lies on the static (Stribeck)
curve, at high frequency it opens. :func:`hysteresis_loops` computes those loops,
:func:`steady_curve` the static curve; :func:`fit_steady_curve` fits the static-curve
parameters to measured steady ``mu(v)`` points and :func:`fit_loops` the bristle
parameters sigma0, sigma1 to measured loops (docs/model.md "LuGre friction",
docs/friction.md).

Modules: :mod:`.curve` (static curve), :mod:`.loops` (bristle dynamics, loops),
:mod:`.fits` (least-squares fits), :mod:`.data` (CSV files, samples). The pointwise
LuGre functions of :mod:`polywear.physics.lugre` are re-exported here, so
``polywear.friction`` (``pw.friction``) holds everything about friction.

All forces are per unit normal load (friction coefficients); velocities are the sliding
velocity of the road relative to the tread [m/s].
"""

from __future__ import annotations

from ..physics.lugre import (
    bristle_decay_rate,
    bristle_rate,
    friction_coefficient,
    steady_deflection,
    steady_friction,
    steady_friction_slope,
    stribeck,
)
from .curve import STEADY_PARAMETERS, SteadyCurve, falling_branch, steady_curve
from .data import (
    FREQUENCY_COLUMN,
    FRICTION_COLUMN,
    LOOP_COLUMNS,
    TIME_COLUMN,
    VELOCITY_COLUMN,
    FrictionDataError,
    read_loops_csv,
    read_steady_csv,
    sample_path,
    synthetic_steady_data,
)
from .fits import (
    LOOP_PARAMETERS,
    FrictionFit,
    LoopFit,
    LoopFitSettings,
    fit_loops,
    fit_steady_curve,
    steady_friction_jacobian,
)
from .loops import BristleResponse, HysteresisLoops, LoopSettings, bristle_response, hysteresis_loops

__all__ = [
    "SteadyCurve",
    "BristleResponse",
    "HysteresisLoops",
    "FrictionFit",
    "LoopFit",
    "LoopSettings",
    "LoopFitSettings",
    "FrictionDataError",
    "STEADY_PARAMETERS",
    "LOOP_PARAMETERS",
    "VELOCITY_COLUMN",
    "FRICTION_COLUMN",
    "FREQUENCY_COLUMN",
    "TIME_COLUMN",
    "LOOP_COLUMNS",
    "steady_curve",
    "falling_branch",
    "bristle_response",
    "hysteresis_loops",
    "steady_friction_jacobian",
    "fit_steady_curve",
    "fit_loops",
    "read_steady_csv",
    "read_loops_csv",
    "synthetic_steady_data",
    "sample_path",
    "stribeck",
    "steady_friction",
    "steady_friction_slope",
    "steady_deflection",
    "bristle_rate",
    "bristle_decay_rate",
    "friction_coefficient",
]
