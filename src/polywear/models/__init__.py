"""Models: state layout, parameter layout and compiled kernels.

``get_model(name)`` returns the :class:`~polywear.models.base.Model` for a name; the
kernel modules are imported only when asked for.
"""

from __future__ import annotations

from importlib import import_module

MODEL_NAMES = ("tread1dof", "axle4dof")


def get_model(name: str):
    """The model called ``name`` ("tread1dof" or "axle4dof")."""
    if name not in MODEL_NAMES:
        raise ValueError(f"model = {name!r}: must be one of {', '.join(MODEL_NAMES)}")
    return import_module(f"polywear.models.{name}").MODEL
