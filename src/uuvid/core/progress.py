"""Progress bars on stderr (thin wrapper over :mod:`rich.progress`).

Bars are drawn on **stderr** so stdout stays clean for data and piping.  They switch themselves
off when stderr is not a terminal (CI, redirected logs, pytest capture) and whenever the
environment variable ``UUVID_NO_PROGRESS`` is set to ``1`` (or ``true``/``yes``/``on``).

Long work names its stages with :meth:`ProgressTask.stage`: on a terminal the bar shows the
current step's name; off a terminal (when the bar is off only because stderr is not a TTY) each
stage prints one line ``description: step (n/N, 12.3 s)`` on stderr, and the end prints
``description: done in 68.2 s`` — so a pipe or a CI log is never silent for a minute.

Two forms::

    for case in progress(cases, description="simulating"):
        ...

    with progress_task("fitting", total=n_iter) as task:
        for _ in range(n_iter):
            ...
            task.advance()

``disable``: ``None`` (default) decides automatically as above; ``True`` always disables;
``False`` draws even when stderr is not a terminal.  ``UUVID_NO_PROGRESS=1`` wins over
everything: it is the user's global off switch.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Iterable, Iterator
from types import TracebackType
from typing import Any, Self, TypeVar

__all__ = ["ProgressTask", "progress", "progress_disabled", "progress_task"]

T = TypeVar("T")

_ENV_VAR = "UUVID_NO_PROGRESS"
#: whether a task has said "interrupted after …" in this process (the command line then does not
#: say "interrupted" again: :class:`uuvid.cli.helptext.TidyHelpGroup`)
_INTERRUPT_SAID = [False]


def interrupt_said() -> bool:
    """True once a task (or the command line) has printed that it was interrupted (Ctrl-C) in
    this process."""
    return _INTERRUPT_SAID[0]


def say_interrupted(text: str = "interrupted") -> None:
    """Print ``text`` on stderr unless an interruption was already said (:func:`interrupt_said`)."""
    if _INTERRUPT_SAID[0]:
        return
    _INTERRUPT_SAID[0] = True
    try:
        sys.stderr.write(text + "\n")
        sys.stderr.flush()
    except (AttributeError, ValueError, OSError):  # closed or missing stderr: stay quiet
        pass
#: off a terminal, a counted task prints its count at most this often (s)
LINE_EVERY_S = 30.0
_TRUTHY = {"1", "true", "yes", "on"}


def progress_disabled(disable: bool | None = None, stream: Any = None) -> bool:
    """Resolve the *disable* argument: env var, explicit choice, then "is stderr (or
    ``stream``) a TTY?"."""
    if os.environ.get(_ENV_VAR, "").strip().lower() in _TRUTHY:
        return True
    if disable is not None:
        return bool(disable)
    stream = sys.stderr if stream is None else stream
    try:
        return stream is None or not stream.isatty()
    except (AttributeError, ValueError):  # no isatty / closed stream
        return True


def _stage_lines(disable: bool | None = None, stream: Any = None) -> bool:
    """One line per stage instead of a bar: stderr is not a terminal and nobody turned progress
    off (neither ``UUVID_NO_PROGRESS`` nor ``disable=True``)."""
    if os.environ.get(_ENV_VAR, "").strip().lower() in _TRUTHY or disable is True:
        return False
    return progress_disabled(disable, stream) and (sys.stderr if stream is None else stream) is not None


def _make_progress(eta: bool = True, stream: Any = None) -> Any:
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    columns = [TextColumn("[progress.description]{task.description}"), BarColumn(),
               MofNCompleteColumn(), TimeElapsedColumn()]
    if eta:  # an ETA from uneven steps lies ("1 s left" for 19 s): callers with uneven steps opt out
        columns.append(TimeRemainingColumn())
    if stream is None:
        return Progress(*columns, console=Console(stderr=True))
    # a pinned stream: sys.stdout/stderr left alone (the bar's proxies, started while a reader
    # captured them, were restored over the reader's own restoring: later prints were lost)
    return Progress(*columns, console=Console(file=stream), redirect_stdout=False,
                    redirect_stderr=False)


class ProgressTask:
    """Handle returned by :func:`progress_task`; a no-op (that still counts) when disabled."""

    def __init__(self, description: str, total: float | None, disable: bool | None,
                 eta: bool = True, n_stages: int | None = None, after_s: float = 0.0,
                 stream: Any = None) -> None:
        self.description = description
        self.total = total
        self.completed: float = 0
        self.stream = stream  # None: sys.stderr at each write
        self.disabled = progress_disabled(disable, stream)
        self.lines = _stage_lines(disable, stream)
        self.eta = eta
        self.n_stages = n_stages
        self.after_s = float(after_s)
        self.stages: list[str] = []
        self._t0 = time.perf_counter()
        self._last_line = self._t0
        self._counted = False  # a count line was printed (off a terminal)
        self._progress: Any = None
        self._task_id: Any = None

    def __enter__(self) -> Self:
        self._t0 = self._last_line = time.perf_counter()
        if not self.disabled and self.after_s <= 0:
            self._start()
        return self

    def _start(self) -> None:
        self._progress = _make_progress(self.eta, self.stream)
        self._progress.start()
        self._task_id = self._progress.add_task(self.description, total=self.total,
                                                completed=self.completed)

    def _late_start(self) -> None:
        """Draw the bar of a task begun with ``after_s`` once that long has passed (a short
        task draws none)."""
        if (self._progress is None and not self.disabled and self.after_s > 0
                and self.elapsed >= self.after_s):
            self.after_s = 0.0  # once: a stopped bar is not started again
            self._start()

    @property
    def elapsed(self) -> float:
        """Seconds since the task started."""
        return time.perf_counter() - self._t0

    def _line(self, text: str) -> None:
        out = sys.stderr if self.stream is None else self.stream
        try:
            out.write(f"{self.description}: {text}\n")
            out.flush()
        except (AttributeError, ValueError, OSError):  # closed or missing stderr: stay quiet
            pass

    def stage(self, name: str) -> None:
        """Start the named step: the bar shows ``description — name``; off a terminal one line
        ``description: name (n/N, elapsed)`` goes to stderr."""
        self.stages.append(name)
        n = len(self.stages)
        if self._progress is not None:
            self._progress.update(self._task_id, description=f"{self.description} — {name}")
        elif self.lines:
            of = f"{n}/{self.n_stages}" if self.n_stages else f"step {n}"
            self._line(f"{name} ({of}, {self.elapsed:.1f} s)")

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if self._progress is not None:
            self._progress.stop()
            self._progress = None
            if exc_type is not None and issubclass(exc_type, KeyboardInterrupt):
                self._line(f"interrupted after {self.elapsed:.1f} s")
                _INTERRUPT_SAID[0] = True
        elif self.lines and (self.stages or self._counted):
            self._line(f"{_ending(exc_type)} {self.elapsed:.1f} s")
            if exc_type is not None and issubclass(exc_type, KeyboardInterrupt):
                _INTERRUPT_SAID[0] = True

    def advance(self, n: float = 1) -> None:
        """Mark *n* more units of work as done (off a terminal: a line ``done of total (%),
        elapsed, ≈ remaining`` at most every :data:`LINE_EVERY_S`, so a long run in a pipe or a
        CI log says how far it is)."""
        self._late_start()  # (before counting n: the bar starts at the count so far)
        self.completed += n
        if self._progress is not None:
            self._progress.advance(self._task_id, n)
        elif self.lines and self.total and self.n_stages is None and not self.stages:
            now = time.perf_counter()  # (a task with stages says each stage instead)
            if now - self._last_line >= LINE_EVERY_S and 0 < self.completed < self.total:
                self._last_line = now
                self._counted = True
                frac = self.completed / self.total
                left = (f", ≈ {self.elapsed * (1.0 - frac) / frac:.0f} s left" if self.eta
                        else "")  # eta=False: steps too uneven for an estimate
                self._line(f"{self.completed:,.0f} of {self.total:,.0f} ({frac:.1%}), "
                           f"{self.elapsed:.0f} s{left}")

    def update(
        self,
        *,
        description: str | None = None,
        total: float | None = None,
        completed: float | None = None,
    ) -> None:
        """Change the description, the total or the absolute completed count."""
        if description is not None:
            self.description = description
        if total is not None:
            self.total = total
        if completed is not None:
            self.completed = completed
        self._late_start()
        if self._progress is not None:
            self._progress.update(
                self._task_id, description=description, total=total, completed=completed
            )


def _ending(exc_type: type[BaseException] | None) -> str:
    """How a task ended: Ctrl-C is "interrupted", not "failed" (the work was not wrong)."""
    if exc_type is None:
        return "done in"
    if issubclass(exc_type, KeyboardInterrupt):
        return "interrupted after"
    return "failed after"


def progress_task(
    description: str = "", total: float | None = None, disable: bool | None = None,
    eta: bool = True, stages: int | None = None, after_s: float = 0.0, stream: Any = None,
) -> ProgressTask:
    """Context manager for a manually advanced bar: ``with progress_task(...) as t: t.advance()``.

    ``total=None`` draws an indeterminate bar; ``eta=False`` drops the time-remaining column
    (for steps of very different lengths); name steps with ``t.stage("...")`` (``stages``: how
    many there will be, for the ``n/N`` of the lines printed off a terminal); ``after_s``: the
    bar appears only when the task has run this long (a file read that is over in a moment
    draws nothing; off a terminal the count lines come every :data:`LINE_EVERY_S` anyway);
    ``stream``: where to draw instead of ``sys.stderr`` (the terminal's stderr while a reader
    captures what a library prints there).
    """
    return ProgressTask(description, total, disable, eta, stages, after_s, stream)


def progress(
    iterable: Iterable[T] | None = None,
    total: float | None = None,
    description: str = "",
    disable: bool | None = None,
) -> Any:
    """Iterate over *iterable* with a progress bar on stderr, yielding every item unchanged.

    *total* defaults to ``len(iterable)`` when available.  With ``iterable=None`` this returns
    :func:`progress_task` ``(description, total, disable)`` for use in a ``with`` statement.
    """
    if iterable is None:
        return progress_task(description, total, disable)
    return _track(iterable, total, description, disable)


def _track(
    iterable: Iterable[T], total: float | None, description: str, disable: bool | None
) -> Iterator[T]:
    if total is None:
        try:
            total = len(iterable)  # type: ignore[arg-type]
        except TypeError:
            total = None
    with ProgressTask(description, total, disable) as task:
        if task.disabled:
            yield from iterable
            return
        for item in iterable:
            yield item
            task.advance()
