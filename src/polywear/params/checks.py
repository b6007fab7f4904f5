"""The validation every parameter table shares: one-line errors naming key, value and rule.

:class:`ParameterError` is what every bad value raises; :func:`_validate` turns pydantic's
errors into it. The helpers coerce TOML numbers (integers in float fields, floats in
integer fields) and turn ``{"table.key": value}`` updates into nested tables.
"""

from __future__ import annotations

from typing import Any, TypeVar

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from ..errors import PolywearError

_T = TypeVar("_T", bound=BaseModel)


class ParameterError(PolywearError, ValueError):
    """A configuration value is unknown, of the wrong type or out of range (one line)."""


class _Table(BaseModel):
    """The base of every table: unknown keys refused, frozen, strict types, no inf or NaN."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True, allow_inf_nan=False)


def _f(default: float, description: str, **rules: float) -> Any:
    """A float field with its default, a one-line description and numeric rules."""
    return Field(default, description=description, **rules)


def _number(value: Any) -> Any:
    """TOML/override numbers in nested tables and arrays: int -> float (bools stay invalid)."""
    if isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    return value


def _tuple(value: Any) -> Any:
    """A TOML array of tables (a list) as the tuple a frozen table holds."""
    return tuple(value) if isinstance(value, list) else value


def _integral(value: Any) -> Any:
    """Integer fields pass through :func:`_coerce_numbers`, which makes 1024 -> 1024.0."""
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return value


def _table_at(root: type[BaseModel], loc: tuple) -> type[BaseModel]:
    """The model class at a validation-error location (array indices skipped)."""
    cls = root
    for part in loc:
        if isinstance(part, str):
            annotation = cls.model_fields[part].annotation
            cls = getattr(annotation, "__args__", (annotation,))[0]  # tuple[StudyParameter, ...]
    return cls


def _describe_error(root: type[BaseModel], exc: ValidationError) -> str:
    """One line for the first problem pydantic found: key, value, rule."""
    err = exc.errors(include_url=False)[0]
    loc = ".".join(str(part) for part in err["loc"])
    value = err.get("input")
    kind = err["type"]
    if kind == "extra_forbidden":
        known = sorted(_table_at(root, err["loc"][:-1]).model_fields)
        return f"{loc}: unknown key (known keys: {', '.join(known)})"
    if kind == "missing":
        return f"{loc}: required key missing"
    ctx = err.get("ctx") or {}
    if isinstance(ctx.get("error"), ParameterError):
        return str(ctx["error"])
    if kind == "finite_number":
        rule = "must be a finite number"
    elif kind in ("float_type", "string_type", "literal_error", "model_type", "dict_type"):
        rule = err["msg"].lower()
        if kind == "float_type":
            rule = "must be a number"
    else:
        rule = err["msg"].lower().replace("input ", "")
    return f"{loc} = {value!r}: {rule}"


def _validate(root: type[_T], data: dict[str, Any]) -> _T:
    try:
        return root.model_validate(data)
    except ValidationError as exc:
        raise ParameterError(_describe_error(root, exc)) from None


def _nested(flat: dict[str, Any]) -> dict[str, Any]:
    """{"a.b": v} -> {"a": {"b": v}}; reject keys deeper than table.key."""
    out: dict[str, Any] = {}
    for key, value in flat.items():
        parts = key.split(".")
        if len(parts) == 1:
            out[key] = value
        elif len(parts) == 2:
            table = out.setdefault(parts[0], {})
            if not isinstance(table, dict):
                raise ParameterError(f"{parts[0]}: is a value, not a table")
            table[parts[1]] = value
        else:
            raise ParameterError(f"{key}: keys are 'key' or 'table.key'")
    return out


def _merge(base: dict[str, Any], update: dict[str, Any]) -> dict[str, Any]:
    merged = {k: (dict(v) if isinstance(v, dict) else v) for k, v in base.items()}
    for key, value in update.items():
        if isinstance(value, dict) and isinstance(merged.get(key), dict):
            merged[key] = {**merged[key], **value}
        else:
            merged[key] = value
    return merged


def _coerce_numbers(data: dict[str, Any]) -> dict[str, Any]:
    """TOML integers become floats where the field is a float (strict mode keeps bools out)."""
    out: dict[str, Any] = {}
    for key, value in data.items():
        if isinstance(value, dict):
            out[key] = _coerce_numbers(value)
        elif isinstance(value, int) and not isinstance(value, bool):
            out[key] = float(value)
        else:
            out[key] = value
    return out
