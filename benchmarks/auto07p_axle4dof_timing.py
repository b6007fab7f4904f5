"""Wall time of AUTO-07p's axle4dof bifurcation diagram (bifpy's callback path).

    .venv/bin/python benchmarks/auto07p_axle4dof_timing.py [--repeat N] [--refined]

Times :func:`polywear.validation.auto07p.model_diagram` on the axle4dof defaults,
20-300 km/h: AUTO calls back into Python for every right-hand side and Jacobian
(``MODEL.f``, ``MODEL.jacobian``, ``MODEL.df_dspeed`` in AUTO's scaled units). Baseline
measured in the same run: polywear's own continuation of the same diagram. Also prints
the cost of one callback of each kind, so the share of the model in AUTO's wall time
can be judged; ``--refined`` adds one run at ``settings.refined()``.
"""

from __future__ import annotations

import argparse
import time
import timeit

import numpy as np

from polywear.dynamics.bifurcation import bifurcation
from polywear.units import kmh_to_ms
from polywear.params import Params
from polywear.validation.auto07p import AUTO_MODELS, SPEED_INDEX, model_diagram


def best_of(repeat, fn):
    times, result = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - start)
    return min(times), result


def callback_microseconds(params: Params) -> tuple[float, float]:
    """(FUNC, Jacobian) callback cost [us] at the equilibrium at 110 km/h."""
    problem = AUTO_MODELS[params.model]
    p = problem.model.pack(params)
    V = kmh_to_ms(110.0)
    u = problem.model.equilibrium(V, p) / np.asarray(problem.state_unit)
    par = np.zeros(36)
    par[0] = V
    func, jacobian_for = problem.equations(p)
    jac = jacobian_for([SPEED_INDEX, 11])
    n = 20_000
    func(u, par), jac(u, par)  # compile / load caches
    return (timeit.timeit(lambda: func(u, par), number=n) / n * 1e6,
            timeit.timeit(lambda: jac(u, par), number=n) / n * 1e6)  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="runs (best is kept)")
    parser.add_argument("--refined", action="store_true", help="also time AUTO at settings.refined()")
    args = parser.parse_args()
    params = Params(model="axle4dof")
    bifurcation(params)  # compile / load caches
    t_ours, ours = best_of(args.repeat, lambda: bifurcation(params, (20.0, 300.0)))
    t_auto, auto = best_of(args.repeat, lambda: model_diagram(params, (20.0, 300.0)))
    n_eq = len(auto["equilibrium"]["speed_kmh"])
    n_cycles = sum(len(c["speed_kmh"]) for c in auto["cycles"])
    settings = AUTO_MODELS["axle4dof"].settings
    print(f"axle4dof diagram 20-300 km/h, AUTO-07p via {auto['auto']['package']} (callback path), "
          f"best of {args.repeat}")
    print(f"  AUTO, NTST {settings.ntst}: {t_auto:6.2f} s ({n_eq} equilibria, {n_cycles} cycles)")
    if args.refined:
        fine = settings.refined()
        t_fine, refined = best_of(1, lambda: model_diagram(params, (20.0, 300.0), fine))
        n_fine = sum(len(c["speed_kmh"]) for c in refined["cycles"])
        print(f"  AUTO refined, NTST {fine.ntst}: {t_fine:6.2f} s ({n_fine} cycles)")
    n_ours = sum(len(b.points) for b in ours.branches)
    print(f"  polywear continuation (baseline): {t_ours:6.2f} s ({n_ours} cycles)")
    print(f"  ratio AUTO / polywear = {t_auto / t_ours:.1f}x")
    func_us, jac_us = callback_microseconds(params)
    print(f"  one callback: FUNC {func_us:.1f} us, Jacobian {jac_us:.1f} us (plus bifpy's ctypes trampoline)")


if __name__ == "__main__":
    main()
