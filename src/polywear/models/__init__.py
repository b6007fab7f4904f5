"""Models: state layout, parameter layout and compiled kernels.

``get_model(name)`` returns the :class:`~polywear.models.base.Model` for a name and
``model_for(params)`` the one a parameter set asks for (the analyses use it); the
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


def model_for(params):
    """The model a parameter set asks for: ``params.model`` with its contact
    (``friction.contact``: "point", the paper's, is ``get_model(params.model)`` itself;
    "patch" is the distributed contact: :mod:`polywear.models.patch` on tread1dof,
    :mod:`polywear.models.axle4dof_patch` on axle4dof)."""
    friction = params.friction
    if friction.contact == "point":
        return get_model(params.model)
    if params.model == "axle4dof":
        from .axle4dof_patch import axle4dof_patch_model

        return axle4dof_patch_model(friction.patch_elements, friction.patch_pressure)
    from .patch import patch_model

    return patch_model(friction.patch_elements, friction.patch_pressure)


_SUBMODULES = (
    "base", "patch", "tread1dof", "axle4dof", "axle4dof_kernels", "axle4dof_derivation",
    "axle4dof_patch", "axle4dof_patch_kernels", "kernels", "profile", "pure",
)  # fmt: skip


def __getattr__(name: str) -> object:
    if name in _SUBMODULES:
        return import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_SUBMODULES})
