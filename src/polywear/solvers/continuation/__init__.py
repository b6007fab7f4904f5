"""Pseudo-arclength continuation of periodic orbits in the speed V.

Each step predicts along the unit tangent, corrects with Newton on the collocation
equations plus the integral phase condition and the arclength condition, and takes
the next tangent from the same bordered matrix. Step length adapts to the number of
Newton iterations. All norms are weighted by scales (state amplitudes, period,
speed) so that the arclength mixes quantities of order one.

Along the branch: Floquet multipliers at every point (monodromy by condensation,
with the trivial multiplier as accuracy check), folds of cycles located by secant
iteration on the speed component of the tangent, period doubling and torus
(Neimark-Sacker) bifurcations detected by multipliers crossing the unit circle
at -1 or as a complex pair, and located on the crossing by root finding on a
test function of the multipliers.

Every branch ends with a typed reason (:class:`BranchEnd`). Before a branch is given
up the numerics are rescued as a specialist would: a step whose monodromy fails the
trivial-multiplier check, or whose Newton iteration fails at the smallest step, is
re-solved on a finer, kink-aligned, adapted mesh. What cannot be rescued ends the
branch as failed, with the speed and the reason.

:func:`locate_fold` finds the fold of cycles at a parameter vector near a fold known at
nearby parameters (the stability maps' fold curves, the fleet's fast band path). The
predictor/corrector step, tangent orientation and step-length control are
:mod:`polywear.solvers.arclength`, shared with the Hopf curves of
:mod:`polywear.solvers.curve_continuation`.

The package, by job (each module imports only those listed before it):

- ``branch.py``: :class:`ContinuationSettings`, :class:`BranchEnd`, :class:`BranchPoint`,
  :class:`Branch`, :class:`HopfStart` (a Hopf point as plain data) and the predicates on
  Floquet multipliers;
- ``kinks.py``: :func:`switching_times` and the kink-aligned meshes;
- ``stepper.py``: the Newton corrector and tangent on one mesh, and the solves built on it
  alone (:func:`solve_at_speed`, :func:`cycle_along_branch`, Newton guesses);
- ``events.py``: PD and NS points between two points of a branch;
- ``folds.py``: folds of cycles, on a branch and at nearby parameters (:func:`solve_fold`,
  :func:`locate_fold`, :func:`fold_at`);
- ``from_hopf.py``: :func:`continue_from_hopf`, the branch from a Hopf point.
"""

from __future__ import annotations

from .branch import (MAX_TRIVIAL_ERROR, Branch, BranchEnd, BranchPoint, ContinuationSettings, HopfStart,
                     certainly_unstable, same_special_point, stability_decided, trivial_error)
from .events import CROSSING_ITERATIONS
from .folds import (FOLD_DIFFERENCE, MAX_FOLD_CORRECTION, MAX_MARCH, MAX_STEP, PARAMETER_DIFFERENCE,
                    SLOW_FOLD_CONTRACTION, SLOW_FOLD_SIZE, fold_at, fold_curvature, fold_parameter_tangent,
                    locate_fold, on_adapted_mesh, recentred, solve_fold)
from .from_hopf import continue_from_hopf
from .kinks import KINK_SIGNALS, switching_times
from .stepper import (MAX_STEPS_TO_SPEED, STALL_FACTOR, cycle_along_branch, newton_converged, orbit_between,
                      orbit_from_hopf, solve_at_speed, solve_at_speed_on_kinks)

__all__ = [
    "BranchEnd",
    "ContinuationSettings",
    "BranchPoint",
    "Branch",
    "HopfStart",
    "continue_from_hopf",
    "solve_at_speed",
    "solve_at_speed_on_kinks",
    "orbit_from_hopf",
    "orbit_between",
    "cycle_along_branch",
    "switching_times",
    "fold_curvature",
    "locate_fold",
    "solve_fold",
    "fold_at",
    "fold_parameter_tangent",
    "recentred",
    "on_adapted_mesh",
    "certainly_unstable",
    "same_special_point",
    "stability_decided",
    "trivial_error",
    "newton_converged",
    "CROSSING_ITERATIONS",
    "FOLD_DIFFERENCE",
    "KINK_SIGNALS",
    "MAX_FOLD_CORRECTION",
    "MAX_MARCH",
    "MAX_STEP",
    "MAX_STEPS_TO_SPEED",
    "MAX_TRIVIAL_ERROR",
    "PARAMETER_DIFFERENCE",
    "SLOW_FOLD_CONTRACTION",
    "SLOW_FOLD_SIZE",
    "STALL_FACTOR",
]
