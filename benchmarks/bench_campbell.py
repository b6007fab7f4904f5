"""Campbell map timings: a 60 s run-up sampled at 5 kHz (goal < 3 s).

The run: 40 -> 160 km/h in 60 s (2 km/h/s); one acceleration channel made of a
constant-frequency feature switching on at 70 km/h (130 Hz with two harmonics), wheel
orders 8, 16 and 24, and white noise: 300 000 samples. Timed: the map with feature
tracking and SEV detection (``campbell(predict=False, correct_ramp=False)``: spectrogram,
ridges, order removal, envelope); the model's prediction (continuation) and the ramp
simulation are timed separately. Baseline in the same run: ``scipy.signal.spectrogram``
of the channel alone (the least any Campbell map costs).

    .venv/bin/python benchmarks/bench_campbell.py
"""

from __future__ import annotations

import time

import numpy as np

from polywear.measured.campbell import campbell
from polywear.units import order_frequency_hz
from polywear.measured.run_file import Run
from polywear.params import Params


def synthetic_run(fs: float = 5000.0, duration_s: float = 60.0) -> Run:
    rng = np.random.default_rng(0)
    t = np.arange(0.0, duration_s, 1.0 / fs)
    speed = 40.0 + 2.0 * t
    on = 1.0 / (1.0 + np.exp(-(speed - 70.0)))
    x = sum(a * on * np.sin(2 * np.pi * k * 130.0 * t) for k, a in ((1, 50.0), (2, 10.0), (3, 3.0)))
    for n in (8, 16, 24):
        x = x + 2.0 * np.sin(2 * np.pi * np.cumsum(order_frequency_hz(n, speed, 0.3)) / fs)
    return Run("synthetic", t, speed, {"acc_y": (x + rng.standard_normal(t.size), "m/s^2")})


def main() -> None:
    from scipy.signal import spectrogram

    run = synthetic_run()
    params = Params()
    campbell(run, params, predict=False, correct_ramp=False)  # imports, first calls
    t0 = time.perf_counter()
    result = campbell(run, params, predict=False, correct_ramp=False)
    t_map = time.perf_counter() - t0
    n = int(0.5 * run.sample_rate_hz)
    t0 = time.perf_counter()
    spectrogram(run.channels["acc_y"][0], run.sample_rate_hz, window="hann", nperseg=n, noverlap=int(0.75 * n))
    t_spec = time.perf_counter() - t0
    t0 = time.perf_counter()
    full = campbell(run, params, predict=True, correct_ramp=True)
    t_full = time.perf_counter() - t0
    sev = result.sev
    print(f"\nCampbell map of a {run.t[-1]:.0f} s run at {run.sample_rate_hz:g} Hz ({run.t.size} samples)")
    print(f"  map + features + SEV detection     {t_map:7.3f} s   (goal < 3 s; {len(result.features)} features, "
          f"SEV at {sev['frequency_hz']:.2f} Hz, onset {sev['onset']['speed_kmh']:.1f} km/h)")
    print(f"  baseline: scipy spectrogram alone  {t_spec:7.3f} s   -> the map costs {t_map / t_spec:.1f}x the "
          "bare spectrogram")
    print(f"  with prediction and ramp delay     {t_full:7.3f} s   (continuation + "
          f"{5} simulated ramps; ramp delay {full.sev['onset'].get('ramp_delay_kmh', float('nan')):.1f} km/h)")


if __name__ == "__main__":
    main()
