"""The one verdict at the top of the report: does the tread vibrate, does the tire wear
into a polygon (from the vibration or from a forced resonance at stable rolling), when,
and what to change so that neither happens (``docs/wear_and_design.md``).

Every design option (which moves the SEV band) is judged by the wear too: the linear
wear map with the option's parameters at the operating speed and on the drive cycle
(:func:`wear_outlook`). The paper's point contact slides under the whole load, so its
steady lateral force (about mu N) can far exceed what a real tire carries at the same slip
angle, ``C_alpha * alpha``; where it does by more than :data:`OVERSTATED_FACTOR`, the wear
judgement says that its growth is overstated (:func:`point_contact`); not with the patch
contact (``friction.contact = "patch"``).
"""

from __future__ import annotations

import math

import numpy as np

from ..models import model_for
from ..params import Params
from ..results import with_deprecated_keys
from ..units import DEFAULT_SPEED_RANGE_KMH, kmh_to_ms, wheel_rotation_frequency_hz
from .wear import _round_km as _km
from .wear import _where

__all__ = ["C_ALPHA_N_PER_RAD", "OVERSTATED_FACTOR", "PATCH_STABILITY_SPEEDS", "glance", "judge_options",
           "patch_beside", "top_sensitivities", "point_contact", "verdict", "wear_outlook"]

C_ALPHA_N_PER_RAD = 50.0e3
"""Cornering stiffness of a passenger tire [N/rad], the documented default where no .tir
file gives one (no parameter key holds it)."""
C_ALPHA_DEFAULT_SOURCE = "the default of a passenger tire (no .tir file loaded)"
"""Where :data:`C_ALPHA_N_PER_RAD` comes from, as the report says it."""
PATCH_STABILITY_SPEEDS = 40
"""Grid speeds of the patch contact's stability sweep beside the point contact (0.1-0.2 s
of CPU time each at M = 40; a pair of Hopf points closer than the grid spacing can be missed)."""
OVERSTATED_FACTOR = 2.0
"""The point contact's wear growth is flagged as overstated where its steady lateral force
exceeds ``C_alpha * alpha`` by more than this factor [-]."""


def point_contact(params: Params, speed_kmh: float, cornering: tuple[float, str] | None = None) -> dict:
    """The point contact's steady lateral force at ``speed_kmh`` [km/h] against a tire's
    ``C_alpha * alpha``, alpha [rad] the steady slip angle ``asin(v_r / V)`` of the model:
    ``{"lateral_force_n", "slip_angle_deg", "c_alpha_n_per_rad", "c_alpha_source",
    "c_alpha_alpha_n", "ratio", "overstated"}`` (``overstated``: the ratio exceeds
    :data:`OVERSTATED_FACTOR`). ``cornering``: (C_alpha [N/rad], where it comes from), e.g.
    a .tir file's at the load; None: :data:`C_ALPHA_N_PER_RAD`."""
    c_alpha, source = cornering if cornering is not None else (C_ALPHA_N_PER_RAD, C_ALPHA_DEFAULT_SOURCE)
    model = model_for(params)
    V = float(kmh_to_ms(speed_kmh))
    q = model.prepared(V, model.pack(params))
    aux = dict(zip(model.aux_names, model.diagnostics(model.equilibrium(V, q), V, q)))
    force = abs(float(aux["friction_force"]))
    alpha = math.asin(min(abs(float(aux["sliding_velocity"])) / V, 1.0))
    linear = c_alpha * alpha
    ratio = force / linear if linear > 0.0 else math.inf
    return {"lateral_force_n": force, "slip_angle_deg": math.degrees(alpha), "c_alpha_n_per_rad": c_alpha,
            "c_alpha_source": source, "c_alpha_alpha_n": linear, "ratio": ratio if math.isfinite(ratio) else None,
            "overstated": bool(ratio > OVERSTATED_FACTOR)}


def _linear_visible_km(params: Params, rates: np.ndarray, distance_km: float) -> float | None:
    """First distance [km] within ``distance_km`` at which the seeded roughness grown at the
    complex ``rates`` per km (``W_n exp(rate_n D)``) reaches the visible depth; None if it does
    not (grid of 200 steps, then bisection to 1 km)."""
    from ..wear.evolution import initial_roughness, peak_to_valley

    W0 = initial_roughness(params)
    limit = params.wear.visible_depth_mm * 1e-3
    pts = params.wear.profile_points

    def visible(D: float) -> bool:
        return peak_to_valley(W0 * np.exp(rates * D), pts) >= limit

    grid = np.linspace(0.0, distance_km, 201)
    hit = next((i for i, D in enumerate(grid) if visible(float(D))), None)
    if hit is None:
        return None
    if hit == 0:
        return 0.0
    lo, hi = float(grid[hit - 1]), float(grid[hit])
    while hi - lo > 1.0:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if visible(mid) else (mid, hi)
    return hi


def wear_outlook(params: Params, distance_km: float, cornering: tuple[float, str] | None = None) -> dict:
    """What the linear wear map says for ``params``, at the operating speed alone
    (``operating``) and on the drive cycle (``cycle``): the speeds where steady rolling is
    unstable (the tread vibrates, the map does not apply: ``rolling_stable`` False), else
    the fastest growing order, its e-folding distance [km] (``efold_km``, at the operating
    speed) and the distance [km] within ``distance_km`` at which the seeded roughness grown
    at the (share-weighted) rates becomes visible (``visible_km``, None: not within it); and
    the :func:`point_contact` check at the operating speed (None with the patch contact;
    ``cornering`` as there)."""
    from ..wear.design import cycle_rates
    from ..wear.map import wear_map

    op = params.operating.speed_kmh
    row = wear_map(params, [op]).rows()[0]
    out = {"operating": {k: row[k] for k in ("speed_kmh", "rolling_stable", "order", "frequency_hz", "efold_km")},
           "cycle": {}, "basis": "linear wear map", "distance_km": distance_km,
           "point_contact": _check(params, cornering)}
    for place, cycle in (("operating", ((op, 1.0),)), ("cycle", params.wear.cycle_shares())):
        rates = cycle_rates(params, cycle)
        if rates is None:
            stable = wear_map(params, [v for v, _ in cycle]).rolling_stable
            out[place].update(rolling_stable=False, visible_km=None, order=None,
                              vibrating_speeds_kmh=[v for (v, _), ok in zip(cycle, stable) if not ok])
        else:
            out[place].update(rolling_stable=True, visible_km=_linear_visible_km(params, rates, distance_km),
                              order=int(np.argmax(rates.real)) + 1, vibrating_speeds_kmh=[])
    return out


def _check(params: Params, cornering: tuple[float, str] | None = None) -> dict | None:
    """:func:`point_contact` at the operating speed for the point contact, None for the patch."""
    return point_contact(params, params.operating.speed_kmh, cornering) if params.friction.contact == "point" else None


def judge_options(params: Params, design: dict, distance_km: float, nominal_visible_km: dict,
                  cornering: tuple[float, str] | None = None) -> list[dict]:
    """The wear judgement of every computed design option (``design``: the report's design
    summary), in its order: :func:`wear_outlook` with the option's values, ``sooner``
    (on the drive cycle or at the operating speed alone the polygon becomes visible before
    the nominal car's, ``nominal_visible_km`` {"cycle", "operating"} [km] or None; None where
    the option leaves the tread vibrating at both, so that the map cannot tell) and ``text``.
    Options not computed (no values) get None. ``cornering``: as in :func:`point_contact`."""
    from ..dynamics.sensitivity import perturbed

    out = []
    for o in design["options"]:
        if o["values"] == o["nominal"]:
            out.append(None)
            continue
        changed = params
        for key, value in zip(o["params"], o["values"]):
            changed = perturbed(changed, key, value)
        look = wear_outlook(changed, distance_km, cornering)
        judged = [look[place]["visible_km"] is not None and (nominal_visible_km.get(place) is None
                                                            or look[place]["visible_km"] < nominal_visible_km[place])
                  for place in ("cycle", "operating") if look[place]["rolling_stable"]]
        look["sooner"] = any(judged) if judged else None
        look["text"] = _option_text(look, nominal_visible_km, distance_km)
        out.append(look)
    return out


def _option_text(look: dict, nominal_visible_km: dict, distance_km: float) -> str:
    """The wear judgement of one option in words (linear wear map), on the drive cycle and
    at the operating speed alone, against the nominal car's visible distances."""
    parts = []
    for place, where in (("cycle", "on the drive cycle"),
                         ("operating", f"at {look['operating']['speed_kmh']:g} km/h alone")):
        c, now = look[place], nominal_visible_km.get(place)
        if not c["rolling_stable"]:
            parts.append(f"{where} the tread still vibrates at "
                         + ", ".join(f"{v:g}" for v in c["vibrating_speeds_kmh"]) + " km/h (the map does not apply)")
            continue
        if c["visible_km"] is None:
            text = f"{where} no visible polygon within {distance_km:,.0f} km"
        else:
            text = f"{where} {c['order']}-sided polygon visible after about {_km(c['visible_km'])} km"
        text += f" (now {_km(now)} km)" if now is not None else f" (now none within {distance_km:,.0f} km)"
        parts.append(text)
    op = look["operating"]
    if op["rolling_stable"] and op["efold_km"] is not None:
        parts.append(f"at {op['speed_kmh']:g} km/h order {op['order']} grows by e every {_km(op['efold_km'])} km")
    text = ("brings the polygon sooner: " if look["sooner"] else "") + "; ".join(parts) + " (linear wear map)"
    if look["point_contact"] is not None and look["point_contact"]["overstated"]:
        text += "; " + _overstated(look["point_contact"])
    return text


def _overstated(pc: dict) -> str:
    return (f"the point contact's lateral force {pc['lateral_force_n']:,.0f} N is {pc['ratio']:.0f} times a "
            f"tire's C_alpha*alpha = {pc['c_alpha_alpha_n']:,.0f} N ({pc['c_alpha_n_per_rad'] / 1e3:.4g} kN/rad, "
            f"{pc['c_alpha_source']}, at {pc['slip_angle_deg']:.2f} deg): it slides under the whole load, so its wear "
            "growth is overstated")


def verdict(summary: dict, params: Params, vibration: str, cornering: tuple[float, str] | None = None) -> dict:
    """The one verdict from the report's summary (``operating``, ``wear``, ``design``,
    ``bifurcation``, ``sensitivity``): ``lines`` (vibration, polygon, what the distances
    assume, the contact, what to change), ``glance`` (:func:`glance`), ``contact``,
    ``vibrates``, ``polygon_visible`` (None: no evolution run), ``dominant_order`` (sides),
    ``visible_km`` per evolution, ``source`` of the polygon, the :func:`point_contact` check,
    the patch contact beside an overstated point contact (``patch``, :func:`patch_beside`;
    None where not computed) and the wear judgement of every design option
    (:func:`judge_options`). ``vibration`` is the sentence on the vibration at the operating
    speed; ``cornering``: as in :func:`point_contact`."""
    v, wear, design = summary["operating"], summary["wear"], summary["design"]
    evs = {ev["label"]: ev for ev in wear["evolutions"] if ev.get("start", "rest") == "rest"}  # as a car drives
    distance = max((ev["distance_km"] for ev in evs.values()), default=params.wear.report_km)
    vibrates = "sev_amplitude_x_mm" in v
    visible = [ev for ev in evs.values() if ev["visible_km"] is not None]
    first = min(visible, key=lambda ev: ev["visible_km"]) if visible else None
    pc = _check(params, cornering)
    stopped = [ev["distance_km"] for ev in evs.values() if not ev.get("complete", True)]
    out = {"contact": params.friction.contact, "vibrates": vibrates, "polygon_visible": bool(visible) if evs else None,
           "dominant_order": first["dominant_order"] if first else None,
           "visible_km": {label: ev["visible_km"] for label, ev in evs.items()},
           "wear_stopped_km": min(stopped) if stopped else None,
           "source": None, "point_contact": pc}
    lines = [vibration]
    if first is not None:
        unstable = {r["speed_kmh"] for r in wear["map_rows"] if not r["rolling_stable"]}
        shaking = sorted({c["speed_kmh"] for ev in visible for c in ev["cycle"]
                          if c["vibration_order_end"] is not None and c["speed_kmh"] in unstable})
        if shaking:  # self-excited; a vibration in the evolution where rolling is stable is the forced response
            out["source"] = "vibration"
            cause = "from the vibration of the tread at " + ", ".join(f"{s:g}" for s in shaking) + " km/h"
        else:
            out["source"] = "forced resonance"
            n, alone = first["dominant_order"], evs.get("operating speed")
            if alone is not None and alone["visible_km"] is not None:
                speed = alone["cycle"][0]["speed_kmh"]
                f = n * wheel_rotation_frequency_hz(kmh_to_ms(speed), params.operating.rolling_radius_m)
                where = f" ({f:.0f} Hz at {speed:g} km/h)"
            else:
                where = " on the drive cycle"
            cause = f"from a forced resonance of the tread at order {n}{where}, while steady rolling is stable"
        lines.append(f"The tire wears into a polygon, {cause}. " + " ".join(wear["headline"]))
    elif evs:
        lines.append(("The tire does not wear into a visible polygon. " if not stopped else
                      f"The tire does not wear into a visible polygon within {min(stopped):,.0f} km; beyond, the wear "
                      "is not judged (an evolution stopped at its step budget). ") + " ".join(wear["headline"]))
    else:
        lines.append("Wear evolution not run (--wear-km 0 or wear.report_km = 0): the wear map alone, "
                     + " ".join(wear["sentences"]))
    if v.get("regime") == "hard SEV region" and evs:
        w = v["wear"]
        lines.append(f"Steady rolling is stable at {v['speed_kmh']:g} km/h, so the evolutions start from it, as a car "
                     f"drives; after a disturbance above {v['trigger_amplitude_x_mm']:.3f} mm (a pothole) the "
                     f"tread vibrates at order {w['frequency_order']:.2f} ({w['frequency_hz']:.0f} Hz) instead, and "
                     + ("wears as said above after a pothole." if any(ev.get("start") == "cycle" for ev in
                                                                     wear["evolutions"])
                        else "the wear from that vibration is not evolved here."))
    lines.append(_contact_line(params))
    out["patch"] = None
    if pc is not None and pc["overstated"]:
        lines.append("Beside the wear judgement: " + _overstated(pc) + " (friction.contact = \"patch\" is the "
                     "distributed contact).")
    nominal = wear_outlook(params, distance, cornering)
    if pc is not None and pc["overstated"]:
        analysed = (summary.get("bifurcation") or {}).get("speed_range_kmh", DEFAULT_SPEED_RANGE_KMH)
        out["patch"] = patch_beside(params, tuple(analysed), nominal["operating"])
        if out["patch"]["disagree"]:
            lines.append(out["patch"]["text"])
    out["wear_outlook"] = nominal
    nominal_visible = {place: evs[label]["visible_km"] for place, label in (("cycle", "drive cycle"),
                                                                            ("operating", "operating speed"))
                       if label in evs}
    judged = judge_options(params, design, distance, nominal_visible, cornering) if (vibrates or visible) else []
    out["design_options"] = judged
    wear_option = None
    if first is not None and not design["options"]:
        from ..wear.design import Judge, WearDesignSettings, wear_design

        cycle = tuple((c["speed_kmh"], c["share"]) for c in first["cycle"])
        found = wear_design(params, target_km=distance, cycle=cycle,
                            settings=WearDesignSettings(judge=Judge.MAP))  # the linear map, as before
        wear_option = (_where(first), found.options[0] if found.options else None,
                       found.nominal_rolling_stable and not found.options and found.nominal_depth_at_target_mm
                       < params.wear.visible_depth_mm)
    out["wear_design_option"] = wear_option[1].summary() if wear_option and wear_option[1] else None
    lines.append(_what_to_change(vibrates, bool(visible), bool(evs), design, judged, distance, wear_option)
                 + _stops(summary.get("wear_design")))
    out["lines"] = lines
    out["glance"] = glance(summary, out, params)
    return with_deprecated_keys(out, {"dominant_order": "sides"})


def _contact_line(params: Params) -> str:
    """Which contact the analysis used, in words."""
    if params.friction.contact == "patch":
        return (f"Contact: the distributed patch (friction.contact = \"patch\", {params.friction.patch_elements} tread "
                "elements carried through the contact length, each with its share of the load).")
    return ("Contact: the paper's point contact (friction.contact = \"point\": one tread element sliding under the "
            "whole wheel load).")


def _bands_text(bands) -> str:
    return ", ".join(f"{lo:.1f}-{hi:.1f} km/h" for lo, hi in bands) or "none"


def patch_beside(params: Params, speed_range_kmh: tuple[float, float], point_operating: dict) -> dict:
    """The patch contact's result beside the point contact's (cheap: linear analysis only,
    about 0.5 s of CPU for tread1dof and 2 s for axle4dof at M = 40): the linear bands of both over ``speed_range_kmh`` [km/h] on the same
    grid (:data:`PATCH_STABILITY_SPEEDS` speeds) and the patch's linear wear growth at the
    operating speed, against the point contact's (``point_operating``: its wear-map row at
    the operating speed, :func:`wear_outlook`). ``disagree``: the
    two differ on whether steady rolling is unstable at the operating speed or anywhere in
    the range, or, both stable there, their e-folding distances differ by more than
    :data:`OVERSTATED_FACTOR`. Returns {"linear_band_kmh", "operating": {"rolling_stable",
    "order", "efold_km"}, "point": the same two, "disagree", "text"}."""
    from ..dynamics.stability import StabilitySettings, stability
    from ..wear.map import wear_map

    patch = params.with_updates({"friction.contact": "patch"})
    op = params.operating.speed_kmh
    lo, hi = speed_range_kmh
    grid = StabilitySettings(n_speeds=PATCH_STABILITY_SPEEDS)
    band = stability(patch, (lo, hi), grid).linear_band_kmh
    point_band = stability(params, (lo, hi), grid).linear_band_kmh
    keys = ("rolling_stable", "order", "efold_km")
    row = wear_map(patch, [op]).rows()[0]
    mine = {k: row[k] for k in keys}
    theirs = {k: point_operating[k] for k in keys}

    def at_op(bands):
        return any(a <= op <= b for a, b in bands)

    disagree = at_op(band) != at_op(point_band) or bool(band) != bool(point_band)
    if mine["rolling_stable"] and theirs["rolling_stable"] and mine["efold_km"] and theirs["efold_km"]:
        disagree = disagree or max(mine["efold_km"] / theirs["efold_km"],
                                   theirs["efold_km"] / mine["efold_km"]) > OVERSTATED_FACTOR

    def unstable(bands):
        return f"unstable at {_bands_text(bands)}" if bands else "stable at every speed"

    def growth(r):
        if not r["rolling_stable"]:
            return "steady rolling is unstable (the tread vibrates; the linear wear map does not apply)"
        if r["efold_km"] is None:
            return "no polygon order grows"
        return f"order {r['order']} grows by e every {_km(r['efold_km'])} km"

    text = (f"The patch contact beside it (friction.contact = \"patch\", {params.friction.patch_elements} elements, "
            f"linear analysis): steady rolling {unstable(band)} in {lo:g}-{hi:g} km/h "
            f"({PATCH_STABILITY_SPEEDS} speeds; point contact: {unstable(point_band)}); at {op:g} km/h "
            f"{growth(mine)} (point contact: {growth(theirs)}).")
    return {"linear_band_kmh": [list(b) for b in band], "operating": mine,
            "point": {"linear_band_kmh": [list(b) for b in point_band], "operating": theirs},
            "disagree": disagree, "text": text}


def top_sensitivities(sensitivity: dict, n: int = 2) -> list[dict]:
    """The ``n`` parameters whose normalized sensitivity S = (p/V) dV/dp [-] on either
    edge of the SEV band (first or second bifurcation speed) is largest in magnitude:
    [{"param", "label", "first", "second"}] (None: that edge has no row), largest first."""
    from ..dynamics.sensitivity import PARAMETER_LABELS

    by_param: dict[str, dict] = {}
    for r in sensitivity["rows"]:
        if r["quantity"] in ("first_bifurcation", "second_bifurcation") and r["normalized"] is not None:
            entry = by_param.setdefault(r["param"], {"param": r["param"], "first": None, "second": None,
                                                     "label": PARAMETER_LABELS.get(r["param"], r["param"])})
            entry[r["quantity"].split("_")[0]] = r["normalized"]

    def size(e):
        return max(abs(v) for v in (e["first"], e["second"]) if v is not None)

    return sorted(by_param.values(), key=size, reverse=True)[:n]


def _best_option(design: dict, judged: list):
    """(option, its wear judgement, whether it keeps the polygon from coming sooner) of the
    first design option that clears the band without bringing the polygon sooner, else of
    the first that clears it; None if none does."""
    cleared = [(o, j) for o, j in zip(design["options"], judged) if o["achieved"] and j is not None]
    good = [(o, j) for o, j in cleared if j["sooner"] is False]
    if not cleared:
        return None
    o, j = (good or cleared)[0]
    return o, j, bool(good)


def _not_judged_beyond(km: float) -> str:
    """The wear where an evolution stopped at its step budget after ``km`` [km], in words."""
    return f"no visible polygon within {km:,.0f} km, beyond not judged (the wear evolution stopped at its step budget)"


def glance(summary: dict, judged: dict, params: Params) -> list[str]:
    """The report at a glance, before any table: at risk or not, how bad, what to change
    (the best design option), which two parameters move the SEV band most (from the
    report's sensitivities) and the contact used. ``judged``: the verdict so far
    (``vibrates``, ``polygon_visible``, ``visible_km``, ``dominant_order``, ``design_options``,
    ``point_contact``, ``patch``)."""
    v, b, design = summary["operating"], summary.get("bifurcation") or {}, summary["design"]
    visible = {label: km for label, km in judged["visible_km"].items() if km is not None}
    risk = judged["vibrates"] or bool(visible)
    unjudged = not risk and judged["polygon_visible"] is None  # the wear evolution was not run
    stopped = judged.get("wear_stopped_km")  # an evolution stopped at its step budget there [km]
    if risk:
        lines = ["At risk: yes"]
    elif unjudged:
        lines = [f"At risk: not from vibration (none at {v['speed_kmh']:g} km/h); the polygon is not judged (the wear "
                 "evolution was not run)"]
    elif stopped is not None:
        lines = [f"At risk: not from vibration (none at {v['speed_kmh']:g} km/h); {_not_judged_beyond(stopped)}"]
    else:
        lines = [f"At risk: no (no self-excited vibration at {v['speed_kmh']:g} km/h, no visible polygon within the "
                 "distance evolved)"]
    bad = []
    if judged["vibrates"]:
        w = v.get("wear")
        bad.append(f"the tread vibrates at {v['speed_kmh']:g} km/h with {v['sev_amplitude_x_mm']:.3f} mm"
                   + (f" at {v['frequency_hz']:.0f} Hz" if v.get("frequency_hz") else "")
                   + (f" (RMS tread acceleration {w['rms_acceleration']:.0f} m/s²)" if w and "rms_acceleration" in w else ""))
    if b.get("sev_band_kmh"):
        bad.append(f"SEV band {_band_edges(b)}")
    if visible:
        label, km = min(visible.items(), key=lambda item: item[1])
        n = judged["dominant_order"]
        bad.append(f"{'an' if str(n)[0] == '8' or n in (11, 18) else 'a'} {n}-sided polygon becomes visible after about {_km(km)} km "
                   f"({'on the drive cycle' if label == 'drive cycle' else 'at ' + format(v['speed_kmh'], 'g') + ' km/h alone'})")
    if stopped is not None and not visible:
        bad.append(_not_judged_beyond(stopped))
    lines.append("How bad: " + ("; ".join(bad) if bad else "nothing vibrates" if unjudged
                                else "nothing vibrates and nothing wears into a polygon") + ".")
    best = _best_option(design, judged.get("design_options") or [])
    if not risk:
        lines.append("What to change: nothing for the vibration" + (" (the wear is not judged)." if unjudged else "."))
    elif best is None and not design["options"] and visible and judged.get("lines"):
        lines.append(judged["lines"][-1])  # no band to move: the verdict's answer, a change of the wear itself
    elif best is None:
        lines.append("What to change: no design option clears the SEV band from the operating range "
                     f"{design['operating_range_kmh'][0]:g}-{design['operating_range_kmh'][1]:g} km/h"
                     + ("" if design["options"] else f" ({design['reason']})") + " (see the verdict below)."
                     + _stops(summary.get("wear_design")))
    else:
        o, j, good = best
        lines.append(f"What to change: {o.get('text') or o['change']}" + ("" if good else "; it brings the polygon sooner")
                     + "." + _stops(summary.get("wear_design")))
    top = top_sensitivities(summary.get("sensitivity") or {"rows": []})
    if top:
        def s(x):
            return "no edge" if x is None else f"{x:+.2f}"

        lines.append("What moves the SEV band most (normalized sensitivity S = (p/V) dV/dp; 1 % more of the "
                     "parameter moves the speed by S %): "
                     + " and ".join(f"{e['label']} ({e['param']}: S = {s(e['first'])} on the first, "
                                    f"{s(e['second'])} on the second bifurcation speed)" for e in top) + ".")
    else:
        lines.append("What moves the SEV band most: no band edge in the analysed range, so no sensitivities.")
    contact = _contact_line(params)
    pc = judged.get("point_contact")
    if pc is not None and pc["overstated"]:
        contact += (f" Outside its validity here: its lateral force is {pc['ratio']:.0f} times C_alpha*alpha "
                    f"(C_alpha {pc['c_alpha_n_per_rad'] / 1e3:.4g} kN/rad, {pc['c_alpha_source']})")
        patch = judged.get("patch")
        contact += ("; the patch contact's result is in the verdict below." if patch and patch["disagree"] else ".")
    lines.append(contact)
    return lines


def _band_edges(b: dict) -> str:
    """The SEV band of a bifurcation summary, an open edge named as such [km/h]."""
    lo, hi = b["speed_range_kmh"]
    first, second = b["first_bifurcation_speed_kmh"], b["second_bifurcation_speed_kmh"]
    return (f"{f'{first:.1f}' if first is not None else f'open below {lo:g}'}-"
            f"{f'{second:.1f}' if second is not None else f'open above {hi:g}'} km/h")


def search_accuracy_note(found: dict, option: dict) -> str:
    """What the report says beside a least change ``option`` that the search (the summary of
    :func:`~polywear.wear.design.wear_design`, ``found``) did not refine to its accuracy: one
    grid level not refined, or refined by a few rounds only; "" where it was refined."""
    from ..dynamics.design import signed_percent
    from ..wear.design import EVOLUTION_GRID, EVOLUTION_REFINE, WearDesignSettings

    rounds = found.get("refine_rounds") if found.get("refined", True) else 0
    if rounds is None:
        return ""
    step = WearDesignSettings().max_factor ** (1.0 / EVOLUTION_GRID)
    grid = f"one step of the search's grid ({signed_percent(step - 1.0)}/{signed_percent(1.0 / step - 1.0)} of each key)"
    if rounds == 0:
        return (f"{grid}, not refined: a smaller change, of this or of another parameter, may do it (polywear "
                f"report --wear-design refines it)")
    below = option.get("below")
    lower = "the car as it is" if below is None else signed_percent(below["relative_change"])
    return (f"{grid}, refined by {rounds} round{'s' if rounds > 1 else ''} of the search, not to its "
            f"{EVOLUTION_REFINE * 100:g} %: the least change lies between {lower} (a visible polygon) and "
            f"{signed_percent(option['relative_change'])} (polywear report --wear-design refines it)")


def _stops(found: dict | None) -> str:
    """The least change judged by the evolution (the report's ``wear_design``) as a sentence
    that follows the design answer, or nothing where it was not searched or found nothing."""
    if not found or not found["options"]:
        return ""
    from ..dynamics.design import parameter_unit, signed_percent

    o = found["options"][0]
    unit = parameter_unit(o["key"])

    def value(v: float) -> str:
        return f"{v:.4g}°" if unit == "deg" else f"{v:.4g}{' ' + unit if unit else ''}"

    text = (f" What stops the polygon (the nonlinear evolution over {found['target_km']:,.0f} km on the drive "
            f"cycle): {o['label']} {value(o['nominal'])} → {value(o['value'])} ({signed_percent(o['relative_change'])})")
    other = o.get("other_direction")
    if other is not None:
        text += f" or → {value(other['value'])} ({signed_percent(other['relative_change'])})"
    undecided = [u for u in found["undecided"] if u["key"] == o["key"]]
    below = o["below"]
    if below is not None and below["visible_km"] is not None:
        text += (f"; at {signed_percent(below['relative_change'])} the polygon is visible after about "
                 f"{_km(below['visible_km'])} km")
    if undecided:
        text += ("; " + ", ".join(signed_percent(u["relative_change"]) for u in undecided)
                 + " undecided (the evolution ran out of its budget there, at the edge of locking)")
    if note := search_accuracy_note(found, o):
        text += f"; {note}"
    return text + "."


def _what_to_change(vibrates: bool, visible: bool, evolved: bool, design: dict, judged: list,
                    distance_km: float, wear_option=None) -> str:
    """The last line of the verdict: nothing, or the first design option that clears the
    band without bringing the polygon sooner (else the first that clears it, marked); with
    no band to move, ``wear_option``: (where the polygon came soonest, the first option of
    :func:`~polywear.wear.design.wear_design` there or None, whether the linear map sees no
    polygon there at all)."""
    if not vibrates and not visible:
        if not evolved:
            return "Nothing to change for the vibration; the wear was not evolved, so it is not judged here."
        return (f"Nothing to change: the tread does not vibrate and no polygon becomes visible within "
                f"{distance_km:,.0f} km.")
    lo, hi = design["operating_range_kmh"]
    best = _best_option(design, judged)
    if best is None:
        if not design["options"] and visible:
            text = (f"What to change: there is no SEV band to move out of {lo:g}-{hi:g} km/h, but the tire still "
                    "wears into a polygon: the wear itself must change")
            where, o, linear_clear = wear_option
            if o is not None:
                from ..dynamics.design import parameter_unit, signed_percent

                unit = parameter_unit(o.key)
                return (text + f": {o.label} {o.nominal:.4g} → {o.value:.4g} {unit} ({signed_percent(o.relative_change)}) keeps "
                        f"the polygon invisible for {distance_km:,.0f} km {where} by the linear wear map, the least "
                        f"such change (polywear wear design --target-km {distance_km:g} lists all; the nonlinear "
                        "evolution can lock and grow faster: check with --verify-km).")
            if linear_clear:
                return (text + f"; the linear wear map sees no visible polygon within {distance_km:,.0f} km {where}, "
                        "the nonlinear evolution does (the tread's response locks to the growing pattern), so the "
                        "map-based wear design has no option to offer: judge changes by the evolution "
                        f"(polywear wear design --target-km {distance_km:g} --verify-km {distance_km:g}).")
            return text + f" (polywear wear design --target-km {distance_km:g} finds no option {where})."
        if not design["options"]:
            return f"What to change: no design option for {lo:g}-{hi:g} km/h: {design['reason']}"
        return f"What to change: no design option clears the SEV band from {lo:g}-{hi:g} km/h (see the design section)."
    o, j, good = best
    text = f"What to change: {o['change']} clears the SEV band from {lo:g}-{hi:g} km/h; wear: {j['text']}."
    if not good:
        text += " No option that clears the band keeps the polygon from coming sooner."
    return text
