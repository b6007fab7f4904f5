"""Local sensitivity of the bifurcation speeds (the paper's eq. 3, made exact).

Quantities: every Hopf speed (``hopf_1``, ``hopf_2``, ...), every fold of cycles
(``fold_1``, ...), and the bounds of the SEV band (``first_bifurcation``,
``second_bifurcation``), which are a Hopf speed or a fold speed.

Methods:

* ``forward``: the paper's eq. (3), ``M = (f(p + dp) - f(p)) / dp``;
* ``central``: ``(f(p + dp) - f(p - dp)) / (2 dp)``;
* ``exact``: the implicit-function theorem on the defining system, no step:
  for a Hopf point ``Re lambda(V, p) = 0`` gives ``dV/dp = -Re(dlambda/dp) / Re(dlambda/dV)``,
  ``dlambda = w^H dJ q`` with the equilibrium shift included; for a fold of cycles
  ``G(X, V, p) = 0`` (collocation + phase condition) with ``G_X`` singular,
  ``dV/dp = -psi^T G_p / psi^T G_V`` where ``psi`` is the left null vector of
  ``G_X``. Partial derivatives come from complex-step evaluations of the kernels.

Parameters are configuration keys, plus the reading ``adhesion_scale`` of the
paper's "adhesion coefficient": mu_s and mu_c scaled together by one factor
(nominal 1). ``friction.mu_static`` is the other reading (peak friction alone).
Derivatives are reported in km/h per unit of the key; ``normalized`` is
``S = (p / V) dV/dp`` (None where the nominal p is 0).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..models import model_for
from ..results import Result
from .. import keys as _keys
from ..keys import ADHESION_SCALE, PAPER_KEYS
from ..params import Params
from ..progress import Progress, StepCounter
from ..settings import check_positive
from ..units import DEFAULT_SPEED_RANGE_KMH, ms_to_kmh
from .bifurcation import bifurcation
from .diagram import BifurcationDiagram
from .derivatives import rhs_directional
from .points import PointKind
from .stability import critical_eigenvalue_derivative

__all__ = [
    "PAPER_PARAMETERS",
    "ADHESION_SCALE",
    "SensitivityResult",
    "SensitivitySettings",
    "sensitivity",
    "parameter_direction",
    "hopf_speed_derivative",
    "fold_speed_derivative",
]

_MU = PAPER_KEYS.index("friction.mu_static") + 1
PAPER_PARAMETERS = (*PAPER_KEYS[:_MU], ADHESION_SCALE, *PAPER_KEYS[_MU:])
"""The paper's seven parameters (Fig. 9), adhesion read both ways."""

METHODS = ("exact", "central", "forward")


@dataclass(frozen=True)
class SensitivitySettings:
    """Numerical settings of :func:`sensitivity`."""

    method: str = "exact"
    """``"exact"``: implicit-function theorem on the defining system of each Hopf point and
    fold; ``"central"`` or ``"forward"``: finite differences (forward as the paper's eq. (3))."""
    step: float = 1e-4
    """Finite-difference step [-], relative to the nominal value (absolute where it is 0)."""

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"SensitivitySettings: method = {self.method!r}: must be one of {', '.join(METHODS)}")
        check_positive(self, "step")


PARAMETER_LABELS = {
    "tread.lateral_stiffness_n_per_m": "tread lateral stiffness",
    "tread.lateral_damping_ns_per_m": "tread lateral damping",
    "operating.toe_deg": "toe angle",
    "operating.camber_deg": "camber angle",
    "friction.mu_static": "adhesion (mu_s alone)",
    ADHESION_SCALE: "adhesion (mu_s, mu_c scaled)",
    "tread.mass_kg": "tread mass",
    "operating.vertical_load_n": "vertical load",
    "axle.toe_stiffness_nm_per_rad": "toe bushing stiffness",
    "axle.toe_damping_nms_per_rad": "toe bushing damping",
    "axle.camber_stiffness_nm_per_rad": "camber bushing stiffness",
    "axle.camber_damping_nms_per_rad": "camber bushing damping",
}


def parameter_direction(model, params: Params, key: str) -> np.ndarray:
    """d p / d(key): the change of the kernel parameter vector per unit of the key.

    Zero vector when the key does not enter the model (e.g. camber in tread1dof).
    """
    direction = np.zeros(len(model.slots))
    for stored, rate in _keys.stored_rates(params, key).items():  # ParameterError for an unknown key
        for i, slot in enumerate(model.slots):
            if slot.key == stored and slot.encode is None:
                direction[i] += slot.factor * rate
    return direction


def nominal_value(params: Params, key: str) -> float:
    """The value of ``key`` in ``params`` (``adhesion_scale``: 1) [key unit]."""
    return float(_keys.get_value(params, key))


def perturbed(params: Params, key: str, value: float) -> Params:
    """Parameters with ``key`` set to ``value`` (``adhesion_scale`` scales mu_s and mu_c)."""
    return _keys.with_updates(params, {key: value})


# -- exact derivatives ----------------------------------------------------------------
def hopf_speed_derivative(model, p, hopf, direction: np.ndarray) -> float:
    """dV_H/dθ [m/s per unit θ] where dp/dθ = ``direction``."""
    if not np.any(direction):
        return 0.0
    num = critical_eigenvalue_derivative(model, hopf.u, hopf.speed_ms, p, hopf.q, hopf.w, dp=direction).real
    den = critical_eigenvalue_derivative(model, hopf.u, hopf.speed_ms, p, hopf.q, hopf.w, dV=1.0).real
    return -num / den


def fold_speed_derivative(model, p, fold, direction: np.ndarray, degree: int = 4) -> float:
    """dV_fold/dθ [m/s per unit θ] for a fold of cycles (a continuation BranchPoint)."""
    if not np.any(direction):
        return 0.0
    from scipy.sparse.linalg import splu

    from ..solvers.collocation import Collocation

    orbit = fold.orbit
    coll = Collocation(model, p, orbit.mesh, orbit.m)
    X = coll.pack(orbit)
    # bordered matrix [[G_X, G_V], [phase, 0], [r^T, 0]] with r the fold tangent (null vector of G_X)
    tangent = fold.tangent.copy()
    tangent[-1] = 0.0
    border = np.vstack([coll.phase_row(orbit), tangent])
    A = coll.sparse_matrix(X, border)
    e = np.zeros(coll.size)
    e[-1] = 1.0
    psi = splu(A).solve(e, trans="T")  # psi^T A = e^T: left null vector of [G_X; phase]
    _, _, _, vcol = coll.evaluate(X)
    # G_p: collocation residual u' - T f(u, V, p) differentiated along the direction
    states = coll.gauss_states(orbit)
    gp = np.concatenate([-orbit.period * rhs_directional(model, u, orbit.speed, p, dp=direction) for u in states])
    nc = len(gp)
    return -float(psi[:nc] @ gp) / float(psi[:nc] @ vcol)


# -- the analysis -----------------------------------------------------------------------
@dataclass
class SensitivityResult(Result):
    """Sensitivities of the bifurcation speeds to parameters (one row per quantity and parameter)."""

    params: Params
    method: str
    rows: list[dict]
    settings: dict = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    """Why a quantity has no row (no bifurcation speed in the range, a band edge open at a range end)."""

    def summary(self) -> dict:
        return {"model": self.params.model, "method": self.method, "rows": self.rows, "notes": self.notes}

    def to_dataframe(self):
        """pandas DataFrame of the rows."""
        import pandas as pd

        return pd.DataFrame(self.rows)

    table = to_dataframe  # the older name

    def _dataset(self):
        """The rows along ``row``."""
        return self._table_dataset()

    def plot(self, ax=None, quantity: str = "first_bifurcation", normalized: bool = True,
             title: str | None = None, legend: bool = True):
        """Bar chart of one quantity's sensitivities, parameters ranked (the paper's Fig. 9).

        Red bars: more of the parameter (a larger magnitude, for S) raises the speed; blue:
        lowers it. Returns the bars.
        """
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(7, 3.5))
        rows = [r for r in self.rows if r["quantity"] == quantity]
        key = "normalized" if normalized else "derivative"
        values = [(r[key] if r[key] is not None else 0.0) for r in rows]
        order = np.argsort(-np.abs(values))
        labels = [PARAMETER_LABELS.get(rows[i]["param"], rows[i]["param"]) for i in order]
        heights = [values[i] for i in order]
        colors = [_RAISES if h > 0 else _LOWERS for h in heights]
        bars = ax.barh(range(len(heights)), heights, color=colors)
        ax.set_yticks(range(len(heights)), labels, fontsize=8)
        ax.invert_yaxis()
        ax.axvline(0.0, color="k", lw=0.8)
        speed = rows[0]["speed_kmh"] if rows else float("nan")
        ax.set_title(f"{title or _quantity_label(quantity)} ({speed:.1f} km/h)", fontsize=10)
        ax.set_xlabel("S = (p/V) dV/dp [-]" if normalized else "dV/dp [km/h per unit]")
        if legend:
            ax.legend(handles=_colour_legend(normalized), fontsize=7, loc="best")
        return list(bars)

    def panels(self) -> list[list[str]]:
        """Quantities grouped by the point they are (e.g. the first bifurcation speed is
        Hopf 1): one group per distinct point, the band bounds first."""
        speed = {r["quantity"]: r["speed_kmh"] for r in self.rows}
        names = sorted(dict.fromkeys(speed), key=lambda q: not q.endswith("_bifurcation"))
        groups: list[list[str]] = []
        for q in names:
            same = next((g for g in groups if speed[g[0]] == speed[q]), None)
            if same is None:
                groups.append([q])
            else:
                same.append(q)
        return groups

    def figure(self, normalized: bool = True):
        """One bar chart per distinct bifurcation speed (the paper's Fig. 9a, 9b and the rest),
        with the colours explained once at the top."""
        import matplotlib.pyplot as plt

        groups = self.panels()
        fig, axes = plt.subplots(len(groups), 1, figsize=(7, 2.6 * len(groups) + 0.4), squeeze=False)
        for ax, group in zip(axes[:, 0], groups):
            self.plot(ax, group[0], normalized, title=" = ".join(_quantity_label(q) for q in group), legend=False)
        fig.legend(handles=_colour_legend(normalized), loc="upper center", ncol=2, fontsize=8, frameon=False)
        fig.tight_layout(rect=(0.0, 0.0, 1.0, 1.0 - 0.35 / fig.get_figheight()))
        return fig


_RAISES, _LOWERS = "tab:red", "tab:blue"


def _colour_legend(normalized: bool) -> list:
    from matplotlib.patches import Patch

    what = "S" if normalized else "dV/dp"
    return [Patch(color=_RAISES, label=f"{what} > 0: more of the parameter raises this speed"),
            Patch(color=_LOWERS, label=f"{what} < 0: more of the parameter lowers this speed")]


def _quantity_label(quantity: str) -> str:
    """'first_bifurcation' -> 'first bifurcation speed', 'hopf_2' -> 'Hopf 2', 'fold_1' -> 'fold 1'."""
    if quantity.endswith("_bifurcation"):
        return quantity.replace("_", " ") + " speed"
    kind, _, k = quantity.partition("_")
    return f"{'Hopf' if kind == 'hopf' else kind} {k}"


def _quantities(diagram: BifurcationDiagram) -> dict[str, tuple[str, object]]:
    """name -> (kind, object): Hopf points, folds, and the SEV band bounds mapped to them."""
    out: dict[str, tuple[str, object]] = {}
    for k, h in enumerate(diagram.hopf_points, 1):
        out[f"hopf_{k}"] = ("hopf", h)
    fold_points = [pt for b in diagram.branches for label, pt, _ in b.special if PointKind(label) is PointKind.LP]
    for k, f in enumerate(fold_points, 1):
        out[f"fold_{k}"] = ("fold", f)
    sev = diagram.sev_band_kmh
    open_at = diagram.open_edges
    if sev:
        for name, speed, edge in (("first_bifurcation", sev[0][0], "lower"), ("second_bifurcation", sev[-1][1], "upper")):
            if edge in open_at:  # the range limit, not a bifurcation speed
                continue
            match = min(out.items(), key=lambda kv: abs(_speed_kmh(kv[1]) - speed), default=None)
            if match is not None and abs(_speed_kmh(match[1]) - speed) < 1e-6 * max(speed, 1.0):
                out[name] = match[1]
    return out


def _speed_kmh(entry) -> float:
    kind, obj = entry
    return obj.speed_kmh if kind == "hopf" else ms_to_kmh(obj.orbit.speed)


def sensitivity(
    params: Params,
    keys: Sequence[str] = PAPER_PARAMETERS,
    settings: SensitivitySettings = SensitivitySettings(),
    speed_range_kmh: tuple[float, float] = DEFAULT_SPEED_RANGE_KMH,
    diagram: BifurcationDiagram | None = None,
    progress: Progress | None = None,
    **diagram_options: Any,
) -> SensitivityResult:
    """Sensitivity of every bifurcation speed to every parameter key.

    ``diagram`` reuses a nominal diagram already computed.
    This is ``polywear sensitivity`` and ``pw.sensitivity``.

    Parameters
    ----------
    params : Params
        The nominal parameter set.
    keys : sequence of str
        Configuration keys (``"table.key"``) or ``"adhesion_scale"`` (mu_s and mu_c
        scaled together); default the paper's seven parameters, adhesion both ways.
    settings : SensitivitySettings
        The method (exact, central or forward differences) and the relative step.
    speed_range_kmh : (float, float)
        Speeds of the nominal (and perturbed) diagrams [km/h].
    diagram : BifurcationDiagram, optional
        The nominal diagram, if already computed.
    progress : callable, optional
        Progress callback (:mod:`polywear.progress`): continuation steps of all the
        diagrams computed, total unknown.
    **diagram_options
        Passed to :func:`polywear.dynamics.bifurcation.bifurcation`.

    Returns
    -------
    SensitivityResult
        One row per (bifurcation speed, parameter): derivative dV/dp [km/h per key
        unit] and normalized ``S = (p/V) dV/dp`` [-].
    """
    method, step = settings.method, settings.step
    model = model_for(params)
    p = model.pack(params)
    if progress is not None:
        diagram_options = {**diagram_options, "progress": StepCounter(progress).relay}
    diagram = diagram or bifurcation(params, speed_range_kmh, **diagram_options)
    nominal_q = _quantities(diagram)
    rows = []
    for key in keys:
        direction = parameter_direction(model, params, key)
        p0 = nominal_value(params, key)
        if method == "exact":
            derivs = {}
            for name, (kind, obj) in nominal_q.items():
                if kind == "hopf":
                    d = hopf_speed_derivative(model, p, obj, direction)
                else:
                    d = fold_speed_derivative(model, p, obj, direction)
                derivs[name] = ms_to_kmh(d)
        else:
            derivs = _finite_difference(params, key, p0, method, step, speed_range_kmh, nominal_q, diagram_options)
        for name, (kind, obj) in nominal_q.items():
            V = _speed_kmh((kind, obj))
            d = derivs.get(name)
            rows.append(
                {
                    "quantity": name,
                    "param": key,
                    "nominal": p0,
                    "speed_kmh": V,
                    "derivative": d,
                    "normalized": (p0 / V * d + 0.0) if (d is not None and p0 != 0.0) else None,
                }
            )
    return SensitivityResult(
        params=params,
        method=method,
        rows=rows,
        settings={"step": step, "speed_range_kmh": list(speed_range_kmh), "keys": list(keys)},
        notes=_notes(diagram, nominal_q),
    )


def _notes(diagram: BifurcationDiagram, quantities: dict) -> list[str]:
    """Why the first/second bifurcation speed (or everything) has no sensitivity."""
    lo, hi = diagram.speed_range_kmh
    if not quantities:
        return [f"no Hopf point and no fold of cycles in the analysed range {lo:g}-{hi:g} km/h: "
                "no bifurcation speed to differentiate"]
    notes = []
    for name, edge, limit in (("first_bifurcation", "lower", lo), ("second_bifurcation", "upper", hi)):
        if edge in diagram.open_edges:
            notes.append(f"{name}: the SEV band runs into the {edge} end of the analysed range ({limit:g} km/h); "
                         "there is no bifurcation speed to differentiate")
    return notes


def _finite_difference(params, key, p0, method, step, speed_range_kmh, nominal_q, diagram_options):
    """Forward or central differences of the quantities, matched by name."""
    h = step * abs(p0) if p0 != 0.0 else step
    plus = _quantities(bifurcation(perturbed(params, key, p0 + h), speed_range_kmh, **diagram_options))
    if method == "forward":
        base, lower, denom = nominal_q, None, h
    else:
        lower = _quantities(bifurcation(perturbed(params, key, p0 - h), speed_range_kmh, **diagram_options))
        base, denom = None, 2.0 * h
    out = {}
    for name in nominal_q:
        if name not in plus or (lower is not None and name not in lower):
            out[name] = None  # the point disappeared under the perturbation
            continue
        hi = _speed_kmh(plus[name])
        lo = _speed_kmh(lower[name]) if lower is not None else _speed_kmh(base[name])
        out[name] = (hi - lo) / denom
    return out
