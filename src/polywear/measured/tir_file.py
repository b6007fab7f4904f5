"""Tyre property files (``.tir``, TeimOrbit format): read the text as real files are written.

A ``.tir`` file holds a Magic Formula (MF) tyre model: MF-Tyre 5.2 (``MF_05``, ``PAC2002``),
MF-Tyre/MF-Swift 6.1 and 6.2. :func:`read_tir` parses sections, ``$``/``!`` comments,
quoted strings, ``{...}`` tables, CRLF, duplicate keys, keys in unexpected sections, any
case, Fortran ``D`` exponents and a ``[UNITS]`` section into a :class:`TirFile`; what the
values mean for polywear is :mod:`.tir`'s job.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

from ..errors import InputError
from ..params import ParameterError

__all__ = ["TirError", "TirEntry", "TirFile", "read_tir", "UNIT_KIND"]


class TirError(InputError, ParameterError):
    """The file is not a readable tyre property file, or lacks what is needed (one line)."""


@dataclass(frozen=True)
class TirEntry:
    """One ``KEY = value`` line: value (float or str), section and 1-based line number."""

    key: str
    value: float | str
    section: str
    line: int


@dataclass(frozen=True)
class TirFile:
    """A parsed tyre property file.

    Attributes
    ----------
    path : Path
    family : str
        ``"MF 5.2"`` (MF_05, PAC2002, FITTYP 5/6/21), ``"MF 6.1"`` or ``"MF 6.2"``.
    format_label : str
        What the file says: ``PROPERTY_FILE_FORMAT`` and/or ``FITTYP``.
    entries : dict
        Section -> upper-case key -> :class:`TirEntry` (the last occurrence when a key
        repeats within a section). Look keys up with :meth:`find`, which also finds a key
        outside its usual section.
    tables : dict
        Section -> (column names, rows) for ``{...}`` tables such as ``[SHAPE]``.
    notes : list of str
        What the parser noticed: duplicate keys, keys outside their usual section, skipped lines.
    """

    path: Path
    family: str
    format_label: str
    entries: dict[str, dict[str, TirEntry]]
    tables: dict[str, tuple[tuple[str, ...], tuple[tuple[float, ...], ...]]]
    notes: tuple[str, ...] = ()

    def find(self, key: str) -> TirEntry | None:
        """The entry of ``key``: in its usual section, else the last one in any other
        section except ``[UNITS]`` (:func:`read_tir` notes such keys)."""
        key = key.upper()
        home = self.entries.get(_HOME.get(key, ""), {})
        if key in home:
            return home[key]
        found = [sec[key] for name, sec in self.entries.items() if key in sec and name != "UNITS"]
        return max(found, key=lambda e: e.line) if found else None

    def number(self, key: str, default: float | None = None) -> float | None:
        """The numeric value of ``key`` in SI units (see ``[UNITS]``), or ``default``."""
        entry = self.find(key)
        if entry is None:
            return default
        if not isinstance(entry.value, float):
            raise TirError(f"{self.path}: {entry.key} = {entry.value!r} (line {entry.line}): expected a number")
        return entry.value * self._unit_factor(key.upper())

    def has(self, *keys: str) -> bool:
        """True when every key is present."""
        return all(self.find(k) is not None for k in keys)

    def _unit_factor(self, key: str) -> float:
        length, force, mass, pressure = (self._units.get(q, 1.0) for q in ("LENGTH", "FORCE", "MASS", "PRESSURE"))
        kind = UNIT_KIND.get(key)
        return {
            None: 1.0,
            "length": length,
            "force": force,
            "mass": mass,
            "pressure": pressure,
            "stiffness": force / length,
            "damping": force / length,  # time is always seconds (checked in read_tir)
            "speed": length,
        }[kind]

    @property
    def _units(self) -> dict[str, float]:
        return _unit_factors(self)


# Where each key is expected, for the "unexpected section" note; the key is found anywhere.
_HOME = {
    "FNOMIN": "VERTICAL", "VERTICAL_STIFFNESS": "VERTICAL", "VERTICAL_DAMPING": "VERTICAL",
    "BREFF": "VERTICAL", "DREFF": "VERTICAL", "FREFF": "VERTICAL", "Q_RE0": "VERTICAL", "Q_V1": "VERTICAL",
    "PFZ1": "VERTICAL", "UNLOADED_RADIUS": "DIMENSION", "WIDTH": "DIMENSION", "LONGVL": "MODEL",
    "NOMPRES": "OPERATING_CONDITIONS", "INFLPRES": "OPERATING_CONDITIONS",
    "PDY1": "LATERAL_COEFFICIENTS", "PDY2": "LATERAL_COEFFICIENTS", "PDY3": "LATERAL_COEFFICIENTS",
    "PPY3": "LATERAL_COEFFICIENTS", "PPY4": "LATERAL_COEFFICIENTS", "PCY1": "LATERAL_COEFFICIENTS",
    "PKY1": "LATERAL_COEFFICIENTS", "PKY2": "LATERAL_COEFFICIENTS", "PKY3": "LATERAL_COEFFICIENTS",
    "PKY4": "LATERAL_COEFFICIENTS", "PKY5": "LATERAL_COEFFICIENTS", "PPY1": "LATERAL_COEFFICIENTS",
    "PPY2": "LATERAL_COEFFICIENTS", "LKY": "SCALING_COEFFICIENTS",
    "LFZO": "SCALING_COEFFICIENTS", "LMUY": "SCALING_COEFFICIENTS", "LGAY": "SCALING_COEFFICIENTS",
    "LCZ": "SCALING_COEFFICIENTS", "LCY": "SCALING_COEFFICIENTS",
    "Q_RA1": "CONTACT_PATCH", "Q_RA2": "CONTACT_PATCH", "Q_RB1": "CONTACT_PATCH", "Q_RB2": "CONTACT_PATCH",
    "Q_A1": "VERTICAL", "Q_A2": "VERTICAL",
    "LATERAL_STIFFNESS": "STRUCTURAL", "FREQ_LAT": "STRUCTURAL", "DAMP_LAT": "STRUCTURAL",
    "PCFY1": "STRUCTURAL", "PCFY2": "STRUCTURAL", "PCFY3": "STRUCTURAL", "BELT_MASS": "INERTIA",
}

UNIT_KIND = {
    "FNOMIN": "force", "VERTICAL_STIFFNESS": "stiffness", "VERTICAL_DAMPING": "damping",
    "UNLOADED_RADIUS": "length", "WIDTH": "length", "LONGVL": "speed",
    "NOMPRES": "pressure", "INFLPRES": "pressure", "LATERAL_STIFFNESS": "stiffness", "BELT_MASS": "mass",
}

_UNIT_NAMES = {
    "LENGTH": {"meter": 1.0, "metre": 1.0, "m": 1.0, "mm": 1e-3, "millimeter": 1e-3, "millimetre": 1e-3,
               "cm": 1e-2, "centimeter": 1e-2, "km": 1e3, "inch": 0.0254, "in": 0.0254},
    "FORCE": {"newton": 1.0, "n": 1.0, "kn": 1e3, "kilonewton": 1e3, "kgf": 9.80665, "kg_force": 9.80665},
    "MASS": {"kg": 1.0, "kilogram": 1.0, "g": 1e-3, "gram": 1e-3, "tonne": 1e3},
    "TIME": {"second": 1.0, "sec": 1.0, "s": 1.0},
    "ANGLE": {"radian": 1.0, "radians": 1.0, "rad": 1.0},
    "PRESSURE": {"pascal": 1.0, "pa": 1.0, "kpa": 1e3, "bar": 1e5, "mpa": 1e6, "psi": 6894.757},
}


def _unit_factors(tir: TirFile) -> dict[str, float]:
    out = {}
    for quantity, names in _UNIT_NAMES.items():
        entry = tir.entries.get("UNITS", {}).get(quantity)
        if entry is None:
            continue
        name = str(entry.value).strip().lower()
        if name not in names:
            raise TirError(
                f"{tir.path}: [UNITS] {quantity} = {entry.value!r} (line {entry.line}) is not supported "
                f"(known: {', '.join(sorted(names))})"
            )
        out[quantity] = names[name]
    return out


_SECTION = re.compile(r"^\[\s*([A-Za-z0-9_]+)\s*\]$")
_ASSIGN = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)\s*=\s*(.*)$")
_NUMBER = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)([eEdD][+-]?\d+)?$")


def _strip_comment(text: str) -> str:
    """The line without a ``$`` or ``!`` comment (quotes respected)."""
    quote = None
    for i, ch in enumerate(text):
        if quote:
            if ch == quote:
                quote = None
        elif ch in "'\"":
            quote = ch
        elif ch in "$!":
            return text[:i]
    return text


def _value(raw: str) -> float | str:
    raw = raw.strip()
    if len(raw) >= 2 and raw[0] == raw[-1] and raw[0] in "'\"":
        return raw[1:-1]
    if _NUMBER.match(raw):
        return float(raw.replace("D", "E").replace("d", "e"))
    return raw


def _family(entries: dict[str, TirEntry], path: Path) -> tuple[str, str]:
    """MF family from PROPERTY_FILE_FORMAT and FITTYP (FITTYP wins when both say something);
    ``entries``: every key of the file, any section."""
    fmt = entries.get("PROPERTY_FILE_FORMAT")
    fit = entries.get("FITTYP")
    label = " / ".join(f"{e.key} = {e.value!r}" for e in (fmt, fit) if e is not None)
    if fit is not None:
        code = fit.value if isinstance(fit.value, float) else None
        by_fit = {5.0: "MF 5.2", 6.0: "MF 5.2", 21.0: "MF 5.2", 61.0: "MF 6.1", 62.0: "MF 6.2"}.get(code)
        if by_fit is None:
            raise TirError(f"{path}: FITTYP = {fit.value!r} (line {fit.line}) is not a known Magic Formula version "
                           "(5, 6, 21: MF 5.2; 61: MF 6.1; 62: MF 6.2)")
        return by_fit, label
    if fmt is not None:
        name = re.sub(r"[\s_.\-/]", "", str(fmt.value)).upper()  # "MF-Tyre 5.2" -> "MFTYRE52"
        version = re.search(r"MF(?:TYRE|SWIFT)*(\d+)", name)
        family = "MF 5.2" if "PAC2002" in name else None
        if version is not None:
            family = {"05": "MF 5.2", "5": "MF 5.2", "52": "MF 5.2", "6": "MF 6.1", "61": "MF 6.1",
                      "62": "MF 6.2"}.get(version.group(1))
        if family is not None:
            return family, label
        raise TirError(f"{path}: PROPERTY_FILE_FORMAT = {fmt.value!r} (line {fmt.line}) is not a Magic Formula "
                       "format polywear reads (MF_05, PAC2002, MF 6.1, MF 6.2; or give FITTYP)")
    # No declaration: pressure-dependence keys appear only from MF 6.1 on.
    return ("MF 6.1" if "NOMPRES" in entries else "MF 5.2"), "not declared"


def read_tir(path: str | Path) -> TirFile:
    """Parse a TeimOrbit tyre property file.

    Raises :class:`TirError` (one line) when the file cannot be read or is not a tyre
    property file: it must have ``[SECTION]`` headers and either ``FILE_TYPE = 'tir'``,
    a ``PROPERTY_FILE_FORMAT``/``FITTYP``, or ``UNLOADED_RADIUS``.
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise TirError(f"{path}: cannot read tyre property file ({exc.strerror})") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")
    if "\x00" in text:
        raise TirError(f"{path}: not a tyre property file (.tir): binary content")
    entries: dict[str, dict[str, TirEntry]] = {}
    tables: dict[str, tuple[tuple[str, ...], list[tuple[float, ...]]]] = {}
    notes: list[str] = []
    section = ""
    n_sections = 0
    for number, line in enumerate(text.splitlines(), start=1):  # \r\n, \r and \n alike
        stripped = line.strip()
        if not stripped or stripped[0] in "$!":
            continue
        match = _SECTION.match(_strip_comment(stripped).strip())
        if match:
            section = match.group(1).upper()
            n_sections += 1
            continue
        if stripped.startswith("{"):
            header = stripped.strip("{} \t").split()
            tables[section] = (tuple(h.lower() for h in header), [])
            continue
        body = _strip_comment(stripped).strip()
        if not body:
            continue
        assign = _ASSIGN.match(body)
        if assign:
            key = assign.group(1).upper()
            entry = TirEntry(key, _value(assign.group(2)), section, number)
            if isinstance(entry.value, float) and not math.isfinite(entry.value):
                raise TirError(f"{path}: {key} = {assign.group(2).strip()} (line {number}): not a finite number")
            previous = entries.setdefault(section, {}).get(key)
            if previous is not None:
                notes.append(f"{key} given twice in [{section}] (lines {previous.line} and {number}): "
                             f"line {number} used")
            entries[section][key] = entry
            continue
        if section in tables:
            try:
                tables[section][1].append(tuple(float(v.replace("D", "E").replace("d", "e")) for v in body.split()))
                continue
            except ValueError:
                pass
        notes.append(f"line {number} skipped (not KEY = value): {body[:40]!r}")
    every = {key: e for sec in entries.values() for key, e in sec.items()}
    looks_like_tir = (
        n_sections > 0
        and (str(getattr(every.get("FILE_TYPE"), "value", "")).lower() == "tir"
             or any(k in every for k in ("PROPERTY_FILE_FORMAT", "FITTYP", "UNLOADED_RADIUS")))
    )
    if not looks_like_tir:
        raise TirError(f"{path}: not a tyre property file (.tir): no [SECTION] with FILE_TYPE = 'tir', "
                       "PROPERTY_FILE_FORMAT, FITTYP or UNLOADED_RADIUS")
    family, label = _family(every, path)
    tir = TirFile(path, family, label, entries, {s: (h, tuple(r)) for s, (h, r) in tables.items()}, tuple(notes))
    for key, home in _HOME.items():
        entry = tir.find(key)
        if entry is not None and entry.section != home:
            notes.append(f"{key} found in [{entry.section or 'no section'}] (line {entry.line}), usually in [{home}]")
    _unit_factors(tir)  # unknown units (TIME and ANGLE: SI only) fail here, once
    return TirFile(path, family, label, entries, tir.tables, tuple(notes))
