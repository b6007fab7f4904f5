"""One progress convention for every long-running entry point.

A progress callback is any callable ``progress(done, total, message)``:

- ``done``: work finished so far, in the entry point's own unit (continuation steps,
  simulation runs, model evaluations, samples, km of wear evolution); it never decreases
  within one call of the entry point;
- ``total``: the whole work in the same unit, or ``None`` where it is not known in
  advance (a continuation ends where the branch does);
- ``message``: where the work stands, one short line: the unit just started or just
  finished (e.g. ``"branch 0: 123.4 km/h"``), ``""`` when there is nothing to say.

Entry points take it as the keyword ``progress=`` (default ``None``: no reports) and call
it from the calling process only (never from a worker). The command-line interface turns
it into a progress bar or status lines on stderr.
"""

from __future__ import annotations

from typing import Protocol

__all__ = ["Progress", "StepCounter", "report", "shifted"]


class Progress(Protocol):
    """``progress(done, total, message)``: see the module docstring."""

    def __call__(self, done: float, total: float | None, message: str = "") -> None: ...


def _silent(done: float, total: float | None, message: str = "") -> None:
    """A progress callback that reports nothing."""


def report(progress: Progress | None) -> Progress:
    """``progress`` itself, or a callback that reports nothing when it is None."""
    return _silent if progress is None else progress


def shifted(progress: Progress | None, start: float, whole: float | None) -> Progress | None:
    """Progress of a part of the work that begins at ``start`` of ``whole`` (None for None)."""
    if progress is None:
        return None
    forward = progress

    def part(done: float, total: float | None, message: str = "") -> None:
        forward(start + done, whole, message)

    return part


class StepCounter:
    """Counts units of work and reports the running count: ``step(message)`` after each
    unit, ``step.begin(message)`` (optional) before a long one."""

    def __init__(self, progress: Progress | None, total: float | None = None) -> None:
        self.progress = report(progress)
        self.total = total
        self.done = 0
        self._open = False  # a unit was begun and is not counted yet

    def begin(self, message: str) -> None:
        """Report the unit about to start; a unit begun before is counted as done."""
        if self._open:
            self.done += 1
        self._open = True
        self.progress(self.done, self.total, message)

    def __call__(self, message: str = "", n: int = 1) -> None:
        """Count ``n`` units done (the open one among them) and report."""
        self._open = False
        self.done += n
        self.progress(self.done, self.total, message)

    def relay(self, done: float, total: float | None, message: str = "") -> None:
        """Progress callback for a sub-task: each of its reports counts as one step here."""
        self(message)

    def detail(self, prefix: str) -> Progress:
        """Progress callback for a sub-task: its messages (after ``prefix``), at this count."""

        def forward(done: float, total: float | None, message: str = "") -> None:
            if message:
                self.progress(self.done, self.total, prefix + message)

        return forward
