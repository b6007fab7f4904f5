"""``polywear measure profile``: measured worn tires, their polygon, and the wear rate they imply."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from .common import Inputs, Outputs, UserError, load, user_errors


def profile(
    files: Annotated[list[Path], typer.Argument(help="Profiles: CSV of angle_deg and depth_mm or radius_mm (optional "
                                                     "rib, distance_km, position), or harmonics tables (order, "
                                                     "amplitude_mm, phase_deg).")],
    unit: Annotated[Optional[str], typer.Option("--unit", help="Length unit of the depth/radius column when the "
                                                "header has none (mm, um, m, cm, in).")] = None,
    max_order: Annotated[int, typer.Option("--max-order", help="Highest order fitted (1-200).")] = 30,
    calibrate: Annotated[bool, typer.Option("--calibrate", help="Fit the wear rate k_e (and the initial roughness "
                                            "where two mileages tell it) by the evolution on the drive cycle.")] = False,
    roughness_known: Annotated[bool, typer.Option("--roughness-known", help="Take wear.initial_roughness_um as "
                                                  "the new tires' roughness (measured or assumed).")] = False,
    cycle: Annotated[Optional[str], typer.Option("--cycle", help="Drive cycle of the measured tires, speed:share,... "
                                                 "(default [[wear.cycle]]).")] = None,
    predict: Annotated[bool, typer.Option("--predict", help="With --calibrate: the visible distance with the "
                                          "calibrated k_e on --predict-cycle and with --predict-set changes.")] = False,
    predict_cycle: Annotated[Optional[str], typer.Option("--predict-cycle", help="Drive cycle of the prediction "
                                                         "(default: the measured one).")] = None,
    predict_set: Annotated[Optional[list[str]], typer.Option("--predict-set", help="A design change for the "
                                                             "prediction, key=value (repeatable).")] = None,
    inputs: Inputs = Inputs(),
    outputs: Outputs = Outputs(),
) -> None:
    """Order spectrum, dominant order and peak-to-valley of measured worn tires; with
    --calibrate the wear rate k_e they imply, measured vs predicted, and --predict."""
    from ..measured.profile import ProfileError, read_profiles

    outputs.check()
    if not 1 <= max_order <= 200:
        raise UserError(f"--max-order {max_order}: must be between 1 and 200")
    if (predict or roughness_known or predict_cycle or predict_set) and not calibrate:
        raise UserError("--predict, --predict-cycle, --predict-set and --roughness-known go with --calibrate")
    if (predict_cycle or predict_set) and not predict:
        raise UserError("--predict-cycle and --predict-set go with --predict")
    params = inputs.load()
    from .wear_cmd import parse_cycle

    pairs = parse_cycle(cycle) if cycle else None
    with user_errors(ProfileError, ValueError):
        measured = read_profiles(files, unit=unit, max_order=max_order)
    for p in measured.profiles:
        for note in p.notes:
            outputs.note(f"note: {p.label}: {note}")
    summary = measured.summary()
    calibration = None
    if calibrate:
        from ..measured.wear_calibration import calibrate_wear, predict_visible_km

        outputs.note("measure profile: calibrating k_e by the wear evolution on the drive cycle ...")
        with user_errors(ProfileError):
            calibration = calibrate_wear(measured, params, pairs, roughness_known=roughness_known)
        summary = calibration.summary()
        if predict:
            if calibration.energetic_rate_mm3_per_j is None:
                raise UserError("--predict: the data do not determine k_e (" + calibration.combination + ")")
            changed = None
            if predict_set:
                from ..params import ParameterError

                with user_errors(ParameterError, prefix="--predict-set: "):
                    changed = load(inputs.config, [*(inputs.set_ or []), *predict_set])
            outputs.note("measure profile: predicting with the calibrated k_e ...")
            summary["prediction"] = predict_visible_km(calibration, changed,
                                                       parse_cycle(predict_cycle) if predict_cycle else None)
    def figure():
        if calibration is None:
            return _polar(measured)
        return _two_panels(measured, calibration, _predicted_profile(calibration))

    outputs.write(make_figure=figure)
    outputs.show(summary, lambda s: _print(s, calibration is not None))


def _predicted_profile(calibration):
    """The calibrated prediction of the worn depth [mm] at 360 angles, at the latest
    measured mileage (None where k_e is not determined)."""
    import numpy as np

    from ..wear.law import profile_samples

    scale = calibration.distance_scale()
    if scale is None:
        return None
    ref = calibration.reference
    at = int(np.argmin(np.abs(ref.distance_km - calibration.comparison["at_km"] * scale)))
    return profile_samples(ref.harmonics[at], 360) * 1e3


def _polar(measured):
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(6, 6))
    measured.plot(fig.add_subplot(projection="polar"))
    return fig


def _two_panels(measured, calibration, predicted):
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(11, 5))
    measured.plot(fig.add_subplot(1, 2, 1, projection="polar"), predicted_mm=predicted,
                  predicted_label="predicted (calibrated k_e)")
    calibration.plot(fig.add_subplot(1, 2, 2))
    fig.tight_layout()
    return fig


def _print(summary: dict, calibrated: bool) -> None:
    rows = summary["profiles"] if not calibrated else None
    if rows is not None:
        for p in rows:
            where = ", ".join(str(x) for x in (p["source"], p["position"] and f"position {p['position']}",
                                               p["rib"] and f"rib {p['rib']}",
                                               p["distance_km"] is not None and f"{p['distance_km']:g} km") if x)
            order = p["dominant_order"]
            typer.echo(f"{where}: " + (f"dominant order {order}, {p['dominant_amplitude_mm']:.3f} mm; "
                                       if order else "no order above the noise floor; ")
                       + f"peak-to-valley {p['peak_to_valley_mm']:.3f} mm")
        for g in summary["growth"]:
            typer.echo(f"  order {g['order']} grows {g['growth_per_1000km']:+.3f} e-folds per 1000 km from "
                       f"{g['from_km']:g} to {g['to_km']:g} km")
        return
    typer.echo(f"dominant order {summary['dominant_order']}, peak-to-valley {summary['peak_to_valley_mm']:.3f} mm")
    rate = summary["energetic_rate_mm3_per_j"]
    if summary["identifiable"] and rate:
        lo, hi = rate["interval"]
        typer.echo(f"k_e = {rate['value']:.3g} mm^3/J (95 %: {lo:.3g}-{hi:.3g}) from orders {summary['fitted_orders']}, "
                   f"chi2 {summary['chi2']:.1f} on {summary['dof']} degrees of freedom")
    else:
        typer.echo(f"k_e not determined: {summary['combination']}")
    c = summary["comparison"]
    typer.echo(f"dominant order at {c['at_km']:g} km: measured {c['measured_dominant_order']}, predicted "
               f"{c['predicted_dominant_order']}")
    mv, pv = c["measured_visible_km"], c["predicted_visible_km"]
    typer.echo("visible (0.1 mm): measured " + (f"{mv:.0f} km" if mv is not None else "not yet") + ", predicted "
               + (f"{pv:.0f} km" if pv is not None else "beyond the evolution"))
    for d in summary["disagreements"]:
        typer.echo(f"disagreement: {d}")
    if "prediction" in summary:
        p = summary["prediction"]
        iv = p["visible_interval_km"]
        typer.echo("prediction: " + (f"visible after {p['visible_km']:.0f} km" + (f" (95 %: {iv[0]:.0f}-{iv[1]:.0f})"
                                                                                if iv else "")
                                     if p["visible_km"] is not None else f"not visible within {p['within_km']:.0f} km")
                   + f", dominant order {p['dominant_order']}")
