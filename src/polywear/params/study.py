"""The ``[study]`` table: a global sensitivity study (method, sample size, outputs, the
uncertain parameters and their distributions). It is no vehicle parameter: not a field
of :class:`~polywear.params.tables.Params`, changed through :meth:`StudySpec.with_updates`.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import Field, TypeAdapter, ValidationError, field_validator, model_validator

from ..units import DEFAULT_OPERATING_RANGE_KMH, DEFAULT_SPEED_RANGE_KMH, MAX_SPEED_KMH
from .checks import ParameterError, _coerce_numbers, _integral, _number, _Table, _tuple, _validate
from .tables import _TABLES, ADHESION_SCALE, DERIVED_FIELDS

MAX_STUDY_BASE = 65536
"""Largest study.n_base (sobol: N (2D + 2) runs, already about a million for D = 7)."""
MAX_BOOTSTRAP = 100_000
"""Most bootstrap resamples of a study."""


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

    _to_tuple = field_validator("parameters", mode="before")(_tuple)

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


class _StudyFile(_Table):
    """The ``[study]`` table alone: validation errors are located at ``study.key``."""

    study: StudySpec = StudySpec()
