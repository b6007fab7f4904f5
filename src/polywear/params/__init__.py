"""Validated, immutable parameter sets; TOML in and out.

- :mod:`.tables`: the vehicle's tables and :class:`Params`, changed only through
  :func:`with_updates`, which validates the result again;
- :mod:`.study`: the ``[study]`` table of the same file (:class:`StudySpec`), which
  specifies a global sensitivity study and is no vehicle parameter;
- :mod:`.files`: reading and writing parameter files, ``--set`` overrides;
- :mod:`.checks`: the shared validation. Every error is a :class:`ParameterError` whose
  message is one line naming the key, the value and the rule that was broken.
"""

from ..units import DEFAULT_OPERATING_RANGE_KMH, DEFAULT_SPEED_RANGE_KMH
from .checks import ParameterError
from .files import default_toml, flat_items, load_params, load_study, parse_override, to_toml
from .study import StudyParameter, StudySpec, study_keys
from .tables import (ADHESION_SCALE, CYCLE_SHARE_TOLERANCE, DERIVED_FIELDS, MAX_WEAR_KM, MAX_WEAR_ORDER, STUDY_TABLE,
                     Axle, Friction, Operating, Params, Tire, Tread, Wear, WearCycleEntry, get_value, with_updates)

__all__ = [
    "ParameterError", "Params", "Operating", "Tread", "Friction", "Axle", "Tire", "Wear", "WearCycleEntry",
    "StudySpec", "StudyParameter", "study_keys", "load_study", "STUDY_TABLE", "ADHESION_SCALE", "DERIVED_FIELDS",
    "load_params", "parse_override", "with_updates", "get_value", "to_toml", "default_toml", "flat_items",
    "MAX_WEAR_KM", "MAX_WEAR_ORDER", "CYCLE_SHARE_TOLERANCE", "DEFAULT_SPEED_RANGE_KMH", "DEFAULT_OPERATING_RANGE_KMH",
]
