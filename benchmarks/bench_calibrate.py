"""Calibration timings: 4 parameters fitted to 6 observations (goal < 10 s tread1dof, < 60 s axle4dof).

Synthetic observations: the model's own values at a perturbed parameter set (every varied
key moved by 5-10 %), fitted from the defaults. Observations: first and second Hopf speed
and the Hopf frequency at toe 0.5 deg, the first Hopf speed at toe 0.3 deg, and two points
of the steady friction curve. Timed: the fit with the exact Jacobian, without and with the
profile-likelihood intervals. Baseline in the same run: the same weighted least squares
with scipy's finite-difference Jacobian (``jac="2-point"``) on the same model evaluations.

    .venv/bin/python benchmarks/bench_calibrate.py [--model tread1dof|axle4dof|both]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from polywear.measured.calibration import Observation, calibrate, predict
from polywear.params import Params, get_value, with_updates

KEYS = {
    "tread1dof": ["tread.lateral_damping_ns_per_m", "friction.stribeck_velocity_m_per_s", "friction.mu_static",
                  "friction.stribeck_exponent"],
    "axle4dof": ["tread.lateral_damping_ns_per_m", "friction.stribeck_velocity_m_per_s", "friction.mu_static",
                 "axle.toe_damping_nms_per_rad"],
}
FACTORS = (1.08, 0.93, 1.05, 1.1)


def _observations() -> list[Observation]:
    toe = (("operating.toe_deg", 0.3),)
    return [
        Observation("first_hopf_kmh", 0.0, 1.0),
        Observation("second_hopf_kmh", 0.0, 2.0),
        Observation("hopf_frequency_hz", 0.0, 0.5),
        Observation("first_hopf_kmh", 0.0, 1.0, set=toe),
        Observation("friction_mu", 0.0, 0.01, at_sliding_speed_m_per_s=0.1),
        Observation("friction_mu", 0.0, 0.01, at_sliding_speed_m_per_s=0.4),
    ]


def _finite_difference_fit(params, observations, keys):
    """The baseline: the same weighted problem, Jacobian by scipy's forward differences."""
    from scipy.optimize import least_squares

    scale = np.array([get_value(params, k) for k in keys])
    observed = np.array([o.value for o in observations])
    sigma = np.array([o.sigma for o in observations])

    def residual(x):
        trial = with_updates(params, dict(zip(keys, map(float, x * scale))))
        return (predict(trial, observations, keys[:0])[0] - observed) / sigma

    return least_squares(residual, np.ones(len(keys)), jac="2-point", method="trf", xtol=1e-10, ftol=1e-10,
                         gtol=1e-10, max_nfev=100)


def bench(model: str) -> None:
    params = with_updates(Params(), {"model": model})
    keys = KEYS[model]
    truth = with_updates(params, {k: get_value(params, k) * f for k, f in zip(keys, FACTORS)})
    base = _observations()
    values, _ = predict(truth, base, keys)  # also compiles / loads the kernels
    obs = [Observation(o.quantity, float(v), o.sigma, o.at_speed_kmh, o.at_sliding_speed_m_per_s, o.set)
           for o, v in zip(base, values)]
    t0 = time.perf_counter()
    fast = calibrate(params, obs, keys, profile=False)
    t_fit = time.perf_counter() - t0
    t0 = time.perf_counter()
    full = calibrate(params, obs, keys, profile=True)
    t_profile = time.perf_counter() - t0
    t0 = time.perf_counter()
    fd = _finite_difference_fit(params, obs, keys)
    t_fd = time.perf_counter() - t0
    worst = max(abs(p["value"] / get_value(truth, p["key"]) - 1.0) for p in fast.parameters if p["identifiable"])
    print(f"\n{model}: {len(keys)} parameters, {len(obs)} observations")
    print(f"  exact Jacobian, linearized intervals   {t_fit:7.2f} s  ({fast.identifiability['evaluations']} evaluations;"
          f" largest relative error of the fit {worst:.1e})")
    closed = sum(1 for p in full.parameters if p["profile_ci"] and None not in p["profile_ci"])
    print(f"  exact Jacobian + profile likelihood    {t_profile:7.2f} s   (goal < {10 if model == 'tread1dof' else 60} s;"
          f" {closed} of {len(keys)} profile intervals closed)")
    print(f"  baseline: finite-difference Jacobian   {t_fd:7.2f} s  ({fd.nfev} fits of residuals + "
          f"{fd.njev} Jacobians) -> exact is {t_fd / t_fit:.1f}x faster")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="both", choices=["tread1dof", "axle4dof", "both"])
    args = parser.parse_args()
    for model in (["tread1dof", "axle4dof"] if args.model == "both" else [args.model]):
        bench(model)


if __name__ == "__main__":
    main()
