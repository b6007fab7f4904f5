"""Every numeric parameter key in one place: unit, bounds, description, stored or derived.

:data:`KEYS` maps each numeric key of a parameter set (``"operating.toe_deg"``, the
integer ``wear.*`` keys too) and each derived key to a frozen :class:`KeyInfo`. Stored
keys come from the fields of :class:`~polywear.params.Params`: bounds from their
validation rules, the description from the field, the unit from the key's name
(:func:`unit_of_name`; polywear puts every unit into the name). The words and choices
(``model``, ``axle.reference``, ``wear.cycle``) have no unit and are no keys here.

A derived key is no field: it scales stored keys together. It is declared beside the
fields (:data:`polywear.params.DERIVED_FIELDS`, where the ``[study]`` validation needs it;
this module sits above ``params``). The one there is, ``adhesion_scale``, multiplies mu_s
and mu_c (nominal 1). Read a key with :func:`get_value` (a derived key: always 1, a
parameter set being its own reference) and set keys with :func:`with_updates`, which
every study, sensitivity, map and design search uses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, Literal

from pydantic import BaseModel

from . import params as _params
from .params import ADHESION_SCALE, DERIVED_FIELDS, ParameterError, Params, study_keys

__all__ = [
    "KeyInfo",
    "KEYS",
    "ADHESION_SCALE",
    "PAPER_KEYS",
    "key_info",
    "unit_of_name",
    "study_keys",
    "stored_rates",
    "get_value",
    "with_updates",
]

PAPER_KEYS = (
    "tread.lateral_stiffness_n_per_m",
    "tread.lateral_damping_ns_per_m",
    "operating.toe_deg",
    "operating.camber_deg",
    "friction.mu_static",
    "tread.mass_kg",
    "operating.vertical_load_n",
)
"""The paper's seven parameters (its Fig. 9), adhesion read as the peak friction mu_s;
:data:`ADHESION_SCALE` is the other reading."""


@dataclass(frozen=True)
class KeyInfo:
    """One numeric key: unit ('-' if dimensionless), bounds, description, kind.

    ``lower``/``upper`` are the validation bounds in the key's unit (infinite where
    there is none); ``*_inclusive`` tells whether the bound itself is allowed. The rules
    between keys (mu_c <= mu_s, wear.max_order below half of wear.profile_points) come on
    top. A derived key multiplies the stored keys ``scales`` (its value is a factor).
    """

    key: str
    unit: str
    lower: float
    upper: float
    lower_inclusive: bool
    upper_inclusive: bool
    description: str
    kind: Literal["stored", "derived"]
    integer: bool = False
    scales: tuple[str, ...] = ()


_SUFFIX_UNITS = {
    "kmh": "km/h",
    "km": "km",
    "deg": "deg",
    "n": "N",
    "m": "m",
    "kg": "kg",
    "mm": "mm",
    "um": "um",
    "kgm2": "kg m^2",
    "per_m": "1/m",
    "n_per_m": "N/m",
    "ns_per_m": "N s/m",
    "s_per_m": "s/m",
    "m_per_s": "m/s",
    "nm_per_rad": "N m/rad",
    "nms_per_rad": "N m s/rad",
    "mm3_per_j": "mm^3/J",
}
"""Name suffix (after the last word of the quantity) -> unit, as written in the descriptions."""


def unit_of_name(name: str) -> str:
    """The unit a key's name ends in (``"toe_deg"`` -> ``"deg"``); ``"-"`` where none.

    The longest matching suffix wins (``"_n_per_m"`` before ``"_per_m"`` and ``"_m"``).
    """
    matches = [s for s in _SUFFIX_UNITS if name.endswith("_" + s)]
    return _SUFFIX_UNITS[max(matches, key=len)] if matches else "-"


def _record(key: str, info: Any, kind: Literal["stored", "derived"]) -> KeyInfo:
    """The record of a float or int key from its pydantic FieldInfo."""
    lower, upper, lower_inc, upper_inc = -math.inf, math.inf, False, False
    for rule in info.metadata:
        for attr, inclusive in (("gt", False), ("ge", True)):
            if getattr(rule, attr, None) is not None:
                lower, lower_inc = float(getattr(rule, attr)), inclusive
        for attr, inclusive in (("lt", False), ("le", True)):
            if getattr(rule, attr, None) is not None:
                upper, upper_inc = float(getattr(rule, attr)), inclusive
    scales = tuple((info.json_schema_extra or {}).get("scales", ())) if kind == "derived" else ()
    return KeyInfo(key, unit_of_name(key.rpartition(".")[2]), lower, upper, lower_inc, upper_inc,
                   info.description or "", kind, integer=info.annotation is int, scales=scales)


def _registry() -> dict[str, KeyInfo]:
    out = {}
    for table, field in Params.model_fields.items():
        cls = field.annotation
        if not isinstance(cls, type) or not issubclass(cls, BaseModel):
            continue  # "model": a word
        for name, info in cls.model_fields.items():
            if info.annotation in (float, int):
                out[f"{table}.{name}"] = _record(f"{table}.{name}", info, "stored")
    for key, info in DERIVED_FIELDS.items():
        out[key] = _record(key, info, "derived")
    return out


KEYS: MappingProxyType[str, KeyInfo] = MappingProxyType(_registry())
"""``"table.key"`` (or a derived key) -> :class:`KeyInfo`, in declaration order, derived keys last."""


def key_info(key: str) -> KeyInfo:
    """The record of a numeric key; :class:`ParameterError` for any other."""
    try:
        return KEYS[key]
    except KeyError:
        raise ParameterError(f"{key}: unknown or non-numeric key") from None


def stored_rates(params: Params, key: str) -> dict[str, float]:
    """d(stored key)/d(key) at ``params`` [stored unit per key unit]: ``{key: 1.0}`` for a
    stored key, mu_s and mu_c for ``adhesion_scale``; :class:`ParameterError` if unknown."""
    if key in DERIVED_FIELDS:
        return {k: float(_params.get_value(params, k)) for k in KEYS[key].scales}
    _params.get_value(params, key)
    return {key: 1.0}


def get_value(params: Params, key: str) -> Any:
    """The value of ``"table.key"`` (or ``"model"``), or of a derived key (``adhesion_scale``: 1)."""
    return 1.0 if key in DERIVED_FIELDS else _params.get_value(params, key)


def with_updates(params: Params, updates: dict[str, Any]) -> Params:
    """A new validated parameter set with ``{"key": value}`` updates, derived keys included.

    A derived key multiplies its stored keys after any direct setting of them in the same
    ``updates`` (``adhesion_scale``: mu_s and mu_c).
    """
    direct = {k: v for k, v in updates.items() if k not in DERIVED_FIELDS}
    for derived in (k for k in DERIVED_FIELDS if k in updates):
        scale = float(updates[derived])
        for key in KEYS[derived].scales:
            direct[key] = direct.get(key, _params.get_value(params, key)) * scale
    return _params.with_updates(params, direct)
