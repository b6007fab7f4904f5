"""polywear's exceptions: one root, :class:`PolywearError`, so a caller can catch what polywear raises.

Three kinds sit under it, each also a builtin so that older ``except`` clauses keep working:

- :class:`polywear.params.ParameterError` (a ``ValueError``): a configuration value is unknown,
  of the wrong type or out of range;
- :class:`InputError` (a ``ValueError``): a data file or measured input cannot be used
  (friction data, run-ups, observations, ``.tir`` files);
- :class:`NumericalError` (a ``RuntimeError``): a numerical method failed on valid input (an
  integrator that gave up, a homotopy that stalled, eigenvalue crossings that cannot be
  separated, an AUTO-07p run that did not complete).

Programming errors (``TypeError``, ``KeyError``, ...) are not wrapped.
"""

from __future__ import annotations

__all__ = ["PolywearError", "InputError", "NumericalError"]


class PolywearError(Exception):
    """The root of every error polywear raises on purpose."""


class InputError(PolywearError, ValueError):
    """A data file or measured input cannot be read or used (one line naming the file and problem)."""


class NumericalError(PolywearError, RuntimeError):
    """A numerical method failed on valid input (no convergence, a stalled homotopy, a solver that gave up)."""
