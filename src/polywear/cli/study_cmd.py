"""``polywear study``: global sensitivity (Sobol / Morris via SALib) on a chosen backend."""

from __future__ import annotations

from typing import Annotated, Optional

import typer

from .common import BackendOpt, ConfigOpt, JsonOpt, PlotOpt, QuietOpt, SchedulerOpt, SetOpt, WorkersOpt, out_option
from .common import (
    PLOT_SUFFIXES,
    UserError,
    chosen_backend,
    dask_connect_timeout,
    emit_json,
    info,
    load_with_study,
    output_file,
    progress,
    write_figure,
    write_output,
)

StudyOutOpt = out_option("Write the result: .nc (samples, outputs, indices), .csv (indices) or .json.")


def study(
    config: ConfigOpt = None,
    set_: SetOpt = None,
    backend: BackendOpt = None,
    scheduler: SchedulerOpt = None,
    workers: WorkersOpt = None,
    batch_size: Annotated[
        Optional[int], typer.Option("--batch-size", min=1, help="Samples per task (default: ~8 tasks per worker).")
    ] = None,
    json_: JsonOpt = False,
    plot: PlotOpt = None,
    out: StudyOutOpt = None,
    connect_timeout: Annotated[
        float, typer.Option("--connect-timeout", help="Seconds to wait for the Dask scheduler to answer.")
    ] = 5.0,
    quiet: QuietOpt = False,
) -> None:
    """Global sensitivity of the SEV band over the ranges given in the study table (docs/sensitivity.md)."""
    output_file(out, "--out", (".nc", ".csv", ".json"))
    output_file(plot, "--plot", PLOT_SUFFIXES)
    if not 0.0 < connect_timeout <= 3600.0:
        raise UserError(f"--connect-timeout {connect_timeout}: must be in (0, 3600] [s]")
    params, study_ = load_with_study(config, set_)
    chosen = chosen_backend(backend, scheduler, connect_timeout)
    from ..parallel import Executor
    from ..studies.global_sensitivity import study, study_parameters

    D = len(study_parameters(params, study_))
    if study_.method == "sobol":
        n_runs = study_.n_base * (2 * D + 2 if study_.second_order else D + 2)
    else:
        n_runs = study_.n_base * (D + 1)
    where = scheduler if chosen == "dask" else f"{workers or 'all'} local workers" if chosen == "processes" else "serial"
    info(f"{study_.method} study of {params.model}: {D} parameters, {n_runs} runs ({study_.outputs}) on {where}", quiet)
    with progress(f"{study_.method} study", enabled=not quiet) as update, dask_connect_timeout(
        connect_timeout if chosen == "dask" else None
    ):
        try:
            result = study(params, study_, executor=Executor(chosen, workers, scheduler, batch_size), progress=update)
        except OSError as exc:  # includes connection failures and timeouts of the Dask client
            raise UserError(f"cannot reach the Dask scheduler {scheduler} within {connect_timeout:g} s: {exc}") from None
    if out:
        write_output(out, result.save, quiet)
    if plot:
        write_figure(plot, result.figure, quiet)
    summary = result.summary()
    if json_:
        emit_json(summary)
    else:
        _print_summary(result)


def _print_summary(result) -> None:
    import numpy as np

    s = result.summary()
    typer.echo(f"model {s['model']}, {s['method']}, N = {s['n_base']}, {s['n_runs']} runs")
    failures = s["failures"]
    typer.echo("failed or incomplete runs: " + (", ".join(f"{k}: {v}" for k, v in failures.items()) or "none"))
    main = ("ST", "S1") if s["method"] == "sobol" else ("mu_star", "sigma")
    for out in result.outputs:
        ind = result.indices[out]
        conv = result.convergence[out]
        change = f" (largest change N/2 -> N: {conv['max_change']:.3g})" if np.isfinite(conv["max_change"]) else ""
        typer.echo(f"\n{out}: {ind['n_used']} blocks used, {ind['n_dropped']} dropped (NaN), "
                   f"{'converged' if conv['converged'] else 'NOT converged'}{change}")
        if main[0] not in ind:
            typer.echo(f"  {ind.get('note', 'no indices')}")
            continue
        for j in np.argsort(-np.nan_to_num(ind[main[0]], nan=-np.inf)):
            cols = "  ".join(
                f"{k} = {ind[k][j]:+.3f} +- {ind[k + '_conf'][j]:.3f}" if k + "_conf" in ind else f"{k} = {ind[k][j]:+.3f}"
                for k in main
            )
            typer.echo(f"  {result.names[j]:36s} {cols}")
