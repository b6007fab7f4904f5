"""Pure-Python twins of compiled kernel modules, for baselines and references.

``pure_python_namespace(module, ...)`` executes the modules' source in one namespace
with the ``@njit`` decorators removed and the package-relative imports dropped, so that
names imported from an earlier module resolve to its pure-Python functions. Nothing is
compiled; the arithmetic is exactly the compiled kernels' arithmetic.
"""

from __future__ import annotations

import inspect
import re

__all__ = ["pure_python_namespace"]

_DECORATOR = re.compile(r"^@njit\(.*\)\s*$", re.MULTILINE)
_RELATIVE_IMPORT = re.compile(r"^from \.+\S* import (?:\([^)]*\)|.*)$", re.MULTILINE)
"""A package-relative import, on one line or parenthesized over several."""


def pure_python_namespace(*modules) -> dict:
    """One namespace holding every module's functions as plain Python (no numba)."""
    namespace: dict = {"__name__": "polywear_pure_python"}
    for module in modules:
        source = inspect.getsource(module)
        source = _DECORATOR.sub("", source)
        source = _RELATIVE_IMPORT.sub("", source)
        exec(compile(source, f"<pure python {module.__name__}>", "exec"), namespace)  # noqa: S102 (our own source)
    return namespace
