"""The main job: a full analysis of one parameter set, written to a folder with an HTML report.

Steps: linear stability, bifurcation diagram (continuation), the verdict at the
operating speed with wear indicators, phase portraits there from small and large
disturbances, exact sensitivities of the bifurcation speeds (Fig. 9), design options
that move the SEV band out of the operating range (Figs. 10-12), the wear map and the
wear evolutions (``wear.report_km``), and one verdict on vibration and wear together
(:mod:`.verdict`).
"""

from __future__ import annotations

import html
import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

from .. import __version__
from ..io import atomic_path, write_text
from ..parallel import on_one_blas_thread
from ..params import Params, to_toml
from ..progress import Progress, StepCounter
from ..results import Result, with_deprecated_keys
from ..units import DEFAULT_SPEED_RANGE_KMH

if TYPE_CHECKING:
    from ..dynamics.diagram import BifurcationDiagram
    from ..dynamics.design import DesignResult
    from ..dynamics.excitation import ExcitationResult
    from ..dynamics.sensitivity import SensitivityResult
    from ..dynamics.simulation import SimulationSet
    from ..dynamics.stability import StabilityResult
    from ..wear.map import WearMap
    from .wear import WearSection

__all__ = ["WEAR_DESIGN_REFINED_BY_DEFAULT", "Report", "ReportSettings", "operating_verdict", "report",
           "report_search"]

WEAR_DESIGN_REFINED_BY_DEFAULT = ("tread1dof",)
"""Models whose report, by default, refines the least change judged by the evolution (for
a car that vibrates on the drive cycle) to the search's accuracy: those where that fits the
main job's budget (tread1dof: about 20-30 s of CPU time on the default car, docs/wear.md).
The others (axle4dof: the refined search alone takes about 3.5 min on 2 cores) search one
grid level, screened, and refine it by one round (:func:`report_search`): the least change
is known to a third or two thirds of a grid step (+19 %/-16 %), and ``--wear-design``
refines it to 2 %."""


def report_search(refined: bool):
    """The report's :class:`~polywear.wear.design.WearDesignSettings`: the least change, one
    undecided probe per bracket; ``refined`` False: one grid level screened by
    :data:`~polywear.wear.design.SCREEN`, refined by one round."""
    from ..wear.design import SCREEN, Judge, WearDesignSettings

    search = WearDesignSettings(judge=Judge.EVOLUTION, least_only=True, max_undecided=1)
    return search if refined else replace(search, max_levels=1, refine_rounds=1, screen=SCREEN)


@dataclass(frozen=True)
class ReportSettings:
    """What :func:`report` ran with, resolved (the defaults filled in), recorded in its :class:`Report`."""

    speed_range_kmh: tuple[float, float]
    """Analysed speeds [km/h] (the range given, widened to hold the operating range)."""
    operating_range_kmh: tuple[float, float]
    """Speeds the design options keep free of SEV [km/h]."""
    wear_evolution_km: float
    """Distance of the wear evolutions [km] (0: not run)."""
    wear_design_by_evolution: bool
    """Whether the least change judged by the evolution is searched for a car that vibrates
    on the drive cycle (``--no-wear-design``: not)."""
    wear_design_refined: bool = True
    """Whether that search refines the least change to its accuracy (``--wear-design``; by
    default for the models in :data:`WEAR_DESIGN_REFINED_BY_DEFAULT`), else it searches one
    grid level and refines it by one round (:func:`report_search`)."""

    def __post_init__(self) -> None:
        for name in ("speed_range_kmh", "operating_range_kmh"):
            lo, hi = getattr(self, name)
            if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
                raise ValueError(f"ReportSettings: {name} = {(lo, hi)!r}: need finite low < high [km/h]")
        if not (math.isfinite(self.wear_evolution_km) and self.wear_evolution_km >= 0.0):
            raise ValueError(f"ReportSettings: wear_evolution_km = {self.wear_evolution_km!r}: must be >= 0 and finite")


@dataclass
class Report(Result):
    """Everything the main job computed: the result objects, the verdict at the operating
    speed and the files written (name -> caption). :meth:`summary` is ``summary.json``; as
    a :class:`~polywear.results.Result` its data, table and plot are those of its
    bifurcation diagram (``bifurcation.nc``, ``cycles.csv``)."""

    params: Params
    diagram: BifurcationDiagram
    """The bifurcation diagram over the analysed speeds."""
    verdict: dict
    """What happens at the operating speed (:func:`operating_verdict`)."""
    disturbances: SimulationSet
    """Runs at the operating speed from small and large disturbances (the phase portraits)."""
    sensitivity: SensitivityResult
    design: DesignResult
    wear: WearSection
    """The linear wear map, the map at the drive-cycle speeds and the evolutions if run."""
    portraits: ExcitationResult | None = None
    """Soft and hard self-excitation at a soft and a hard speed (empty if there is none)."""
    files: dict = field(default_factory=dict)
    overall: dict = field(default_factory=dict)
    """The one verdict on vibration and wear together (:func:`.verdict.verdict`)."""
    wear_design: dict | None = None
    """Where the tread vibrates on the drive cycle and its polygon becomes visible within the
    report's distance: the least change (of the design keys, those an engineer sets first)
    after which no polygon is visible within that distance, judged by the evolution
    (:func:`polywear.wear.design.wear_design` summary, ``least_only``); else None."""
    settings: ReportSettings | None = None
    """What the report ran with (:class:`ReportSettings`)."""

    @property
    def stability(self) -> StabilityResult:
        """Linear stability of steady rolling (the diagram's)."""
        return self.diagram.stability

    @property
    def wear_map(self) -> WearMap:
        return self.wear.wear_map

    def _dataset(self):
        """The bifurcation diagram's data (what ``bifurcation.nc`` holds)."""
        return self.diagram._dataset()

    def to_dataframe(self):
        """The bifurcation diagram's cycle table (what ``cycles.csv`` holds)."""
        return self.diagram.to_dataframe()

    def plot(self, ax=None):
        """The bifurcation diagram onto ``ax``. Returns artists."""
        return self.diagram.plot(ax)

    def summary(self) -> dict:
        """The JSON summary (``summary.json``, ``polywear report --json``), from the results."""
        return {
            "polywear_version": __version__,
            "model": self.params.model,
            "operating": self.verdict,
            "bifurcation": self.diagram.summary(),
            "sensitivity": self.sensitivity.summary(),
            "design": self.design.summary(),
            "wear": self.wear.summary(),
            "verdict": self.overall,
            "wear_design": self.wear_design,
        }


def operating_verdict(diagram, params: Params, speed_kmh: float) -> dict:
    """What happens at one speed: the regime, amplitude and frequency, trigger, wear indicators.

    Regimes: ``"no SEV"``, ``"unstable rolling (soft SEV)"``, ``"hard SEV region"`` (a
    stable cycle of the continuation there), and, where steady rolling is unstable or the
    speed lies in the SEV band but no continued cycle is stable, the motion a simulation
    reaches (:func:`polywear.dynamics.attractor.reached_attractors`): period-multiplied
    (stick-slip), quasi-periodic or chaotic, a cycle off the continued branches, or
    static divergence (a real eigenvalue: the tread drifts, it does not vibrate). The same
    simulation decides a speed in a gap of the SEV band of a diagram with period doublings
    or torus bifurcations (``in_band_gap_after_pd_ns``): the band counts period-1 cycles
    only, and the motions past those bifurcations can persist where steady rolling is
    stable (measured: chaotic SEV of 0.56 mm at 58 km/h in such a gap, 56.55-59.75 km/h).
    """
    import numpy as np

    from ..dynamics.attractor import Regime, reached_attractors
    from ..dynamics.diagram import statically_divergent
    from ..wear.indicators import wear_indicators
    from ..models import model_for
    from ..units import kmh_to_ms

    model = model_for(params)
    p = model.pack(params)
    x = diagram.state_names.index("x")
    V = kmh_to_ms(speed_kmh)
    lam = np.linalg.eigvals(model.jacobian(model.equilibrium(V, p), V, p))
    rolling_stable = not np.any(lam.real > 0.0)
    divergent = statically_divergent(lam)
    sev = diagram.sev_band_kmh
    in_sev = any(a <= speed_kmh <= b for a, b in sev)
    in_gap = any(a < speed_kmh < b for a, b in diagram.gaps_after_pd_ns_kmh)
    cycles = diagram.cycles_at(speed_kmh) if (in_sev or not rolling_stable) else []
    stable = [c for c in cycles if c.stable]
    unstable = [c for c in cycles if not c.stable]
    verdict = {
        "speed_kmh": speed_kmh,
        "steady_rolling_stable": rolling_stable,
        "in_sev_band": in_sev,
        "in_band_gap_after_pd_ns": in_gap,
    }
    if divergent:
        verdict["divergence"] = True
    if stable:
        big = stable[-1]
        verdict["regime"] = Regime.HARD if rolling_stable else Regime.SOFT
        verdict["sev_amplitude_x_mm"] = 1e3 * float(big.amplitude[x])
        verdict["frequency_hz"] = 1.0 / big.period
        verdict["wear"] = wear_indicators(model, p, big.orbit, params.operating.rolling_radius_m).summary()
    elif in_sev or not rolling_stable or in_gap:
        found, *others = reached_attractors(diagram, speed_kmh)
        verdict["regime"] = found.regime
        verdict["attractor"] = found.summary()
        verdict["other_attractors"] = [a.summary() for a in others]
        if found.oscillating:
            verdict["sev_amplitude_x_mm"] = 1e3 * float(found.amplitude[x])
            verdict["frequency_hz"] = found.dominant_frequency_hz
    else:
        verdict["regime"] = Regime.NO_SEV
    if unstable and rolling_stable and "sev_amplitude_x_mm" in verdict:
        verdict["trigger_amplitude_x_mm"] = 1e3 * float(min(c.amplitude[x] for c in unstable))
    open_at = diagram.open_edges
    if sev:
        verdict["margin_to_first_bifurcation_kmh"] = None if "lower" in open_at else sev[0][0] - speed_kmh
        verdict["margin_to_second_bifurcation_kmh"] = None if "upper" in open_at else sev[-1][1] - speed_kmh
    return with_deprecated_keys(verdict, {"sev_amplitude_x_mm": ("sev_amplitude_x_m", 1e-3),
                                          "trigger_amplitude_x_mm": ("trigger_amplitude_x_m", 1e-3)})


def _sentence(v: dict) -> str:
    s = f"At {v['speed_kmh']:.0f} km/h: "
    regime = v["regime"]
    if regime == "no SEV" and "attractor" not in v:
        return s + "no self-excited vibration; steady rolling is stable and no stable limit cycle exists."
    if "attractor" in v:
        a = v["attractor"]
        rolling = ("steady rolling is unstable (static divergence: a real eigenvalue)" if v.get("divergence")
                   else "steady rolling is unstable" if not v["steady_rolling_stable"]
                   else "steady rolling is stable")
        s += f"{rolling} and no continued period-1 cycle is stable; a {a['simulated_s']:g} s simulation from {a['start']} "
        s += f"ends in {_motion(a)}."
        for other in v.get("other_attractors", []):
            s += f" From {other['start']} it ends in {_motion(other)} instead (coexisting attractors)."
        return s
    w = v["wear"]
    s += (
        f"self-excited vibration of {v['sev_amplitude_x_mm']:.3f} mm at {w['frequency_hz']:.1f} Hz "
        f"(frequency order {w['frequency_order']:.2f}, RMS tread acceleration {w['rms_acceleration']:.0f} m/s², "
        f"uneven-wear index {w['uneven_wear_index']:.3f})"
    )
    if v["steady_rolling_stable"]:  # a stable cycle with stable rolling: the hard SEV region
        s += (
            f"; steady rolling is stable, but a disturbance of the tread above "
            f"{v.get('trigger_amplitude_x_mm', float('nan')):.3f} mm starts it (hard excitation)."
        )
    else:
        s += "; steady rolling is unstable, so any disturbance starts it."
    return s


def text_summary(summary: dict) -> list[str]:
    """The report's result as lines of text: the verdict at a glance, the verdict, the SEV
    band (``open`` at an open edge), and the bifurcations besides Hopf points and folds (PD,
    NS, static divergence)."""
    b = summary["bifurcation"]
    lines = ([*summary["verdict"]["glance"], "", *summary["verdict"]["lines"][:-1]] if summary.get("verdict")
             else [_sentence(summary["operating"])])
    if b["sev_band_kmh"]:
        first, second = b["first_bifurcation_speed_kmh"], b["second_bifurcation_speed_kmh"]
        lo, hi = b["speed_range_kmh"]
        lines.append(
            "SEV band (first/second bifurcation speed): "
            f"{f'{first:.1f}' if first is not None else f'open below {lo:g}'} - "
            f"{f'{second:.1f}' if second is not None else f'open above {hi:g}'} km/h"
        )
    for name, key in (("period doubling", "period_doublings"), ("torus bifurcation", "torus_bifurcations"),
                      ("static divergence (real eigenvalue crossing)", "real_eigenvalue_crossings_kmh")):
        if b.get(key):
            lines.append(f"{name} at {', '.join(f'{v:.1f}' for v in b[key])} km/h")
    design = summary["design"]
    lo, hi = design["operating_range_kmh"]
    first = next((o for o in design["options"] if o["achieved"]), None)
    if first or not summary.get("verdict", {}).get("polygon_visible"):  # else "nothing to move" misleads
        lines.append(f"design for {lo:g}-{hi:g} km/h: "
                     + (first["text"] if first else design["reason"] or "no option clears the range (see report.html)"))
    if summary.get("verdict"):
        lines.append(summary["verdict"]["lines"][-1])
    return lines


def _motion(a: dict) -> str:
    """One attractor (an ``Attractor.summary()``) in words."""
    if a["regime"] == "static divergence":
        return (f"static divergence, not SEV: no oscillation, {a['offset_x_mm']:+.3f} mm away from "
                "steady rolling")
    if a["regime"] == "no SEV":
        return "steady rolling: no self-excited vibration"
    mpp = f", {a['maxima_per_period']} maxima of x per period" if a["maxima_per_period"] > 1 else ""
    return (f"{a['regime']}: {a['amplitude_x_mm']:.3f} mm at a dominant frequency of "
            f"{a['dominant_frequency_hz']:.1f} Hz{mpp}")


@on_one_blas_thread
def report(
    params: Params,
    out_dir: Path,
    speed_range_kmh: tuple[float, float] = DEFAULT_SPEED_RANGE_KMH,
    operating_range_kmh: tuple[float, float] | None = None,
    progress: Progress | None = None,
    wear_evolution_km: float | None = None,
    wear_design_by_evolution: bool | None = None,
    cornering_stiffness: tuple[float, str] | None = None,
) -> Report:
    """Run the main job and write figures, data, ``summary.json`` and ``report.html`` to ``out_dir``.

    ``progress(stages done, None, message)`` is called before each stage (and with the
    design diagrams), :mod:`polywear.progress`. This is ``polywear report`` and ``pw.report``.

    Parameters
    ----------
    params : Params
        The parameter set; ``operating.speed_kmh`` is the speed of the verdict.
    out_dir : path
        Output folder (created if missing).
    speed_range_kmh : (float, float)
        Speeds of the analysis [km/h].
    operating_range_kmh : (float, float), optional
        Speeds to keep free of SEV [km/h] for the design options (default: the
        operating speed -30/+20 km/h).
    progress : callable, optional
        Progress callback (:mod:`polywear.progress`); the message names the stage.
    wear_evolution_km : float, optional
        Distance [km] of the wear evolutions at the operating speed and on the drive cycle
        (default ``wear.report_km``; 0: not run); the wear map is always in the report.
    wear_design_by_evolution : bool, optional
        For a car that vibrates on the drive cycle and wears a visible polygon within
        ``wear_evolution_km``: the least change (toe, camber, bushings, tread; adhesion only
        where none of those does it) after which the evolution shows no polygon within that
        distance (about ten to twenty evolutions, side by side; ``polywear report
        --wear-design / --no-wear-design``). True: refined to the search's accuracy; False:
        not searched. Default: refined where that fits the main job's budget
        (:data:`WEAR_DESIGN_REFINED_BY_DEFAULT`, tread1dof), else one grid level of the
        search (axle4dof: +19 %/-16 % of each key) refined by one round (:func:`report_search`).
    cornering_stiffness : (float, str), optional
        The tire's cornering stiffness C_alpha [N/rad] and where it comes from (a .tir
        file's, at the load), against which the point contact's lateral force is judged
        (default: :data:`.verdict.C_ALPHA_N_PER_RAD`, a passenger tire's).

    Returns
    -------
    Report
        The results (diagram, runs, sensitivities, design options, wear), the verdict and
        the files written; ``summary()`` is what ``summary.json`` holds.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..dynamics.bifurcation import bifurcation
    from ..dynamics.design import default_operating_range, design
    from ..dynamics.sensitivity import sensitivity
    from ..dynamics.simulation import simulate_disturbances

    stage = StepCounter(progress)
    say = stage.begin
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    files: dict[str, str] = {}
    speed = params.operating.speed_kmh
    operating_range = operating_range_kmh or default_operating_range(speed)
    # the analysed range holds the operating range (the diagram widens it further where needed)
    speed_range_kmh = (min(speed_range_kmh[0], operating_range[0]), max(speed_range_kmh[1], operating_range[1]))

    def save(fig, name, caption):
        with atomic_path(out_dir / name) as tmp:
            fig.savefig(tmp, dpi=120, bbox_inches="tight")
        plt.close(fig)
        files[name] = caption

    def save_result(result, name):
        with atomic_path(out_dir / name) as tmp:
            result.save(tmp)

    say("bifurcation diagram (continuation)")
    diagram = bifurcation(params, speed_range_kmh)
    save_result(diagram, "bifurcation.nc")
    save_result(diagram, "cycles.csv")
    files["bifurcation.nc"] = "bifurcation diagram: branch table and equilibria (netCDF)"
    files["cycles.csv"] = "cycle branch table (CSV)"
    save(diagram.figure(operating_range_kmh=operating_range), "bifurcation.png",
         "Bifurcation diagram: amplitude of every coordinate against speed, with the operating speed and range "
         "(paper Fig. 6)")
    fig, ax = plt.subplots(figsize=(7, 4))
    diagram.stability.plot(ax)
    save(fig, "stability.png", "Real parts of the eigenvalues of steady rolling against speed")

    say("verdict at the operating speed")
    verdict = operating_verdict(diagram, params, speed)

    say("phase portraits at the operating speed")
    runs = simulate_disturbances(params, [1e-5, 1e-4, 1e-3], speed_kmh=speed, duration_s=1.0)
    from ..dynamics.excitation import default_speeds, excitation

    speeds = default_speeds(diagram, speed)
    portraits = excitation(diagram, speeds)
    if portraits:
        save(portraits.figure(), "excitation.png",
             "Soft and hard self-excitation: cycles from the continuation and trajectories from inside and "
             "outside them (paper Fig. 2)")
    save(runs.plot()[0].figure, "phase_portraits.png", f"Phase portraits at {speed:g} km/h from small and large disturbances (paper Fig. 5)")

    say("exact sensitivities of the bifurcation speeds")
    sens = sensitivity(params, diagram=diagram)
    save_result(sens, "sensitivity.csv")
    files["sensitivity.csv"] = "sensitivity rows (CSV)"
    if sens.rows:
        save(sens.figure(), "sensitivity.png", "Normalized sensitivities S = (p/V) dV/dp of every bifurcation speed (paper Fig. 9)")

    say("design options for the operating range")
    options = design(params, operating_range, speed_range_kmh=speed_range_kmh, diagram=diagram,
                     progress=stage.detail("design diagram: "))
    if options.best is not None:
        fig, ax = plt.subplots(figsize=(8, 4.5))
        options.plot(ax)
        save(fig, "design.png", f"Original bifurcation diagram and the first-ranked design option, "
                                f"{options.best.change_text()} (paper Figs. 10-12)")

    from .wear import wear_section

    sev = diagram.sev_band_kmh
    km = params.wear.report_km if wear_evolution_km is None else wear_evolution_km
    wear = wear_section(params, speed_range_kmh, save, out_dir, km,
                        sev_band_kmh=(sev[0][0], sev[-1][1]) if sev and None not in (sev[0][0], sev[-1][1]) else None,
                        progress=stage.detail(""), diagram=diagram)
    files.update(_wear_data_files(wear))

    from ..wear.design import cycle_growth, wear_design

    stops = None
    refined = wear_design_by_evolution or (wear_design_by_evolution is None
                                           and params.model in WEAR_DESIGN_REFINED_BY_DEFAULT)
    wear_design_by_evolution = wear_design_by_evolution is not False
    worn = dict(wear.evolutions).get("drive cycle")
    if (wear_design_by_evolution and worn is not None and worn.complete and worn.visible_km is not None
            and not cycle_growth(params)[2]):  # vibrates on the cycle and wears a visible polygon
        say("what stops the polygon: the least change judged by the evolution"
            + ("" if refined else " (one grid level, one round; --wear-design refines it)"))
        stops = wear_design(params, target_km=km, settings=report_search(refined),
                            progress=stage.detail("wear design: "), nominal=worn).summary()

    say("one verdict: vibration and wear together, design options judged by the wear")
    from .verdict import verdict as overall_verdict

    result = Report(params, diagram, verdict, runs, sens, options, wear, portraits, files, wear_design=stops,
                    settings=ReportSettings(speed_range_kmh, operating_range, km, wear_design_by_evolution, refined))
    result.overall = overall_verdict(result.summary(), params, _sentence(verdict), cornering_stiffness)
    summary = result.summary()
    write_text(out_dir / "summary.json", json.dumps(summary, indent=2, default=float))
    write_text(out_dir / "params.toml", to_toml(params))
    files["summary.json"] = "everything above as JSON"
    files["params.toml"] = "the parameter set used"
    files["report.html"] = "this report"
    write_text(out_dir / "report.html", _html(params, summary, files))
    stage()
    return result


def _wear_data_files(wear: WearSection) -> dict[str, str]:
    """The data files the wear section writes (name -> caption): the map, and each evolution's."""
    from .wear import FROM_CYCLE, evolution_stem

    files = {"wear_map.nc": "linear wear map: growth of every polygon order at every speed (netCDF)"}
    for label, _ in wear.evolutions:
        stem = "wear_evolution_operating" if label == "operating speed" else "wear_evolution_cycle"
        files[f"{stem}.nc"] = f"wear evolution, {label}: worn profile w(distance, angle) and its harmonics (netCDF)"
    for label, _ in wear.from_cycle:
        files[f"{evolution_stem(label, 'cycle')}.nc"] = (f"wear evolution, {label}{FROM_CYCLE}: worn profile "
                                                          "w(distance, angle) and its harmonics (netCDF)")
    return files


def _html(params: Params, summary: dict, files: dict) -> str:
    from .verdict import top_sensitivities
    from .wear import wear_html

    b = summary["bifurcation"]
    e = html.escape

    range_lo, range_hi = b["speed_range_kmh"]

    def edge(v, limit, word):  # None: the band is open at that end of the analysed range
        return f"{v:.1f}" if v is not None else f"{word} {limit:g}"

    def band(bands):
        return ", ".join(f"{edge(lo, range_lo, 'below')}-{edge(hi, range_hi, 'above')} km/h" for lo, hi in bands) or "none"

    rows = "".join(
        f"<tr><td>Hopf</td><td>{h['speed_kmh']:.2f}</td><td>{h['frequency_hz']:.1f}</td><td>{e(h['criticality'])}, mode {e(h['mode'])}</td></tr>"
        for h in b["hopf_points"]
    ) + "".join(
        f"<tr><td>fold of cycles</td><td>{f['speed_kmh']:.2f}</td><td>{f['frequency_hz']:.1f}</td><td>amplitude {f['amplitude_x_mm']:.3f} mm</td></tr>"
        for f in b["folds"]
    ) + "".join(
        f"<tr><td>{label}</td><td>{v:.2f}</td><td></td><td>{note}</td></tr>"
        for label, key, note in (
            ("period doubling", "period_doublings", "a Floquet multiplier crosses -1: the period-1 cycle hands over to a doubled one"),
            ("torus (Neimark-Sacker)", "torus_bifurcations", "a complex pair of multipliers leaves the unit circle"),
            ("static divergence", "real_eigenvalue_crossings_kmh", "a real eigenvalue of steady rolling crosses zero (no oscillation)"),
        )
        for v in b.get(key, [])
    )
    notes = "".join(f"<li>{e(n)}</li>" for n in [*b.get("range_notes", []), *b.get("continuation_notes", []), *b.get("warnings", [])])
    sens_notes = "".join(f"<li>{e(n)}</li>" for n in summary["sensitivity"].get("notes", []))
    sens_rows = "".join(
        f"<tr><td>{e(r['label'])}</td><td>{e(r['param'])}</td><td>{_signed(r['first'])}</td><td>{_signed(r['second'])}</td></tr>"
        for r in top_sensitivities(summary["sensitivity"], n=len(summary["sensitivity"]["rows"])))
    figures = "".join(
        f"<figure><img src='{e(name)}' alt='{e(caption)}'><figcaption>{e(caption)}</figcaption></figure>"
        for name, caption in files.items()
        if name.endswith(".png")
    )
    file_list = "".join(f"<li><a href='{e(n)}'>{e(n)}</a>: {e(c)}</li>" for n, c in files.items())
    return f"""<!doctype html>
<html><head><meta charset="utf-8"><title>polywear report: {e(params.model)}</title>
<style>body{{font-family:sans-serif;max-width:960px;margin:2em auto;color:#222}}
table{{border-collapse:collapse}}td,th{{border:1px solid #ccc;padding:3px 8px;text-align:left}}
figure{{margin:1.5em 0}}img{{max-width:100%}}.verdict{{background:#fff4e0;padding:1em;border-left:4px solid #e69500}}
.glance{{font-size:1.1em}}.glance li{{margin:.3em 0}}</style>
</head><body>
<h1>polywear report: {e(params.model)}</h1>
<ul class="glance">{"".join(f"<li>{_glance_item(line)}</li>" for line in summary["verdict"]["glance"])}</ul>
<div class="verdict">{"".join(f"<p>{e(line)}</p>" for line in summary["verdict"]["lines"])}</div>
<h2>Speed bands</h2>
<ul><li>steady rolling unstable (linear band): {band(b['linear_band_kmh'])}</li>
<li>SEV after a large disturbance (first to second bifurcation speed): {band(b['sev_band_kmh'])}</li>
<li>hard excitation (stable rolling and stable SEV coexist): {band(b['hard_regions_kmh'])}</li>
{f"<li>static divergence (steady rolling unstable through a real eigenvalue; it drifts, it does not vibrate): {band(b['divergence_kmh'])}</li>" if b.get('divergence_kmh') else ""}</ul>
<p>Analysed speed range {range_lo:g}-{range_hi:g} km/h.</p><ul>{notes}</ul>
<table><tr><th>point</th><th>speed [km/h]</th><th>frequency [Hz]</th><th></th></tr>{rows or "<tr><td colspan='4'>no Hopf point, fold or other bifurcation in the analysed range</td></tr>"}</table>
<h2>Sensitivities</h2>{f"<ul>{sens_notes}</ul>" if sens_notes else ""}{
    "<p>Normalized sensitivities S = (p/V) dV/dp of the SEV band's edges (1 % more of the parameter moves the "
    "speed by S %), largest first (sensitivity.png, sensitivity.csv):</p><table><tr><th>parameter</th><th>key</th>"
    f"<th>S, first bifurcation speed</th><th>S, second</th></tr>{sens_rows}</table>" if sens_rows else
    "<p>No edge of an SEV band in the analysed range: no sensitivities.</p>"}
<h2>Design options for {summary['design']['operating_range_kmh'][0]:.0f}-{summary['design']['operating_range_kmh'][1]:.0f} km/h</h2>
{_design_html(summary["design"], summary["verdict"])}{_wear_design_html(summary["wear_design"])}
{wear_html(summary.get("wear"))}
{figures}
<h2>Files</h2><ul>{file_list}</ul>
<h2>Parameters</h2><pre>{e(to_toml(params))}</pre>
<p>polywear {e(__version__)}</p>
</body></html>
"""


def _signed(value: float | None) -> str:
    """A sensitivity with its sign, or a dash where the edge has none."""
    return "&mdash;" if value is None else f"{value:+.2f}".replace("-", "&minus;")


def _glance_item(line: str) -> str:
    """One line of the glance, its label (up to the first colon) in bold."""
    label, sep, rest = line.partition(": ")
    return f"<b>{html.escape(label)}:</b> {html.escape(rest)}" if sep else html.escape(line)


def _wear_design_html(found: dict | None) -> str:
    """What stops the polygon for a car that vibrates on the drive cycle (the least change
    judged by the evolution, the bracket the search left, the undecided probes and why the
    other keys give no option), or nothing."""
    from ..dynamics.design import signed_percent
    from .verdict import search_accuracy_note

    if found is None:
        return ""
    e = html.escape
    km = found["target_km"]
    head = (f"<p>What stops the polygon, judged by the nonlinear evolution over {km:,.0f} km on the drive cycle "
            f"(the tread vibrates there, so the linear wear map does not apply; {found['evolutions']} evolutions): ")
    ev = found["nominal_evolution"]
    if ev is not None and ev["visible_km"] is None:
        return head + "nothing to change: no polygon becomes visible within that distance.</p>"
    lines = []
    for o in found["options"]:
        text = (f"{e(o['label'])} {o['nominal']:.4g} &rarr; {o['value']:.4g} ({signed_percent(o['relative_change'])}): "
                f"depth {o['evolution']['depth_mm']:.3f} mm after {km:,.0f} km, no visible polygon")
        other = o.get("other_direction")
        if other is not None:
            text += (f"; {other['value']:.4g} ({signed_percent(other['relative_change'])}) does it too (depth "
                     f"{other['evolution']['depth_mm']:.3f} mm, no visible polygon)")
        below = o["below"]
        if below is not None:
            text += (f"; at {below['value']:.4g} ({signed_percent(below['relative_change'])}) "
                     + (f"visible after {below['visible_km']:,.0f} km" if below["visible_km"] is not None
                        else "not an option"))
        else:
            text += f"; the car as it is: visible after {ev['visible_km']:,.0f} km"
        between = [u for u in found["undecided"] if u["key"] == o["key"]]
        if between:
            text += ("; undecided at " + ", ".join(f"{u['value']:.4g}" for u in between)
                     + " (the evolution stopped at its step budget: the profile changes faster than its steps there)")
        if note := search_accuracy_note(found, o):
            text += f" ({e(note)})"
        lines.append(text)
    notes = "".join(f"<li>{e(n)}</li>" for n in found["not_found"])
    if not lines:
        return head + "no change within the search finds it:</p><ul>" + notes + "</ul>"
    return (head + "the least change, then any other found at the same step of the search "
            "(what an engineer sets first):</p><ul>" + "".join(f"<li>{line}</li>" for line in lines) + "</ul>"
            + (f"<p>The other parameters:</p><ul>{notes}</ul>" if notes else ""))


def _design_html(design: dict, verdict: dict) -> str:
    """The design section: the ranked options as a table (signed changes with units, the
    bound flag, what each does to the band and, from the ``verdict``'s judgements in the
    same order, to the wear), or why there are none."""
    e = html.escape
    lo, hi = design["operating_range_kmh"]
    wear = verdict.get("design_options") or []
    if not design["options"]:
        reason = design.get("reason") or f"the SEV band does not reach the operating range {lo:g}-{hi:g} km/h"
        worn = (" That is the vibration only: the tire still wears into a polygon (see the verdict at the top)."
                if verdict.get("polygon_visible") else "")
        return f"<p>No design option for the SEV band: {e(reason)}{worn}</p>"
    bound = design["max_relative_change"]
    groups = {"alignment": "you control", "axle bushing": "you control", "tread": "you control",
              "road/compound": "road/compound (friction, not a vehicle setting)", "other": "other"}
    rows = []
    for o, judged in zip(design["options"], wear or [None] * len(design["options"])):
        if o["relative_change"] == 0.0:  # nothing computed (see the note)
            change, relative = e(" + ".join(o["labels"])), "&mdash;"
        else:
            change = "<br>".join(f"{e(label)} {e(c)}" for label, c in zip(o["labels"], o["value_changes"]))
            relative = ", ".join(f"{r * 100:+.1f} %".replace("-", "&minus;") for r in o["relative_changes"])
        if o["achieved"]:
            status = f"yes, {e(o['outcome'])}" + ("" if o["within_bound"] else f" <b>(beyond the &plusmn;{bound * 100:g} % bound)</b>")
        else:
            status = f"no: {e(o['note'])}"
        bands = ("&mdash;" if o["relative_change"] == 0.0
                 else ", ".join(f"{a:.1f}-{b:.1f} km/h" for a, b in o["sev_band_kmh"]) or "none")
        worn = "&mdash;" if judged is None else (f"<b>{e(judged['text'])}</b>" if judged["sooner"] else e(judged["text"]))
        rows.append(f"<tr><td>{e(groups[o['category']])}</td><td>{change}</td><td>{relative}</td><td>{status}</td>"
                    f"<td>{bands}</td><td>{worn}</td></tr>")
    return (f"<p>Least change of each parameter that keeps the SEV band {design['margin_kmh']:g} km/h clear of "
            f"{lo:g}-{hi:g} km/h, both directions searched, each verified by a full bifurcation diagram. "
            f"Parameters you control come first; adhesion (tread-road friction) is a road or compound option. "
            f"Changes beyond &plusmn;{bound * 100:g} % are flagged. Each option is judged by the wear too: the "
            "linear wear map with the option's parameters at the operating speed and on the drive cycle; an "
            "option that brings the polygon sooner is in bold.</p>"
            "<table><tr><th>option</th><th>change</th><th>relative change</th><th>range cleared</th>"
            f"<th>SEV band after</th><th>wear</th></tr>{''.join(rows)}</table>")

