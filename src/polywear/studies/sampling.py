"""One sample of a study, a pilot stage or a fleet: its values set on a base parameter set,
and the errors its evaluation records as the sample's failure (shared by the global study,
the fast band's pilot stage and the fleet, so that none of them imports another for it)."""

from __future__ import annotations

from ..keys import with_updates
from ..params import Params

__all__ = ["SAMPLE_FAILURES", "sample_params"]

SAMPLE_FAILURES = (ValueError, ArithmeticError, RuntimeError)
"""What the evaluation of one sample may raise and a study records as that sample's failure
(with the exception's type and message): invalid parameters (``ParameterError``, a
``ValueError``), the solvers' numerical failures (``ValueError``, ``np.linalg.LinAlgError``
(a ``ValueError``), ``RuntimeError``, ``IntegrationError`` (a ``RuntimeError``),
``FloatingPointError``, ``ZeroDivisionError``, ``OverflowError``). Programming errors
(``TypeError``, ``AttributeError``, ``NameError``, ``KeyError``, ``IndexError``) propagate."""


def sample_params(base: Params, keys, values) -> Params:
    """``base`` with ``keys`` set to ``values`` (validated once, all together).

    ``adhesion_scale`` multiplies mu_s and mu_c (after any direct setting of them).
    """
    return with_updates(base, {k: float(v) for k, v in zip(keys, values)})
