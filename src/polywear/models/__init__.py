"""Models: state layout, parameter layout and compiled kernels.

``get_model(name)`` returns the :class:`~polywear.models.base.Model` for a name; the
kernel modules are imported only when asked for, also as attributes
(``pw.models.tread1dof``, ``pw.models.base``).
"""

from __future__ import annotations

from importlib import import_module

MODEL_NAMES = ("tread1dof", "axle4dof")


def get_model(name: str):
    """The model called ``name`` ("tread1dof" or "axle4dof")."""
    if name not in MODEL_NAMES:
        raise ValueError(f"model = {name!r}: must be one of {', '.join(MODEL_NAMES)}")
    return import_module(f"polywear.models.{name}").MODEL


_SUBMODULES = ("base", "tread1dof", "axle4dof", "axle4dof_kernels", "axle4dof_derivation", "kernels", "profile", "pure")


def __getattr__(name: str) -> object:
    if name in _SUBMODULES:
        return import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_SUBMODULES})
