"""The wear section of the report: the linear wear map, the evolutions at the operating
speed and on the drive cycle (``wear.report_km``, by default), and the answer in words
(``docs/wear.md``, ``docs/wear_and_design.md``)."""

from __future__ import annotations

import html
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..params import Params
from ..wear.evolution import EvolutionResult, EvolutionSettings, StepBudgetError, wear_evolution
from ..wear.start import cycle_start_states

if TYPE_CHECKING:
    from ..wear.map import WearMap
from ..progress import Progress, StepCounter

__all__ = ["WearSection", "wear_section", "wear_html", "wear_sentences", "wear_headline", "evolution_entry",
           "evolution_stem", "from_cycle_sentence", "FROM_CYCLE"]

ROUGHNESS_FACTOR = 10.0
"""The headline says how much sooner the polygon is visible from this many times the
initial roughness [-]."""
K_E_UNCERTAINTY = 10.0
"""Factor by which the energetic wear rate k_e is uncertain either way [-] (docs/wear.md)."""
FROM_CYCLE = ", from the large vibration"
"""Appended to the label of an evolution that starts on the large stable cycle (``start="cycle"``)."""


@dataclass
class WearSection:
    """The report's wear results: the linear map over the speed range, the map at the
    operating and drive-cycle speeds, and the evolutions ``(label, result)`` if run: from
    steady rolling, and (``from_cycle``) from the large stable cycle where a speed of the run
    lies in a hard region (hard self-excitation: a pothole starts the vibration)."""

    wear_map: WearMap
    points: WearMap
    evolutions: list[tuple[str, EvolutionResult]] = field(default_factory=list)
    from_cycle: list[tuple[str, EvolutionResult]] = field(default_factory=list)
    cycle_start_kmh: list[float] = field(default_factory=list)
    """Speeds [km/h] where the ``from_cycle`` evolutions start on the large stable cycle."""

    def summary(self) -> dict:
        """The JSON-ready wear section of ``summary.json``, with the verdict in words
        (``headline``: the answer at the top of the report; ``sentences``: the details)."""
        params = self.wear_map.params
        out = {"map_rows": self.points.summary()["rows"],
               "linear_band_kmh": [list(b) for b in self.wear_map.linear_band_kmh],
               "energetic_rate_mm3_per_j": params.wear.energetic_rate_mm3_per_j,
               "initial_roughness_um": params.wear.initial_roughness_um,
               "evolutions": [evolution_entry(label, result) for label, result in self.evolutions]
               + [evolution_entry(f"{label}{FROM_CYCLE}", result, "cycle") for label, result in self.from_cycle],
               "cycle_start_kmh": list(self.cycle_start_kmh)}
        out["sentences"] = wear_sentences(out)
        out["headline"] = wear_headline(out)
        return out


def evolution_entry(label: str, result: EvolutionResult, start: str = "rest") -> dict:
    """One evolution in ``summary.json``: ``label``, its ``start`` (``"rest"``, or ``"cycle"``:
    from the large stable cycle, :mod:`polywear.wear.start`) and the fields of
    :meth:`EvolutionResult.summary` (``visible_km``, ``dominant_order``, ``final_depth_mm``, ...),
    with per cycle speed ``locked_at_end`` (the vibration locked in the last step) and
    ``growth_efolds``: e-folds [-] the dominant harmonic grew by from the initial roughness to
    the visible depth (None if not visible)."""
    entry = {"label": label, "start": start, **result.summary()}
    for j, c in enumerate(entry["cycle"]):
        c["locked_at_end"] = bool(result.locked[-1, j]) if result.locked.size else False
    visible = entry["visible_km"]
    entry["growth_efolds"] = None
    if visible is not None and visible > 0.0:
        n = entry["dominant_order"] - 1
        amp = np.abs(result.harmonics[:, n])
        at = float(np.interp(visible, result.distance_km, np.log(np.maximum(amp, 1e-300))))
        entry["growth_efolds"] = at - math.log(max(float(amp[0]), 1e-300))
    return entry


def wear_section(params: Params, speed_range_kmh, save, out_dir, evolution_km: float | None = None,
                 evolution: EvolutionSettings = EvolutionSettings(), sev_band_kmh=None,
                 progress: Progress | None = None, diagram=None) -> WearSection:
    """Compute the wear section; figures through ``save(fig, name, caption)``.

    The map over ``speed_range_kmh`` [km/h] (300 speeds) is always computed (about a second);
    with ``evolution_km`` [km] (None or 0: not run) the evolutions at the operating speed and
    on the drive cycle too, and where the bifurcation ``diagram`` (if given) has a hard
    region at one of their speeds, each again from the large stable cycle
    (``start="cycle"``, :mod:`polywear.wear.start`), with ``evolution``
    (:class:`~polywear.wear.evolution.EvolutionSettings`). ``progress``
    (:mod:`polywear.progress`) gets a message per stage and every tenth of an evolution's
    distance. Returns the wear results (:class:`WearSection`).
    """
    import matplotlib.pyplot as plt

    from ..io import atomic_path

    def save_result(result, name):
        with atomic_path(out_dir / name) as tmp:
            result.save(tmp)
    from ..wear.map import wear_map

    stage = StepCounter(progress)
    say = stage.begin
    say("polygonal wear: linear map")
    lo, hi = speed_range_kmh
    speeds = np.linspace(lo, hi, 300)
    m = wear_map(params, speeds)
    save_result(m, "wear_map.nc")
    op = params.operating.speed_kmh
    fig, ax = plt.subplots(figsize=(9, 5.5))
    m.plot(ax, sev_band_kmh=sev_band_kmh)
    ax.axvline(op, color="tab:green", lw=1.4, ls="-.", label=f"operating speed {op:g} km/h")
    handles, labels = ax.get_legend_handles_labels()
    unique = dict(zip(labels, handles))
    ax.legend(unique.values(), unique.keys(), fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=3)
    save(fig, "wear_map.png", "Wear-stability map: growth of every polygon order over speed (Campbell form), "
                              f"the operating speed {op:g} km/h dash-dotted; distances scale as 1/k_e")
    at = sorted({op, *(v for v, _ in params.wear.cycle_shares())})
    section = WearSection(m, wear_map(params, at))
    if evolution_km:
        runs = [("operating speed", ((op, 1.0),)), ("drive cycle", params.wear.cycle_shares())]
        hard = cycle_start_states(params, at, diagram) if diagram is not None else {}
        section.cycle_start_kmh = sorted(hard)
        for start, into, label, cycle in [("rest", section.evolutions, *run) for run in runs] + [
                ("cycle", section.from_cycle, *run) for run in runs if any(v in hard for v, _ in run[1])]:
            name = label if start == "rest" else label + FROM_CYCLE
            if into and tuple(cycle) == runs[0][1]:  # the cycle is the operating speed alone
                result = into[0][1]
            else:
                say(f"polygonal wear: evolution over {evolution_km:,.0f} km, {name}")
                try:
                    result = wear_evolution(params, evolution_km, cycle, evolution,
                                            progress=_tenths(stage.detail(f"evolution, {name}: ")), start=start)
                except StepBudgetError as stopped:
                    if stopped.partial is None:
                        raise
                    say(f"polygonal wear: the evolution {name} stopped at its step budget after "
                        f"{stopped.done_km:,.0f} km; the report keeps it up to there ({stopped})")
                    result = stopped.partial
            stem = evolution_stem(label, start)
            save_result(result, f"{stem}.nc")
            fig, ax = plt.subplots(figsize=(8, 4.5))
            result.plot(ax)
            save(fig, f"{stem}.png", f"Worn depth (log) and dominant order against distance, {name}, with the "
                                     f"visibility threshold {params.wear.visible_depth_mm:g} mm")
            fig = plt.figure(figsize=(5.5, 5.5))
            result.plot_polar(fig.add_subplot(projection="polar"))
            save(fig, f"{stem}_polar.png", f"The worn tire at four distances, {name} (depth exaggerated)")
            fig, ax = plt.subplots(figsize=(8, 4.5))
            result.plot_waterfall(ax)
            save(fig, f"{stem}_waterfall.png", f"Amplitude of every polygon order against distance, {name}")
            into.append((label, result))
    return section


def evolution_stem(label: str, start: str = "rest") -> str:
    """File stem of the evolution ``label`` (``"operating speed"`` or ``"drive cycle"``) from
    ``start`` (``"rest"`` or ``"cycle"``)."""
    stem = "wear_evolution_operating" if label == "operating speed" else "wear_evolution_cycle"
    return stem if start == "rest" else f"{stem}_from_cycle"


STEPS_BETWEEN_NOTES = 50
"""An evolution whose distance creeps (short steps near locking) still says where it is after
this many distance steps without a new tenth of its distance [-]."""


def _tenths(progress: Progress) -> Progress:
    """Forward an evolution's progress (km done, km in all) as a message at every tenth of the
    distance, and every STEPS_BETWEEN_NOTES steps in between, with the steps taken."""
    reached, steps, noted = [0], [0], [0]

    def forward(done: float, total: float | None, message: str = "") -> None:
        steps[0] += 1
        tenth = int(10.0 * done / total) if total else 0
        if tenth > reached[0] or steps[0] - noted[0] >= STEPS_BETWEEN_NOTES:
            reached[0], noted[0] = max(tenth, reached[0]), steps[0]
            progress(done, total, f"{done:,.0f} of {total:,.0f} km, {steps[0]} distance steps")

    return forward


def _where(ev: dict) -> str:
    """'on the drive cycle (30 % at 50 km/h, ...)' or 'at 110 km/h alone'."""
    if ev["label"].removesuffix(FROM_CYCLE) == "drive cycle":
        return "on the drive cycle (" + ", ".join(f"{c['share'] * 100:.0f} % at {c['speed_kmh']:g} km/h"
                                                  for c in ev["cycle"]) + ")"
    return f"at {ev['cycle'][0]['speed_kmh']:g} km/h alone"


def _outcome(ev: dict) -> str:
    """'an 8-sided polygon becomes visible (0.1 mm) after about 20,000 km' or 'no visible polygon
    within 100,000 km (0.031 mm peak to valley at the end, largest order 10)'."""
    if ev["visible_km"] is not None:
        sides = ev["dominant_order"]
        article = "an" if str(sides).startswith("8") or sides in (11, 18) else "a"  # an eight, an eleven
        return (f"{article} {sides}-sided polygon becomes visible ({ev['visible_depth_mm']:g} mm) "
                f"after about {_round_km(ev['visible_km'])} km")
    text = (f"no visible polygon within {ev['distance_km']:,.0f} km ({ev['final_depth_mm']:.3f} mm peak to valley "
            f"at the end, largest order {ev['dominant_order']})")
    if not ev.get("complete", True):
        text += (f"; the evolution stopped there, at its step budget, short of the {ev['requested_km']:,.0f} km asked "
                 "(its writes changed from window to window faster than its tolerance): beyond, not judged")
    return text


def wear_headline(section: dict) -> list[str]:
    """The answer at the top of the report, in a fleet engineer's words: how many sides,
    after how many km, on the drive cycle and at the operating speed alone; whether the
    vibration locks to the tire; and what the distances assume (k_e, initial roughness).
    Empty if no evolution was run."""
    evs = {ev["label"]: ev for ev in section["evolutions"] if ev.get("start", "rest") == "rest"}
    if not evs:
        return []
    first, *rest = [evs[k] for k in ("drive cycle", "operating speed") if k in evs]
    kicked = [ev for ev in section["evolutions"] if ev.get("start") == "cycle"]
    text = f"{_where(first)[0].upper()}{_where(first)[1:]}, {_outcome(first)}"
    for ev in rest:
        text += f"; {_where(ev)}, " + (f"after about {_round_km(ev['visible_km'])} km"
                                       if ev["visible_km"] is not None and ev["dominant_order"] == first["dominant_order"]
                                       and first["visible_km"] is not None else _outcome(ev))
    lines = [f"From steady rolling: {text[0].lower()}{text[1:]}." if kicked else text + "."]
    if kicked:
        lines.append(from_cycle_sentence(section, kicked))
    locking = []
    steady = {r["speed_kmh"] for r in section["map_rows"] if r["rolling_stable"]}
    for ev in [first, *rest]:
        for c in ev["cycle"]:
            nu = c["vibration_order_end"]
            if nu is None or any(c["speed_kmh"] == v for v, _ in locking):
                continue
            what = ("the tread's forced response to the growing pattern" if c["speed_kmh"] in steady
                    else "the tread vibrates and")
            locking.append((c["speed_kmh"], f"at {c['speed_kmh']:g} km/h {what} locks to the tire at "
                                            f"order {round(nu)}" if c.get("locked_at_end") else
                            f"at {c['speed_kmh']:g} km/h the tread vibrates at order {nu:.2f} without locking to the "
                            f"tire: its own pattern drifts round the tread and wears evenly"))
    if locking:
        sentence = "; ".join(t for _, t in locking)
        if not any(c.get("locked_at_end") for ev in [first, *rest] for c in ev["cycle"]):
            sentence += f"; the order that grows is the profile's own, {first['dominant_order']}"
        lines.append(sentence[0].upper() + sentence[1:] + ".")
    lines.append(_assumptions(section, [first, *rest]))
    return lines


def from_cycle_sentence(section: dict, kicked: list[dict]) -> str:
    """The outcome of the evolutions ``kicked`` that start on the large stable cycle (hard
    self-excitation at the speeds ``cycle_start_kmh`` of the ``section``), in words."""
    hard = section.get("cycle_start_kmh", [])
    speeds = ", ".join(f"{v:g}" for v in hard)
    parts = []
    for ev in kicked:
        text = f"{_where(ev)}, {_outcome(ev)}"
        for c in ev["cycle"]:
            if c["speed_kmh"] not in hard:
                continue
            nu = c["vibration_order_end"]
            text += (f" (at {c['speed_kmh']:g} km/h the large vibration dies out as the tire wears)" if nu is None else
                     f" (at {c['speed_kmh']:g} km/h the tread keeps vibrating at order {nu:.2f}, "
                     + ("locked to the tire)" if c.get("locked_at_end") else "without locking to the tire)"))
        parts.append(text)
    return (f"After a pothole starts the large vibration at {speeds} km/h (steady rolling is stable there, but a large "
            f"stable cycle coexists with it: hard self-excitation): " + "; ".join(parts) + ".")


def _assumptions(section: dict, evs: list[dict]) -> str:
    """What the distances assume: k_e (every distance scales as 1/k_e) and the initial
    roughness (the visible distance is the e-folds of growth from it)."""
    k_e = section["energetic_rate_mm3_per_j"]
    text = (f"These distances assume the energetic wear rate k_e = {k_e:g} mm³/J, known to about a factor of "
            f"{K_E_UNCERTAINTY:g} either way: every distance scales as 1/k_e ({K_E_UNCERTAINTY:g} times k_e, "
            f"{K_E_UNCERTAINTY:g} times sooner)")
    grown = [ev for ev in evs if ev.get("growth_efolds")]
    if grown:
        ev = grown[0]
        n, km = ev["growth_efolds"], ev["visible_km"]
        sooner = km * math.log(ROUGHNESS_FACTOR) / n
        text += (f"; and an initial roughness of {section['initial_roughness_um']:g} um RMS: {_where(ev)} the "
                 f"{ev['dominant_order']}-sided pattern grows by {n:.1f} e-folds (a factor {math.exp(n):,.0f}) "
                 f"until it is visible, so {ROUGHNESS_FACTOR:g} times the roughness takes about "
                 f"{_round_km(sooner)} km off")
    return text + "."


def wear_sentences(section: dict) -> list[str]:
    """The details in words, from the map rows and the evolutions."""
    lines = []
    for ev in section["evolutions"]:
        where = ", ".join(f"{c['speed_kmh']:g} km/h" for c in ev["cycle"])
        lines.append(f"{ev['label']} ({where}): {_outcome(ev)}.")
        for c in ev["cycle"]:
            if c["vibration_order_end"] is None:
                continue
            locked = c.get("locked_at_end", bool(c["locked_fraction"]))
            lines.append(f"at {c['speed_kmh']:g} km/h the tread vibrates at order {c['vibration_order_end']:.3f}, "
                         + ("locked to an integer order." if locked else
                            "not locked to an integer order: its own pattern drifts and wears evenly."))
    for row in section["map_rows"]:
        if not row["rolling_stable"]:
            lines.append(f"at {row['speed_kmh']:g} km/h steady rolling is unstable: vibrating, see the evolution.")
        elif row["efold_km"] is not None:
            lines.append(f"at {row['speed_kmh']:g} km/h order {row['order']} ({row['frequency_hz']:.0f} Hz) grows from "
                         f"small roughness, by e every {_round_km(row['efold_km'])} km.")
        else:
            lines.append(f"at {row['speed_kmh']:g} km/h every order heals.")
    lines.append(f"All distances scale as 1/k_e (k_e = {section['energetic_rate_mm3_per_j']:g} mm³/J).")
    return lines


def _round_km(km: float) -> str:
    digits = max(0, int(math.floor(math.log10(max(km, 1.0)))) - 1)
    return f"{round(km, -digits):,.0f}"


def wear_html(section: dict | None) -> str:
    """HTML fragment of the wear section ('' if the section was not computed)."""
    if not section:
        return ""
    e = html.escape
    rows = "".join(
        f"<tr><td>{r['speed_kmh']:g}</td>" + (
            f"<td colspan='4'>{e(r['note'])}</td>" if not r["rolling_stable"] else
            f"<td>{r['order']}</td><td>{r['frequency_hz']:.1f}</td>"
            f"<td>{'-' if r['efold_km'] is None else format(r['efold_km'], ',.0f')}</td>"
            f"<td>{r['drift_deg_per_rev']:.2e}</td>") + "</tr>"
        for r in section["map_rows"])
    evolutions = "".join(
        f"<tr><td>{e(ev['label'])}</td><td>{ev['distance_km']:,.0f}"
        + ("" if ev.get("complete", True) else f" of {ev['requested_km']:,.0f} (stopped at its step budget)")
        + f"</td><td>{ev['final_depth_mm']:.4f}</td>"
        f"<td>{ev['dominant_order']}</td><td>{'-' if ev['visible_km'] is None else format(ev['visible_km'], ',.0f')}</td></tr>"
        for ev in section["evolutions"])
    table = ("<table><tr><th>evolution</th><th>distance [km]</th><th>depth [mm]</th><th>dominant order</th>"
             f"<th>visible after [km]</th></tr>{evolutions}</table>") if evolutions else \
        ("<p>Evolution not run: turned off (<code>--wear-km 0</code> or <code>wear.report_km = 0</code>); "
         "<code>polywear report --wear-km 100000</code> or <code>polywear wear evolve</code> runs it.</p>")
    sentences = "".join(f"<li>{e(s)}</li>" for s in section["sentences"])
    headline = "".join(f"<p>{e(s)}</p>" for s in section.get("headline", []))
    return (f"<h2>Polygonal wear</h2>{headline}<ul>{sentences}</ul>"
            "<table><tr><th>speed [km/h]</th><th>most unstable order</th><th>frequency [Hz]</th>"
            f"<th>e-folding distance [km]</th><th>drift [deg/rev]</th></tr>{rows}</table>{table}")
