"""Kinks of the vector field along a cycle: where the sliding velocity passes through zero
or the contact is lost, the Jacobian jumps. :func:`switching_times` finds them, and the
collocation meshes put a mesh point on each (:func:`_with_kinks`), so that no interval
straddles one.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..collocation import PeriodicOrbit

if TYPE_CHECKING:
    from ...models.base import Model

__all__ = ["KINK_SIGNALS", "switching_times"]

KINK_SIGNALS = (("sliding_velocity", 0.0), ("contact_lost", 0.5))
"""Auxiliary outputs whose crossing of the given level is a kink of the vector field."""


def switching_times(model: Model, p: np.ndarray, orbit: PeriodicOrbit, per_interval: int = 8,
                    tol: float = 1e-13, samples: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Normalized times where the orbit crosses a kink of the vector field (bisection-refined);
    ``samples``: ``orbit.dense(per_interval)`` if the caller has it.

    The vector field is continuous there (|v_r| and the clamp max(N, 0) are Lipschitz),
    so no jump (saltation) of the monodromy matrix occurs, but the Jacobian jumps: the
    collocation mesh is aligned with these times so that no interval straddles one.
    """
    signals = [(model.aux_names.index(name), level) for name, level in KINK_SIGNALS if name in model.aux_names]
    if not signals:
        return np.empty(0)
    tau, u = orbit.dense(per_interval) if samples is None else samples
    aux = model.diagnostics(u, orbit.speed, p)
    times = []
    for col, level in signals:
        g = aux[:, col] - level
        for i in np.flatnonzero(np.sign(g[:-1]) * np.sign(g[1:]) < 0):
            a, b, ga = tau[i], tau[i + 1], g[i]
            while b - a > tol:
                mid = 0.5 * (a + b)
                gm = model.diagnostics(orbit.evaluate(mid)[0], orbit.speed, p)[col] - level
                if np.sign(gm) == np.sign(ga):
                    a, ga = mid, gm
                else:
                    b = mid
            times.append(0.5 * (a + b))
    return np.sort(np.mod(times, 1.0))


def _kinks_off_mesh(times: np.ndarray, mesh: np.ndarray) -> bool:
    """Whether any kink time lies more than 1e-9 from every mesh point."""
    return times.size > 0 and float(np.max(np.min(np.abs(times[:, None] - mesh[None, :]), axis=1))) >= 1e-9


def _with_kinks(mesh: np.ndarray, times: np.ndarray) -> np.ndarray:
    """The mesh with its nearest interior point moved onto each switching time."""
    if times.size == 0:
        return mesh
    mesh = mesh.copy()
    free = np.ones(len(mesh), dtype=bool)
    free[[0, -1]] = False
    for tc in times:
        candidates = np.flatnonzero(free)
        j = candidates[np.argmin(np.abs(mesh[candidates] - tc))]
        mesh[j] = tc
        free[j] = False
    mesh = np.sort(mesh)
    if np.min(np.diff(mesh)) <= 1e-9:
        return np.sort(np.unique(mesh))  # two kinks in one interval: keep what is distinct
    return mesh
