"""Numerical solvers: time integration, periodic orbits, bordered linear algebra, continuation.

The submodules are imported on first attribute access (``pw.solvers.integrate``), so
``import polywear.solvers`` stays light.

Solvers work in SI: a speed here is the model's ``V`` [m/s] (``PeriodicOrbit.speed``,
``Branch.end_speed``), labels of special points are AUTO-07p's strings (``"LP"``,
``"PD"``, ``"NS"``). The analysis layer turns them into results in km/h (a field in m/s
there ends in ``_ms``) and into ``PointKind`` members (``polywear.dynamics.points``).
"""

from __future__ import annotations

_SUBMODULES = ("arclength", "bordered", "collocation", "continuation", "curve_continuation", "integrate")


def __getattr__(name: str) -> object:
    if name in _SUBMODULES:
        from importlib import import_module

        return import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_SUBMODULES})
