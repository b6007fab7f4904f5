"""Execution backends: serial, local processes, and a real Dask cluster on 127.0.0.1
(scheduler and two workers started from the venv's ``dask`` executable; one worker is
killed in the middle of a study, which must still complete with identical results)."""

from __future__ import annotations

import math
import pickle
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from polywear.studies.global_sensitivity import study
from polywear.parallel import Executor, default_batch_size, map_batched
from polywear.params import Params, StudySpec

DASK = Path(sys.executable).parent / "dask"


def square(x):
    return x * x


def fails_on_three(x):
    if x == 3:
        raise ArithmeticError("three")
    return x


@settings(max_examples=30, deadline=None)
@given(items=st.lists(st.integers(-1000, 1000), max_size=60), batch=st.one_of(st.none(), st.integers(1, 70)))
def test_serial_is_the_plain_map_in_order(items, batch):
    done = []
    assert map_batched(square, items, backend="serial", batch_size=batch,
                       progress=lambda d, total, message="": done.append((d, total))) == [x * x for x in items]
    assert [d for d, _ in done] == sorted(d for d, _ in done) and all(t == len(items) for _, t in done)
    assert (done[-1][0] if done else 0) == len(items)


def test_processes_keep_the_order_and_report_progress():
    items = list(range(101))
    done = []
    out = map_batched(square, items, backend="processes", workers=2, batch_size=7,
                      progress=lambda d, total, message="": done.append((d, total)))
    assert out == [x * x for x in items]
    assert done[-1] == (101, 101) and len(done) == math.ceil(101 / 7)
    assert [d for d, _ in done] == sorted(d for d, _ in done)


def test_errors_in_a_task_propagate():
    for backend in ("serial", "processes"):
        with pytest.raises(ArithmeticError, match="three"):
            map_batched(fails_on_three, range(6), backend=backend, workers=2, batch_size=2)


@pytest.mark.parametrize("kwargs, fragment", [
    ({"backend": "threads"}, "backend"),
    ({"backend": "dask"}, "scheduler"),
    ({"backend": "processes", "scheduler": "tcp://127.0.0.1:1"}, "dask"),
    ({"workers": 0}, "workers"),
    ({"batch_size": 0}, "batch_size"),
])
def test_bad_arguments(kwargs, fragment):
    with pytest.raises(ValueError, match=fragment):
        map_batched(square, [1, 2], **kwargs)


@pytest.mark.parametrize("kwargs, fragment", [
    ({"backend": "threads"}, "backend"),
    ({"backend": "dask"}, "scheduler"),
    ({"scheduler": "tcp://127.0.0.1:1"}, "dask"),
    ({"workers": 0}, "workers"),
    ({"batch_size": 0}, "batch_size"),
])
def test_an_executor_is_checked_when_made(kwargs, fragment):
    with pytest.raises(ValueError, match=fragment):
        Executor(**kwargs)


def test_executor_from_options_or_given_not_both():
    made = Executor.from_options("serial", batch_size=3)
    assert made == Executor("serial", None, None, 3)
    assert Executor.from_options() == Executor("processes")  # the default backend of pw.study and pw.fleet
    assert Executor.from_options(executor=made) is made
    with pytest.raises(ValueError, match="not both"):
        Executor.from_options(workers=2, executor=made)


def test_executor_map_reports_each_batch_and_survives_pickling():
    executor = pickle.loads(pickle.dumps(Executor("serial", batch_size=3)))  # a task's argument on Dask
    done = []
    assert executor.map(square, range(10), lambda d, total, message="": done.append(d)) == [x * x for x in range(10)]
    assert done == [3, 6, 9, 10]


def test_default_batch_size():
    assert default_batch_size(16384, 2) == 1024
    assert default_batch_size(5, 4) == 1
    assert default_batch_size(0, 0) == 1


# -- a real Dask cluster ------------------------------------------------------------------------
def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(10)


class Cluster:
    """``dask scheduler`` and ``dask worker`` subprocesses on 127.0.0.1."""

    def __init__(self, n_workers: int, tmp: Path):
        port = _free_port()
        self.address = f"tcp://127.0.0.1:{port}"
        self.procs: list[subprocess.Popen] = []
        self.tmp = tmp
        self._start([str(DASK), "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"], "scheduler")
        self.workers = [
            self._start([str(DASK), "worker", self.address, "--nthreads", "1", "--no-nanny", "--host", "127.0.0.1",
                         "--no-dashboard", "--name", f"w{i}", "--local-directory", str(tmp / f"w{i}")], f"w{i}")
            for i in range(n_workers)
        ]
        self.wait_for_workers(n_workers)

    def _start(self, cmd, name) -> subprocess.Popen:
        with open(self.tmp / f"{name}.log", "w") as log:
            proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT)
        self.procs.append(proc)
        return proc

    def n_workers(self) -> int:
        from distributed import Client

        with Client(self.address, timeout="20s") as client:
            return len(client.scheduler_info()["workers"])

    def wait_for_workers(self, n: int, timeout: float = 90.0) -> None:
        from distributed import Client

        deadline = time.monotonic() + timeout
        while True:
            try:
                with Client(self.address, timeout="5s") as client:
                    client.wait_for_workers(n, timeout=max(deadline - time.monotonic(), 1.0))
                    return
            except (OSError, TimeoutError):
                if time.monotonic() > deadline:
                    logs = {p.name: p.read_text()[-2000:] for p in self.tmp.glob("*.log")}
                    raise RuntimeError(f"dask cluster did not come up: {logs}") from None
                time.sleep(0.5)

    def stop(self) -> None:
        for proc in reversed(self.procs):
            _stop(proc)


@pytest.fixture
def cluster(request, tmp_path):
    if not DASK.exists():
        pytest.fail(f"{DASK} missing: dask[distributed] is a dependency")
    c = Cluster(2, tmp_path)
    request.addfinalizer(c.stop)
    return c


def _study(seed: int = 12345) -> StudySpec:
    """A small Sobol study on the Hopf path: 3 parameters, N = 64, 512 runs of ~1 ms."""
    return StudySpec().with_updates({
        "method": "sobol",
        "outputs": "hopf",
        "n_base": 64,
        "bootstrap": 50,
        "seed": seed,
        "parameters": [
            {"key": "operating.toe_deg", "low": 0.4, "high": 0.6},
            {"key": "adhesion_scale", "low": 0.95, "high": 1.05, "distribution": "normal", "std": 0.03},
            {"key": "tread.lateral_damping_ns_per_m", "low": 60.0, "high": 100.0, "distribution": "triangular"},
        ],
    })


def _same(a, b) -> None:
    np.testing.assert_array_equal(a.samples, b.samples)
    np.testing.assert_array_equal(a.values, b.values)
    assert a.status == b.status
    for out in a.outputs:
        for key, value in a.indices[out].items():
            np.testing.assert_array_equal(value, b.indices[out][key])


@pytest.fixture(scope="module")
def reference():
    result = study(Params(), _study(), backend="serial")
    assert result.failures() == {} and len(result.status) == 64 * 8
    return result


def test_a_study_takes_an_executor_or_the_separate_options(reference):
    _same(reference, study(Params(), _study(), executor=Executor("serial", batch_size=5)))
    with pytest.raises(ValueError, match="not both"):
        study(Params(), _study(), backend="serial", executor=Executor("serial"))


@pytest.mark.slow
def test_same_seed_same_numbers_on_serial_processes_and_dask(cluster, reference):
    _same(reference, study(Params(), _study(), backend="processes", workers=2))
    _same(reference, study(Params(), _study(), backend="dask", scheduler=cluster.address))
    assert not np.array_equal(study(Params(), _study(seed=7), backend="serial").samples, reference.samples)


@pytest.mark.slow
def test_dask_study_survives_a_killed_worker(cluster, reference):
    victim = cluster.workers[1]
    done = []

    def kill_after_first_batch(n, total, message=""):
        done.append(n)
        if len(done) == 1:
            victim.kill()  # SIGKILL: tasks held or running there are recomputed elsewhere
            victim.wait(10)

    result = study(Params(), _study(), backend="dask", scheduler=cluster.address, batch_size=4,
                   progress=kill_after_first_batch)
    assert victim.poll() is not None and len(done) == 128 and done[-1] == 512 and done == sorted(done)
    assert cluster.n_workers() == 1
    _same(reference, result)


def test_unreachable_scheduler_is_a_one_line_user_error():
    import dask
    import distributed  # noqa: F401 - its config defaults must exist before dask.config.set below,
    # or leaving the block drops them and a later xarray save fails (KeyError 'distributed')

    from .cli_runner import run_main

    port = _free_port()  # nothing listens there
    with dask.config.set({"distributed.comm.timeouts.connect": "1s"}):
        code, out, err = run_main(["study", "-q", "--scheduler", f"tcp://127.0.0.1:{port}",
                                   "-s", "study.n_base=8", "-s", "study.second_order=false"])
    assert code == 2 and out == "" and err.startswith("error: ") and err.count("\n") == 1 and str(port) in err
