"""Global sensitivity of the SEV band over user-given parameter ranges (SALib).

The ``[study]`` table of the parameter file (:class:`polywear.params.StudySpec`, read by
:func:`polywear.params.load_study`; not part of the parameters) names the
uncertain parameters with their ranges and distributions, the method (Sobol indices
from Saltelli sampling, or Morris elementary effects), the sample size and the seed.
Samples are drawn here, in the calling process, from ``numpy.random.SeedSequence(seed)``;
the evaluations run on any backend of :mod:`polywear.parallel` and are deterministic, so
a seed gives the same numbers on every backend.

Outputs per sample (``study.outputs``):

``"hopf"`` (fast path, ~1 ms per sample)
    ``hopf_1_kmh``, ``hopf_2_kmh``: the lowest and highest bound of the linear band
    (where steady rolling is unstable: Hopf speeds), from
    :func:`~polywear.dynamics.stability.fast_linear_band`;
    ``linear_band_width_kmh``: its total width.
``"bifurcation"`` (continuation, ~0.3 s per sample for tread1dof, a few s for axle4dof)
    ``first_bifurcation_speed_kmh``, ``second_bifurcation_speed_kmh``: bounds of the SEV band;
    ``sev_band_width_kmh``; ``max_amplitude_mm``: the largest tread amplitude of a
    stable cycle in ``study.operating_range_kmh`` (0 where there is none).

Failed evaluations are recorded per sample with a reason and counted, never dropped
silently: invalid parameter combinations, equilibrium or continuation failures (all
outputs NaN); no band in the speed range (speeds NaN, width 0); a band reaching the
edge of the speed range (that bound and the width NaN). SALib's estimators have no
NaN handling (one NaN makes every index NaN), so for each output the analysis drops
the whole Saltelli block (Sobol: the ``2D + 2`` or ``D + 2`` runs of one base sample)
or Morris trajectory (``D + 1`` runs) that holds a NaN, and reports how many it
dropped. Indices of a speed are therefore conditional on the band existing.

Confidence intervals are SALib's bootstrap intervals (``study.bootstrap`` resamples,
level ``study.confidence``). Convergence: the indices are recomputed from the first
N/4 and N/2 base samples (prefixes of a scrambled Sobol sequence are balanced too) or
trajectories; an output counts as converged when no index moved by more than its
confidence half-width from N/2 to N, and every half-width is at most
:data:`CONVERGED_HALF_WIDTH` (Sobol indices; for Morris, that fraction of the largest mu*).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field, replace

import numpy as np

from ..keys import PAPER_KEYS
from ..params import (
    Params,
    ParameterError,
    StudyParameter,
    StudySpec,
    get_value,
)
from ..parallel import Executor
from ..progress import Progress
from ..results import Result, with_deprecated_keys
from .study_evaluator import RENAMED_OUTPUTS, SampleOutcome, SampleStatus, StudyEvaluator

__all__ = [
    "default_study_parameters",
    "study_parameters",
    "GlobalSensitivityResult",
    "study",
]

CONVERGED_HALF_WIDTH = 0.1
"""Largest confidence half-width of a converged index (Sobol; Morris: relative to max mu*)."""

DEFAULT_SPREAD = 0.10
"""Relative half-width of the default ranges (the paper's seven parameters, uniform)."""

DEFAULT_KEYS = PAPER_KEYS
"""The paper's seven parameters; adhesion read as the peak friction mu_s (the usual
meaning of "adhesion coefficient"); give ``adhesion_scale`` explicitly for the other reading."""


# -- study set-up ---------------------------------------------------------------------------
def default_study_parameters(params: Params) -> tuple[StudyParameter, ...]:
    """The paper's seven parameters, uniform within +-10 % of their nominal values."""
    out = []
    for key in DEFAULT_KEYS:
        nominal = float(get_value(params, key))
        if nominal == 0.0:
            raise ParameterError(f"{key} = 0: no default range; give [[study.parameters]] explicitly")
        a, b = sorted((nominal * (1 - DEFAULT_SPREAD), nominal * (1 + DEFAULT_SPREAD)))
        out.append(StudyParameter(key=key, low=a, high=b))
    return tuple(out)


def study_parameters(params: Params, study: StudySpec) -> tuple[StudyParameter, ...]:
    """``[[study.parameters]]`` of ``study``, or the default seven (around ``params``) when none are given."""
    return study.parameters or default_study_parameters(params)


def _salib_problem(parameters) -> dict:
    """SALib problem dict: names, bounds and distributions in SALib's conventions."""
    bounds, dists = [], []
    for q in parameters:
        if q.distribution == "uniform":
            bounds.append([q.low, q.high])
            dists.append("unif")
        elif q.distribution == "loguniform":
            bounds.append([q.low, q.high])
            dists.append("logunif")
        elif q.distribution == "triangular":
            mode = 0.5 * (q.low + q.high) if q.mode is None else q.mode
            bounds.append([q.low, q.high, (mode - q.low) / (q.high - q.low)])
            dists.append("triang")
        else:  # normal, truncated to [low, high]
            mean = 0.5 * (q.low + q.high) if q.mean is None else q.mean
            std = 0.25 * (q.high - q.low) if q.std is None else q.std
            bounds.append([q.low, q.high, mean, std])
            dists.append("truncnorm")
    return {"num_vars": len(parameters), "names": [q.key for q in parameters], "bounds": bounds, "dists": dists}


def _seeds(seed: int):
    """Independent seed sequences for the sampling and the bootstrap."""
    return np.random.SeedSequence(seed).spawn(2)


# -- one evaluation ----------------------------------------------------------------------------


# -- analysis -------------------------------------------------------------------------------
def _analyze(method, problem, X, Y, n_base, settings, boot_seed, second_order=True) -> dict:
    """Indices of one output from the first ``n_base`` blocks, NaN blocks dropped.

    ``second_order=False`` on a second-order Saltelli sample uses only its A, AB_j and B
    runs (the first-order layout): first and total indices, without the cost of S2.
    """
    from SALib.analyze import morris, sobol

    D = problem["num_vars"]
    if method == "sobol":
        step = 2 * D + 2 if settings["second_order"] else D + 2
    else:
        step = D + 1
    blocks = Y[: n_base * step].reshape(n_base, step)
    keep = np.all(np.isfinite(blocks), axis=1)
    second_order = second_order and settings["second_order"]
    if method == "sobol" and settings["second_order"] and not second_order:
        blocks = blocks[:, [*range(D + 1), 2 * D + 1]]
    y = blocks[keep].ravel()
    out = {"n_used": int(keep.sum()), "n_dropped": int((~keep).sum())}
    if keep.sum() < 4 or np.ptp(y) == 0.0:
        out["note"] = "output constant over the samples" if keep.sum() >= 4 else "fewer than 4 valid blocks"
        return out
    rng = np.random.default_rng(boot_seed)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # SALib's notes on sample sizes; the counts above say it
        if method == "sobol":
            S = sobol.analyze(problem, y, calc_second_order=second_order,
                              num_resamples=settings["bootstrap"], conf_level=settings["confidence"], seed=rng)
            keys = ("S1", "S1_conf", "ST", "ST_conf") + (("S2", "S2_conf") if second_order else ())
        else:
            x = X[: n_base * step].reshape(n_base, step, D)[keep].reshape(-1, D)
            S = morris.analyze(problem, x, y, num_resamples=settings["bootstrap"],
                               conf_level=settings["confidence"], num_levels=settings["morris_levels"], seed=rng)
            keys = ("mu", "mu_star", "sigma", "mu_star_conf")
    out.update({k: np.asarray(S[k], dtype=float) for k in keys})
    return out


def _converged(final: dict, main: str, conf: str, change: np.ndarray) -> bool:
    """Indices stable from N/2 to N (within their intervals) and the intervals narrow."""
    if main not in final:
        return False
    scale = 1.0 if main == "ST" else float(np.max(final[main]))
    return bool(np.all(change <= final[conf]) and np.all(final[conf] <= CONVERGED_HALF_WIDTH * scale))


def _primary(method) -> tuple[str, str]:
    return ("ST", "ST_conf") if method == "sobol" else ("mu_star", "mu_star_conf")


@dataclass
class GlobalSensitivityResult(Result):
    """Samples, outputs, statuses and sensitivity indices of a global study."""

    params: Params
    study: StudySpec
    parameters: tuple[StudyParameter, ...]
    outputs: tuple[str, ...]
    samples: np.ndarray  # (n_runs, D) parameter values [key units]
    values: np.ndarray  # (n_runs, n_outputs)
    status: list[SampleOutcome]
    indices: dict  # output -> indices at N (arrays over parameters)
    convergence: dict  # output -> {"n_base": [...], index: [[...] per n], "max_change", "converged"}
    settings: dict = field(default_factory=dict)

    @property
    def method(self) -> str:
        return self.study.method

    @property
    def names(self) -> list[str]:
        return [q.key for q in self.parameters]

    def failures(self) -> dict:
        """Number of samples per status other than ok (by the status's text)."""
        counts: dict[str, int] = {}
        for s in self.status:
            if s.status is not SampleStatus.OK:
                counts[s.status.value] = counts.get(s.status.value, 0) + 1
        return counts

    def summary(self) -> dict:
        """JSON summary: indices per output, convergence, failures."""
        def clean(v):
            if isinstance(v, np.ndarray):
                return [clean(x) for x in v.tolist()]
            if isinstance(v, list):
                return [clean(x) for x in v]
            return None if isinstance(v, float) and not np.isfinite(v) else v

        examples = {}
        for s in self.status:
            if s.status is not SampleStatus.OK:
                examples.setdefault(s.status.value, str(s))
        return {
            "model": self.params.model,
            "method": self.method,
            "outputs": list(self.outputs),
            "parameters": [q.model_dump(exclude_none=True) for q in self.parameters],
            "n_base": self.study.n_base,
            "n_runs": len(self.status),
            "failures": self.failures(),
            "failure_examples": examples,
            "indices": with_deprecated_keys({
                out: {k: clean(v) for k, v in ind.items()} for out, ind in self.indices.items()
            }, RENAMED_OUTPUTS),
            "convergence": with_deprecated_keys({out: {k: clean(v) for k, v in c.items()}
                                                 for out, c in self.convergence.items()}, RENAMED_OUTPUTS),
            "settings": self.settings,
        }

    def to_dataframe(self):
        """pandas DataFrame: one row per output and parameter with the indices at N."""
        import pandas as pd

        rows = []
        for out, ind in self.indices.items():
            for j, name in enumerate(self.names):
                row = {"output": out, "param": name}
                row.update({k: float(v[j]) for k, v in ind.items() if isinstance(v, np.ndarray) and v.ndim == 1})
                rows.append(row)
        return pd.DataFrame(rows)

    table = to_dataframe  # the older name

    def _dataset(self):
        """xarray Dataset: samples, outputs and statuses per run; indices per output and parameter."""
        import xarray as xr

        data = {
            "sample": (("run", "param"), self.samples),
            "value": (("run", "output"), self.values),
            "status": ("run", np.array([str(s) for s in self.status], dtype=str)),
        }
        for key in ("S1", "S1_conf", "ST", "ST_conf", "mu", "mu_star", "sigma", "mu_star_conf"):
            if any(key in ind for ind in self.indices.values()):
                data[key] = (("output", "param"), np.array(
                    [ind.get(key, np.full(len(self.names), np.nan)) for ind in self.indices.values()]))
        from ..params import to_toml

        return xr.Dataset(
            data,
            coords={"param": self.names, "output": list(self.outputs)},
            attrs={"method": self.method, "params_toml": to_toml(self.params, study=self.study)},
        )

    def plot(self, ax=None, output: str | None = None):
        """Bar chart of one output's indices with confidence intervals, parameters ranked."""
        import matplotlib.pyplot as plt

        from ..dynamics.sensitivity import PARAMETER_LABELS

        if ax is None:
            _, ax = plt.subplots(figsize=(7, 3.5))
        output = output or self.outputs[0]
        ind = self.indices[output]
        main, conf = _primary(self.method)
        if main not in ind:
            ax.set_title(f"{output}: {ind.get('note', 'no indices')}", fontsize=10)
            return []
        order = np.argsort(-np.nan_to_num(ind[main]))
        y = np.arange(len(order))
        labels = [PARAMETER_LABELS.get(self.names[j], self.names[j]) for j in order]
        artists = []
        if self.method == "sobol":
            artists.append(ax.barh(y - 0.2, ind["ST"][order], 0.4, xerr=ind["ST_conf"][order], label="total (ST)"))
            artists.append(ax.barh(y + 0.2, ind["S1"][order], 0.4, xerr=ind["S1_conf"][order], label="first order (S1)"))
            ax.set_xlabel("Sobol index [-]")
        else:
            artists.append(ax.barh(y - 0.2, ind["mu_star"][order], 0.4, xerr=ind["mu_star_conf"][order], label="mu*"))
            artists.append(ax.barh(y + 0.2, ind["sigma"][order], 0.4, label="sigma"))
            ax.set_xlabel(f"elementary effect [{output.rsplit('_', 1)[-1]} per unit range]")
        ax.set_yticks(y, labels, fontsize=8)
        ax.invert_yaxis()
        ax.axvline(0.0, color="k", lw=0.8)
        c = self.convergence.get(output, {})
        flag = "converged" if c.get("converged") else "NOT converged"
        ax.set_title(f"{output} ({ind['n_used']} of {ind['n_used'] + ind['n_dropped']} blocks used, {flag})",
                     fontsize=10)
        ax.legend(fontsize=8, loc="lower right")
        return artists

    def figure(self):
        """One panel per output."""
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(len(self.outputs), 1, figsize=(7, 2.8 * len(self.outputs)), squeeze=False)
        for ax, out in zip(axes[:, 0], self.outputs):
            self.plot(ax, out)
        fig.tight_layout()
        return fig


def study(
    params: Params,
    study: StudySpec | None = None,
    *,
    backend: str | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    batch_size: int | None = None,
    executor: Executor | None = None,
    progress: Progress | None = None,
    fast_band: bool = True,
    edges_only: bool = True,
    top_fold: bool = True,
    gap_fold: bool = True,
) -> GlobalSensitivityResult:
    """Run ``study`` around ``params`` on an executor (:class:`polywear.parallel.Executor`).

    This is ``polywear study`` and ``pw.study``.

    Parameters
    ----------
    params : Params
        The nominal parameter set.
    study : StudySpec, optional
        The ``[study]`` table (:func:`polywear.params.load_study`): method (Sobol or
        Morris), sample size, outputs, seed and the uncertain parameters; default
        ``StudySpec()``.
    backend : {"serial", "processes", "dask"}, optional
        Where the samples are evaluated (default ``"processes"``).
    workers : int, optional
        Process-pool size (default: the number of CPUs).
    scheduler : str, optional
        Dask scheduler address, e.g. ``tcp://host:8786`` (backend ``"dask"``).
    batch_size : int, optional
        Samples per task (the pilot stage keeps the default batches).
    executor : Executor, optional
        The four options above as one object (give either).
    progress : callable, optional
        Progress callback (:mod:`polywear.progress`): samples finished of all samples,
        after every batch.
    fast_band : bool
        With ``outputs = "bifurcation"``: try the fast band path
        (:mod:`polywear.studies.fast_band`, warm-started from the nearest of the nominal and
        pilot diagrams with the sample's Hopf signature, :func:`~polywear.studies.fast_band.pilot_size`
        evenly spaced samples) on every sample before the full continuation; the counts of
        both are in ``settings``.
    edges_only : bool
        With ``outputs = "bifurcation"`` and the fast band path: where it does not apply,
        continue the branches only as far as the SEV band's edges need
        (:mod:`polywear.studies.edges`; about half the continuation's cost on cars with four
        Hopf points); those samples have ``max_amplitude_mm`` NaN (counted in ``settings``
        as ``edges_only_samples``), so the amplitude's indices come from the other blocks.
        False: the whole diagram (amplitudes too).
    top_fold : bool
        With ``edges_only``: where the last Hopf point is hard, the fold above it followed in
        the parameters from the nearest reference that has one
        (:meth:`~polywear.studies.fast_band.FastBand.top_fold`) instead of that point's
        branch (counted in ``settings`` as ``top_fold_samples``).
    gap_fold : bool
        With ``top_fold``: for four Hopf points of criticalities hard, soft, hard, hard, the
        band in the gap between the two intervals of the linear band from the first fold of
        the third Hopf point's branch followed in the parameters from the nearest reference
        that has it (:meth:`~polywear.studies.fast_band.FastBand.gap_fold`) instead of that
        branch (counted in ``settings`` as ``gap_fold_samples``; on 60 four-Hopf cars 1.08x
        less CPU per car, the bands within 1e-8 km/h of the full continuation).

    Returns
    -------
    GlobalSensitivityResult
        Indices with bootstrap confidence intervals per output, and the samples.
    """
    from SALib.sample import morris as morris_sample
    from SALib.sample import sobol as sobol_sample

    executor = Executor.from_options(backend, workers, scheduler, batch_size, executor)
    study = StudySpec() if study is None else study
    parameters = study_parameters(params, study)
    problem = _salib_problem(parameters)
    sample_seed, boot_seed = _seeds(study.seed)
    rng = np.random.default_rng(sample_seed)
    if study.method == "sobol":
        X = sobol_sample.sample(problem, study.n_base, calc_second_order=study.second_order, seed=rng)
    else:
        X = morris_sample.sample(problem, study.n_base, num_levels=study.morris_levels, seed=rng)
    fast = None
    if study.outputs == "bifurcation" and fast_band:
        from .fast_band import FastBand, pilot_stage

        # the nominal set and evenly spaced samples: one reference per topology met
        pilot = pilot_stage(params, problem["names"], X, params, study.speed_range_kmh, study.operating_range_kmh,
                            executor=replace(executor, batch_size=None))
        fast = FastBand(pilot.references, tuple(study.speed_range_kmh), tuple(study.operating_range_kmh))
    evaluator = StudyEvaluator(
        params, tuple(problem["names"]), study.outputs, study.speed_range_kmh, study.operating_range_kmh, fast,
        edges_only=fast is not None and edges_only, top_fold=top_fold, gap_fold=top_fold and gap_fold,
    )
    results = executor.map(evaluator, list(X), progress)
    Y = np.array([r[0] for r in results], dtype=float)
    status = [r[1] for r in results]
    n_fast = sum(r[1].fast for r in results)  # fast band path; the others: continuation
    settings = {
        "second_order": study.second_order,
        "bootstrap": study.bootstrap,
        "confidence": study.confidence,
        "morris_levels": study.morris_levels,
    }
    indices, convergence = {}, {}
    main, conf = _primary(study.method)
    sizes = [study.n_base // 4, study.n_base // 2, study.n_base]
    for k, name in enumerate(evaluator.names):
        runs = [_analyze(study.method, problem, X, Y[:, k], n, settings, boot_seed, n == study.n_base)
                for n in sizes]
        indices[name] = runs[-1]
        history = [r.get(main, np.full(problem["num_vars"], np.nan)) for r in runs]
        change = np.abs(history[2] - history[1])
        convergence[name] = {
            "n_base": sizes,
            main: history,
            "max_change": float(np.max(change)) if np.all(np.isfinite(change)) else np.nan,
            "converged": _converged(runs[-1], main, conf, change),
        }
    return GlobalSensitivityResult(
        params=params,
        study=study,
        parameters=parameters,
        outputs=evaluator.names,
        samples=X,
        values=Y,
        status=status,
        indices=indices,
        convergence=convergence,
        settings={**settings, "backend": executor.backend, "seed": study.seed, "n_base": study.n_base,
                  "fast_band_samples": n_fast,
                  "edges_only_samples": sum(r[1].edges_only for r in results),
                  "top_fold_samples": sum(r[1].top_fold for r in results),
                  "gap_fold_samples": sum(r[1].gap_fold for r in results),
                  "gap_after_pd_ns_samples": sum(r[1].gap_after_pd_ns for r in results),
                  "speed_range_kmh": list(study.speed_range_kmh),
                  "operating_range_kmh": list(study.operating_range_kmh)},
    )
