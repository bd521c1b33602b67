"""The progress of many cases or runs: a bar on a terminal, a plain line every 10 s (and at
the end) in a log or a pipe, each with how many failed. Shared by ``swarm campaign`` and
``task verify``."""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TaskID,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)

__all__ = ["Tally", "tally"]

#: Seconds between two plain progress lines where there is no bar.
LINE_EVERY = 10.0


@dataclass(slots=True)
class Tally:
    """What finished so far; :meth:`count` one more."""

    total: int
    console: Console
    bar: Progress
    task: TaskID
    began: float = field(default_factory=time.perf_counter)
    done: int = 0
    failed: int = 0
    _said: float = field(default_factory=time.perf_counter)

    def count(self, ok: bool) -> None:
        self.done += 1
        self.failed += not ok
        self.bar.update(self.task, advance=1, failed=self.failed)
        now = time.perf_counter()
        # Not a terminal (a CI log, a pipe): no bar, a plain line now and then instead.
        if not self.console.is_terminal and (
            now - self._said >= LINE_EVERY or self.done == self.total
        ):
            self._said = now
            self.console.print(
                f"[{self.done}/{self.total}] {self.failed} failed, {now - self.began:.0f} s",
                markup=False,
            )


@contextmanager
def tally(console: Console, total: int, noun: str) -> Iterator[Tally]:
    """A :class:`Tally` of ``total`` ``noun`` s with its bar shown while the block runs (the
    bar is gone after it, leaving the lines printed meanwhile)."""
    with Progress(
        TextColumn(noun),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.fields[failed]} failed"),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        console=console,
        transient=True,
        disable=not console.is_terminal,
    ) as bar:
        task = bar.add_task(noun, total=total, failed=0)
        yield Tally(total, console, bar, task)
