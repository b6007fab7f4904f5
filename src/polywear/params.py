"""Validated, immutable parameter sets; TOML in and out.

Every configuration key of docs/model.md section 6 lives here as a field of a frozen
pydantic model, with its unit in the name and the docstring. Parameters are changed
only through :func:`with_updates`, which validates the result again.

The ``[study]`` table of the same file is no vehicle parameter: it specifies a global
sensitivity study (:class:`StudySpec`, read by :func:`load_study`), is not a field of
:class:`Params` and is changed through :meth:`StudySpec.with_updates`.

Errors are reported as :class:`ParameterError` whose message is one line naming the
key, the value and the rule that was broken.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Iterable
from pathlib import Path
from typing import Annotated, Any, Literal, TypeVar

from pydantic import BaseModel, ConfigDict, Field, TypeAdapter, ValidationError, field_validator, model_validator

from .errors import PolywearError
from .units import DEFAULT_OPERATING_RANGE_KMH, DEFAULT_SPEED_RANGE_KMH, MAX_SPEED_KMH

__all__ = [
    "ParameterError",
    "Params",
    "Operating",
    "Tread",
    "Friction",
    "Axle",
    "Tire",
    "Wear",
    "WearCycleEntry",
    "StudySpec",
    "StudyParameter",
    "study_keys",
    "load_study",
    "STUDY_TABLE",
    "ADHESION_SCALE",
    "DERIVED_FIELDS",
    "load_params",
    "parse_override",
    "with_updates",
    "get_value",
    "to_toml",
    "default_toml",
    "flat_items",
    "DEFAULT_SPEED_RANGE_KMH",
    "DEFAULT_OPERATING_RANGE_KMH",
]


MAX_STUDY_BASE = 65536
"""Largest study.n_base (sobol: N (2D + 2) runs, already about a million for D = 7)."""
MAX_BOOTSTRAP = 100_000
"""Most bootstrap resamples of a study."""


_T = TypeVar("_T", bound=BaseModel)


class ParameterError(PolywearError, ValueError):
    """A configuration value is unknown, of the wrong type or out of range (one line)."""


class _Table(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, strict=True, allow_inf_nan=False)


def _f(default: float, description: str, **rules: float) -> Any:
    """A float field with its default, a one-line description and numeric rules."""
    return Field(default, description=description, **rules)


class Operating(_Table):
    """Operating point of the wheel on the drum."""

    speed_kmh: float = _f(110.0, "vehicle (drum) speed V [km/h]", gt=0.0, le=MAX_SPEED_KMH)
    toe_deg: float = _f(0.5, "static toe-in per wheel [deg]", gt=-20.0, lt=20.0)
    camber_deg: float = _f(-1.0, "static camber, positive top outward [deg]", gt=-20.0, lt=20.0)
    vertical_load_n: float = _f(4000.0, "static vertical load N0 [N]", ge=500.0, le=60_000.0)
    rolling_radius_m: float = _f(0.30, "effective rolling radius R_e [m]", ge=0.15, le=0.8)


class Tread(_Table):
    """Lateral tread element on the rim (the self-exciting oscillator).

    Bounds (what a tread element can be): the mass from one tread block of a few
    millimetres of rubber (0.1 g) to the whole tread band of a truck tire (tens of kg),
    100 kg; the lateral stiffness three decades either side of the default 1e6 N/m (a whole
    passenger tire's lateral carcass stiffness is of order 1e5 N/m, Pacejka, *Tire and
    Vehicle Dynamics*, 3rd ed., 2012; 1e9 N/m is a tread rigid against the bristle, the
    limit the patch contact's closed forms take); the damping up to 1e5 N s/m (critical
    damping of 1 kg on 1e9 N/m is 6e4 N s/m).
    """

    mass_kg: float = _f(1.0, "tread mass m [kg]", ge=1.0e-4, le=100.0)
    lateral_stiffness_n_per_m: float = _f(1.0e6, "tread lateral stiffness k [N/m]", ge=1.0e3, le=1.0e9)
    lateral_damping_ns_per_m: float = _f(80.0, "tread lateral damping c [N s/m]", ge=0.0, le=1.0e5)


class Friction(_Table):
    """LuGre tread-road friction, normalized by the normal load N (docs/model.md section 2).

    Bounds (what a rubber-road LuGre parameter can be), spanning the published sets: the
    tire's lumped LuGre model (Canudas-de-Wit, Tsiotras, Velenis, Basset, Gissinger,
    *Vehicle System Dynamics* 39, 2003: sigma0 = 40 1/m, sigma1 = 4.9487 s/m,
    sigma2 = 0.0018 s/m, v_s = 12.5 m/s) and the original LuGre example at a unit load
    (Canudas-de-Wit, Olsson, Astrom, Lischinsky, *IEEE TAC* 40, 1995: sigma0 = 1e5 1/m,
    sigma1 = 316 s/m, sigma2 = 0.4 s/m, v_s = 0.001 m/s). sigma0 from 10 1/m (0.1 m of
    bristle deflection at mu = 1, the size of the contact patch) to 1e8 1/m (10 nm); sigma1
    up to 1e3 s/m; sigma2 up to 1 s/m (viscous friction of 1 at 1 m/s sliding); v_s from
    1e-4 to 100 m/s. Friction coefficients from 0.05 (tire on wet ice) to 3 (soft rubber on
    a dry rough surface; racing tires reach 1.5-1.8), the limit ``friction fit`` holds
    measured coefficients to.
    """

    sigma0_per_m: float = _f(400.0, "bristle stiffness per unit load sigma0 [1/m]", ge=10.0, le=1.0e8)
    sigma1_s_per_m: float = _f(0.05, "bristle damping per unit load sigma1 [s/m]", ge=0.0, le=1.0e3)
    sigma2_s_per_m: float = _f(0.002, "viscous friction per unit load sigma2 [s/m]", ge=0.0, le=1.0)
    mu_static: float = _f(0.9, "static (peak) friction coefficient mu_s [-]", ge=0.05, le=3.0)
    mu_coulomb: float = _f(0.5, "Coulomb (sliding) friction coefficient mu_c [-]", ge=0.05, le=3.0)
    stribeck_velocity_m_per_s: float = _f(0.25, "Stribeck velocity v_s [m/s]", ge=1.0e-4, le=100.0)
    stribeck_exponent: float = _f(
        2.0, "Stribeck exponent delta [-] (>= 1 keeps G smooth at v = 0)", ge=1.0, le=10.0
    )
    contact: Literal["point", "patch"] = Field(
        default="point",
        description='"point": one tread element under the whole load (the paper); "patch": '
        "patch_elements tread elements travelling through the contact patch",
    )
    patch_elements: int = Field(
        default=40, description="tread elements M along the contact patch (contact = patch) [-]", ge=2, le=400
    )
    patch_pressure: Literal["parabolic", "uniform"] = Field(
        default="parabolic", description="normal pressure distribution along the patch (contact = patch)"
    )

    @field_validator("patch_elements", mode="before")
    @classmethod
    def _to_int(cls, value: Any) -> Any:
        return _integral(value)

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
    arm_length_m: float = _f(0.45, "arm length L, O to contact point along -x [m]", ge=0.0, le=2.0)
    lateral_offset_m: float = _f(0.0, "lateral offset b of the contact point along -y [m]", ge=-0.5, le=0.5)
    pivot_height_m: float = _f(0.30, "pivot height H of O above the road [m]", ge=0.0, le=1.5)
    camber_thrust_factor: float = _f(0.1, "camber-thrust factor eps [-]", ge=0.0, le=1.0)
    wheel_spin_inertia_kgm2: float = _f(0.0, "wheel spin inertia I_w (0 = paper) [kg m^2]", ge=0.0)
    reference: Literal["running", "unloaded"] = Field(
        "running",
        description='"running": toe/camber are running angles; "unloaded": springs relax at '
        "alpha = beta = gamma = 0 and the tire force deflects the axle",
    )


class Tire(_Table):
    """Radial (vertical) tire stiffness and damping at the contact point."""

    vertical_stiffness_n_per_m: float = _f(2.0e5, "tire vertical stiffness k_z [N/m]", ge=0.0, le=1.0e7)
    vertical_damping_ns_per_m: float = _f(100.0, "tire vertical damping c_z [N s/m]", ge=0.0, le=1.0e5)
    contact_length_m: float = _f(
        0.11, "contact patch length 2a along the circumference [m]", ge=0.01, le=0.5
    )
    tread_width_m: float = _f(0.16, "tread (contact patch) width b_w [m]", ge=0.03, le=0.6)


ADHESION_SCALE = "adhesion_scale"
"""Study and sensitivity key scaling mu_s and mu_c together (nominal 1; the paper's
adhesion coefficient, second reading)."""

DERIVED_FIELDS: dict[str, Any] = {
    ADHESION_SCALE: Field(
        gt=0.0,
        description="factor on mu_s and mu_c together, nominal 1 (the paper's adhesion, second reading) [-]",
        json_schema_extra={"scales": ("friction.mu_static", "friction.mu_coulomb")},
    ),
}
"""Derived keys (no fields: a factor on the stored keys ``scales``), declared beside the
fields; read and set through :mod:`polywear.keys`."""

DISTRIBUTIONS = ("uniform", "loguniform", "triangular", "normal")


def _study_fields() -> dict[str, Any]:
    """"table.key" -> pydantic FieldInfo of every float key of the model tables (not the
    wear's), then the derived keys."""
    out = {}
    for table, cls in _TABLES.items():
        if table == "wear":
            continue
        for name, info in cls.model_fields.items():
            if info.annotation is float:
                out[f"{table}.{name}"] = info
    return {**out, **DERIVED_FIELDS}


def study_keys() -> tuple[str, ...]:
    """Keys a study (or a sensitivity) may vary: every float key, and ``adhesion_scale``."""
    return tuple(_study_fields())


def _number(value: Any) -> Any:
    """TOML/override numbers in nested tables and arrays: int -> float (bools stay invalid)."""
    if isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    return value


def _integral(value: Any) -> Any:
    """Integer fields pass through :func:`_coerce_numbers`, which makes 1024 -> 1024.0."""
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return value


MAX_WEAR_ORDER = 500
"""Highest polygon order of a wear profile (``wear.max_order``, ``--max-order``) [-]."""
MAX_PROFILE_POINTS = 8192
"""Most samples of a worn profile (``wear.profile_points``) [-]."""
MAX_WEAR_KM = 1.0e6
"""Longest wear distance (``wear.report_km``, ``--distance-km``, ``--wear-km``): ten times
what any tire lasts [km]."""

CYCLE_SHARE_TOLERANCE = 0.01
"""``[[wear.cycle]]`` shares must sum to 1 within this (rounding); they are then normalised."""


class WearCycleEntry(_Table):
    """One speed of the drive cycle and the share of the distance driven at it."""

    speed_kmh: float = Field(description="vehicle speed [km/h]", gt=0.0, le=MAX_SPEED_KMH)
    share: float = Field(description="share of the distance driven at this speed [-]", gt=0.0, le=1.0)

    _to_float = field_validator("speed_kmh", "share", mode="before")(_number)


def _default_cycle() -> tuple[WearCycleEntry, ...]:
    """Urban / rural / motorway mix of the distance (a typical passenger-car use)."""
    return (
        WearCycleEntry(speed_kmh=50.0, share=0.3),
        WearCycleEntry(speed_kmh=80.0, share=0.4),
        WearCycleEntry(speed_kmh=120.0, share=0.3),
    )


class Wear(_Table):
    """Polygonal wear: wear law, initial roughness, profile resolution, drive cycle."""

    energetic_rate_mm3_per_j: float = _f(
        1.0e-3, "energetic wear rate k_e: worn volume per friction energy [mm^3/J]", ge=1.0e-6, le=0.1
    )
    initial_roughness_um: float = _f(
        1.0, "RMS of the seeded initial roughness over orders 1..max_order [um]", gt=0.0, le=1000.0
    )
    max_order: int = Field(
        60, description="highest harmonic (polygon order) of the profile [-]", ge=1, le=MAX_WEAR_ORDER
    )
    profile_points: int = Field(
        720, description="samples of the worn profile around the tire [-]", ge=8, le=MAX_PROFILE_POINTS
    )
    seed: int = Field(0, description="seed of the initial roughness (numpy SeedSequence) [-]", ge=0)
    visible_depth_mm: float = _f(
        0.1, "peak-to-valley depth at which the polygon counts as visible [mm]", gt=0.0, le=10.0
    )
    report_km: float = _f(
        100_000.0, "distance of the wear evolutions in the main job, polywear report [km] (0: not run)",
        ge=0.0, le=MAX_WEAR_KM,
    )
    cycle: tuple[WearCycleEntry, ...] = Field(
        default_factory=_default_cycle,
        description="drive cycle ([[wear.cycle]]): speeds and shares of the distance",
    )

    _to_int = field_validator("max_order", "profile_points", "seed", mode="before")(_integral)

    @field_validator("cycle", mode="before")
    @classmethod
    def _array_of_tables(cls, value: Any) -> Any:
        return tuple(value) if isinstance(value, list) else value

    @model_validator(mode="after")
    def _consistent(self) -> Wear:
        if 2 * self.max_order >= self.profile_points:
            raise ParameterError(
                f"wear.max_order = {self.max_order!r}: must be below half of wear.profile_points = "
                f"{self.profile_points!r} (sampling)"
            )
        if not self.cycle:
            raise ParameterError("wear.cycle: needs at least one [[wear.cycle]] entry")
        speeds = [entry.speed_kmh for entry in self.cycle]
        duplicates = sorted({v for v in speeds if speeds.count(v) > 1})
        if duplicates:
            raise ParameterError(f"wear.cycle: speed_kmh = {duplicates[0]!r} given more than once")
        total = sum(entry.share for entry in self.cycle)
        if abs(total - 1.0) > CYCLE_SHARE_TOLERANCE:
            raise ParameterError(
                f"wear.cycle: shares sum to {total:.6g}: must sum to 1 (within {CYCLE_SHARE_TOLERANCE})"
            )
        return self

    def cycle_shares(self) -> tuple[tuple[float, float], ...]:
        """(speed [km/h], share [-]) of the drive cycle, shares normalised to sum exactly 1."""
        total = math.fsum(entry.share for entry in self.cycle)
        return tuple((entry.speed_kmh, entry.share / total) for entry in self.cycle)


class StudyParameter(_Table):
    """One uncertain parameter of a global sensitivity study and its distribution."""

    key: str = Field(description='configuration key ("table.key") or "adhesion_scale"')
    low: float = Field(description="lower bound [key units]")
    high: float = Field(description="upper bound [key units]")
    distribution: Literal["uniform", "loguniform", "triangular", "normal"] = Field(
        "uniform", description="uniform, loguniform, triangular (peak at mode) or normal "
        "(mean, std; truncated to [low, high])"
    )
    mode: float | None = Field(None, description="peak of the triangular distribution [key units]")
    mean: float | None = Field(None, description="mean of the normal distribution [key units]")
    std: float | None = Field(None, description="standard deviation of the normal distribution [key units]")

    _to_float = field_validator("low", "high", "mode", "mean", "std", mode="before")(_number)

    @model_validator(mode="after")
    def _consistent(self) -> StudyParameter:
        where = f"study.parameters: {self.key}"
        fields = _study_fields()
        if self.key not in fields:
            raise ParameterError(f"{where}: unknown or non-numeric key (use a table.key of a float, or {ADHESION_SCALE})")
        if not self.low < self.high:
            raise ParameterError(f"{where}: low = {self.low!r} must be below high = {self.high!r}")
        rule = Annotated[(float, *fields[self.key].metadata)]
        for name in ("low", "high"):
            try:
                TypeAdapter(rule).validate_python(getattr(self, name))
            except ValidationError as exc:
                msg = exc.errors(include_url=False)[0]["msg"].lower().replace("input ", "")
                raise ParameterError(f"{where}: {name} = {getattr(self, name)!r}: {msg}") from None
        extras = {"triangular": ("mode",), "normal": ("mean", "std")}.get(self.distribution, ())
        for name in ("mode", "mean", "std"):
            if getattr(self, name) is not None and name not in extras:
                raise ParameterError(f"{where}: {name} is not used by distribution {self.distribution!r}")
        if self.mode is not None and not self.low <= self.mode < self.high:
            raise ParameterError(f"{where}: mode = {self.mode!r} must lie in [low, high)")
        if self.mean is not None and not self.low <= self.mean <= self.high:
            raise ParameterError(f"{where}: mean = {self.mean!r} must lie in [low, high]")
        if self.std is not None and not self.std > 0.0:
            raise ParameterError(f"{where}: std = {self.std!r} must be positive")
        if self.distribution == "loguniform" and not self.low > 0.0:
            raise ParameterError(f"{where}: loguniform needs low > 0 (low = {self.low!r})")
        return self


class StudySpec(_Table):
    """Global sensitivity study (polywear study): method, sample size, outputs, parameters.

    The ``[study]`` table of the parameter file (:func:`load_study`); not a field of
    :class:`Params`. Validated on construction, frozen.
    """

    method: Literal["sobol", "morris"] = Field("sobol", description="sobol (Saltelli sampling) or morris")
    outputs: Literal["hopf", "bifurcation"] = Field(
        "hopf", description="hopf: Hopf speeds, linear band width (ms per sample); bifurcation: first/second "
        "bifurcation speeds, SEV band width, largest amplitude in the operating range (continuation)"
    )
    n_base: int = Field(
        1024, description="base samples N (sobol: power of 2, N (2D + 2) runs) or trajectories (morris)"
    )
    second_order: bool = Field(True, description="sobol: also second-order indices (N (2D + 2) runs, else N (D + 2))")
    morris_levels: int = Field(4, description="morris: grid levels p")
    seed: int = Field(12345, description="seed of the sampling and the bootstrap (numpy SeedSequence)")
    bootstrap: int = Field(1000, description="bootstrap resamples for the confidence intervals")
    confidence: float = Field(0.95, description="confidence level of the intervals", gt=0.0, lt=1.0)
    speed_range_kmh: tuple[float, float] = Field(DEFAULT_SPEED_RANGE_KMH, description="speeds searched [km/h]")
    operating_range_kmh: tuple[float, float] = Field(
        DEFAULT_OPERATING_RANGE_KMH, description="operating speeds for the largest amplitude [km/h]"
    )
    parameters: tuple[StudyParameter, ...] = Field(
        (), description="uncertain parameters ([[study.parameters]]); none: the paper's seven, +-10 % uniform"
    )

    _to_int = field_validator("n_base", "morris_levels", "seed", "bootstrap", mode="before")(_integral)

    @field_validator("speed_range_kmh", "operating_range_kmh", mode="before")
    @classmethod
    def _pair(cls, value: Any) -> Any:
        return tuple(_number(v) for v in value) if isinstance(value, list) else value

    @field_validator("parameters", mode="before")
    @classmethod
    def _array_of_tables(cls, value: Any) -> Any:
        return tuple(value) if isinstance(value, list) else value

    @model_validator(mode="after")
    def _consistent(self) -> StudySpec:
        n = self.n_base
        if self.method == "sobol" and (n < 8 or n & (n - 1)):
            raise ParameterError(f"study.n_base = {n!r}: sobol needs a power of 2, at least 8")
        if self.method == "morris" and n < 4:
            raise ParameterError(f"study.n_base = {n!r}: morris needs at least 4 trajectories")
        if n > MAX_STUDY_BASE:
            raise ParameterError(f"study.n_base = {n!r}: at most {MAX_STUDY_BASE}")
        if self.morris_levels < 2:
            raise ParameterError(f"study.morris_levels = {self.morris_levels!r}: must be at least 2")
        if self.seed < 0:
            raise ParameterError(f"study.seed = {self.seed!r}: must be >= 0")
        if not 10 <= self.bootstrap <= MAX_BOOTSTRAP:
            raise ParameterError(f"study.bootstrap = {self.bootstrap!r}: must be between 10 and {MAX_BOOTSTRAP}")
        for name in ("speed_range_kmh", "operating_range_kmh"):
            lo, hi = getattr(self, name)
            if not 0.0 < lo < hi <= MAX_SPEED_KMH:
                raise ParameterError(f"study.{name} = [{lo!r}, {hi!r}]: need 0 < low < high <= {MAX_SPEED_KMH:g}")
        keys = [q.key for q in self.parameters]
        duplicates = sorted({k for k in keys if keys.count(k) > 1})
        if duplicates:
            raise ParameterError(f"study.parameters: {', '.join(duplicates)} given more than once")
        return self

    def with_updates(self, updates: dict[str, Any]) -> StudySpec:
        """A new study with ``{"key": value}`` updates (keys of the ``[study]`` table, e.g.
        ``"n_base"``), validated again; raises :class:`ParameterError` naming ``study.key``."""
        data = {**self.model_dump(), **updates}
        return _validate(_StudyFile, _coerce_numbers({"study": data})).study


class Params(_Table):
    """A complete, validated parameter set (every key: docs/model.md, "Configuration keys")."""

    model: Literal["tread1dof", "axle4dof"] = Field(
        "tread1dof", description='model: "tread1dof" or "axle4dof"'
    )
    operating: Operating = Operating()
    tread: Tread = Tread()
    friction: Friction = Friction()
    axle: Axle = Axle()
    tire: Tire = Tire()
    wear: Wear = Wear()

    def with_updates(self, updates: dict[str, Any]) -> Params:
        """A new parameter set with ``{"table.key": value}`` updates, validated again.

        Same as :func:`polywear.params.with_updates`; raises :class:`ParameterError`.
        """
        return with_updates(self, updates)


class _StudyFile(_Table):
    """The ``[study]`` table alone: validation errors are located at ``study.key``."""

    study: StudySpec = StudySpec()


_TABLES: dict[str, type[_Table]] = {
    name: field.annotation  # type: ignore[misc]
    for name, field in Params.model_fields.items()
    if name != "model"
}
STUDY_TABLE = "study"
"""Name of the parameter file's table read by :func:`load_study`."""


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


def _no_study_keys(keys: Iterable[str]) -> None:
    """``study.*`` keys set the study (:func:`load_study`), not the parameters."""
    for key in keys:
        if key.split(".", 1)[0] == STUDY_TABLE:
            raise ParameterError(
                f"{key}: a study setting, not a parameter (polywear study --set {key}=..., "
                "StudySpec.with_updates or load_study)"
            )


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
    _no_study_keys(updates)
    data = _merge(params.model_dump(), _nested(updates))
    return _validate(Params, _coerce_numbers(data))


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
