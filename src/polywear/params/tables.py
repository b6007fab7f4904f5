"""The vehicle's parameter tables (operating point, tread, friction, axle, tire, wear) and
:class:`Params`, the complete set; changed only through :func:`with_updates`, which
validates the result again.

Every configuration key is a field of a frozen pydantic model, with its unit in the
name and the description.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any, Literal

from pydantic import BaseModel, Field, field_validator, model_validator

from ..units import MAX_SPEED_KMH
from .checks import ParameterError, _coerce_numbers, _f, _integral, _merge, _nested, _number, _Table, _tuple, _validate


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

    _to_tuple = field_validator("cycle", mode="before")(_tuple)

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


_TABLES: dict[str, type[_Table]] = {
    name: field.annotation  # type: ignore[misc]
    for name, field in Params.model_fields.items()
    if name != "model"
}
STUDY_TABLE = "study"
"""Name of the parameter file's table read by :func:`load_study`."""


def _no_study_keys(keys: Iterable[str]) -> None:
    """``study.*`` keys set the study (:func:`load_study`), not the parameters."""
    for key in keys:
        if key.split(".", 1)[0] == STUDY_TABLE:
            raise ParameterError(
                f"{key}: a study setting, not a parameter (polywear study --set {key}=..., "
                "StudySpec.with_updates or load_study)"
            )


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
