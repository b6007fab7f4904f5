"""Parameter files: TOML in (``load_params``, ``load_study``, ``--set`` overrides) and out
(``to_toml``, the commented ``default_toml``), and the flat ``table.key`` listing."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from .checks import ParameterError, _coerce_numbers, _merge, _nested, _validate
from .study import StudySpec, _StudyFile
from .tables import _TABLES, CYCLE_SHARE_TOLERANCE, STUDY_TABLE, Params, _no_study_keys


def parse_override(text: str) -> tuple[str, Any]:
    """Parse ``table.key=value`` (value in TOML syntax; bare words are strings)."""
    if "=" not in text:
        raise ParameterError(f"--set {text!r}: expected table.key=value")
    key, raw = (s.strip() for s in text.split("=", 1))
    if not key or not raw:
        raise ParameterError(f"--set {text!r}: expected table.key=value")
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw
    if isinstance(value, float) and not math.isfinite(value):
        raise ParameterError(f"{key} = {raw}: must be a finite number")
    return key, value


def _read_toml(path: str | Path | None) -> dict[str, Any]:
    """The parameter file at ``path`` as a dict ({} without a path)."""
    if path is None:
        return {}
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ParameterError(f"{path}: cannot read parameter file ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise ParameterError(f"{path}: not a text (UTF-8 TOML) file") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ParameterError(f"{path}: not valid TOML ({exc})") from None


def _study_file(data: dict[str, Any], flat: dict[str, Any]) -> StudySpec:
    """The study of a file's ``data`` and ``{"study.key": value}`` overrides, validated."""
    merged = _merge({STUDY_TABLE: data.get(STUDY_TABLE, {})}, _nested(flat))
    return _validate(_StudyFile, _coerce_numbers(merged)).study


def load_params(
    path: str | Path | None = None,
    overrides: list[str] | tuple[str, ...] = (),
    base: dict[str, Any] | None = None,
) -> Params:
    """Defaults, then ``base`` (``{"table.key": value}``, e.g. from a .tir file), then the
    TOML file at ``path`` (if any), then ``table.key=value`` overrides.

    The file's ``[study]`` table is validated too (a bad one fails here as well) but is not
    part of the parameters: :func:`load_study` reads it; ``study.*`` overrides are refused.
    """
    data = _read_toml(path)
    flat = dict(parse_override(item) for item in overrides)
    _no_study_keys(flat)
    _study_file(data, {})
    data = {k: v for k, v in data.items() if k != STUDY_TABLE}
    data = _merge(_merge(_nested(dict(base or {})), data), _nested(flat))
    return _validate(Params, _coerce_numbers(data))


def load_study(path: str | Path | None = None, overrides: list[str] | tuple[str, ...] = ()) -> StudySpec:
    """The study specification: defaults, then the ``[study]`` table of the TOML file at
    ``path`` (if any), then ``study.key=value`` overrides (e.g. ``"study.n_base=256"``)."""
    flat = dict(parse_override(item) for item in overrides)
    for key in flat:
        if key.split(".", 1)[0] != STUDY_TABLE:
            raise ParameterError(f"{key}: not a study setting (study.key)")
    return _study_file(_read_toml(path), flat)


def _tables(params: Params, study: StudySpec | None) -> dict[str, BaseModel]:
    """Table name -> table of the parameters, then ``[study]`` if a study is given."""
    tables: dict[str, BaseModel] = {table: getattr(params, table) for table in _TABLES}
    if study is not None:
        tables[STUDY_TABLE] = study
    return tables


def flat_items(params: Params, study: StudySpec | None = None) -> list[tuple[str, Any, str]]:
    """(key, value, description) for every key, in declaration order; the ``study.*`` keys
    last if a study is given."""
    rows: list[tuple[str, Any, str]] = [("model", params.model, Params.model_fields["model"].description or "")]
    for table, sub in _tables(params, study).items():
        for name, field in type(sub).model_fields.items():
            rows.append((f"{table}.{name}", getattr(sub, name), field.description or ""))
    return rows


def _toml_value(value: Any) -> str:
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, tuple):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    return repr(float(value))


_STUDY_EXAMPLE = """\
# [[study.parameters]]                    # one table per uncertain parameter
# key = "operating.toe_deg"               # any float key, or "adhesion_scale"
# low = 0.2                               # bounds [key units]
# high = 0.8
# distribution = "uniform"                # uniform, loguniform, triangular (mode = ...),
#                                         # normal (mean = ..., std = ...; truncated to [low, high])"""


_ARRAY_COMMENTS = {
    "wear.cycle": "# drive cycle: one [[wear.cycle]] per speed, share = share of the distance "
    f"(shares sum to 1 within {CYCLE_SHARE_TOLERANCE}, then normalised)",
}


def _array_of_tables(name: str, entries: tuple[BaseModel, ...], comments: bool) -> list[str]:
    """``[[name]]`` blocks, one per entry (None fields left out)."""
    if not entries:
        return ["", _STUDY_EXAMPLE] if comments else []
    lines: list[str] = ["", _ARRAY_COMMENTS[name]] if comments and name in _ARRAY_COMMENTS else []
    for entry in entries:
        lines += ["", f"[[{name}]]"]
        lines += [f"{k} = {_toml_value(v)}" for k, v in entry if v is not None]
    return lines


def to_toml(params: Params, comments: bool = False, study: StudySpec | None = None) -> str:
    """The parameter set (and the ``[study]`` table if a study is given) as TOML text,
    optionally with a comment per key."""
    lines: list[str] = []
    arrays: list[str] = []
    current = None
    tables = _tables(params, study)
    for key, value, description in flat_items(params, study):
        table, _, name = key.rpartition(".")
        if isinstance(value, tuple) and all(isinstance(v, BaseModel) for v in value):
            arrays += _array_of_tables(key, value, comments)
            continue
        if table != current:
            lines += arrays
            arrays = []
            if table:
                lines.append("")
                if comments:
                    doc = (type(tables[table]).__doc__ or "").strip().splitlines()[0]
                    lines.append(f"# {doc}")
                lines.append(f"[{table}]")
            current = table
        entry = f"{name} = {_toml_value(value)}"
        if comments:
            entry = f"{entry:<42} # {description}"
        lines.append(entry)
    return "\n".join(lines + arrays) + "\n"


def default_toml() -> str:
    """A commented parameter file holding the built-in defaults."""
    header = (
        "# polywear parameter file. Every key is optional; missing keys take these defaults.\n"
        "# Units are in the key names. Override any key on the command line with\n"
        "#   --set table.key=value\n"
    )
    return header + to_toml(Params(), comments=True, study=StudySpec())
