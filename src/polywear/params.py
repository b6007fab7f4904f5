"""Validated, immutable parameter sets; TOML in and out.

Every configuration key of MODEL.md section 6 lives here as a field of a frozen
pydantic model, with its unit in the name and the docstring. Parameters are changed
only through :func:`with_updates`, which validates the result again.

Errors are reported as :class:`ParameterError` whose message is one line naming the
key, the value and the rule that was broken.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

__all__ = [
    "ParameterError",
    "Params",
    "Operating",
    "Tread",
    "Friction",
    "Axle",
    "Tire",
    "load_params",
    "parse_override",
    "with_updates",
    "get_value",
    "to_toml",
    "default_toml",
    "flat_items",
]


class ParameterError(ValueError):
    """A configuration value is unknown, of the wrong type or out of range (one line)."""


class _Table(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, strict=True, allow_inf_nan=False)


def _f(default: float, description: str, **rules: float) -> Any:
    """A float field with its default, a one-line description and numeric rules."""
    return Field(default, description=description, **rules)


class Operating(_Table):
    """Operating point of the wheel on the drum."""

    speed_kmh: float = _f(110.0, "vehicle (drum) speed V [km/h]", gt=0.0, le=1000.0)
    toe_deg: float = _f(0.5, "static toe-in per wheel [deg]", gt=-20.0, lt=20.0)
    camber_deg: float = _f(-1.0, "static camber, positive top outward [deg]", gt=-20.0, lt=20.0)
    vertical_load_n: float = _f(4000.0, "static vertical load N0 [N]", gt=0.0)
    rolling_radius_m: float = _f(0.30, "effective rolling radius R_e [m]", gt=0.0)


class Tread(_Table):
    """Lateral tread element on the rim (the self-exciting oscillator)."""

    mass_kg: float = _f(1.0, "tread mass m [kg]", gt=0.0)
    lateral_stiffness_n_per_m: float = _f(1.0e6, "tread lateral stiffness k [N/m]", gt=0.0)
    lateral_damping_ns_per_m: float = _f(80.0, "tread lateral damping c [N s/m]", ge=0.0)


class Friction(_Table):
    """LuGre tread-road friction, normalized by the normal load N (MODEL.md section 2)."""

    sigma0_per_m: float = _f(400.0, "bristle stiffness per unit load sigma0 [1/m]", gt=0.0)
    sigma1_s_per_m: float = _f(0.05, "bristle damping per unit load sigma1 [s/m]", ge=0.0)
    sigma2_s_per_m: float = _f(0.002, "viscous friction per unit load sigma2 [s/m]", ge=0.0)
    mu_static: float = _f(0.9, "static (peak) friction coefficient mu_s [-]", gt=0.0, le=5.0)
    mu_coulomb: float = _f(0.5, "Coulomb (sliding) friction coefficient mu_c [-]", gt=0.0, le=5.0)
    stribeck_velocity_m_per_s: float = _f(0.25, "Stribeck velocity v_s [m/s]", gt=0.0)
    stribeck_exponent: float = _f(
        2.0, "Stribeck exponent delta [-] (>= 1 keeps G smooth at v = 0)", ge=1.0, le=10.0
    )

    @model_validator(mode="after")
    def _coulomb_below_static(self) -> Friction:
        if self.mu_coulomb > self.mu_static:
            raise ParameterError(
                f"friction.mu_coulomb = {self.mu_coulomb!r}: must not exceed "
                f"friction.mu_static = {self.mu_static!r}"
            )
        return self


class Axle(_Table):
    """Twist-beam trailing arm with wheel carrier and wheel, rotating about bushing centre O."""

    inertia_x_kgm2: float = _f(2.0, "J1 = Jxx about O (camber axis) [kg m^2]", gt=0.0)
    inertia_y_kgm2: float = _f(8.0, "J2 = Jyy about O (pitch axis) [kg m^2]", gt=0.0)
    inertia_z_kgm2: float = _f(8.0, "J3 = Jzz about O (toe axis) [kg m^2]", gt=0.0)
    toe_stiffness_nm_per_rad: float = _f(2.58e5, "toe spring at O [N m/rad]", gt=0.0)
    toe_damping_nms_per_rad: float = _f(1440.0, "toe damping at O, equivalent [N m s/rad]", ge=0.0)
    camber_stiffness_nm_per_rad: float = _f(3.44e5, "camber spring at O [N m/rad]", gt=0.0)
    camber_damping_nms_per_rad: float = _f(
        830.0, "camber damping at O, equivalent [N m s/rad]", ge=0.0
    )
    pitch_stiffness_nm_per_rad: float = _f(5.06e3, "pitch (vertical) spring at O [N m/rad]", gt=0.0)
    pitch_damping_nms_per_rad: float = _f(304.0, "pitch (vertical) damping at O [N m s/rad]", ge=0.0)
    arm_length_m: float = _f(0.45, "arm length L, O to contact point along -x [m]", ge=0.0)
    lateral_offset_m: float = _f(0.0, "lateral offset b of the contact point along -y [m]")
    pivot_height_m: float = _f(0.30, "pivot height H of O above the road [m]", ge=0.0)
    camber_thrust_factor: float = _f(0.1, "camber-thrust factor eps [-]", ge=0.0, le=1.0)
    wheel_spin_inertia_kgm2: float = _f(0.0, "wheel spin inertia I_w (0 = paper) [kg m^2]", ge=0.0)
    reference: Literal["running", "unloaded"] = Field(
        "running",
        description='"running": toe/camber are running angles; "unloaded": springs relax at '
        "alpha = beta = gamma = 0 and the tire force deflects the axle",
    )


class Tire(_Table):
    """Radial (vertical) tire stiffness and damping at the contact point."""

    vertical_stiffness_n_per_m: float = _f(2.0e5, "tire vertical stiffness k_z [N/m]", ge=0.0)
    vertical_damping_ns_per_m: float = _f(100.0, "tire vertical damping c_z [N s/m]", ge=0.0)


class Params(_Table):
    """A complete, validated parameter set (MODEL.md section 6)."""

    model: Literal["tread1dof", "axle4dof"] = Field(
        "tread1dof", description='model: "tread1dof" or "axle4dof"'
    )
    operating: Operating = Operating()
    tread: Tread = Tread()
    friction: Friction = Friction()
    axle: Axle = Axle()
    tire: Tire = Tire()


_TABLES: dict[str, type[_Table]] = {
    name: field.annotation  # type: ignore[misc]
    for name, field in Params.model_fields.items()
    if name != "model"
}


def _describe_error(exc: ValidationError, data: dict[str, Any]) -> str:
    """One line for the first problem pydantic found: key, value, rule."""
    err = exc.errors(include_url=False)[0]
    loc = ".".join(str(part) for part in err["loc"])
    value = err.get("input")
    kind = err["type"]
    if kind == "extra_forbidden":
        table = loc.rsplit(".", 1)[0] if "." in loc else ""
        known = sorted(_TABLES[table].model_fields) if table in _TABLES else sorted(Params.model_fields)
        return f"{loc}: unknown key (known keys: {', '.join(known)})"
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


def _validate(data: dict[str, Any]) -> Params:
    try:
        return Params.model_validate(data)
    except ValidationError as exc:
        raise ParameterError(_describe_error(exc, data)) from None
    except ParameterError:
        raise


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


def with_updates(params: Params, updates: dict[str, Any]) -> Params:
    """A new validated parameter set with ``{"table.key": value}`` updates applied."""
    data = _merge(params.model_dump(), _nested(updates))
    return _validate(_coerce_numbers(data))


def get_value(params: Params, key: str) -> Any:
    """The value of ``"table.key"`` (or ``"model"``) in ``params``."""
    parts = key.split(".")
    obj: Any = params
    for part in parts:
        if not isinstance(obj, BaseModel) or part not in type(obj).model_fields:
            raise ParameterError(f"{key}: unknown key")
        obj = getattr(obj, part)
    return obj


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


def load_params(path: str | Path | None = None, overrides: list[str] | tuple[str, ...] = ()) -> Params:
    """Defaults, then the TOML file at ``path`` (if any), then ``table.key=value`` overrides."""
    data: dict[str, Any] = {}
    if path is not None:
        path = Path(path)
        try:
            text = path.read_text()
        except OSError as exc:
            raise ParameterError(f"{path}: cannot read parameter file ({exc.strerror})") from None
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise ParameterError(f"{path}: not valid TOML ({exc})") from None
    flat = dict(parse_override(item) for item in overrides)
    data = _merge(data, _nested(flat))
    return _validate(_coerce_numbers(data))


def flat_items(params: Params) -> list[tuple[str, Any, str]]:
    """(key, value, description) for every key, in declaration order."""
    rows: list[tuple[str, Any, str]] = [("model", params.model, Params.model_fields["model"].description or "")]
    for table in _TABLES:
        sub = getattr(params, table)
        for name, field in type(sub).model_fields.items():
            rows.append((f"{table}.{name}", getattr(sub, name), field.description or ""))
    return rows


def _toml_value(value: Any) -> str:
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(float(value))


def to_toml(params: Params, comments: bool = False) -> str:
    """The parameter set as TOML text, optionally with a comment per key."""
    lines: list[str] = []
    current = None
    for key, value, description in flat_items(params):
        table, _, name = key.rpartition(".")
        if table != current:
            if table:
                lines.append("")
                if comments:
                    doc = (_TABLES[table].__doc__ or "").strip().splitlines()[0]
                    lines.append(f"# {doc}")
                lines.append(f"[{table}]")
            current = table
        entry = f"{name} = {_toml_value(value)}"
        if comments:
            entry = f"{entry:<42} # {description}"
        lines.append(entry)
    return "\n".join(lines) + "\n"


def default_toml() -> str:
    """A commented parameter file holding the built-in defaults."""
    header = (
        "# polywear parameter file. Every key is optional; missing keys take these defaults.\n"
        "# Units are in the key names. Override any key on the command line with\n"
        "#   --set table.key=value\n"
    )
    return header + to_toml(Params(), comments=True)
