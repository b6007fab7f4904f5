"""One progress convention: ``progress(done, total, message)`` on every long-running entry
point, the counting helpers, and the command line's bar and status lines built on it."""

from __future__ import annotations

import inspect
import time
from importlib import import_module

import numpy as np
import pytest

from polywear.params import Params
from polywear.progress import StepCounter, report, shifted

ENTRY_POINTS = [
    "polywear.dynamics.bifurcation:bifurcation",
    "polywear.measured.calibration:calibrate",
    "polywear.dynamics.design:design",
    "polywear.dynamics.excitation:excitation",
    "polywear.studies.fleet:fleet",
    "polywear.friction.fits:fit_loops",
    "polywear.friction.loops:hysteresis_loops",
    "polywear.studies.global_sensitivity:study",
    "polywear.dynamics.sensitivity:sensitivity",
    "polywear.dynamics.simulation:simulate_disturbances",
    "polywear.dynamics.simulation:simulate_values",
    "polywear.dynamics.stability_map:stability_map",
    "polywear.dynamics.sweep:sweep",
    "polywear.wear.evolution:wear_evolution",
    "polywear.parallel:map_batched",
    "polywear.report.main:report",
    "polywear.report.wear:wear_section",
]


@pytest.mark.parametrize("where", ENTRY_POINTS)
def test_entry_point_takes_progress_and_no_other_callback(where):
    module, _, name = where.partition(":")
    parameters = inspect.signature(getattr(import_module(module), name)).parameters
    assert "progress" in parameters and parameters["progress"].default is None
    assert not {"on_step", "on_run", "on_progress", "on_evaluation"} & set(parameters)


def _recorder():
    calls = []
    return calls, lambda done, total, message="": calls.append((done, total, message))


def test_step_counter_counts_units_and_begun_units():
    calls, progress = _recorder()
    step = StepCounter(progress, total=3)
    step.begin("first")  # about to start: nothing done yet
    step()  # the begun unit is done
    step.begin("second")
    step.begin("third")  # the second is done when the third begins
    step("last", n=1)
    assert calls == [(0, 3, "first"), (1, 3, ""), (1, 3, "second"), (2, 3, "third"), (3, 3, "last")]


def test_relay_detail_and_shifted_forward_a_sub_task():
    calls, progress = _recorder()
    step = StepCounter(progress)
    step.relay(7, None, "a")  # each report of the sub-task is one step here
    step.relay(8, None, "b")
    step.detail("design: ")(5, 9, "toe")  # messages only, at this count
    step.detail("design: ")(6, 9, "")  # nothing to say: not forwarded
    shifted(progress, 10, 20)(3, 5, "c")  # the sub-task's 3 of 5 is 13 of 20 overall
    assert calls == [(1, None, "a"), (2, None, "b"), (2, None, "design: toe"), (13, 20, "c")]
    assert shifted(None, 1, 2) is None
    report(None)(1, 2, "ignored")  # the silent default accepts the call


def test_simulations_report_runs_done_of_all_runs():
    from polywear.dynamics.simulation import simulate_disturbances

    calls, progress = _recorder()
    result = simulate_disturbances(Params(), [1e-5, 1e-4, 1e-3], 110.0, 0.01, progress=progress)
    assert [(d, t) for d, t, _ in calls] == [(1, 3), (2, 3), (3, 3)]
    assert [m for _, _, m in calls] == [run.label for run in result.runs]


def test_bifurcation_counts_continuation_steps():
    from polywear.dynamics.bifurcation import bifurcation

    calls, progress = _recorder()
    diagram = bifurcation(Params(), progress=progress)
    assert [d for d, _, _ in calls] == list(range(1, len(calls) + 1))  # one report per step, counted on
    assert all(total is None and message.startswith("branch ") for _, total, message in calls)
    assert len(calls) >= sum(len(b.points) for b in diagram.branches) > 0


def test_friction_loops_report_each_frequency():
    from polywear.friction.loops import LoopSettings, hysteresis_loops

    calls, progress = _recorder()
    hysteresis_loops(Params().friction, 0.05, 0.04, [1.0, 10.0], settings=LoopSettings(points_per_period=16),
                     progress=progress)
    assert calls == [(1, 2, "1 Hz"), (2, 2, "10 Hz")]


def test_map_batched_reports_items_done_of_all_items():
    from polywear.parallel import map_batched

    calls, progress = _recorder()
    assert map_batched(np.square, list(range(10)), backend="serial", batch_size=4, progress=progress) == [
        x * x for x in range(10)]
    assert calls == [(4, 10, ""), (8, 10, ""), (10, 10, "")]


def test_cli_bar_shows_count_total_and_message(monkeypatch, capsys):
    from polywear.cli.common import progress

    monkeypatch.setenv("FORCE_COLOR", "1")  # rich treats stderr as a terminal
    monkeypatch.delenv("NO_COLOR", raising=False)
    with progress("simulating", enabled=True) as update:
        update(1, 3, "run a")
        time.sleep(0.35)  # the bar is redrawn 10 times a second
        update(3, 3, "")
    err = capsys.readouterr().err
    assert "simulating: run a" in err and "1/3" in err and "3/3" in err
    with progress("simulating", enabled=False) as update:  # --quiet
        update(1, 3, "run a")
    assert capsys.readouterr().err == ""


def test_cli_status_lines_print_messages_only(capsys):
    from polywear.cli.common import status_lines

    show = status_lines("polywear report: ")
    show(0, None, "bifurcation diagram")
    show(1, None, "")
    assert capsys.readouterr().err == "polywear report: bifurcation diagram ...\n"
    status_lines("polywear report: ", quiet=True)(0, None, "bifurcation diagram")
    assert capsys.readouterr().err == ""
