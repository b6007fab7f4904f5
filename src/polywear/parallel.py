"""One interface for many small independent evaluations: serial, local processes, Dask.

An :class:`Executor` (backend, workers, scheduler address, batch size; made once, then
handed to the studies, the fleet and the sweep) computes ``executor.map(func, items)`` =
``[func(item) for item in items]`` with the work cut into batches (one task per batch, so
that task overhead stays small against the work); :func:`map_batched` is the same call
with the options as keywords. The backends:

``"serial"``     in this process, batch after batch (debugging, tiny jobs);
``"processes"``  a local pool of ``workers`` processes (the default). Processes are
                 started with ``spawn``, so ``func`` must be a picklable top-level
                 function (or a ``functools.partial`` / instance of a top-level class);
``"dask"``       a Dask distributed cluster given by its scheduler address
                 (``tcp://host:port``). Tasks lost with a worker are recomputed by the
                 scheduler on the remaining workers; results come back in item order.

Results never depend on the backend: the work is deterministic in its inputs, and
random inputs are drawn beforehand in the calling process (from
``numpy.random.SeedSequence``), never inside a task. Dask is imported only when used.
"""

from __future__ import annotations

import functools
import math
import os
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any, Callable, Sequence

from .progress import Progress, StepCounter

__all__ = ["BACKENDS", "Executor", "map_batched", "default_batch_size"]

BACKENDS = ("serial", "processes", "dask")

TASKS_PER_SLOT = 8
"""Batches per worker slot: enough to balance load and show progress, few enough that
the per-task overhead (pickling, scheduling; ~1 ms local, ~10 ms on Dask) stays small."""


def run_batch(func: Callable[[Any], Any], batch: Sequence[Any]) -> list:
    """``[func(item) for item in batch]``: the task every backend runs."""
    return [func(item) for item in batch]


def default_batch_size(n_items: int, slots: int) -> int:
    """Items per task: ``n_items / (slots * TASKS_PER_SLOT)``, at least 1."""
    return max(1, math.ceil(n_items / (max(slots, 1) * TASKS_PER_SLOT)))


@dataclass(frozen=True)
class Executor:
    """Where many small independent evaluations run (picklable, validated when made).

    Parameters
    ----------
    backend : ``"serial"``, ``"processes"`` (default) or ``"dask"``.
    workers : size of the process pool [-] (default: the number of CPUs; ``"processes"`` only).
    scheduler : Dask scheduler address, e.g. ``tcp://10.0.0.5:8786`` (backend ``"dask"``).
    batch_size : items per task [-] (default :func:`default_batch_size`).
    """

    backend: str = "processes"
    workers: int | None = None
    scheduler: str | None = None
    batch_size: int | None = None

    def __post_init__(self) -> None:
        if self.backend not in BACKENDS:
            raise ValueError(f"backend = {self.backend!r}: must be one of {', '.join(BACKENDS)}")
        if self.backend == "dask" and not self.scheduler:
            raise ValueError("backend dask: give the scheduler address (tcp://host:port)")
        if self.backend != "dask" and self.scheduler:
            raise ValueError(f"a scheduler address needs backend dask, not {self.backend!r}")
        if self.workers is not None and self.workers < 1:
            raise ValueError(f"workers = {self.workers!r}: must be at least 1")
        if self.batch_size is not None and self.batch_size < 1:
            raise ValueError(f"batch_size = {self.batch_size!r}: must be at least 1")

    @classmethod
    def from_options(cls, backend: str | None = None, workers: int | None = None, scheduler: str | None = None,
                     batch_size: int | None = None, executor: Executor | None = None) -> Executor:
        """``executor``, or the executor of the separate options (the keywords of ``pw.study``
        and ``pw.fleet``; ``backend`` default ``"processes"``); ValueError when both are given."""
        if executor is None:
            return cls(backend or "processes", workers, scheduler, batch_size)
        if any(v is not None for v in (backend, workers, scheduler, batch_size)):
            raise ValueError("give an executor or backend/workers/scheduler/batch_size, not both")
        return executor

    def map(self, func: Callable[[Any], Any], items: Sequence[Any], progress: Progress | None = None) -> list:
        """``[func(item) for item in items]`` computed in batches on the backend.

        ``func``: picklable callable of one item (top-level function or class instance);
        the result list has the order of ``items``. ``progress`` (:mod:`polywear.progress`):
        items finished of all items, after every batch.
        """
        items = list(items)
        if not items:
            return []
        step = StepCounter(progress, len(items))

        def report(n: int) -> None:
            step(n=n)

        if self.backend == "serial":
            size = self.batch_size or default_batch_size(len(items), 1)
            out: list = []
            for start in range(0, len(items), size):
                out += run_batch(func, items[start : start + size])
                report(len(items[start : start + size]))
            return out
        if self.backend == "processes":
            return _processes(func, items, self.workers or os.cpu_count() or 1, self.batch_size, report)
        return _dask(func, items, self.scheduler, self.batch_size, report)


def map_batched(
    func: Callable[[Any], Any],
    items: Sequence[Any],
    *,
    backend: str = "processes",
    workers: int | None = None,
    scheduler: str | None = None,
    batch_size: int | None = None,
    progress: Progress | None = None,
) -> list:
    """``Executor(backend, workers, scheduler, batch_size).map(func, items, progress)``
    (:class:`Executor`: the options and their defaults)."""
    return Executor(backend, workers, scheduler, batch_size).map(func, items, progress)


def _batches(items: list, size: int) -> list[list]:
    return [items[start : start + size] for start in range(0, len(items), size)]


def _gather(completed, futures: dict, batches: list[list], report) -> list:
    """Results of the futures as they complete, reassembled in item order."""
    results: list[list | None] = [None] * len(batches)
    for future in completed:
        index = futures[future]
        results[index] = future.result()
        report(len(batches[index]))
    return [value for batch in results for value in batch]


@contextmanager
def _interrupts_ignored_by_new_processes():
    """SIGINT ignored while worker processes start, so they inherit the ignored signal
    (an ignored signal survives exec, and Python then keeps it ignored): a Ctrl-C while a
    worker is still importing gives no traceback from it. Main thread only; a Ctrl-C in
    this short window is lost."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def one_blas_thread():
    """Limit BLAS (OpenBLAS, MKL) in this process to one thread; returns the limiter, a
    context manager that restores the previous limits on exit. Every matrix polywear
    factors is small (up to about 130 states with the patch contact): on 2 shared cores a
    multi-threaded BLAS made a 42x42 eigenvalue problem 2.3x and the patch model's
    stability at 40 speeds 4.4x slower in wall time (1.24 against 0.28 s, load 3.6)."""
    import numpy  # noqa: F401  (BLAS is limited once it is loaded)
    from threadpoolctl import threadpool_limits

    return threadpool_limits(1, user_api="blas")


def on_one_blas_thread(func: Callable) -> Callable:
    """Decorator: ``func`` runs with BLAS on one thread (:func:`one_blas_thread`), the
    caller's limits restored after it."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        with one_blas_thread():
            return func(*args, **kwargs)

    return wrapper


def _ignore_interrupt() -> None:
    """Worker initializer: Ctrl-C is the parent's to handle (no traceback per worker), and
    BLAS on one thread (:func:`one_blas_thread`: the workers already share the cores)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    one_blas_thread()


def _processes(func, items, workers, batch_size, report) -> list:
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    batches = _batches(items, batch_size or default_batch_size(len(items), workers))
    context = multiprocessing.get_context("spawn")
    before = set(multiprocessing.active_children())
    pool = ProcessPoolExecutor(max_workers=min(workers, len(batches)), mp_context=context,
                               initializer=_ignore_interrupt)
    try:
        with _interrupts_ignored_by_new_processes():  # the workers start during the submits
            futures = {pool.submit(run_batch, func, batch): i for i, batch in enumerate(batches)}
        return _gather(as_completed(futures), futures, batches, report)
    except BaseException:
        # interrupted or failed: stop the pool's workers now instead of waiting for their batches
        pool.shutdown(wait=False, cancel_futures=True)
        for child in set(multiprocessing.active_children()) - before:
            child.terminate()
        raise
    finally:
        pool.shutdown(wait=True)


def _dask(func, items, scheduler, batch_size, report) -> list:
    try:
        from distributed import Client, as_completed
    except ImportError as exc:  # pragma: no cover - dask[distributed] is a dependency
        raise RuntimeError("the dask backend needs dask[distributed]") from exc

    with Client(scheduler) as client:  # connect timeout: dask config distributed.comm.timeouts.connect
        slots = sum(client.nthreads().values())
        batches = _batches(items, batch_size or default_batch_size(len(items), slots))
        futures = {client.submit(run_batch, func, batch, pure=False): i for i, batch in enumerate(batches)}
        return _gather(as_completed(futures), futures, batches, report)
