"""The wear section of the report: the linear wear map, optionally the evolution at the
operating speed and on the drive cycle, and the verdict in words (``docs/wear.md``)."""

from __future__ import annotations

import html
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..wear.evolution import EvolutionResult, EvolutionSettings, evolve
from ..params import Params

if TYPE_CHECKING:
    from ..wear.map import WearMap
from ..progress import Progress, StepCounter

__all__ = ["WearSection", "wear_section", "wear_html", "wear_sentences"]


@dataclass
class WearSection:
    """The report's wear results: the linear map over the speed range, the map at the
    operating and drive-cycle speeds, and the evolutions ``(label, result)`` if run."""

    wear_map: WearMap
    points: WearMap
    evolutions: list[tuple[str, EvolutionResult]] = field(default_factory=list)

    def summary(self) -> dict:
        """The JSON-ready wear section of ``summary.json``, with the verdict in words."""
        out = {"map_rows": self.points.summary()["rows"],
               "linear_band_kmh": [list(b) for b in self.wear_map.linear_band_kmh],
               "energetic_rate_mm3_per_j": self.wear_map.params.wear.energetic_rate_mm3_per_j,
               "evolutions": [{"label": label, **result.summary()} for label, result in self.evolutions]}
        out["sentences"] = wear_sentences(out)
        return out


def wear_section(params: Params, speed_range_kmh, save, out_dir, evolution_km: float | None = None,
                 evolution: EvolutionSettings = EvolutionSettings(step_km=2000.0), sev_band_kmh=None,
                 progress: Progress | None = None) -> dict:
    """Compute the wear section; figures through ``save(fig, name, caption)``.

    The map over ``speed_range_kmh`` [km/h] (300 speeds) is always computed (about a second);
    with ``evolution_km`` [km] the evolution at the operating speed and on the drive cycle too
    (minutes), with ``evolution`` (:class:`~polywear.wear.evolution.EvolutionSettings`, here
    2000 km steps). ``progress`` (:mod:`polywear.progress`) counts these stages. Returns the
    wear results (:class:`WearSection`).
    """
    import matplotlib.pyplot as plt

    from ..io import atomic_path

    def save_result(result, name):
        with atomic_path(out_dir / name) as tmp:
            result.save(tmp)
    from ..wear.map import wear_map

    say = StepCounter(progress).begin
    say("polygonal wear: linear map")
    lo, hi = speed_range_kmh
    speeds = np.linspace(lo, hi, 300)
    m = wear_map(params, speeds)
    save_result(m, "wear_map.nc")
    fig, ax = plt.subplots(figsize=(9, 5.5))
    m.plot(ax, sev_band_kmh=sev_band_kmh)
    save(fig, "wear_map.png", "Wear-stability map: growth of every polygon order over speed (Campbell form); "
                              "distances scale as 1/k_e")
    op = params.operating.speed_kmh
    at = sorted({op, *(v for v, _ in params.wear.cycle_shares())})
    section = WearSection(m, wear_map(params, at))
    if evolution_km:
        runs = [("operating speed", ((op, 1.0),)), ("drive cycle", params.wear.cycle_shares())]
        for label, cycle in runs:
            say(f"polygonal wear: evolution over {evolution_km:,.0f} km, {label}")
            result = evolve(params, evolution_km, cycle, evolution)
            stem = "wear_evolution_operating" if label == "operating speed" else "wear_evolution_cycle"
            save_result(result, f"{stem}.nc")
            fig, ax = plt.subplots(figsize=(8, 4.5))
            result.plot(ax)
            save(fig, f"{stem}.png", f"Worn depth and dominant order against distance, {label}")
            fig = plt.figure(figsize=(5.5, 5.5))
            result.plot_polar(fig.add_subplot(projection="polar"))
            save(fig, f"{stem}_polar.png", f"The worn tire at four distances, {label}")
            section.evolutions.append((label, result))
    return section


def wear_sentences(section: dict) -> list[str]:
    """The verdict in words, from the map rows and the evolutions."""
    lines = []
    for ev in section["evolutions"]:
        where = ", ".join(f"{c['speed_kmh']:g} km/h" for c in ev["cycle"])
        if ev["visible_km"] is not None:
            lines.append(f"{ev['label']} ({where}): a {ev['dominant_order']}-sided polygon becomes visible "
                         f"({ev['visible_depth_mm']:g} mm) after about {_round_km(ev['visible_km'])} km.")
        else:
            lines.append(f"{ev['label']} ({where}): no visible polygon within {ev['distance_km']:,.0f} km "
                         f"(depth {ev['final_depth_mm']:.3f} mm, dominant order {ev['dominant_order']}).")
        for c in ev["cycle"]:
            if c["vibration_order_end"] is None:
                continue
            state = "locked to" if c["locked_fraction"] else "not locked to"
            lines.append(f"at {c['speed_kmh']:g} km/h the tread vibrates at order {c['vibration_order_end']:.3f}, "
                         f"{state} an integer order" + ("" if c["locked_fraction"] else
                                                        ": its own pattern drifts and wears evenly") + ".")
    for row in section["map_rows"]:
        if not row["rolling_stable"]:
            lines.append(f"at {row['speed_kmh']:g} km/h steady rolling is unstable: vibrating, see the evolution.")
        elif row["efold_km"] is not None:
            lines.append(f"at {row['speed_kmh']:g} km/h order {row['order']} ({row['frequency_hz']:.0f} Hz) grows from "
                         f"small roughness, by e every {_round_km(row['efold_km'])} km.")
        else:
            lines.append(f"at {row['speed_kmh']:g} km/h every order heals.")
    lines.append(f"All distances scale as 1/k_e (k_e = {section['energetic_rate_mm3_per_j']:g} mm^3/J).")
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
        f"<tr><td>{e(ev['label'])}</td><td>{ev['distance_km']:,.0f}</td><td>{ev['final_depth_mm']:.4f}</td>"
        f"<td>{ev['dominant_order']}</td><td>{'-' if ev['visible_km'] is None else format(ev['visible_km'], ',.0f')}</td></tr>"
        for ev in section["evolutions"])
    table = ("<table><tr><th>evolution</th><th>distance [km]</th><th>depth [mm]</th><th>dominant order</th>"
             f"<th>visible after [km]</th></tr>{evolutions}</table>") if evolutions else \
        "<p>Evolution not run (<code>polywear report --wear-km 60000</code>, or <code>polywear wear evolve</code>).</p>"
    sentences = "".join(f"<li>{e(s)}</li>" for s in section["sentences"])
    return (f"<h2>Polygonal wear</h2><ul>{sentences}</ul>"
            "<table><tr><th>speed [km/h]</th><th>most unstable order</th><th>frequency [Hz]</th>"
            f"<th>e-folding distance [km]</th><th>drift [deg/rev]</th></tr>{rows}</table>{table}")
