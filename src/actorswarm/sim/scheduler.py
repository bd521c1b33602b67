"""Deterministic discrete-event scheduler in virtual time.

Theory of operation
-------------------
Virtual time :attr:`Scheduler.now` starts at 0.0 and only moves when events run: no wall clock
is ever read, so a simulation runs as fast as the host allows and identically every time.

Events live in one binary heap of plain tuples ``(time, seq, fn, args)``. ``seq`` is a
counter that grows with every scheduling call, so events at the same time run in the order
they were scheduled and the heap never has to compare two callables. An event is a tuple
and nothing more: the simulated radio schedules millions of deliveries per simulated second
through :meth:`Scheduler.call_at`, which allocates no handle.

:meth:`Scheduler.at` and :meth:`Scheduler.after` also return a :class:`Timer` handle. Cancelling
it does not touch the heap (removing from the middle of a heap is O(n)): the event's ``seq``
goes into a set and the event is skipped when it reaches the top. An event that has already
run is recognised by the *watermark* — the (time, seq) of the last event run — because events
run in strictly increasing (time, seq) order: scheduling in the past is refused, and an event
scheduled for the current time gets a larger ``seq`` than anything already run.
"""

from __future__ import annotations

import gc
import heapq
import math
from collections.abc import Callable
from typing import Any, Final

__all__ = ["Scheduler", "Timer"]

_INF: Final = math.inf

#: The cyclic garbage collector's thresholds while :meth:`Scheduler.run_until` runs. A
#: simulation allocates millions of short-lived objects (events, packets, decoded
#: messages) that reference counting frees, beside a large long-lived graph (every
#: platform's stack) that each older-generation collection walks again: at the default
#: (700, 10, 10), 2000 platforms spent 9 % of a run there. These collect about 30 times
#: less often; the previous thresholds come back when the call returns.
RUN_GC_THRESHOLDS: Final = (20_000, 50, 100)

#: One heap entry: (time, seq, callable, positional arguments).
_Event = tuple[float, int, Callable[..., object], tuple[Any, ...]]


class Timer:
    """Handle of one event scheduled with :meth:`Scheduler.at` or :meth:`Scheduler.after`."""

    __slots__ = ("_sched", "_seq", "cancelled", "when")

    def __init__(self, sched: Scheduler, when: float, seq: int) -> None:
        self._sched = sched
        self._seq = seq
        #: Virtual time the event is (or was) due.
        self.when = when
        #: True once :meth:`cancel` took effect (the event will never run).
        self.cancelled = False

    @property
    def fired(self) -> bool:
        """True once the event has run (a cancelled event never fires)."""
        return not self.cancelled and self._sched._has_run(self.when, self._seq)

    @property
    def active(self) -> bool:
        """True while the event is still due: neither run nor cancelled."""
        return not self.cancelled and not self._sched._has_run(self.when, self._seq)

    def cancel(self) -> None:
        """Make sure the event never runs. Idempotent; a no-op once the event has run."""
        if self.cancelled:
            return
        sched = self._sched
        if sched._has_run(self.when, self._seq):
            return
        self.cancelled = True
        sched._cancelled.add(self._seq)

    def __repr__(self) -> str:
        state = "cancelled" if self.cancelled else ("fired" if self.fired else "pending")
        return f"Timer(when={self.when!r}, {state})"


class Scheduler:
    """A heap of timed callbacks and the virtual clock they advance.

    Contract: events run one at a time, in increasing time; events due at the same time run
    in the order they were scheduled. While an event runs, :attr:`now` is its time. Callbacks
    may schedule and cancel events (also for the current time, which then run in the same
    :meth:`run_until` call) but must not call :meth:`run_until` or :meth:`run_next`
    themselves. An exception raised by a callback propagates out of the ``run_*`` call; the
    event that raised is consumed and the scheduler stays usable.
    """

    __slots__ = ("_cancelled", "_heap", "_ran_seq", "_running", "_seq", "now")

    def __init__(self) -> None:
        #: Current virtual time, seconds.
        self.now: float = 0.0
        self._heap: list[_Event] = []
        self._seq = 0
        # seq of the last event run; with ``now`` it is the watermark Timer.cancel checks.
        self._ran_seq = 0
        self._cancelled: set[int] = set()
        self._running = False

    # --- scheduling ---------------------------------------------------------------------

    def call_at(self, t: float, fn: Callable[..., object], *args: Any) -> None:
        """Run ``fn(*args)`` at virtual time ``t`` (>= :attr:`now`), without a handle.

        The lean form of :meth:`at` for events that are never cancelled.
        """
        if not self.now <= t < _INF:
            raise ValueError(f"cannot schedule at t={t!r}: now is {self.now!r}")
        self._seq = seq = self._seq + 1
        heapq.heappush(self._heap, (t, seq, fn, args))

    def call_after(self, delay: float, fn: Callable[..., object], *args: Any) -> None:
        """Run ``fn(*args)`` ``delay`` (>= 0) seconds from now, without a handle."""
        if not 0.0 <= delay < _INF:
            raise ValueError(f"delay must be finite and >= 0, got {delay!r}")
        self._seq = seq = self._seq + 1
        heapq.heappush(self._heap, (self.now + delay, seq, fn, args))

    def at(self, t: float, fn: Callable[..., object], *args: Any) -> Timer:
        """Run ``fn(*args)`` at virtual time ``t``; ``ValueError`` if ``t`` is in the past.

        Returns a :class:`Timer` that can cancel the event.
        """
        if not self.now <= t < _INF:
            raise ValueError(f"cannot schedule at t={t!r}: now is {self.now!r}")
        self._seq = seq = self._seq + 1
        heapq.heappush(self._heap, (t, seq, fn, args))
        return Timer(self, t, seq)

    def after(self, delay: float, fn: Callable[..., object], *args: Any) -> Timer:
        """Run ``fn(*args)`` ``delay`` seconds from now; ``ValueError`` if ``delay < 0``."""
        if not 0.0 <= delay < _INF:
            raise ValueError(f"delay must be finite and >= 0, got {delay!r}")
        t = self.now + delay
        self._seq = seq = self._seq + 1
        heapq.heappush(self._heap, (t, seq, fn, args))
        return Timer(self, t, seq)

    # --- running ------------------------------------------------------------------------

    def run_until(self, t: float) -> None:
        """Run every event due at or before ``t``, then set :attr:`now` to ``t``.

        Events that these events schedule at or before ``t`` run too. ``t`` must be finite
        and not in the past.
        """
        if not self.now <= t < _INF:
            raise ValueError(f"cannot run until t={t!r}: now is {self.now!r}")
        if self._running:
            raise RuntimeError("run_until called from inside an event")
        heap = self._heap
        cancelled = self._cancelled
        pop = heapq.heappop
        self._running = True
        thresholds = gc.get_threshold()
        gc.set_threshold(*RUN_GC_THRESHOLDS)
        try:
            while heap and heap[0][0] <= t:
                when, seq, fn, args = pop(heap)
                if cancelled and seq in cancelled:
                    cancelled.remove(seq)
                    continue
                self.now = when
                self._ran_seq = seq
                fn(*args)
        finally:
            self._running = False
            gc.set_threshold(*thresholds)
        self.now = t
        # Every event scheduled so far that is due at or before t has now been consumed.
        self._ran_seq = self._seq

    def run_next(self) -> bool:
        """Run the next event that is still due; False (and nothing happens) if none is."""
        if self._running:
            raise RuntimeError("run_next called from inside an event")
        heap = self._heap
        cancelled = self._cancelled
        while heap:
            when, seq, fn, args = heapq.heappop(heap)
            if cancelled and seq in cancelled:
                cancelled.remove(seq)
                continue
            self.now = when
            self._ran_seq = seq
            self._running = True
            try:
                fn(*args)
            finally:
                self._running = False
            return True
        return False

    def next_time(self) -> float | None:
        """Time of the next event still due, or None when nothing is scheduled."""
        heap = self._heap
        cancelled = self._cancelled
        # Cancelled events at the top are dropped here for good; that cannot change the order.
        while heap and heap[0][1] in cancelled:
            cancelled.remove(heapq.heappop(heap)[1])
        return heap[0][0] if heap else None

    @property
    def pending(self) -> int:
        """Number of events still due (scheduled, not run, not cancelled)."""
        return len(self._heap) - len(self._cancelled)

    def _has_run(self, when: float, seq: int) -> bool:
        # Events run in increasing (time, seq) order, so "at or below the watermark" means
        # the event has been taken off the heap.
        now = self.now
        return when < now or (when == now and seq <= self._ran_seq)

    def __repr__(self) -> str:
        return f"Scheduler(now={self.now!r}, pending={self.pending})"
