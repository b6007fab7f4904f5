"""Tyre property files (``.tir``, TeimOrbit format) in: read them and map what they determine.

A ``.tir`` file holds a Magic Formula (MF) tyre model (MF-Tyre 5.2, 6.1, 6.2), read by
:func:`~polywear.measured.tir_file.read_tir`. :func:`tir_parameters` evaluates the few
quantities polywear's models use at the operating point (load, camber, speed) and says
where each one came from; everything else stays at its default. :func:`load_with_tir` resolves a complete parameter set: defaults, the .tir
values, the TOML file, ``--set`` overrides, in that order. The mapping and its assumptions
are written down in ``docs/tir.md``.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from ..keys import KEYS, KeyInfo, study_keys
from ..params import Params, flat_items, get_value, load_params, parse_override
from ..results import Result
from ..units import kmh_to_ms
from .tir_file import UNIT_KIND, TirError, TirFile, read_tir

__all__ = ["TirMapping", "TirParameterSet", "tir_parameters", "user_keys", "load_with_tir"]





@dataclass(frozen=True)
class TirMapping:
    """polywear values determined by a .tir file at one operating point.

    Attributes
    ----------
    values : dict
        ``{"table.key": value}`` in polywear units.
    sources : dict
        ``"table.key"`` -> the tir key(s) and formula it came from.
    conditions : dict
        Operating point used: load [N], camber [deg], speed [km/h], inflation pressure [Pa].
    notes : list of str
        Assumptions and everything the parser noticed.
    """

    tir: TirFile
    values: dict[str, float]
    sources: dict[str, str]
    conditions: dict[str, float]
    notes: tuple[str, ...] = field(default=())


def _put(values: dict, sources: dict, key: str, value: float, source: str, known: set[str]) -> None:
    if key in known:
        values[key] = float(value)
        sources[key] = source


_FILE_FIELDS = {"FNOMIN": "operating.vertical_load_n", "UNLOADED_RADIUS": "operating.rolling_radius_m"}
"""File fields held to the bounds of the key they stand for (docs/model.md section 6): a
nominal load is a wheel load, a free radius a tire's radius."""

_UNIT_HINT = {"force": "FORCE", "length": "LENGTH", "mass": "MASS", "pressure": "PRESSURE",
              "stiffness": "FORCE, LENGTH", "damping": "FORCE, LENGTH", "speed": "LENGTH"}


def _within(info: KeyInfo, value: float) -> bool:
    """True when ``value`` keeps the validation bounds of the key ``info``."""
    low = value >= info.lower if info.lower_inclusive else value > info.lower
    high = value <= info.upper if info.upper_inclusive else value < info.upper
    return math.isfinite(value) and low and high


def _bounds(info: KeyInfo) -> str:
    """``"0.15 to 0.8 m"``: the plausible range of a key, as said in an error."""
    return f"{info.lower:g} to {info.upper:g} {info.unit}"


def _check_field(tir: TirFile, name: str, key: str) -> None:
    """A :class:`TirError` naming the file's field ``name`` when its SI value is outside
    what a tire can be (the bounds of ``key``), with a hint at the file's ``[UNITS]``."""
    value = tir.number(name)
    info = KEYS[key]
    if value is None or _within(info, value):
        return
    entry = tir.find(name)
    units = _UNIT_HINT.get(UNIT_KIND.get(name, ""), "")
    hint = f": check the [UNITS] of the file ({units})" if units else ""
    raise TirError(f"{tir.path}: {name} = {entry.value:g} (line {entry.line}) is {value:g} {info.unit}, "
                   f"not what a tire can be ({_bounds(info)}, the bounds of {key}){hint}")


def _check_mapped(mapping: TirMapping) -> None:
    """A :class:`TirError` when a value the file determines is outside its key's bounds,
    naming the file's fields it came from (a value from the file, not a default)."""
    for key, value in mapping.values.items():
        info = KEYS.get(key)
        if info is not None and not _within(info, value):
            raise TirError(f"{mapping.tir.path}: {key} = {value:.4g} {info.unit} from the file's "
                           f"{mapping.sources[key]}: not what a tire can be ({_bounds(info)})")


def tir_parameters(
    tir: TirFile,
    *,
    load_n: float | None = None,
    camber_deg: float = 0.0,
    speed_kmh: float = 0.0,
    coulomb_ratio: float | None = None,
    belt_mode: bool = False,
) -> TirMapping:
    """Evaluate what the file determines at the operating point.

    Parameters
    ----------
    tir : TirFile
    load_n : float, optional
        Vertical load F_z [N]; default the file's ``FNOMIN`` (which also becomes
        ``operating.vertical_load_n``).
    camber_deg : float
        Camber angle [deg] for the camber dependence of the peak friction (``PDY3``).
    speed_kmh : float
        Speed [km/h] for the speed term of the free rolling radius (``Q_V1``).
    coulomb_ratio : float, optional
        mu_c / mu_s kept from the parameter set without the file; the MF model has no
        Stribeck velocity law, so only the peak level is determined. None: mu_c not set.
    belt_mode : bool
        Also map the belt's lateral mode (``BELT_MASS``, ``FREQ_LAT`` or
        ``LATERAL_STIFFNESS``, ``DAMP_LAT``) onto the tread oscillator (``tread.*``). Off by
        default: the rigid-ring belt mode (40-80 Hz) is not the 100-150 Hz tread mode of
        the models; the values are then only reported in the notes.

    Returns
    -------
    TirMapping
    """
    known = set(study_keys())
    values: dict[str, float] = {}
    sources: dict[str, str] = {}
    notes = list(tir.notes)
    num = tir.number
    mf6 = tir.family != "MF 5.2"

    fz0 = num("FNOMIN")
    r0 = num("UNLOADED_RADIUS")
    if fz0 is None or fz0 <= 0.0:
        raise TirError(f"{tir.path}: FNOMIN (nominal load) missing or not positive: needed for every load-dependent value")
    for name, key in _FILE_FIELDS.items():
        _check_field(tir, name, key)
    fz = fz0 if load_n is None else float(load_n)
    if load_n is None:
        _put(values, sources, "operating.vertical_load_n", fz0, "FNOMIN", known)
    lfzo = num("LFZO", 1.0)
    fz0s = fz0 * lfzo
    dfz = (fz - fz0s) / fz0s
    p0 = num("NOMPRES")
    pi = num("INFLPRES", p0)
    dpi = (pi - p0) / p0 if mf6 and p0 else 0.0
    conditions = {"load_n": fz, "camber_deg": camber_deg, "speed_kmh": speed_kmh, "pressure_pa": pi or math.nan}

    cz0 = num("VERTICAL_STIFFNESS")
    cz = None
    if cz0 is not None:
        cz = cz0 * num("LCZ", 1.0) * (1.0 + num("PFZ1", 0.0) * dpi)
        _put(values, sources, "tire.vertical_stiffness_n_per_m", cz,
             "VERTICAL_STIFFNESS" + (" * LCZ * (1 + PFZ1 dpi)" if mf6 else " * LCZ"), known)
        if num("Q_FZ2", 0.0):
            notes.append("Q_FZ2 (progressive vertical stiffness) ignored: the linear VERTICAL_STIFFNESS is used")
    cz_damp = num("VERTICAL_DAMPING")
    if cz_damp is not None:
        _put(values, sources, "tire.vertical_damping_ns_per_m", cz_damp, "VERTICAL_DAMPING", known)

    if r0 is not None and cz is not None and tir.has("BREFF", "DREFF", "FREFF"):
        v0 = num("LONGVL", 16.7)
        v = kmh_to_ms(speed_kmh)
        omega_r0_v0 = v / v0  # Omega R0 / V0 with Omega ~ V / R0
        r_omega = r0 * (num("Q_RE0", 1.0) + num("Q_V1", 0.0) * omega_r0_v0**2)
        rho = fz / fz0
        re = r_omega - fz0 / cz * (num("DREFF") * math.atan(num("BREFF") * rho) + num("FREFF") * rho)
        _put(values, sources, "operating.rolling_radius_m", re,
             "UNLOADED_RADIUS, Q_RE0, Q_V1, LONGVL, BREFF, DREFF, FREFF, FNOMIN, VERTICAL_STIFFNESS", known)
    elif r0 is not None:
        notes.append("no BREFF/DREFF/FREFF: operating.rolling_radius_m not set (UNLOADED_RADIUS is the free radius, "
                     "not the effective rolling radius)")

    if tir.has("PDY1"):
        gamma = math.radians(camber_deg)
        lmuy = num("LMUY", 1.0)
        if mf6:
            camber_term = 1.0 - num("PDY3", 0.0) * math.sin(gamma) ** 2
            pressure_term = 1.0 + num("PPY3", 0.0) * dpi + num("PPY4", 0.0) * dpi**2
            formula = "|PDY1 + PDY2 dfz| (1 + PPY3 dpi + PPY4 dpi^2) (1 - PDY3 sin^2 gamma) LMUY"
        else:
            camber_term = 1.0 - num("PDY3", 0.0) * (gamma * num("LGAY", 1.0)) ** 2
            pressure_term = 1.0
            formula = "|PDY1 + PDY2 dfz| (1 - PDY3 (gamma LGAY)^2) LMUY"
        level = num("PDY1") + num("PDY2", 0.0) * dfz
        if num("PDY1") < 0.0:
            notes.append("PDY1 < 0 (this file's sign convention for Fy): the magnitude is the friction level")
        mu = abs(level) * pressure_term * camber_term * lmuy
        if not mu > 0.0:
            raise TirError(f"{tir.path}: peak lateral friction at {fz:g} N evaluates to {mu:g} (PDY1, PDY2, LMUY)")
        _put(values, sources, "friction.mu_static", mu, formula + ", dfz = (Fz - LFZO FNOMIN)/(LFZO FNOMIN)", known)
        large_slip = math.sin(num("PCY1") * num("LCY", 1.0) * math.pi / 2.0) if tir.has("PCY1") else None
        if large_slip is not None and 0.0 < large_slip <= 1.0:
            _put(values, sources, "friction.mu_coulomb", large_slip * mu,
                 "mu_static sin(PCY1 LCY pi/2) (the MF force at large slip: full sliding)", known)
        elif coulomb_ratio is not None:
            if large_slip is not None:
                notes.append(f"PCY1: large-slip level sin(PCY1 LCY pi/2) = {large_slip:.3f} not in (0, 1]: not used")
            _put(values, sources, "friction.mu_coulomb", coulomb_ratio * mu,
                 f"mu_static * {coulomb_ratio:.4g} (ratio mu_c/mu_s of the set without the file)", known)
    else:
        notes.append("no PDY1 (peak lateral friction) in the file: friction.mu_static and friction.mu_coulomb "
                     "are not from the file (the defaults, or the config's and --set values, stand)")

    if tir.has("PKY1", "PKY2"):
        conditions["cornering_stiffness_n_per_rad"] = _cornering_stiffness(tir, fz, fz0s, math.radians(camber_deg), dpi)
    _map_structure(tir, values, sources, notes, known if belt_mode else set(), dfz, dpi)
    _map_contact(tir, values, sources, notes, known, fz, fz0, cz, r0, mf6)
    return TirMapping(tir, values, sources, conditions, tuple(notes))


CORNERING_SOURCE = "PKY1, PKY2 (PKY3, PKY4, PKY5, PPY1, PPY2, LKY), FNOMIN, LFZO: the file's cornering stiffness"


def _cornering_stiffness(tir: TirFile, fz: float, fz0s: float, gamma: float, dpi: float) -> float:
    """MF cornering stiffness K_ya [N/rad] at the load ``fz`` [N] (magnitude; ``fz0s`` = LFZO FNOMIN).

    MF 5.2: ``PKY1 Fz0' sin(2 atan(Fz/(PKY2 Fz0'))) (1 - PKY3 |gamma|) LKY``; MF 6.x:
    ``PKY1 Fz0' (1 + PPY1 dpi) (1 - PKY3 |gamma|) sin(PKY4 atan(Fz/((PKY2 + PKY5 gamma^2)(1 + PPY2 dpi) Fz0'))) LKY``."""
    num = tir.number
    if tir.family == "MF 5.2":
        kya = num("PKY1") * fz0s * math.sin(2.0 * math.atan(fz / (num("PKY2") * fz0s))) * (1.0 - num("PKY3", 0.0) * abs(gamma))
    else:
        den = (num("PKY2") + num("PKY5", 0.0) * gamma**2) * (1.0 + num("PPY2", 0.0) * dpi) * fz0s
        kya = (num("PKY1") * fz0s * (1.0 + num("PPY1", 0.0) * dpi) * (1.0 - num("PKY3", 0.0) * abs(gamma))
               * math.sin(num("PKY4", 2.0) * math.atan(fz / den)))
    kya = abs(kya * num("LKY", 1.0))
    if not (math.isfinite(kya) and kya > 0.0):
        raise TirError(f"{tir.path}: cornering stiffness at {fz:g} N evaluates to {kya:g} N/rad (PKY1, PKY2)")
    return kya


BRISTLE_RATIO = 50.0
"""With a .tir file and the patch contact, the LuGre bristle's stiffness sigma0 is set so that
the bristle alone (rigid tread) would have this many times the file's cornering stiffness:
the bristle is the micro-slip of the rubber on the road (2 % of the patch's lateral
compliance), the tread elements carry the rest (docs/tir.md)."""

PATCH_SOURCES = {
    "friction.patch_pressure": "uniform: a Magic Formula leaves the line K_ya alpha as alpha^3, without the "
                               "sliding at the trailing edge that a pressure vanishing there has at any slip",
    "friction.sigma0_per_m": f"{BRISTLE_RATIO:g} K_ya / (Fz a), a = half the contact length: the bristle is the "
                             "rubber-road micro-slip, stiff against the tread (" + CORNERING_SOURCE + ")",
    "tread.lateral_stiffness_n_per_m": CORNERING_SOURCE + ", through the patch model",
}
"""Sources of the keys the cornering stiffness sets with the patch contact."""


def _patch_shape(params: Params, c_alpha: float, given: set[str]) -> dict:
    """Pressure distribution and bristle stiffness sigma0 [1/m] of the patch contact with a
    .tir file's cornering stiffness ``c_alpha`` [N/rad], for the keys the user does not give.

    Uniform pressure: the file's Magic Formula departs from ``K_ya alpha`` as alpha^3, while a
    pressure that vanishes at the trailing edge (parabolic) slides there at any slip and falls
    below the line as ``K_ya alpha / (3 mu Fz)`` (brush theory: 1.8 % at 0.2 deg, 3000 N).
    A stiff bristle (:data:`BRISTLE_RATIO`): LuGre's bristle creeps in proportion to the
    friction it uses, so a bristle that carries the patch's compliance (the default
    sigma0 = 400 /m carries 80 % of it) bends the force from the smallest slip on."""
    shape: dict = {}
    if "friction.patch_pressure" not in given:
        shape["friction.patch_pressure"] = "uniform"
    if "friction.sigma0_per_m" not in given:
        half_length = 0.5 * params.tire.contact_length_m
        shape["friction.sigma0_per_m"] = BRISTLE_RATIO * c_alpha / (params.operating.vertical_load_n * half_length)
    return shape


def _patch_stiffness(params: Params, c_alpha: float) -> float | None:
    """Tread lateral stiffness k [N/m] whose patch contact has the cornering stiffness
    ``c_alpha`` [N/rad] at the operating speed and load (the other keys as they are);
    None when even a rigid tread (the key's upper bound, at most 1e10 N/m) stays below it
    (the bristle limits it)."""
    from scipy.optimize import brentq

    from ..models.patch import steady_lateral_force

    info = KEYS["tread.lateral_stiffness_n_per_m"]
    lowest, highest = max(1.0e3, info.lower), min(1.0e10, info.upper)

    def stiffness(log_k: float) -> float:
        return min(max(math.exp(log_k), lowest), highest)

    def excess(log_k: float) -> float:
        trial = params.with_updates({"tread.lateral_stiffness_n_per_m": stiffness(log_k)})
        return steady_lateral_force(trial, [])["cornering_stiffness_n_per_rad"] - c_alpha

    lo, hi = math.log(lowest), math.log(highest)
    if excess(hi) < 0.0:
        return None
    return stiffness(brentq(excess, lo, hi, xtol=1e-10, rtol=1e-12))


def _map_structure(tir, values, sources, notes, known, dfz, dpi) -> None:
    """Belt lateral mode -> the lateral tread oscillator (mass, stiffness, damping)."""
    num = tir.number
    mass = num("BELT_MASS")
    if mass is None:
        if tir.has("FREQ_LAT") or tir.has("LATERAL_STIFFNESS"):
            notes.append("lateral structure keys without BELT_MASS: tread.* not set")
        return
    if tir.has("FREQ_LAT"):
        k = mass * (2.0 * math.pi * num("FREQ_LAT")) ** 2
        k_source = "BELT_MASS (2 pi FREQ_LAT)^2"
    elif tir.has("LATERAL_STIFFNESS"):
        k = num("LATERAL_STIFFNESS") * (1.0 + num("PCFY1", 0.0) * dfz + num("PCFY2", 0.0) * dfz**2) * (
            1.0 + num("PCFY3", 0.0) * dpi)
        k_source = "LATERAL_STIFFNESS (1 + PCFY1 dfz + PCFY2 dfz^2)(1 + PCFY3 dpi)"
    else:
        notes.append("BELT_MASS without FREQ_LAT or LATERAL_STIFFNESS: tread.* not set")
        return
    c = 2.0 * num("DAMP_LAT", 0.0) * math.sqrt(k * mass)
    if not known:
        notes.append(f"belt lateral mode in the file ({k_source}, DAMP_LAT: "
                     f"m = {mass:.4g} kg, k = {k:.4g} N/m, c = {c:.4g} N s/m, "
                     f"{math.sqrt(k / mass) / (2 * math.pi):.1f} Hz): not applied to tread.* (belt mode option)")
        return
    _put(values, sources, "tread.mass_kg", mass, "BELT_MASS", known)
    _put(values, sources, "tread.lateral_stiffness_n_per_m", k, k_source, known)
    if tir.has("DAMP_LAT"):
        _put(values, sources, "tread.lateral_damping_ns_per_m", c, "2 DAMP_LAT sqrt(k m)", known)
    notes.append("tread.* from the belt's lateral mode (MF-Swift rigid ring): an assumption, see docs/tir.md")


def _map_contact(tir, values, sources, notes, known, fz, fz0, cz, r0, mf6) -> None:
    """Contact patch length 2a and width 2b where the file gives their coefficients."""
    num = tir.number
    wanted = [k for k in ("tire.contact_length_m", "tire.tread_width_m") if k not in known]
    if mf6 and r0 is not None and cz is not None and tir.has("Q_RA1", "Q_RA2"):
        rho = fz / (cz * r0)
        half_length = r0 * (num("Q_RA2") * rho + num("Q_RA1") * math.sqrt(rho))
        _put(values, sources, "tire.contact_length_m", 2.0 * half_length,
             "2 R0 (Q_RA2 rho + Q_RA1 sqrt(rho)), rho = Fz/(Cz R0)", known)
        if tir.has("Q_RB1", "Q_RB2", "WIDTH"):
            half_width = num("WIDTH") * (num("Q_RB2") * rho + num("Q_RB1") * rho ** (1.0 / 3.0))
            _put(values, sources, "tire.tread_width_m", 2.0 * half_width,
                 "2 WIDTH (Q_RB2 rho + Q_RB1 rho^(1/3))", known)
    elif not mf6 and r0 is not None and tir.has("Q_A1", "Q_A2"):
        half_length = r0 * (num("Q_A2") * fz / fz0 + num("Q_A1") * math.sqrt(fz / fz0))
        _put(values, sources, "tire.contact_length_m", 2.0 * half_length,
             "2 R0 (Q_A2 Fz/FNOMIN + Q_A1 sqrt(Fz/FNOMIN))", known)
    if wanted and any(tir.has(k) for k in ("Q_RA1", "Q_A1")):
        notes.append(f"contact patch in the file, but this polywear has no key {', '.join(wanted)}")


def _condition(params: Any) -> dict[str, float]:
    """The operating point of a parameter set that the .tir values depend on."""
    return {"camber_deg": params.operating.camber_deg, "speed_kmh": params.operating.speed_kmh,
            "coulomb_ratio": params.friction.mu_coulomb / params.friction.mu_static}


def user_keys(config: str | Path | None, sets: list[str] | tuple[str, ...] = ()) -> set[str]:
    """``"table.key"`` of every value the TOML file and ``--set`` give (the file is read
    and checked by :func:`~polywear.params.load_params` first)."""
    import tomllib

    keys: set[str] = set()
    if config is not None:
        for table, body in tomllib.loads(Path(config).read_text(encoding="utf-8")).items():
            keys |= {f"{table}.{key}" for key in body} if isinstance(body, dict) else {table}
    return keys | {parse_override(item)[0] for item in sets}


@dataclass(frozen=True)
class TirParameterSet(Result):
    """:func:`load_with_tir`'s answer: the parameter set and where each of its values came from."""

    file: str
    """The .tir file as given."""
    params: Params
    mapping: TirMapping
    """What the file determines at the operating point (``mapping.tir`` is the parsed file)."""
    config_keys: frozenset[str] = frozenset()
    """Keys the TOML file gives (they override the file)."""
    set_keys: frozenset[str] = frozenset()
    """Keys the ``--set`` overrides give."""

    def sources(self) -> list[dict]:
        """Per key (model, then table order): value, source (``"file: ..."``, ``"--config"``,
        ``"--set"`` or ``"default"``) and whether the file's value stands."""
        rows = []
        for key, value, _ in flat_items(self.params):
            if isinstance(value, tuple):
                continue
            user = "--set" if key in self.set_keys else "--config" if key in self.config_keys else None
            tir_source = self.mapping.sources.get(key)
            if user and tir_source:
                source = f"{user} (overrides the file: {tir_source})"
            else:
                source = user or (f"file: {tir_source}" if tir_source else "default")
            rows.append({"key": key, "value": value, "source": source,
                         "from_file": tir_source is not None and not user})
        return rows

    def file_values(self) -> list[dict]:
        """Every value of the file (``[UNITS]`` aside) and what polywear does with it: ``"used"``
        (in the formula of a value it sets), ``"noted"`` (reported in a note only) or
        ``"ignored"``; file order."""
        used = " ".join(self.mapping.sources.values())
        if "dpi" in used:
            used += " NOMPRES INFLPRES"  # dpi = (INFLPRES - NOMPRES)/NOMPRES
        noted = " ".join(self.mapping.notes)
        rows = []
        for section, entries in self.mapping.tir.entries.items():
            if section == "UNITS":
                continue
            for entry in sorted(entries.values(), key=lambda e: e.line):
                word = re.compile(rf"\b{re.escape(entry.key)}\b")
                use = "used" if word.search(used) else "noted" if word.search(noted) else "ignored"
                rows.append({"key": entry.key, "section": section, "value": entry.value, "line": entry.line, "use": use})
        return sorted(rows, key=lambda r: r["line"])

    def summary(self) -> dict:
        """File, format, operating point, every key's value and source, notes, and every value
        of the file with its use (``polywear params from-tir --json``)."""
        return {
            "file": self.file,
            "format": self.mapping.tir.family,
            "format_declared": self.mapping.tir.format_label,
            "conditions": {k: v if math.isfinite(v) else None for k, v in self.mapping.conditions.items()},
            "parameters": self.sources(),
            "notes": list(self.mapping.notes),
            "file_values": self.file_values(),
        }

    def to_dataframe(self):
        """pandas DataFrame: one row per key (value, source, from_file)."""
        import pandas as pd

        return pd.DataFrame(self.sources())

    def _dataset(self):
        """The table of :meth:`to_dataframe` along ``row``."""
        return self._table_dataset()

    def plot(self, ax=None):
        """Relative change from the defaults of every value the file sets (bars). Returns artists."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(7, 4))
        defaults = Params()
        changes = [(r["key"], r["value"] / get_value(defaults, r["key"]) - 1.0) for r in self.sources()
                   if r["from_file"] and isinstance(r["value"], float) and get_value(defaults, r["key"])]
        if not changes:
            return [ax.text(0.5, 0.5, "the file sets no value", ha="center", va="center", transform=ax.transAxes)]
        keys, rel = zip(*changes)
        artists = list(ax.barh(range(len(keys)), [100.0 * r for r in rel], color="C0"))
        ax.set_yticks(range(len(keys)), keys, fontsize=8)
        ax.axvline(0.0, color="k", lw=0.5)
        ax.set_xlabel("change from the default [%]")
        ax.set_title(f"{Path(self.file).name}: values from the file ({self.mapping.tir.family})", fontsize=10)
        return artists


def load_with_tir(
    tir_path: str | Path,
    config: str | Path | None = None,
    sets: list[str] | tuple[str, ...] = (),
    belt_mode: bool = False,
) -> TirParameterSet:
    """Defaults, then the .tir values, then the TOML file, then ``--set`` overrides.

    The file's values are evaluated at the resolved operating point: the user's load if
    the TOML file or ``--set`` gives one (else ``FNOMIN``), camber and speed. Where the
    user gives ``friction.mu_static``, the file does not set ``friction.mu_coulomb``
    either (the user's ratio stands).

    Returns
    -------
    TirParameterSet
        The parameters (``.params``), the file's mapping (``.mapping``) and each key's source.
    """
    tir = read_tir(tir_path)
    plain = load_params(config, sets)
    given = user_keys(config, sets)
    load_n = plain.operating.vertical_load_n if "operating.vertical_load_n" in given else None
    try:
        mapping = tir_parameters(tir, load_n=load_n, belt_mode=belt_mode, **_condition(plain))
    except TirError:
        raise
    except (ArithmeticError, ValueError) as exc:  # e.g. 1e159 squared, or a math domain error
        raise TirError(f"{tir.path}: the file's values are out of range for the Magic Formula at the operating "
                       f"point ({exc})") from None
    _check_mapped(mapping)
    if "friction.mu_static" in given:
        drop = "friction.mu_coulomb"
        mapping = replace(mapping, values={k: v for k, v in mapping.values.items() if k != drop},
                          sources={k: v for k, v in mapping.sources.items() if k != drop})
    base = {key: value for key, value in mapping.values.items() if key not in given}
    params = load_params(config, sets, base=base)
    c_alpha = mapping.conditions.get("cornering_stiffness_n_per_rad")
    stiffness = "tread.lateral_stiffness_n_per_m"
    if c_alpha is not None:
        note = None
        if params.friction.contact != "patch":
            note = (f"cornering stiffness {c_alpha / 1e3:.4g} kN/rad at {mapping.conditions['load_n']:g} N "
                    "(PKY1, PKY2): used by the patch contact only (friction.contact = patch)")
        elif stiffness in given or stiffness in mapping.values:
            note = f"cornering stiffness {c_alpha / 1e3:.4g} kN/rad not mapped: {stiffness} is given"
        else:
            shape = _patch_shape(params, c_alpha, given)
            params = load_params(config, sets, base={**base, **shape})
            k = _patch_stiffness(params, c_alpha)
            if k is None:
                note = (f"cornering stiffness {c_alpha / 1e3:.4g} kN/rad: above what the patch reaches with a rigid "
                        "tread (raise friction.sigma0_per_m or tire.contact_length_m): tread.* not set")
                params = load_params(config, sets, base=base)
            else:
                shape[stiffness] = k
                mapping = replace(mapping, values={**mapping.values, **shape},
                                  sources={**mapping.sources, **{key: PATCH_SOURCES[key] for key in shape}})
                params = load_params(config, sets, base={**base, **shape})
        if note:
            mapping = replace(mapping, notes=(*mapping.notes, note))
    return TirParameterSet(str(tir_path), params, mapping,
                           frozenset(user_keys(config)), frozenset(user_keys(None, sets)))
