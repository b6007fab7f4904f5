"""The report reads at a glance (issue 24 §4) and names its contact (issue 23 §5): the
verdict before any table, the two parameters that move the band most, m/s², the complete
file list, labelled order rays, one phase-portrait convention, every --speeds speed of the
wear map printed, C_alpha from a .tir file, the patch contact beside an overstated point
contact.

Oracles: for tread1dof the speed enters only through V sin(toe), so the normalized
sensitivity of every bifurcation speed to the toe angle is -p cot(p) (p the toe in rad,
closed form); the steady slip angle of tread1dof is the toe angle (the tread does not
move at steady rolling); the folder's own listing; rendered text extents.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from polywear.params import Params, with_updates

from .cli_runner import run_main

TIR = Path(__file__).parent / "data" / "mf62_example.tir"


@pytest.fixture(scope="module")
def quiet_car(tmp_path_factory):
    """The report of toe 0.05 deg (no SEV band in 20-300 km/h; the point contact's force
    82 times C_alpha alpha), without the wear evolution: seconds."""
    from polywear.report.main import report

    out = tmp_path_factory.mktemp("quiet")
    return report(with_updates(Params(), {"operating.toe_deg": 0.05}), out, wear_evolution_km=0), out


@pytest.fixture(scope="module")
def nominal_diagram():
    from polywear.dynamics.bifurcation import bifurcation

    return bifurcation(Params(), (20.0, 300.0))


def test_file_list_names_every_file_written(quiet_car):
    result, out = quiet_car
    written = {p.name for p in out.iterdir()}
    assert written == set(result.files)
    page = (out / "report.html").read_text()
    files = page[page.index("<h2>Files</h2>"):page.index("<h2>Parameters</h2>")]
    assert set(re.findall(r"<a href='([^']+)'>", files)) == written
    assert {"wear_map.nc", "bifurcation.nc", "stability.png", "wear_map.png", "report.html"} <= written


def test_glance_comes_first_names_the_contact_and_the_risk(quiet_car):
    result, out = quiet_car
    page = (out / "report.html").read_text()
    glance = result.overall["glance"]
    assert page.index('<ul class="glance">') < page.index("<table")
    assert [line.split(":")[0] for line in glance] == ["At risk", "How bad", "What to change",
                                                       "What moves the SEV band most", "Contact"]
    assert glance[0].startswith("At risk: not from vibration") and "not judged" in glance[0]  # no evolution run
    assert 'friction.contact = "point"' in glance[-1] and "82 times C_alpha*alpha" in glance[-1]
    assert result.overall["contact"] == "point"
    assert any(line.startswith('Contact: the paper\'s point contact (friction.contact = "point"') for line in
               result.overall["lines"])


def test_patch_result_beside_an_overstated_point_contact(quiet_car):
    """At toe 0.05 deg the two contacts disagree on the wear growth at 110 km/h by orders of
    magnitude (docs/patch_contact.md: 4 700 km against 2.9e9 km); the patch's steady rolling
    is stable there (its eigenvalues, computed here directly)."""
    from polywear.models import model_for
    from polywear.units import kmh_to_ms

    result, _ = quiet_car
    patch = result.overall["patch"]
    assert patch["disagree"] and patch["linear_band_kmh"] == [] and patch["point"]["linear_band_kmh"] == []
    assert patch["operating"]["efold_km"] > 1e5 * patch["point"]["operating"]["efold_km"]
    assert patch["text"] in result.overall["lines"]
    params = with_updates(Params(), {"operating.toe_deg": 0.05, "friction.contact": "patch"})
    model = model_for(params)
    p = model.pack(params)
    V = float(kmh_to_ms(110.0))
    assert np.linalg.eigvals(model.jacobian(model.equilibrium(V, p), V, p)).real.max() < 0.0


def test_no_caret_units_in_the_report(quiet_car):
    from polywear.report.main import _sentence

    _, out = quiet_car
    assert "m/s^2" not in (out / "report.html").read_text()
    v = {"speed_kmh": 110.0, "regime": "unstable rolling (soft SEV)", "steady_rolling_stable": False,
         "sev_amplitude_x_mm": 0.269, "wear": {"frequency_hz": 138.1, "frequency_order": 8.52,
                                               "rms_acceleration": 145.0, "uneven_wear_index": 0.552}}
    assert "RMS tread acceleration 145 m/s²" in _sentence(v) and "^" not in _sentence(v)


def test_glance_names_the_two_parameters_that_move_the_band_most(nominal_diagram):
    """Ranked by the largest |S| on either edge of the band; the toe's S checked against the
    closed form -p cot(p)."""
    from polywear.dynamics.sensitivity import sensitivity
    from polywear.report.verdict import glance, top_sensitivities

    sens = sensitivity(Params(), diagram=nominal_diagram).summary()
    rows = [r for r in sens["rows"] if r["quantity"] in ("first_bifurcation", "second_bifurcation")]
    toe = math.radians(0.5)
    for r in rows:
        if r["param"] == "operating.toe_deg":
            assert r["normalized"] == pytest.approx(-toe / math.tan(toe), rel=1e-6)
    largest = {}
    for r in rows:
        largest[r["param"]] = max(largest.get(r["param"], 0.0), abs(r["normalized"]))
    expected = sorted(largest, key=largest.get, reverse=True)[:2]
    assert [e["param"] for e in top_sensitivities(sens)] == expected
    summary = {"operating": {"speed_kmh": 110.0}, "bifurcation": nominal_diagram.summary(), "sensitivity": sens,
               "design": {"operating_range_kmh": [80.0, 130.0], "options": [], "reason": "r"}}
    judged = {"vibrates": False, "visible_km": {}, "polygon_visible": None, "dominant_order": None,
              "design_options": [], "point_contact": None, "patch": None}
    (line,) = [x for x in glance(summary, judged, Params()) if x.startswith("What moves the SEV band most")]
    assert all(key in line for key in expected) and line.index(expected[0]) < line.index(expected[1])


def test_c_alpha_from_a_tir_file_is_used_and_named(tmp_path):
    """The report's C_alpha is the file's, PKY1 FNOMIN sin(2 atan(Fz / (PKY2 FNOMIN))) at the
    load (closed form: no camber or pressure terms in the file), named with the file; the
    point contact's C_alpha*alpha is that times the toe (tread1dof: slip angle = toe)."""
    from polywear.cli.common import _TIR_PATH
    from polywear.cli.report_cmd import _load_with_cornering
    from polywear.report.verdict import C_ALPHA_N_PER_RAD, point_contact

    tir = tmp_path / "lateral.tir"
    tir.write_text(TIR.read_text().replace("PDY1 ", "PKY1 = -18.0\nPKY2 = 1.9\nPKY3 = 0.0\nPDY1 ", 1))
    token = _TIR_PATH.set(tir)
    try:
        params, (c_alpha, source) = _load_with_cornering(None, [])
    finally:
        _TIR_PATH.reset(token)
    fz = params.operating.vertical_load_n
    assert c_alpha == pytest.approx(18.0 * 4000.0 * math.sin(2.0 * math.atan(fz / (1.9 * 4000.0))), rel=1e-12)
    assert "lateral.tir" in source and c_alpha != C_ALPHA_N_PER_RAD
    token = _TIR_PATH.set(TIR)  # a file without PKY1/PKY2: the default
    try:
        assert _load_with_cornering(None, [])[1] is None
    finally:
        _TIR_PATH.reset(token)
    pc = point_contact(params, 110.0, (c_alpha, source))
    assert pc["c_alpha_alpha_n"] == pytest.approx(c_alpha * math.radians(params.operating.toe_deg), rel=1e-9)
    assert pc["c_alpha_source"] == source
    default = point_contact(Params(), 110.0)
    assert default["c_alpha_n_per_rad"] == C_ALPHA_N_PER_RAD and "no .tir file" in default["c_alpha_source"]
    params_plain, cornering = _load_with_cornering(None, [])
    assert cornering is None and params_plain == Params()


def test_wear_map_prints_every_requested_speed():
    code, out, _ = run_main(["wear", "map", "--speeds", "100,110,115,120", "-q"])
    assert code == 0
    speeds = [float(line.split()[0]) for line in out.splitlines()[1:]]
    assert speeds == [100.0, 110.0, 115.0, 120.0] and "..." not in out
    code, out, _ = run_main(["wear", "map", "--speed-range", "80", "140", "--n-speeds", "7", "-q"])
    assert code == 0 and out.splitlines()[1].endswith("...")  # a range's grid: a vibrating run in two lines


def _label_boxes(ax):
    fig = ax.figure
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    return {t.get_text(): t.get_window_extent(renderer) for t in ax.texts if t.get_text().startswith("n=")}


def _disjoint(boxes):
    items = list(boxes.values())
    return all(not a.overlaps(b) for i, a in enumerate(items) for b in items[i + 1:])


@pytest.mark.parametrize("speeds, top, first", [((20.0, 300.0), 254.0, ()), ((41.0, 79.0), 467.0, (8, 16))])
def test_every_order_ray_drawn_is_labelled_and_no_labels_overlap(speeds, top, first):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from polywear.units import order_rays

    fig, ax = plt.subplots(figsize=(8, 5))
    ax.set_xlim(*speeds)
    ax.set_ylim(0, top)
    drawn = order_rays(ax, range(1, 61), 0.3, speeds, top, first=first)
    boxes = _label_boxes(ax)
    assert sorted(boxes) == sorted(f"n={n}" for n in drawn) and len(ax.lines) == len(drawn)
    assert set(first) <= set(drawn) and len(drawn) >= 5
    assert _disjoint(boxes)
    plt.close(fig)


def test_one_phase_portrait_convention_and_the_operating_speed_on_stability(nominal_diagram):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from polywear.dynamics.excitation import excitation
    from polywear.dynamics.simulation import simulate

    run = simulate(Params(), 110.0, 0.05)
    ax = run.plot()[0].axes
    np.testing.assert_allclose(ax.lines[0].get_xdata(), 1e3 * (run.u[:, 0] - run.equilibrium[0]))
    portrait = excitation(nominal_diagram, [110.0]).portraits[0]
    fig, other = plt.subplots()
    portrait.plot(other)
    assert (ax.get_xlabel(), ax.get_ylabel()) == (other.get_xlabel(), other.get_ylabel()) == ("x − x_eq [mm]",
                                                                                              "dx/dt [m/s]")
    fig2, st = plt.subplots()
    nominal_diagram.stability.plot(st)
    assert any(line.get_label() == "operating speed 110 km/h" and list(line.get_xdata()) == [110.0, 110.0]
               for line in st.lines)
    plt.close("all")


def test_panel_labels_of_a_multi_panel_diagram_do_not_overlap(nominal_diagram):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = nominal_diagram.figure(states=["x", "z", "xdot"])
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    labels = [ax.yaxis.label for ax in fig.axes]
    assert [t.get_text() for t in labels] == ["x [mm]", "z [mm]", "xdot [m/s]"]
    boxes = [t.get_window_extent(renderer) for t in labels]
    assert all(not a.overlaps(b) for i, a in enumerate(boxes) for b in boxes[i + 1:])
    plt.close(fig)


def test_glance_gives_the_wear_change_where_there_is_no_band_to_move():
    """A car without SEV band that still wears into a polygon (toe 0.05 deg at 110 km/h): the
    glance's "What to change" is the verdict's answer, a change of the wear itself, not "no
    design option clears the SEV band"."""
    from polywear.report.verdict import glance

    answer = ("What to change: there is no SEV band to move out of 80-130 km/h, but the tire still wears into a "
              "polygon: the wear itself must change: tread lateral stiffness 1e+06 -> 1.565e+06 N/m (+56.5 %) ...")
    summary = {"operating": {"speed_kmh": 110.0}, "design": {"operating_range_kmh": [80.0, 130.0], "options": [],
                                                              "reason": "No SEV band in 20-300 km/h"}}
    judged = {"vibrates": False, "visible_km": {"operating speed": 29000.0, "drive cycle": None},
              "polygon_visible": True, "dominant_order": 10, "design_options": [], "point_contact": None,
              "patch": None, "lines": ["At 110 km/h: no self-excited vibration.", answer]}
    lines = glance(summary, judged, Params())
    assert lines[0] == "At risk: yes" and lines[2] == answer
    assert not any("no design option clears the SEV band" in line for line in lines)
