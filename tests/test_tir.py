"""Tyre property files (.tir): parser traps, format variants, mapping, CLI (--tir, params from-tir).

Every file here is written by these tests (tests/data/mf62_example.tir and variants of it
built below); the numbers are invented. Expected values are closed forms of the Magic
Formula expressions at chosen operating points, or invariances (units, line ends, sign
convention, case) that a correct reader must respect.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import pytest

from polywear.params import Params, StudySpec, flat_items, load_params, load_study
from polywear.measured.tir import TirError, load_with_tir, read_tir, tir_parameters

from .cli_runner import run_main

EXAMPLE = Path(__file__).parent / "data" / "mf62_example.tir"
TEXT = EXAMPLE.read_text()


def _write(tmp_path: Path, text: str, name: str = "t.tir", newline: str = "\n") -> Path:
    path = tmp_path / name
    path.write_bytes(text.replace("\n", newline).encode())
    return path


def _set(text: str, key: str, value: str) -> str:
    """The text with ``key``'s value replaced (the key must occur once)."""
    pattern = re.compile(rf"^({key}\s*=\s*)[^$\n]*", re.M)
    assert len(pattern.findall(text)) == 1, key
    return pattern.sub(lambda m: m.group(1) + value + " ", text)


def _drop(text: str, key: str) -> str:
    return re.sub(rf"^{key}\s*=.*\n", "", text, flags=re.M)


def _map(path: Path, **kw):
    return tir_parameters(read_tir(path), **kw)


def test_example_parses_as_mf62_with_table_and_unknown_section():
    tir = read_tir(EXAMPLE)
    assert tir.family == "MF 6.2"
    assert tir.tables["SHAPE"][0] == ("radial", "width")
    assert tir.tables["SHAPE"][1][-1] == (0.9, 1.0)
    assert tir.find("PDXP1").section == "TURNSLIP_COEFFICIENTS"  # read, not used
    # MASS in [UNITS] (a unit name) and in [INERTIA] (kg): different keys, no duplicate
    assert tir.find("MASS").value == 9.3
    assert tir.entries["UNITS"]["MASS"].value == "kg"
    assert not any("twice" in n for n in tir.notes)


def test_peak_friction_closed_forms_mf6():
    tir = read_tir(EXAMPLE)
    pdy1, pdy2, pdy3 = 1.05, -0.12, 2.5
    # at FNOMIN (LFZO = 1), nominal pressure, zero camber: mu = PDY1
    assert tir_parameters(tir).values["friction.mu_static"] == pytest.approx(pdy1, rel=1e-14)
    # twice the nominal load: dfz = 1
    m = tir_parameters(tir, load_n=8000.0)
    assert m.values["friction.mu_static"] == pytest.approx(pdy1 + pdy2, rel=1e-14)
    assert "operating.vertical_load_n" not in m.values  # the user's load is not overwritten
    # camber: MF 6.x uses sin(gamma)
    g = math.radians(-3.0)
    mu = tir_parameters(tir, camber_deg=-3.0).values["friction.mu_static"]
    assert mu == pytest.approx(pdy1 * (1 - pdy3 * math.sin(g) ** 2), rel=1e-14)


def test_pressure_dependence_and_scaling(tmp_path):
    text = _set(_set(TEXT, "INFLPRES", "264000"), "LMUY", "0.8")  # dpi = 0.2
    m = _map(_write(tmp_path, text))
    dpi = 0.2
    assert m.values["friction.mu_static"] == pytest.approx(0.8 * 1.05 * (1 - 0.2 * dpi + 0.3 * dpi**2), rel=1e-14)
    assert m.values["tire.vertical_stiffness_n_per_m"] == pytest.approx(2.1e5 * (1 + 0.7 * dpi), rel=1e-14)
    # LFZO: the nominal load of the load dependence scales, FNOMIN itself stays the operating load
    m = _map(_write(tmp_path, _set(TEXT, "LFZO", "1.25")))
    dfz = (4000.0 - 5000.0) / 5000.0
    assert m.values["friction.mu_static"] == pytest.approx(1.05 - 0.12 * dfz, rel=1e-14)
    assert m.values["operating.vertical_load_n"] == 4000.0


def test_rolling_radius_vertical_and_contact_patch():
    m = tir_parameters(read_tir(EXAMPLE))
    r0, fz0, cz = 0.316, 4000.0, 2.1e5
    expected = r0 - fz0 / cz * (0.27 * math.atan(8.4) + 0.07)  # at FNOMIN, zero speed
    assert m.values["operating.rolling_radius_m"] == pytest.approx(expected, rel=1e-14)
    assert m.values["tire.vertical_damping_ns_per_m"] == 50.0
    rho = fz0 / (cz * r0)
    assert m.values["tire.contact_length_m"] == pytest.approx(2 * r0 * (0.9 * rho + 0.55 * math.sqrt(rho)), rel=1e-14)
    assert m.values["tire.tread_width_m"] == pytest.approx(2 * 0.205 * (-0.6 * rho + 0.95 * rho ** (1 / 3)), rel=1e-14)
    # the speed term raises the free radius by R0 Q_V1 (V/LONGVL)^2
    fast = tir_parameters(read_tir(EXAMPLE), speed_kmh=16.7 * 3.6)
    assert fast.values["operating.rolling_radius_m"] - expected == pytest.approx(r0 * 7.0e-4, rel=1e-10)


def test_contact_length_load_law(tmp_path):
    """With the linear terms zero, length grows as sqrt(Fz) and width as Fz^(1/3)."""
    text = _set(_set(TEXT, "Q_RA2", "0"), "Q_RB2", "0")
    tir = read_tir(_write(tmp_path, text))
    a1, a8 = (tir_parameters(tir, load_n=f).values for f in (1000.0, 8000.0))
    assert a8["tire.contact_length_m"] / a1["tire.contact_length_m"] == pytest.approx(math.sqrt(8.0), rel=1e-13)
    assert a8["tire.tread_width_m"] / a1["tire.tread_width_m"] == pytest.approx(2.0, rel=1e-13)


def test_crlf_and_case_and_fortran_exponent_change_nothing(tmp_path):
    reference = _map(EXAMPLE, camber_deg=-1.0).values
    assert _map(_write(tmp_path, TEXT, newline="\r\n"), camber_deg=-1.0).values == reference
    assert _map(_write(tmp_path, TEXT, newline="\r"), camber_deg=-1.0).values == reference
    lower = "\n".join(line if line.lstrip().startswith(("$", "!")) else line.lower() for line in TEXT.splitlines())
    assert _map(_write(tmp_path, lower), camber_deg=-1.0).values == reference
    fortran = _set(TEXT, "VERTICAL_STIFFNESS", "2.1D+05")
    assert _map(_write(tmp_path, fortran), camber_deg=-1.0).values == reference


def test_units_section_converts_to_si(tmp_path):
    text = TEXT.replace("LENGTH                   ='meter'", "LENGTH = 'mm'")
    text = text.replace("FORCE                    ='newton'", "FORCE = 'kN'")
    text = text.replace("MASS                     ='kg'", "MASS = 'gram'")
    for key, value in (("UNLOADED_RADIUS", "316"), ("WIDTH", "205"), ("FNOMIN", "4"), ("LONGVL", "16700"),
                       ("VERTICAL_STIFFNESS", "0.21"), ("VERTICAL_DAMPING", "0.00005"), ("BELT_MASS", "7100"),
                       ("LATERAL_STIFFNESS", "0.15")):
        text = _set(text, key, value)
    scaled = _map(_write(tmp_path, text), speed_kmh=90.0, belt_mode=True).values
    reference = _map(EXAMPLE, speed_kmh=90.0, belt_mode=True).values
    assert scaled.keys() == reference.keys()
    for key in reference:
        assert scaled[key] == pytest.approx(reference[key], rel=1e-12), key
    bad = TEXT.replace("ANGLE                    ='radians'", "ANGLE = 'degree'")
    with pytest.raises(TirError, match="ANGLE = 'degree'.*not supported"):
        read_tir(_write(tmp_path, bad))


MF52 = """\
$ MF-Tyre 5.2 style file, lower-case keys, written for polywear's tests
[mdi_header]
file_type = 'tir'
[units]
length = 'meter'
force = 'newton'
[model]
property_file_format = 'MF_05'   ! Magic Formula 5.2
tyreside = 'RIGHT $ not a comment'
[dimension]
unloaded_radius = 0.30
width = 0.195
[vertical]
fnomin = 3000
vertical_stiffness = 180000
vertical_damping = 40
q_a1 = 0.6
q_a2 = 1.2
pdy1 = 9.99  $ misplaced, and superseded below
[scaling_coefficients]
lmuy = 1
lgay = 2
[lateral_coefficients]
pdy1 = -1.10
pdy2 = 0.15
pdy3 = 4.0
[shape]
{radial width}
 1.0 0.0
 1.0 1.0
"""


def test_mf52_sign_convention_and_camber_form(tmp_path):
    path = _write(tmp_path, MF52)
    tir = read_tir(path)
    assert tir.family == "MF 5.2"
    assert tir.find("TYRESIDE").value == "RIGHT $ not a comment"  # $ inside quotes is text
    # PDY1 in [LATERAL_COEFFICIENTS] wins over the misplaced one in [VERTICAL]
    assert tir.find("PDY1").value == -1.10
    g = math.radians(-1.0)
    m = tir_parameters(tir, camber_deg=-1.0, load_n=6000.0)  # dfz = 1
    assert m.values["friction.mu_static"] == pytest.approx(abs(-1.10 + 0.15) * (1 - 4.0 * (2 * g) ** 2), rel=1e-14)
    assert any("PDY1 < 0" in note for note in m.notes)
    # the mirrored file (all friction signs flipped) gives the same friction level
    flipped = MF52.replace("pdy1 = -1.10", "pdy1 = 1.10").replace("pdy2 = 0.15", "pdy2 = -0.15")
    again = tir_parameters(read_tir(_write(tmp_path, flipped, "f.tir")), camber_deg=-1.0, load_n=6000.0)
    assert again.values["friction.mu_static"] == pytest.approx(m.values["friction.mu_static"], rel=1e-15)
    # MF 5.2 contact length from Q_A1, Q_A2 (no width: WIDTH is the section width)
    m = tir_parameters(tir)
    assert m.values["tire.contact_length_m"] == pytest.approx(2 * 0.30 * (1.2 + 0.6), rel=1e-14)
    assert "tire.tread_width_m" not in m.values
    assert "operating.rolling_radius_m" not in m.values  # no BREFF/DREFF/FREFF
    assert any("rolling_radius" in note for note in m.notes)


def test_pac2002_and_fittyp_variants(tmp_path):
    pac = MF52.replace("'MF_05'", "'PAC2002'").replace("lmuy = 1", "lmuy = 0.8")
    m = tir_parameters(read_tir(_write(tmp_path, pac)))
    assert read_tir(_write(tmp_path, pac)).family == "MF 5.2"
    assert m.values["friction.mu_static"] == pytest.approx(0.8 * 1.10, rel=1e-14)
    for fmt, family in (("'MF61'", "MF 6.1"), ("'MF 6.2'", "MF 6.2"), ("'MF-Tyre 5.2'", "MF 5.2")):
        assert read_tir(_write(tmp_path, MF52.replace("'MF_05'", fmt))).family == family
    # FITTYP decides when both are given
    both = MF52.replace("[model]\n", "[model]\nfittyp = 61\n")
    assert read_tir(_write(tmp_path, both)).family == "MF 6.1"
    with pytest.raises(TirError, match="FITTYP = 7.0"):
        read_tir(_write(tmp_path, MF52.replace("[model]\n", "[model]\nfittyp = 7\n")))
    with pytest.raises(TirError, match="PROPERTY_FILE_FORMAT = 'FTIRE'"):
        read_tir(_write(tmp_path, MF52.replace("'MF_05'", "'FTIRE'")))


def test_duplicate_and_misplaced_keys_are_noted(tmp_path):
    text = TEXT.replace("PDY2                     = -0.12", "PDY2 = -0.12\nPDY2 = -0.20")
    text = _drop(text, "LMUY")  # only the misplaced one is left
    text = text.replace("[CONTACT_PATCH]\n", "[CONTACT_PATCH]\nLMUY = 0.9\n")
    tir = read_tir(_write(tmp_path, text))
    assert any("PDY2 given twice" in n for n in tir.notes)
    assert any(n.startswith("LMUY found in [CONTACT_PATCH]") for n in tir.notes)
    m = tir_parameters(tir, load_n=8000.0)
    assert m.values["friction.mu_static"] == pytest.approx(0.9 * (1.05 - 0.20), rel=1e-14)


def test_belt_mode_is_opt_in_and_consistent():
    off = tir_parameters(read_tir(EXAMPLE))
    assert not any(key.startswith("tread.") for key in off.values)
    assert any("belt lateral mode" in n for n in off.notes)
    on = tir_parameters(read_tir(EXAMPLE), belt_mode=True).values
    m, k, c = on["tread.mass_kg"], on["tread.lateral_stiffness_n_per_m"], on["tread.lateral_damping_ns_per_m"]
    assert math.sqrt(k / m) / (2 * math.pi) == pytest.approx(48.0, rel=1e-14)
    assert c / (2 * math.sqrt(k * m)) == pytest.approx(0.05, rel=1e-14)


def test_lateral_stiffness_when_no_frequency(tmp_path):
    tir = read_tir(_write(tmp_path, _drop(TEXT, "FREQ_LAT")))
    values = tir_parameters(tir, load_n=6000.0, belt_mode=True).values
    assert values["tread.lateral_stiffness_n_per_m"] == pytest.approx(1.5e5 * (1 + 0.2 * 0.5), rel=1e-14)


@pytest.mark.parametrize(
    "content",
    [b'[operating]\nspeed_kmh = 100\n', b"time,speed\n0,1\n", b"\x89PNG\r\n\x1a\n\x00\x00", b"", b"FNOMIN = 4000\n"],
)
def test_not_a_tir_is_one_line(tmp_path, content):
    path = tmp_path / "x.tir"
    path.write_bytes(content)
    with pytest.raises(TirError, match="not a tyre property file"):
        read_tir(path)
    code, out, err = run_main(["stability", "--tir", str(path)])
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("error: ") and "Traceback" not in err


def test_missing_fnomin_and_missing_file(tmp_path):
    with pytest.raises(TirError, match="FNOMIN"):
        tir_parameters(read_tir(_write(tmp_path, _drop(TEXT, "FNOMIN"))))
    code, _, err = run_main(["params", "show", "--tir", str(tmp_path / "none.tir")])
    assert code == 2 and "cannot read" in err


def test_order_tir_then_config_then_set(tmp_path):
    config = tmp_path / "c.toml"
    config.write_text("[operating]\nvertical_load_n = 8000.0\n[tire]\nvertical_damping_ns_per_m = 77.0\n")
    loaded = load_with_tir(EXAMPLE, config, ["tire.vertical_stiffness_n_per_m=1.5e5"])
    params = loaded.params
    assert params.operating.vertical_load_n == 8000.0
    camber = 1 - 2.5 * math.sin(math.radians(Params().operating.camber_deg)) ** 2
    assert params.friction.mu_static == pytest.approx((1.05 - 0.12) * camber, rel=1e-12)  # at the user's load
    assert params.tire.vertical_damping_ns_per_m == 77.0  # the file's 50 loses to --config
    assert params.tire.vertical_stiffness_n_per_m == 1.5e5  # and to --set
    # the large-slip level of the Magic Formula, D sin(C pi/2): full sliding (PCY1 = 1.3)
    assert params.friction.mu_coulomb / params.friction.mu_static == pytest.approx(math.sin(1.3 * math.pi / 2), rel=1e-12)
    # a user mu_static keeps the user's mu_coulomb: the file does not move it
    loaded = load_with_tir(EXAMPLE, None, ["friction.mu_static=0.6"])
    params, mapping = loaded.params, loaded.mapping
    assert params.friction.mu_coulomb == Params().friction.mu_coulomb
    assert "friction.mu_coulomb" not in mapping.values


def test_load_with_tir_answers_with_the_source_of_every_value(tmp_path):
    """Every value the summary credits to the file is the file's mapped value; --config and
    --set values are the user's; every other numeric key keeps its default."""
    config = tmp_path / "c.toml"
    config.write_text("[tire]\nvertical_damping_ns_per_m = 77.0\n")
    loaded = load_with_tir(EXAMPLE, config, ["friction.mu_static=0.6"])
    rows = {r["key"]: r for r in loaded.summary()["parameters"]}
    assert rows["tire.vertical_damping_ns_per_m"]["source"].startswith("--config (overrides the file: ")
    assert rows["friction.mu_static"]["source"].startswith("--set (overrides the file: ")
    assert rows["friction.mu_static"]["value"] == 0.6 and rows["tire.vertical_damping_ns_per_m"]["value"] == 77.0
    from_file = {k for k, r in rows.items() if r["from_file"]}
    assert from_file == set(loaded.mapping.values) - {"tire.vertical_damping_ns_per_m", "friction.mu_static"}
    assert all(rows[k]["value"] == loaded.mapping.values[k] for k in from_file)
    defaults = {key: value for key, value, _ in flat_items(Params())}
    assert all(r["value"] == defaults[k] for k, r in rows.items() if r["source"] == "default")
    assert loaded.summary()["file"] == str(EXAMPLE) and loaded.params.friction.mu_static == 0.6


def test_cli_from_tir_and_tir_option_agree(tmp_path):
    out = tmp_path / "tire.toml"
    code, stdout, err = run_main(["params", "from-tir", str(EXAMPLE), "--out", str(out), "--json"])
    assert code == 0, err
    summary = json.loads(stdout)
    rows = {r["key"]: r for r in summary["parameters"]}
    assert rows["friction.mu_static"]["source"].startswith("file: |PDY1")
    assert rows["operating.vertical_load_n"]["source"] == "file: FNOMIN"
    assert rows["friction.sigma0_per_m"]["source"] == "default"
    assert rows["tread.mass_kg"]["source"] == "default"  # no --belt-mode
    assert summary["format"] == "MF 6.2"
    # the written TOML reproduces the set, and every command's --tir gives the same
    from_file = load_params(out)
    via_option = load_with_tir(EXAMPLE).params
    assert from_file == via_option
    assert load_study(out) == StudySpec()  # the [study] table is written too (here: --config has none)
    config = tmp_path / "car.toml"
    config.write_text("[study]\nn_base = 64\n")
    kept = tmp_path / "tire_study.toml"
    assert run_main(["params", "from-tir", str(EXAMPLE), "-c", str(config), "--out", str(kept), "-q"])[0] == 0
    assert load_study(kept) == StudySpec().with_updates({"n_base": 64}) and load_params(kept) == from_file
    code, a, _ = run_main(["params", "show", "--json", "--tir", str(EXAMPLE)])
    code2, b, _ = run_main(["params", "show", "--json", "-c", str(out)])
    assert code == code2 == 0 and json.loads(a) == json.loads(b)
    # text output names each source; --set is reported as overriding the file
    code, stdout, _ = run_main(["params", "from-tir", str(EXAMPLE), "-s", "friction.mu_static=0.7", "-q"])
    line = next(s for s in stdout.splitlines() if s.startswith("friction.mu_static"))
    assert "--set (overrides the file" in line


@pytest.mark.parametrize("key, value, message", [
    ("UNLOADED_RADIUS", "308", r"UNLOADED_RADIUS = 308 \(line \d+\) is 308 m, not what a tire can be \(0.15 to 0.8 m.*LENGTH"),
    ("UNLOADED_RADIUS", "1e308", r"UNLOADED_RADIUS = 1e\+308 \(line \d+\).*0.15 to 0.8 m"),
    ("FNOMIN", "4000000", r"FNOMIN = 4e\+06 \(line \d+\) is 4e\+06 N, not what a tire can be \(500 to 60000 N.*FORCE"),
])
def test_implausible_file_fields_are_refused_by_their_own_name(tmp_path, key, value, message):
    path = _write(tmp_path, _set(TEXT, key, value))
    with pytest.raises(TirError, match=message):
        load_with_tir(path)
    code, out, err = run_main(["simulate", "--tir", str(path), "--json"])
    assert code == 2 and out == "" and key in err and "contact_length" not in err and len(err.splitlines()) == 1


def test_kilonewton_file_with_values_in_newtons_is_refused(tmp_path):
    text = TEXT.replace("FORCE                    ='newton'", "FORCE = 'kilonewton'")
    with pytest.raises(TirError, match=r"FNOMIN = 4000 .*is 4e\+06 N.*check the \[UNITS\] of the file \(FORCE\)"):
        load_with_tir(_write(tmp_path, text))


def test_implausible_derived_value_names_the_file_fields(tmp_path):
    # a plausible radius, an absurd contact-patch coefficient: the patch length comes from the file
    path = _write(tmp_path, _set(TEXT, "Q_RA2", "500"))
    with pytest.raises(TirError, match=r"tire.contact_length_m = .* m from the file's 2 R0 \(Q_RA2.*0.01 to 0.5 m"):
        load_with_tir(path)


def test_missing_pdy1_is_noted_and_the_friction_is_the_default(tmp_path):
    result = load_with_tir(_write(tmp_path, _drop(TEXT, "PDY1")))
    assert any(note.startswith("no PDY1") for note in result.mapping.notes)
    rows = {row["key"]: row for row in result.sources()}
    assert rows["friction.mu_static"]["source"] == "default"
    assert rows["friction.mu_static"]["value"] == Params().friction.mu_static
    assert rows["operating.vertical_load_n"]["source"] == "file: FNOMIN"
    assert not any(note.startswith("no PDY1") for note in load_with_tir(EXAMPLE).mapping.notes)


# -- cornering stiffness, large-slip friction and the patch contact (issue 23) ------------
LATERAL = "\n".join(["PKY1 = -18.0", "PKY2 = 1.9", "PKY3 = 0.0", "PEY1 = -0.8", "PEY2 = -0.6"])


def _with_lateral(tmp_path: Path) -> Path:
    text = TEXT.replace("PDY1 ", LATERAL + "\nPDY1 ", 1)
    return _write(tmp_path, text, "lateral.tir")


def _magic_formula(path: Path, fz: float, alpha: float) -> float:
    """The file's pure-slip lateral force |Fy| [N] at load fz [N], slip alpha [rad], camber 0,
    nominal pressure (no shifts in the file), written out from the MF 6.2 equations."""
    tir = read_tir(path)
    num = tir.number
    fz0 = num("FNOMIN") * num("LFZO", 1.0)
    dfz = (fz - fz0) / fz0
    p0, pi = num("NOMPRES"), num("INFLPRES")
    dpi = (pi - p0) / p0
    mu = abs(num("PDY1") + num("PDY2") * dfz) * (1 + num("PPY3") * dpi + num("PPY4") * dpi**2) * num("LMUY", 1.0)
    kya = abs(num("PKY1") * fz0 * math.sin(2.0 * math.atan(fz / (num("PKY2") * fz0))))
    C, D = num("PCY1"), mu * fz
    B = kya / (C * D)
    E = num("PEY1") + num("PEY2") * dfz
    x = B * alpha
    return D * math.sin(C * math.atan(x - E * (x - math.atan(x))))


def test_cornering_stiffness_closed_form(tmp_path):
    path = _with_lateral(tmp_path)
    for fz in (2000.0, 4000.0, 8000.0):
        c = tir_parameters(read_tir(path), load_n=fz).conditions["cornering_stiffness_n_per_rad"]
        assert c == pytest.approx(18.0 * 4000.0 * math.sin(2.0 * math.atan(fz / (1.9 * 4000.0))), rel=1e-12)
    assert "cornering_stiffness_n_per_rad" not in tir_parameters(read_tir(EXAMPLE)).conditions


@pytest.mark.parametrize("fz", [3000.0, 4000.0, 6000.0])
def test_patch_small_slip_force_reproduces_the_magic_formula(tmp_path, fz):
    """With the patch contact the file sets the tread stiffness so that the patch has the
    file's cornering stiffness at the load; the steady force at small slip is then the
    file's Magic Formula force within 1 %; the point contact keeps its tread and is told."""
    from polywear.models.patch import steady_lateral_force

    path = _with_lateral(tmp_path)
    sets = ["friction.contact=patch", f"operating.vertical_load_n={fz}"]
    loaded = load_with_tir(path, None, sets)
    assert "tread.lateral_stiffness_n_per_m" in loaded.mapping.values
    assert loaded.params.friction.patch_pressure == "uniform"
    slips = [0.01, 0.02, 0.05, 0.1, 0.2]
    rows = steady_lateral_force(loaded.params, slips)["rows"]
    for slip, row in zip(slips, rows):
        assert row["force_n"] == pytest.approx(_magic_formula(path, fz, math.radians(slip)), rel=0.01)
    point = load_with_tir(path, None, [f"operating.vertical_load_n={fz}"])
    assert point.params.tread == Params().tread
    assert any("used by the patch contact only" in n for n in point.mapping.notes)


@pytest.mark.parametrize("fz", [3000.0, 6000.0])
def test_a_parabolic_pressure_cannot_follow_the_magic_formula_at_small_slip(tmp_path, fz):
    """Why the file's patch has a uniform pressure (brush theory, closed forms): with the file's
    cornering stiffness and friction, a Coulomb brush under a parabolic pressure slides at its
    trailing edge at any slip and falls below the line K alpha by K alpha/(3 mu Fz), more than
    1 % below the file's Magic Formula at 0.2 deg; under a uniform pressure it adheres all along
    (F = K alpha up to mu Fz/2), as the Magic Formula, which leaves the line as alpha^3."""
    from polywear.models.patch import brush_force

    path = _with_lateral(tmp_path)
    m = tir_parameters(read_tir(path), load_n=fz)
    c_alpha, mu = m.conditions["cornering_stiffness_n_per_rad"], m.values["friction.mu_static"]
    alpha = math.radians(0.2)
    mf = _magic_formula(path, fz, alpha)
    c_p, a = 1.0, math.sqrt(c_alpha / 2.0)  # C_alpha = 2 c_p a^2
    parabolic = brush_force(alpha, c_p, a, mu, fz, "parabolic")
    uniform = brush_force(alpha, c_p, a, mu, fz, "uniform")
    psi = c_alpha * math.tan(alpha) / (3.0 * mu * fz)
    assert parabolic / (c_alpha * math.tan(alpha)) == pytest.approx(1.0 - psi + psi**2 / 3.0, rel=1e-12)
    assert parabolic < 0.99 * mf
    assert uniform == pytest.approx(c_alpha * math.tan(alpha), rel=1e-12)
    assert uniform == pytest.approx(mf, rel=1e-3)


def test_patch_shape_from_the_file_unless_given(tmp_path):
    """With the patch contact the file sets pressure (uniform) and bristle (sigma0 = 50 K/(Fz a))
    besides the tread; the user's values stand, and the tread is then solved with them."""
    from polywear.measured.tir import BRISTLE_RATIO
    from polywear.models.patch import steady_lateral_force

    path = _with_lateral(tmp_path)
    loaded = load_with_tir(path, None, ["friction.contact=patch"])
    p = loaded.params
    c_alpha = loaded.mapping.conditions["cornering_stiffness_n_per_rad"]
    assert p.friction.sigma0_per_m == pytest.approx(
        BRISTLE_RATIO * c_alpha / (p.operating.vertical_load_n * 0.5 * p.tire.contact_length_m), rel=1e-12)
    rows = {r["key"]: r for r in loaded.sources()}
    assert rows["friction.patch_pressure"]["source"].startswith("file: uniform")
    assert rows["friction.sigma0_per_m"]["from_file"]
    own = load_with_tir(path, None, ["friction.contact=patch", "friction.patch_pressure=parabolic",
                                     "friction.sigma0_per_m=2000"])
    assert (own.params.friction.patch_pressure, own.params.friction.sigma0_per_m) == ("parabolic", 2000.0)
    assert own.params.tread.lateral_stiffness_n_per_m != p.tread.lateral_stiffness_n_per_m
    for got in (loaded, own):
        assert steady_lateral_force(got.params, [])["cornering_stiffness_n_per_rad"] == pytest.approx(c_alpha, rel=1e-8)
    point = load_with_tir(path, None, []).params.friction  # the point contact: the set's own
    assert (point.patch_pressure, point.sigma0_per_m) == (Params().friction.patch_pressure, Params().friction.sigma0_per_m)


def test_every_file_value_is_listed_as_used_noted_or_ignored(tmp_path):
    path = _with_lateral(tmp_path)
    summary = load_with_tir(path, None, ["friction.contact=patch"]).summary()
    uses = {v["key"]: v["use"] for v in summary["file_values"]}
    tir = read_tir(path)
    assert set(uses) == {k for sec, e in tir.entries.items() if sec != "UNITS" for k in e}
    for key in ("PKY1", "PKY2", "PCY1", "PDY1", "FNOMIN", "Q_RA1", "NOMPRES", "LONGVL"):
        assert uses[key] == "used", key
    assert uses["BELT_MASS"] == "noted" and uses["PEY1"] == "ignored" and uses["PDXP1"] == "ignored"
    code, _, err = run_main(["params", "from-tir", str(path)])
    assert code == 0 and "file values ignored:" in err and "PEY1" in err


def test_file_without_pressure_gives_json_without_nan(tmp_path):
    """An MF 5.2 file has no NOMPRES/INFLPRES: the pressure of the conditions is null, not NaN."""
    text = MF52.replace("q_a1 = 0.6", "q_a1 = 0.1").replace("q_a2 = 1.2", "q_a2 = 0.05")
    code, out, err = run_main(["params", "from-tir", str(_write(tmp_path, text)), "--json", "-q"])
    assert code == 0, err
    assert json.loads(out, parse_constant=lambda c: pytest.fail(c))["conditions"]["pressure_pa"] is None


def test_overflowing_coefficient_is_one_line(tmp_path):
    """PPY4 = 3e159 with a pressure off the nominal one: dpi^2 PPY4 overflows; one line, not a traceback."""
    text = _set(_set(TEXT, "PPY4", "2.9497177445873714e+159"), "INFLPRES", "1e300")
    with pytest.raises(TirError, match="out of range for the Magic Formula"):
        load_with_tir(_write(tmp_path, text))


@pytest.mark.parametrize("value", ["1e999", "-1D999", "nan"])
def test_non_finite_number_in_the_file_is_one_line(tmp_path, value):
    """Found by the fuzz harness: LATERAL_STIFFNESS = 1e999 reached the JSON as Infinity."""
    path = _write(tmp_path, _set(TEXT, "LATERAL_STIFFNESS", value))
    code, out, err = run_main(["params", "from-tir", str(path), "--json", "-q"])
    if value == "nan":  # not a number at all: a word, which the mapping does not read here
        assert code == 0 and "NaN" not in out
        return
    assert code == 2 and out == "" and f"LATERAL_STIFFNESS = {value}" in err and "not a finite number" in err
