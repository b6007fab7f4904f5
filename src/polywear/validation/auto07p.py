"""Bifurcation diagrams computed by AUTO-07p, as an independent reference.

AUTO-07p (Doedel et al.) is the reference continuation code; it is reached through the
``bifpy`` package (PyPI, optional extra ``polywear[auto07p]``), which compiles AUTO-07p
from source at install time (gfortran and GNU make: ``scripts/ensure-auto07p.sh``).
:func:`model_diagram` runs the same diagram for either model; only the way the
equations reach AUTO differs (:data:`AUTO_MODELS`):

* ``tread1dof``: the equations are written here again, from docs/model.md section 3,
  independently of the numba kernels in :mod:`polywear.models.tread1dof` (the tests
  check that both agree), as plain Python that bifpy traces symbolically and compiles
  to a native AUTO-07p executable (``transpile=True``). This checks both the equations
  and the continuation.
* ``axle4dof``: its 9 equations come from a sympy derivation and exist only as compiled
  kernels, so AUTO calls back into Python (``transpile=False``): FUNC is ``MODEL.f``,
  the analytic Jacobian ``MODEL.jacobian`` and ``MODEL.df_dspeed``. This validates the
  continuation (AUTO's algorithms against ours) on the 9-dimensional system, not the
  equations; those are checked by ``tests/test_axle4dof.py``.

The equations in AUTO's form and scaled units (ms, mm, mrad; ``V`` [m/s] is PAR(1)) and
AUTO's constants are in :mod:`polywear.validation.auto07p_problem`; this module runs
AUTO and reads its results.

Runs: (1) the steady rolling state continued in ``V`` over the speed range, Hopf
points detected (HB); (2) from every Hopf point not already reached by an earlier
branch, the family of periodic orbits continued in ``V`` with folds (LP) and
Floquet stability, until it returns to a Hopf point (AUTO reports a branch point, BP,
where the cycle shrinks onto the equilibrium) or leaves the speed range. Every branch
point's orbit is stored (NPR = 1) so amplitudes come from the orbit itself; the cycle at
the operating speed of ``params`` is located exactly (UZR).

AUTO's scratch files live in a temporary directory that is removed afterwards, also when
AUTO fails.
"""

from __future__ import annotations

import re
import shutil
import tempfile
import time
from contextlib import contextmanager
from dataclasses import asdict
from pathlib import Path
from typing import Any, Iterator

import numpy as np

from ..dynamics.points import PointKind, SpecialPoint
from ..errors import NumericalError
from ..models import get_model
from ..params import ParameterError, Params
from ..units import DEFAULT_SPEED_RANGE_KMH, kmh_to_ms, ms_to_kmh
from .auto07p_problem import (AUTO_MODELS, AXLE4DOF_STATE_UNIT, SPEED_INDEX, STATE_UNIT, TIME_UNIT_S, AutoModel,
                              AutoSettings, auto_jacobian, auto_rhs, kernel_jacobian, kernel_rhs, starting_point)

__all__ = [
    "AutoSettings",
    "AutoModel",
    "AUTO_MODELS",
    "Auto07pError",
    "INSTALL_HINT",
    "STATE_UNIT",
    "AXLE4DOF_STATE_UNIT",
    "TIME_UNIT_S",
    "auto07p_available",
    "auto_rhs",
    "auto_jacobian",
    "kernel_rhs",
    "kernel_jacobian",
    "orbit_extremes",
    "model_diagram",
    "tread1dof_diagram",
    "headline_numbers",
    "AUTO_KINDS",
    "point_kind",
    "special_points",
    "refinement_study",
]

INSTALL_HINT = (
    "AUTO-07p is not available: run `scripts/ensure-auto07p.sh .venv` (installs gfortran "
    "if missing, then `pip install polywear[auto07p]`, i.e. bifpy, which compiles AUTO-07p)"
)

AUTO_KINDS = {
    "HOPF_BIFURCATION": PointKind.HOPF,
    "FOLD": PointKind.LP,
    "BRANCH_POINT": PointKind.BP,
    "PERIOD_DOUBLING": PointKind.PD,
    "TORUS": PointKind.NS,
    "GENERALIZED_HOPF": PointKind.GH,
}
"""AUTO-07p's point types (bifpy's ``PointType`` names) as special-point kinds."""


def point_kind(point) -> PointKind | None:
    """The :class:`~polywear.dynamics.points.PointKind` of an AUTO-07p solution point
    (None: a regular, end or user point)."""
    return AUTO_KINDS.get(point.point_type.name)


class Auto07pError(NumericalError):
    """AUTO-07p did not complete a run (its output, already deleted, is quoted)."""


def auto07p_available() -> tuple[bool, str]:
    """(True, "") when bifpy imports and gfortran is on PATH, else (False, how to install)."""
    try:
        import bifpy.auto  # noqa: F401
    except ImportError:
        return False, INSTALL_HINT
    if shutil.which("gfortran") is None:
        return False, INSTALL_HINT
    return True, ""


# -- orbits ---------------------------------------------------------------------------
def orbit_extremes(state, ncol: int, samples_per_interval: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """Per-state minimum and maximum of AUTO's piecewise-polynomial orbit.

    ``state`` is an orbit as AUTO stores it: ``ntst * ncol + 1`` rows, ``ncol + 1``
    equispaced values per mesh interval (shared at interval ends), which define the
    degree-``ncol`` collocation polynomial of that interval. Each extremum is found on
    ``samples_per_interval`` points per interval, then polished by Newton steps on the
    derivative of that interval's polynomial, so it does not depend on where AUTO
    happened to store points.
    """
    values = np.asarray(state, dtype=float)
    ntst, rest = divmod(len(values) - 1, ncol)
    if rest or ntst < 1:
        raise ValueError(f"orbit of {len(values)} points is not ntst * {ncol} + 1")
    pieces = np.stack([values[i * ncol : (i + 1) * ncol + 1] for i in range(ntst)])
    order = np.arange(ncol + 1)
    to_monomial = np.linalg.inv(np.linspace(0.0, 1.0, ncol + 1)[:, None] ** order)
    coeffs = np.einsum("mj,ijn->imn", to_monomial, pieces)  # p(s) = sum_m c_m s^m, s in [0, 1]
    grid = np.linspace(0.0, 1.0, samples_per_interval)
    fine = np.einsum("sm,imn->isn", grid[:, None] ** order, coeffs)
    extremes = np.empty((2, values.shape[1]))
    for row, sign in enumerate((-1.0, 1.0)):
        for n in range(values.shape[1]):
            interval, sample = np.unravel_index(np.argmax(sign * fine[:, :, n]), fine.shape[:2])
            c = sign * coeffs[interval, :, n]
            best, s = sign * fine[interval, sample, n], grid[sample]
            for _ in range(4):  # Newton on p'(s) = 0 from the best sample
                slope = np.sum(order[1:] * c[1:] * s ** (order[1:] - 1))
                curvature = np.sum(order[2:] * (order[2:] - 1) * c[2:] * s ** (order[2:] - 2))
                if curvature >= 0.0:
                    break
                s = min(max(s - slope / curvature, 0.0), 1.0)
                best = max(best, float(np.sum(c * s**order)))
            extremes[row, n] = sign * best
    return extremes[0], extremes[1]


def _cycle_summary(point, problem: AutoModel, p, settings: AutoSettings) -> dict[str, Any]:
    """Speed, period, per-state amplitude (SI), smallest sliding velocity, stability of one
    periodic-orbit point.

    The sliding velocity (the model's ``aux`` kernel) at the stored points is extended by
    the same piecewise polynomial as the states (exact where it is linear in the state,
    as in ``tread1dof``).
    """
    orbit = point.periodic_orbit
    if orbit is None:
        raise Auto07pError(f"AUTO stored no orbit for point {point.point_number} (NPR = 1 expected)")
    model, units, speed = problem.model, np.asarray(problem.state_unit), point.parameters[0]
    ncol, samples = orbit.collocation_points_per_interval, settings.samples_per_interval
    low, high = orbit_extremes(orbit.state, ncol, samples)
    aux = model.diagnostics(np.asarray(orbit.state) * units, speed, p)
    sliding = aux[:, model.aux_names.index("sliding_velocity")]
    min_sliding = orbit_extremes(sliding[:, None], ncol, samples)[0][0]
    multipliers = np.asarray(point.floquet_multipliers or (), dtype=complex)
    if multipliers.size:  # drop the trivial multiplier (the one nearest 1)
        multipliers = np.delete(multipliers, np.argmin(np.abs(multipliers - 1.0)))
    return {
        "speed_kmh": float(ms_to_kmh(speed)),
        "period_s": float(orbit.period) * TIME_UNIT_S,
        "amplitude": {
            name: float(a) for name, a in zip(model.state_names, 0.5 * (high - low) * units)
        },
        "min_sliding_velocity_m_per_s": float(min_sliding),
        "stable": point.stability.name == "STABLE",
        "floquet_max_modulus": float(np.abs(multipliers).max()) if multipliers.size else None,
    }


# -- running AUTO ---------------------------------------------------------------------
@contextmanager
def _scratch_directory() -> Iterator[str]:
    """Point the ``tempfile`` default at a fresh directory, removed on exit.

    bifpy makes its run directories with ``tempfile.mkdtemp()`` and keeps them when a
    run fails; routing them into this directory removes every scratch file.
    """
    previous = tempfile.tempdir
    with tempfile.TemporaryDirectory(prefix="polywear-auto07p-") as scratch:
        tempfile.tempdir = scratch
        try:
            yield scratch
        finally:
            tempfile.tempdir = previous


def _auto_seconds(output_directory: str | None) -> float | None:
    """AUTO's own reported run time ("Total Time" in its output) [s], None if absent."""
    if output_directory is None:
        return None
    path = Path(output_directory) / "stdout.txt"
    match = re.search(r"Total Time\s+([0-9.Ee+-]+)", path.read_text()) if path.is_file() else None
    return float(match.group(1)) if match else None


def _call_auto(entry, *args, **kwargs):
    """Run bifpy's ``run``/``restart``; AUTO's own run time alongside the result."""
    from bifpy import auto

    try:
        result = entry(*args, keep_output=True, **kwargs)
    except auto.AutoError as exc:
        tail = "\n".join(str(exc).strip().splitlines()[-12:])
        raise Auto07pError(f"AUTO-07p failed:\n{tail}") from None
    return result, _auto_seconds(result.output_directory)


def _constants(settings: AutoSettings, ndim: int, ips: int, lo: float, hi: float, dsmax: float) -> dict[str, Any]:
    return dict(
        ips=ips, ndim=ndim, npar=SPEED_INDEX, jac=1, ilp=1, isp=2, iad=3,
        ntst=settings.ntst, ncol=settings.ncol, nmx=settings.nmx, npr=1,
        ds=settings.ds, dsmin=settings.dsmin, dsmax=dsmax, rl0=lo, rl1=hi,
        epsl=settings.epsl, epsu=settings.epsu, epss=settings.epss,
    )  # fmt: skip


def _return_to_hopf(amplitude: np.ndarray, speed: np.ndarray, hopf_speeds: list[float]) -> tuple[int, int | None]:
    """(index, Hopf index) where a cycle branch first shrinks back onto a Hopf point.

    AUTO passes through such a point as through a regular one (only sometimes flagging
    a BP a step later) and would go round the closed family again, so the branch is
    cut at the first local minimum of the amplitude below 1 % of its maximum, after it
    has grown past 10 %, if that speed is within 1e-3 of a Hopf speed. (None: no return.)
    """
    big = amplitude.max(initial=0.0)
    if big <= 0.0 or not hopf_speeds:
        return len(amplitude) - 1, None
    grown = int(np.argmax(amplitude > 0.1 * big))
    for k in range(grown, len(amplitude)):
        if amplitude[k] < 0.01 * big and (k == len(amplitude) - 1 or amplitude[k + 1] >= amplitude[k]):
            nearest = int(np.argmin([abs(speed[k] - h) for h in hopf_speeds]))
            if abs(speed[k] - hopf_speeds[nearest]) <= 1e-3 * hopf_speeds[nearest]:
                return k, nearest
    return len(amplitude) - 1, None


def _end_reason(point, lo: float, hi: float) -> str:
    """Why AUTO stopped a branch that did not return to a Hopf point."""
    name = point.point_type.name
    if name == "END_POINT" and not lo < point.parameters[0] < hi:
        return "speed_range"
    return {"ABNORMAL_TERMINATION": "no_convergence", "BRANCH_POINT": "branch_point"}.get(name, "step_limit")


def model_diagram(
    params: Params,
    speed_range_kmh: tuple[float, float] = DEFAULT_SPEED_RANGE_KMH,
    settings: AutoSettings | None = None,
) -> dict[str, Any]:
    """Bifurcation diagram of ``params.model`` in the vehicle speed, by AUTO-07p.

    Parameters
    ----------
    params : every value is used (``model.pack(params)``); the operating speed is also
        located on every cycle branch that passes it.
    speed_range_kmh : (low, high) speed range [km/h], low > 0.
    settings : AUTO constants, :class:`AutoSettings`; default: the model's own
        (``AUTO_MODELS[params.model].settings``). ``axle4dof`` needs ``transpile=False``.

    Returns
    -------
    A JSON-serializable dict: ``hopf`` (speed_kmh, frequency_hz), ``folds``
    (speed_kmh, amplitude_x_m, period_s), ``operating_point`` (cycles at the operating
    speed), ``equilibrium`` (speed_kmh, stable), ``cycles`` (one entry per branch:
    arrays speed_kmh, period_s, amplitude per state [SI], stable,
    floquet_max_modulus, min_sliding_velocity_m_per_s, and how the branch ended),
    ``auto`` (versions, settings) and ``wall_time_s`` / ``auto_time_s`` (AUTO's own
    solver time, without tracing, compiling and parsing; None on the callback path,
    where AUTO does not report it).
    """
    if params.model not in AUTO_MODELS:
        raise ParameterError(f"model = {params.model!r}: AUTO-07p covers {', '.join(AUTO_MODELS)}")
    problem = AUTO_MODELS[params.model]
    settings = problem.settings if settings is None else settings
    if settings.transpile and not problem.traceable:
        raise ParameterError(
            f"model = {params.model!r}: its equations are compiled kernels that bifpy cannot "
            "trace; use AutoSettings(transpile=False)"
        )
    lo_kmh, hi_kmh = (float(v) for v in speed_range_kmh)
    if not 0.0 < lo_kmh < hi_kmh:
        raise ParameterError(f"speed range {speed_range_kmh!r} km/h: need 0 < low < high")
    try:
        from bifpy import auto
    except ImportError:
        raise ImportError(INSTALL_HINT) from None
    from importlib.metadata import version

    lo, hi = kmh_to_ms(lo_kmh), kmh_to_ms(hi_kmh)
    operating = kmh_to_ms(params.operating.speed_kmh)
    model = problem.model
    p = model.pack(params)
    func, jacobian_for = problem.equations(p)
    common = dict(transpile=settings.transpile)
    start = time.perf_counter()
    auto_seconds = []

    with _scratch_directory():
        eq_constants = _constants(settings, model.n, auto.IPS_EQUILIBRIUM, lo, hi, settings.dsmax_equilibrium)
        equilibrium, seconds = _call_auto(
            auto.run, func, starting_point(model.equilibrium(lo, p), lo, problem.state_unit), eq_constants,
            icu=[SPEED_INDEX], jac=jacobian_for([SPEED_INDEX]), **common,
        )  # fmt: skip
        auto_seconds.append(seconds)
        eq_points = [pt for branch in equilibrium.branches for pt in branch.points]
        hopf_points = [pt for pt in eq_points if point_kind(pt) is PointKind.HOPF]
        hopf = [
            {
                "speed_kmh": float(ms_to_kmh(pt.all_parameters[SPEED_INDEX - 1])),
                "frequency_hz": 1.0 / (pt.all_parameters[auto.PERIOD_INDEX - 1] * TIME_UNIT_S),
            }
            for pt in hopf_points
        ]
        hopf_speeds = [pt.all_parameters[SPEED_INDEX - 1] for pt in hopf_points]

        cycle_constants = _constants(settings, model.n, auto.IPS_PERIODIC_ORBIT, lo, hi, settings.dsmax_cycles)
        icu = [SPEED_INDEX, auto.PERIOD_INDEX]
        cycles, folds, at_operating, reached = [], [], [], set()
        for index, hb in enumerate(hopf_points):
            if index in reached:
                continue
            result, seconds = _call_auto(
                auto.restart, func, cycle_constants, restart_point=hb, icu=icu,
                isw=auto.ISW_HOPF_TO_PERIODIC_ORBIT, source_ips=auto.IPS_EQUILIBRIUM,
                jac=jacobian_for(icu), stop=["BP1"],
                uzr={SPEED_INDEX: [operating]} if lo < operating < hi else None, **common,
            )  # fmt: skip
            auto_seconds.append(seconds)
            points = [pt for branch in result.branches for pt in branch.points]
            rows = [_cycle_summary(pt, problem, p, settings) for pt in points]
            end, hopf_index = _return_to_hopf(
                np.array([r["amplitude"]["x"] for r in rows]),
                np.array([pt.parameters[0] for pt in points]),
                hopf_speeds,
            )
            ended = "hopf" if hopf_index is not None else _end_reason(points[-1], lo, hi)
            if hopf_index is not None:
                reached.add(hopf_index)
            points, rows = points[: end + 1], rows[: end + 1]
            end_speed = points[-1].parameters[0]
            largest = max(r["amplitude"]["x"] for r in rows)
            for pt, row in zip(points, rows):
                # AUTO also flags LP where the branch turns back through a Hopf point
                # (amplitude -> 0): a fold of the parametrization, not of cycles
                if point_kind(pt) is PointKind.LP and row["amplitude"]["x"] > 0.01 * largest:
                    folds.append(
                        {"speed_kmh": row["speed_kmh"], "amplitude_x_m": row["amplitude"]["x"],
                         "period_s": row["period_s"], "amplitude": row["amplitude"]}
                    )  # fmt: skip
                if pt.point_type == auto.PointType.USER_SPECIFIED_VALUE:
                    at_operating.append(row)
            cycles.append(
                {
                    "from_hopf_kmh": hopf[index]["speed_kmh"],
                    "ended": ended,
                    "end_speed_kmh": float(ms_to_kmh(end_speed)),
                    "speed_kmh": [r["speed_kmh"] for r in rows],
                    "period_s": [r["period_s"] for r in rows],
                    "amplitude": {n: [r["amplitude"][n] for r in rows] for n in model.state_names},
                    "stable": [r["stable"] for r in rows],
                    "floquet_max_modulus": [r["floquet_max_modulus"] for r in rows],
                    "min_sliding_velocity_m_per_s": [r["min_sliding_velocity_m_per_s"] for r in rows],
                }
            )

    return {
        "model": model.name,
        "params": params.model_dump(),
        "speed_range_kmh": [lo_kmh, hi_kmh],
        "hopf": hopf,
        "folds": folds,
        "operating_point": {"speed_kmh": params.operating.speed_kmh, "cycles": at_operating},
        "equilibrium": {
            "speed_kmh": [float(ms_to_kmh(pt.parameters[0])) for pt in eq_points],
            "stable": [pt.stability.name == "STABLE" for pt in eq_points],
        },
        "cycles": cycles,
        "auto": {
            "package": f"bifpy {version('bifpy')}",
            "settings": asdict(settings),
            "units": problem.units,
        },
        "wall_time_s": time.perf_counter() - start,
        "auto_time_s": None if None in auto_seconds else sum(auto_seconds),
    }


def tread1dof_diagram(
    params: Params,
    speed_range_kmh: tuple[float, float] = DEFAULT_SPEED_RANGE_KMH,
    settings: AutoSettings = AutoSettings(),
) -> dict[str, Any]:
    """:func:`model_diagram` for ``tread1dof`` parameters (others are refused)."""
    if params.model != "tread1dof":
        raise ParameterError(f"model = {params.model!r}: tread1dof_diagram covers tread1dof only")
    return model_diagram(params, speed_range_kmh, settings)


def headline_numbers(diagram: dict[str, Any]) -> dict[str, float]:
    """Hopf speeds and frequencies, fold speeds, amplitudes and periods, amplitude and
    period at the operating speed of a :func:`model_diagram` result, by name."""
    out = {}
    for i, h in enumerate(diagram["hopf"]):
        out[f"hopf{i + 1}_speed_kmh"] = h["speed_kmh"]
        out[f"hopf{i + 1}_frequency_hz"] = h["frequency_hz"]
    for i, f in enumerate(diagram["folds"]):
        out[f"fold{i + 1}_speed_kmh"] = f["speed_kmh"]
        out[f"fold{i + 1}_amplitude_x_m"] = f["amplitude_x_m"]
        out[f"fold{i + 1}_period_s"] = f["period_s"]
    for i, c in enumerate(diagram["operating_point"]["cycles"]):
        out[f"operating{i + 1}_amplitude_x_m"] = c["amplitude"]["x"]
        out[f"operating{i + 1}_period_s"] = c["period_s"]
    return out


def special_points(diagram: dict[str, Any]) -> list[SpecialPoint]:
    """The Hopf points (HB) and folds of cycles (LP) of a :func:`model_diagram` result as
    :class:`~polywear.dynamics.points.SpecialPoint`, by speed: comparable one to one with
    ``BifurcationDiagram.special_points`` of the same parameters."""
    names = get_model(diagram["model"]).state_names
    points = [SpecialPoint(PointKind.HOPF, h["speed_kmh"], h["frequency_hz"]) for h in diagram["hopf"]]
    points += [SpecialPoint(PointKind.LP, f["speed_kmh"], 1.0 / f["period_s"],
                            np.array([f["amplitude"][n] for n in names])) for f in diagram["folds"]]
    return sorted(points, key=lambda s: s.speed_kmh)


def refinement_study(
    params: Params,
    speed_range_kmh: tuple[float, float] = DEFAULT_SPEED_RANGE_KMH,
    settings: AutoSettings | None = None,
) -> dict[str, Any]:
    """Run the diagram at ``settings`` (default: the model's) and at ``settings.refined()``;
    relative changes.

    Returns ``{"base": {...}, "refined": {...}, "relative_change": {...},
    "max_relative_change": float}`` over the Hopf speeds and frequencies, fold speeds,
    amplitudes and periods, and the amplitude and period at the operating speed.
    """
    settings = AUTO_MODELS[params.model].settings if settings is None else settings
    base = headline_numbers(model_diagram(params, speed_range_kmh, settings))
    fine = headline_numbers(model_diagram(params, speed_range_kmh, settings.refined()))
    if base.keys() != fine.keys():
        raise Auto07pError(f"refinement changed the special points found: {sorted(base)} vs {sorted(fine)}")
    change = {k: abs(fine[k] - base[k]) / abs(fine[k]) for k in base}
    return {
        "base": base,
        "refined": fine,
        "relative_change": change,
        "max_relative_change": max(change.values(), default=0.0),
    }
