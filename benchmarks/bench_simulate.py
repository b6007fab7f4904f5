"""Compiled Rodas4 fast path against scipy's Radau with the pure-Python right-hand side.

For each model: a ``--duration`` s run at ``--speed`` km/h from the equilibrium with x
moved by 0.1 mm, both integrators at the same tolerances and on the same output grid,
timed in this process. The baseline is ``scipy.integrate.solve_ivp(method="Radau")``
with ``models.<name>.rhs_python`` (plain Python/NumPy) and no Jacobian (scipy's own
finite differences: the models ship no pure-Python Jacobian). Prints the speed-up
(goal >= 100x) and the steady amplitude of every state from both runs (half the
peak-to-peak of the grid samples over the last quarter; goal: agree within 0.5 %).

    .venv/bin/python benchmarks/bench_simulate.py [--duration 2] [--speed 110] [--models tread1dof,axle4dof]
"""

from __future__ import annotations

import argparse
import importlib
import time

import numpy as np
from scipy.integrate import solve_ivp

from polywear.models import get_model
from polywear.params import Params, with_updates
from polywear.solvers.integrate import integrate, output_grid


def _amplitudes(t, u, t_end):
    tail = t >= 0.75 * t_end
    return 0.5 * np.ptp(u[tail], axis=0)


def bench(name: str, duration: float, speed_kmh: float, rtol: float, atol: float, dt_out: float) -> None:
    try:
        module = importlib.import_module(f"polywear.models.{name}")
    except ImportError as exc:
        print(f"{name}: skipped (model not available: {exc})")
        return
    model = get_model(name)
    params = with_updates(Params(), {"model": name})
    p = model.pack(params)
    V = speed_kmh / 3.6
    u0 = model.equilibrium(V, p).copy()
    u0[model.index("x")] += 1e-4
    grid = output_grid(duration, dt_out)

    t0 = time.perf_counter()
    integrate(model, u0, V, p, 1e-3, rtol=rtol, atol=atol)
    cold = time.perf_counter() - t0
    fast_times = []
    for _ in range(5):  # best of 5: the fast path is short enough for timer and load noise to matter
        t0 = time.perf_counter()
        fast = integrate(model, u0, V, p, duration, dt_out=dt_out, rtol=rtol, atol=atol)
        fast_times.append(time.perf_counter() - t0)
    t_fast = min(fast_times)

    rhs = module.rhs_python

    def baseline(pv):
        t0 = time.perf_counter()
        sol = solve_ivp(lambda t, u: rhs(t, u, V, pv), (0.0, duration), u0, method="Radau", t_eval=grid,
                        rtol=rtol, atol=atol)
        return sol, time.perf_counter() - t0

    # the baseline: the pure-Python rhs of the same derivation, evaluating everything
    # at every call as a lambdified function would; and, where the model caches speed-only
    # quantities for the fast path (model.prepared), the same rhs given that cache too
    ref, t_ref = baseline(p)
    p_run = model.prepared(V, p)
    cached = None if p_run is p else baseline(p_run)
    if ref.status != 0:
        print(f"{name}: baseline failed: {ref.message}")
        return

    a_fast = _amplitudes(fast.t, fast.u, duration)
    a_ref = _amplitudes(ref.t, ref.y.T, duration)
    print(f"\n{name}: {duration:g} s at {speed_kmh:g} km/h, rtol {rtol:g}, atol {atol:g}, output every {dt_out:g} s")
    print(f"  fast path  Rodas4 (numba, cfunc kernels, analytic Jacobian): {t_fast:8.3f} s best of 5, "
          f"median {np.median(fast_times):.3f} s ({fast.stats.accepted} steps, {fast.stats.rejected} rejected; "
          f"first call incl. cache load {cold:.2f} s)")
    print(f"  baseline   solve_ivp Radau, rhs_python, finite-difference Jacobian: {t_ref:8.3f} s "
          f"({ref.nfev} rhs calls, {ref.njev} Jacobians)")
    print(f"  speed-up   {t_ref / t_fast:8.1f}x   (goal >= 100x)")
    if cached is not None:
        print(f"  baseline with the fast path's per-speed cache:                    {cached[1]:8.3f} s "
              f"-> speed-up {cached[1] / t_fast:.1f}x")
    print(f"  {'state':>10s} {'fast':>13s} {'baseline':>13s} {'rel. diff':>10s}")
    for q, unit, a, b in zip(model.state_names, model.state_units, a_fast, a_ref):
        rel = abs(a - b) / abs(b) if b else float("nan")
        print(f"  {q:>10s} {a:13.6e} {b:13.6e} {rel:10.2e}  [{unit}]")
    worst = np.nanmax(np.abs(a_fast - a_ref) / np.where(a_ref > 0, a_ref, np.nan))
    print(f"  largest relative amplitude difference {worst:.2e} (goal < 5e-3)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=2.0, help="simulated time [s]")
    parser.add_argument("--speed", type=float, default=110.0, help="speed [km/h]")
    parser.add_argument("--rtol", type=float, default=1e-8)
    parser.add_argument("--atol", type=float, default=1e-12)
    parser.add_argument("--dt-out", type=float, default=2e-5, help="output grid [s]")
    parser.add_argument("--models", default="tread1dof,axle4dof")
    args = parser.parse_args()
    for name in args.models.split(","):
        bench(name.strip(), args.duration, args.speed, args.rtol, args.atol, args.dt_out)


if __name__ == "__main__":
    main()
