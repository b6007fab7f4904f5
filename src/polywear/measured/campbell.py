"""Measured run-ups and coast-downs as a Campbell map, with automatic SEV detection.

A run (time, vehicle or wheel speed, one or more acceleration channels) becomes a
spectrogram per channel (Hann windows, ``scipy.signal.spectrogram``), each time slice
placed at its mean speed: the Campbell map. On it:

* **Features.** Spectral peaks that stand ``peak_db`` above the slice's spectral floor (medians
  over blocks of ``FLOOR_BINS`` frequency bins, interpolated) are linked from slice to slice into
  ridges. A ridge is classified by the
  slope of ``ln f`` against ``ln V``: about 1, an *order-tracking* feature (a worn polygon,
  an imbalance: ``f = n V / (2 pi R)``, with its order ``n``); about 0, a
  *constant-frequency* feature (SEV, or a structural mode excited by the road).
* **SEV** is a constant-frequency feature that switches on within the run and stands
  ``sev_db`` above the floor. Its onset and offset speeds come from the envelope of the
  band-passed signal (``|hilbert|``, smoothed over 10 periods, wheel orders removed): the
  last upward crossing of the floor + ``ONSET_DB`` before the SEV is developed, and the
  first downward crossing after it; uncertainty: half the speed between the crossings
  6 dB lower and higher. Its
  frequency at onset from the phase of the analytic signal over the first second
  (uncertainty from the scatter of the phase fit), its amplitude as sqrt(2) x RMS of the
  band over the developed part (uncertainty: scatter over 1 s blocks).
* **Ramp delay.** A run-up passes a slowly moving Hopf point late: the amplitude needs
  time to grow from the disturbance level to the detection threshold. :func:`ramp_delay`
  simulates the model along the measured ramp through its nearest Hopf point, the tread
  kicked by random displacements of ``disturbance_m`` every 20 ms, and runs the same
  detector on the simulated tread acceleration: delay = ``V_onset,sim - V_Hopf``, the mean
  over ``RAMP_SEEDS`` seeds. The measured onset is corrected by it; its uncertainty adds
  the scatter over the seeds and half the spread of the delays for kicks 10x smaller and
  10x larger (the disturbance of a real road is not known).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..params import Params
from ..results import Result
from ..settings import check_fraction, check_positive
from ..units import order_rays
from .run_file import MeasurementError, Run
from .sev_detection import (
    HOPF_MISMATCH_KMH,
    RAMP_SEEDS,
    classify_ridge,
    fundamental,
    log_slope,
    no_evidence,
    ramp_delay,
    remove_orders,
    sev_from_envelope,
    spectral_floor,
    split_ridge,
    track_ridges,
)

__all__ = ["CampbellResult", "CampbellSettings", "campbell"]


@dataclass(frozen=True)
class CampbellSettings:
    """Numerical settings of :func:`campbell` (spectrogram, feature detection, ramp simulation)."""

    window_s: float = 0.5
    """Spectrogram window [s] (frequency resolution 1/window_s)."""
    overlap: float = 0.75
    """Overlap of consecutive windows [-], in [0, 1)."""
    f_range_hz: tuple[float, float] | None = None
    """Frequencies searched for features [Hz]; default 10 Hz to 0.4 fs."""
    peak_db: float = 15.0
    """Peak prominence over the bin's median level [dB]."""
    sev_db: float = 20.0
    """Level SEV must reach over the bin's median level [dB]."""
    disturbance_m: float = 1e-6
    """Tread disturbance of the ramp simulation [m] (see :func:`ramp_delay`)."""

    def __post_init__(self) -> None:
        check_positive(self, "window_s", "peak_db", "sev_db", "disturbance_m")
        check_fraction(self, "overlap", closed_low=True)
        if self.overlap >= 1.0:
            raise ValueError(f"CampbellSettings: overlap = {self.overlap!r}: must lie in [0, 1)")
        if self.f_range_hz is not None:
            lo, hi = self.f_range_hz
            if not (math.isfinite(lo) and math.isfinite(hi) and 0.0 <= lo < hi):
                raise ValueError(f"CampbellSettings: f_range_hz = {self.f_range_hz!r}: need 0 <= low < high [Hz]")


@dataclass
class CampbellResult(Result):
    """Campbell map of a run, detected features, SEV and the model's prediction over it."""

    run: Run
    frequencies_hz: np.ndarray
    times_s: np.ndarray
    speeds_kmh: np.ndarray
    power_db: np.ndarray  # (channel, frequency, slice), channel-summed in [0] if several
    channel_names: list[str]
    features: list[dict]
    sev: dict | None
    prediction: dict
    radius_m: float
    settings: dict
    no_sev: str | None = None
    """Why no SEV was found (None when it was)."""

    def summary(self) -> dict:
        return {
            "source": self.run.source,
            "sample_rate_hz": self.run.sample_rate_hz,
            "speed_range_kmh": [float(self.run.speed_kmh.min()), float(self.run.speed_kmh.max())],
            "channels": {n: u for n, (_, u) in self.run.channels.items()},
            "features": self.features,
            "sev": self.sev,
            **({"no_sev": self.no_sev} if self.sev is None else {}),
            "prediction": self.prediction,
            "notes": self.run.notes,
        }

    def observations(self) -> list[dict]:
        """The SEV onset and frequency as calibration observations (``[[observation]]``
        entries of ``polywear calibrate``): only a ramp-corrected onset is a Hopf speed, and
        only one whose model's Hopf point lies within ``HOPF_MISMATCH_KMH`` of it."""
        onset = (self.sev or {}).get("onset") or {}
        index = onset.get("hopf_index")
        if onset.get("corrected_speed_kmh") is None or index not in (0, 1) or onset.get("warning"):
            return []
        prefix = ("first_hopf", "hopf") if index == 0 else ("second_hopf", "second_hopf")
        source = f"measure campbell {Path(self.run.source).name}"
        out = [{"quantity": f"{prefix[0]}_kmh", "value": onset["corrected_speed_kmh"],
                "sigma": onset["corrected_uncertainty_kmh"], "label": f"{source}: ramp-corrected SEV onset"}]
        if self.sev.get("corrected_frequency_hz") is not None:
            out.append({"quantity": f"{prefix[1]}_frequency_hz", "value": self.sev["corrected_frequency_hz"],
                        "sigma": max(self.sev["corrected_frequency_uncertainty_hz"], 1e-6),
                        "label": f"{source}: SEV frequency at onset, ramp-corrected"})
        return out

    def _dataset(self):
        """xarray Dataset: power [dB] over (channel, frequency_hz, time_s), speed per time."""
        import xarray as xr

        ds = xr.Dataset(
            {"power_db": (("channel", "frequency_hz", "time_s"), self.power_db)},
            coords={"channel": self.channel_names, "frequency_hz": self.frequencies_hz, "time_s": self.times_s,
                    "speed_kmh": ("time_s", self.speeds_kmh)},
            attrs={"source": self.run.source, "rolling_radius_m": self.radius_m,
                   **{k: str(v) for k, v in self.settings.items()}},
        )
        ds["power_db"].attrs["units"] = "dB (re 1 channel unit^2)"
        return ds

    def save(self, path) -> Path:
        """As :meth:`Result.save`; a netCDF (.nc) map gets the summary as JSON next to it (.json)."""
        import json

        from ..io import write_text

        path = super().save(path)
        if path.suffix.lower() == ".nc":
            write_text(path.with_suffix(".json"), json.dumps(self.summary(), indent=2, allow_nan=False))
        return path

    def plot(self, ax=None, channel: int = 0, orders: tuple[int, ...] = tuple(range(1, 31))):
        """Frequency against speed in dB, labelled order rays (:func:`~polywear.units.order_rays`:
        the orders found as features first), Hopf points, SEV band, the model's operating
        speed where the run covers it, detected SEV; the
        frequency axis up to 1.2 times the highest feature or predicted frequency [Hz]
        (the whole map without either)."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(8, 5))
        level = self.power_db[channel]
        order = np.argsort(self.speeds_kmh)
        mesh = ax.pcolormesh(self.speeds_kmh[order], self.frequencies_hz, level[:, order], shading="nearest",
                             cmap="magma", vmin=np.percentile(level, 5), vmax=np.max(level))
        plt.colorbar(mesh, ax=ax, label="power [dB]")
        shown = [f["frequency_to_hz"] for f in self.features]
        shown += [h["frequency_hz"] for h in self.prediction.get("hopf_points", [])]
        fmax = min(float(self.frequencies_hz[-1]), 1.2 * max(shown)) if shown else float(self.frequencies_hz[-1])
        ax.set_ylim(0, fmax)
        found = [int(round(f["frequency_order"])) for f in self.features if f["kind"] == "order"]
        order_rays(ax, orders, self.radius_m, (self.speeds_kmh.min(), self.speeds_kmh.max()), fmax,
                   first=tuple(dict.fromkeys(found)), color="w", lw=0.5, alpha=0.5)
        for lo, hi in self.prediction.get("sev_band_kmh", []):
            ax.axvspan(lo, hi, ymin=0.97, ymax=1.0, color="tab:cyan", label="predicted SEV band")
            for edge in (lo, hi):
                ax.axvline(edge, color="tab:cyan", lw=0.8, ls=":")
        for h in self.prediction.get("hopf_points", []):
            ax.plot(h["speed_kmh"], h["frequency_hz"], "c^", ms=7, label="predicted Hopf point")
        wear = self.prediction.get("wear_most_unstable_orders", [])
        if wear:
            ax.plot([w["speed_kmh"] for w in wear], [w["frequency_hz"] for w in wear], "o", mfc="none",
                    color="tab:olive", ms=4, label="wear map: fastest-growing order")
        operating = self.prediction.get("operating_speed_kmh")
        if operating is not None and self.speeds_kmh.min() <= operating <= self.speeds_kmh.max():
            ax.axvline(operating, color="w", ls="-.", lw=1.2, label=f"operating speed {operating:g} km/h")
        if self.sev and self.sev.get("onset"):
            on = self.sev["onset"]
            ax.axvline(on["speed_kmh"], color="tab:green", ls="--", label="detected SEV onset")
            if on.get("corrected_speed_kmh") is not None:
                ax.axvline(on["corrected_speed_kmh"], color="tab:green", label="onset, ramp-corrected")
        handles, labels = ax.get_legend_handles_labels()
        unique = dict(zip(labels, handles))
        if unique:
            ax.legend(unique.values(), unique.keys(), fontsize=7, loc="upper left")
        ax.set_xlim(self.speeds_kmh.min(), self.speeds_kmh.max())
        ax.set_xlabel("speed [km/h]")
        ax.set_ylabel("frequency [Hz]")
        return mesh


def _prediction(params: Params, speed_range, run_speeds_kmh) -> dict:
    """Hopf points and SEV band of the model; where steady rolling is stable, the wear
    map's fastest-growing polygon order at 25 speeds of the run (its frequency n V/(2 pi R));
    the model's operating speed [km/h]."""
    from ..dynamics.bifurcation import bifurcation
    from ..wear.map import wear_map

    diagram = bifurcation(params, speed_range)
    wear = wear_map(params, np.linspace(run_speeds_kmh.min(), run_speeds_kmh.max(), 25))
    return {
        "operating_speed_kmh": params.operating.speed_kmh,
        "hopf_points": [h.summary() for h in diagram.hopf_points],
        "sev_band_kmh": [list(b) for b in diagram.sev_band_kmh],
        "linear_band_kmh": [list(b) for b in getattr(diagram, "linear_band_kmh", [])],
        "wear_most_unstable_orders": [
            {k: r[k] for k in ("speed_kmh", "order", "frequency_hz", "efold_km")}
            for r in wear.rows() if r["order"] is not None and r["efold_km"] is not None
        ],
    }


def campbell(
    run: Run,
    params: Params,
    settings: CampbellSettings = CampbellSettings(),
    predict: bool = True,
    correct_ramp: bool = True,
) -> CampbellResult:
    """Campbell map of ``run`` with features, SEV and (``predict``) the model's band over it.

    Parameters
    ----------
    run : Run
    params : Params
        The model's parameters: rolling radius for the order rays, the prediction and the
        ramp-delay simulation.
    settings : CampbellSettings
        Spectrogram window and overlap, frequencies searched, detection levels [dB] and
        the disturbance of the ramp simulation.
    predict : bool
        Hopf points and SEV band of the model (a continuation) and the wear map's
        fastest-growing orders over the map.
    correct_ramp : bool
        Simulate the ramp through the nearest destabilizing Hopf point and correct the onset.
    """
    from scipy.signal import spectrogram

    window_s, overlap, peak_db, sev_db = settings.window_s, settings.overlap, settings.peak_db, settings.sev_db

    fs = run.sample_rate_hz
    n = int(round(window_s * fs))
    if n < 16 or n > len(run.t) // 2:
        raise MeasurementError(f"window of {window_s} s is {n} samples: need 16 to half the run ({len(run.t)} samples)")
    f_lo, f_hi = settings.f_range_hz or (10.0, 0.4 * fs)
    power = []
    for x, _ in run.channels.values():
        freqs, times, sxx = spectrogram(x, fs, window="hann", nperseg=n, noverlap=int(overlap * n),
                                        detrend="constant", scaling="spectrum")
        power.append(sxx)
    total = np.sum(power, axis=0)
    tiny = np.finfo(float).tiny
    stack = [total] + power if len(power) > 1 else power
    power_db = 10.0 * np.log10(np.maximum(np.array(stack), tiny))
    speeds = np.interp(times, run.t, run.speed_kmh)
    level = power_db[0] - spectral_floor(power_db[0])
    radius = params.operating.rolling_radius_m
    ridges = [piece for r in track_ridges(freqs, level, peak_db, f_lo, f_hi, speeds) for piece in split_ridge(r, speeds, 6)]
    classified = [(f, r) for r in ridges for f in [classify_ridge(r, speeds, radius, 6)] if f is not None]
    for feature, _ in classified:
        feature["sev"] = False
    # SEV: constant frequency, strong, switching on or off within the run, with the evidence of it
    strong = [(f, r) for f, r in classified if f["kind"] == "constant_frequency" and f["level_db"] >= sev_db]
    candidates = [(f, r) for f, r in strong if r.segments[0] > 1 or r.segments[-1] < len(times) - 2]
    for f, r in strong:
        if (f, r) not in candidates:
            f["not_sev"] = "present over the whole run"
    orders = [f["frequency_order"] for f, _ in classified if f["kind"] == "order"]
    cleaned: dict[str, np.ndarray] = {}  # channel -> without the order features
    found = {}  # id(ridge) -> (channel, frequency, envelope analysis) of the candidates with evidence
    for feature, ridge in candidates:
        f0 = float(np.median(ridge.freqs))
        channel = max(run.channels, key=lambda name: float(np.sum(
            np.array(power[list(run.channels).index(name)])[np.abs(freqs - f0) < 2 * (freqs[1] - freqs[0])])))
        if channel not in cleaned:
            x = run.channels[channel][0]
            cleaned[channel] = remove_orders(x, run.speed_kmh, fs, orders, radius) if orders else x
        t_start, t_end = times[ridge.segments[0]] - window_s / 2, times[ridge.segments[-1]] + window_s / 2
        envelope = sev_from_envelope(run.t, run.speed_kmh, cleaned[channel], fs, f0, t_start, t_end)
        reason = no_evidence(ridge, speeds, envelope, sev_db, freqs[1] - freqs[0])
        if reason:
            feature["not_sev"] = reason
        else:
            found[id(ridge)] = (channel, f0, envelope)
    evidenced = [(f, r) for f, r in candidates if id(r) in found]
    sev = None
    no_sev = None
    if evidenced:
        feature, ridge = fundamental(max(evidenced, key=lambda fr: fr[0]["level_db"]), evidenced)
        feature["sev"] = True
        feature.pop("not_sev", None)
        for f, r in candidates:
            ratio = np.median(r.freqs) / np.median(ridge.freqs)
            if r is not ridge and round(ratio) >= 2 and abs(ratio - round(ratio)) < 0.03 * ratio:
                f["harmonic_of_sev"] = int(round(ratio))
        strongest, f0, sev = found[id(ridge)]
        if sev.get("onset") and "frequency_hz" in sev:
            # the frequency drifts with speed: an uncertain onset speed is an uncertain frequency
            drift = log_slope(speeds[ridge.segments], np.array(ridge.freqs))
            sev["frequency_drift_hz_per_kmh"] = drift
            sev["frequency_uncertainty_hz"] = math.hypot(sev["frequency_uncertainty_hz"],
                                                         drift * sev["onset"]["uncertainty_kmh"])
        sev.update(channel=strongest, unit=run.channels[strongest][1], ridge_frequency_hz=f0,
                   orders_removed=orders,
                   frequency_range_hz=[feature["frequency_from_hz"], feature["frequency_to_hz"]])
    elif strong:
        no_sev = "no constant-frequency feature switches on or off within the run: " + "; ".join(
            f"{np.median(r.freqs):.1f} Hz ({f['speed_from_kmh']:.0f}-{f['speed_to_kmh']:.0f} km/h) {f['not_sev']}"
            for f, r in strong)
    else:
        no_sev = f"no constant-frequency feature stands {sev_db:g} dB above the floor"
    prediction = _prediction(params, (max(5.0, 0.5 * run.speed_kmh.min()), max(300.0, 1.2 * run.speed_kmh.max())),
                             run.speed_kmh) if predict else {}
    if sev is not None and sev.get("onset") and correct_ramp:
        _correct_onset(sev, run, params, settings.disturbance_m)
    features = sorted((f for f, _ in classified), key=lambda f: -f["level_db"])
    return CampbellResult(run, freqs, times, speeds, power_db,
                          (["sum"] if len(power) > 1 else []) + list(run.channels), features, sev, prediction,
                          radius, {"window_s": window_s, "overlap": overlap, "peak_db": peak_db, "sev_db": sev_db,
                                   "disturbance_m": settings.disturbance_m}, no_sev)


def _correct_onset(sev: dict, run: Run, params: Params, disturbance_m: float) -> None:
    """Ramp rate at the onset, the model's nearest destabilizing Hopf point, the delay."""
    from ..dynamics.stability import StabilitySettings, stability

    onset = sev["onset"]
    near = np.abs(run.t - onset["time_s"]) <= 2.0
    rate = float(np.polyfit(run.t[near], run.speed_kmh[near], 1)[0])
    onset["ramp_rate_kmh_per_s"] = rate
    if abs(rate) < 0.05:
        onset["correction"] = "not corrected: the speed is not ramping at the onset"
        return
    hopfs = stability(params, (5.0, max(300.0, 1.5 * run.speed_kmh.max())), StabilitySettings(n_speeds=300)).hopf_points
    entering = [h for h in hopfs if (h.dre_dspeed > 0) == (rate > 0)]
    if not entering:
        onset["correction"] = "not corrected: the model has no Hopf point entering instability in this direction"
        return
    hopf = min(entering, key=lambda h: abs(h.speed_kmh - onset["speed_kmh"]))
    runs = [(disturbance_m, seed) for seed in range(RAMP_SEEDS)] + [(disturbance_m / 10, 0), (disturbance_m * 10, 0)]
    delays = [ramp_delay(params, hopf.speed_kmh, hopf.frequency_hz, rate, d, band_hz=sev["ridge_frequency_hz"], seed=k)
              for d, k in runs]
    shifts = [d[1] for d in delays[:RAMP_SEEDS] if d is not None and math.isfinite(d[1])]
    delays = [None if d is None else d[0] for d in delays]
    same = [d for d in delays[:RAMP_SEEDS] if d is not None]
    if not same:
        onset["correction"] = "not corrected: the simulated ramp shows no onset within 20 km/h of the Hopf point"
        return
    delay = float(np.mean(same))
    scatter = float(np.std(same, ddof=1)) if len(same) > 1 else 0.0
    levels = [d for d in delays[RAMP_SEEDS:] if d is not None] + [delay]
    level_spread = 0.5 * (max(levels) - min(levels))
    if shifts and sev.get("frequency_hz") is not None:
        sev["frequency_shift_hz"] = float(np.mean(shifts))
        sev["corrected_frequency_hz"] = sev["frequency_hz"] - sev["frequency_shift_hz"]
        sev["corrected_frequency_uncertainty_hz"] = math.hypot(
            sev["frequency_uncertainty_hz"], float(np.std(shifts, ddof=1)) if len(shifts) > 1 else 0.0)
    onset.update(
        hopf_speed_kmh=hopf.speed_kmh,
        hopf_index=hopfs.index(hopf),
        ramp_delay_kmh=delay,
        ramp_delay_scatter_kmh=scatter,
        ramp_delay_by_disturbance_kmh={f"{d:.2g}": x for (d, _), x in zip(runs[RAMP_SEEDS:], delays[RAMP_SEEDS:])},
        corrected_speed_kmh=onset["speed_kmh"] - math.copysign(delay, rate),
        corrected_uncertainty_kmh=math.sqrt(onset["uncertainty_kmh"] ** 2 + scatter**2 + level_spread**2),
        correction=(f"ramp-corrected: the model, ramped at {rate:.3g} km/h/s through its Hopf point at "
                    f"{hopf.speed_kmh:.1f} km/h with tread kicks of {disturbance_m:g} m, shows SEV {delay:.1f} "
                    f"+- {scatter:.1f} km/h late ({RAMP_SEEDS} seeds; kicks x0.1 / x10 give "
                    + ", ".join("none" if x is None else f"{x:.1f}" for x in delays[RAMP_SEEDS:]) + " km/h)"),
    )
    off = abs(onset["corrected_speed_kmh"] - hopf.speed_kmh)
    if off > HOPF_MISMATCH_KMH:
        onset["warning"] = (f"the model's Hopf point ({hopf.speed_kmh:.1f} km/h) is {off:.1f} km/h from the "
                            f"ramp-corrected onset ({onset['corrected_speed_kmh']:.1f} km/h), more than "
                            f"{HOPF_MISMATCH_KMH:g} km/h: the model describes another tyre, and its delay may not "
                            "hold for this one; not a calibration observation (calibrate roughly first, e.g. "
                            "with the detected onset)")
