"""Checks the built-in plugins share for values read back from a snapshot (or a message):
plain data that may come from another version, a damaged backup or another host, so every
reader validates it and names what is wrong."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from actorswarm.runtime.plugin import Point

__all__ = [
    "TaskTime",
    "after_task",
    "finite",
    "on_this_clock",
    "read_flag",
    "read_point",
    "read_time",
]


def finite(value: object) -> bool:
    """Whether ``value`` is a finite int or float (a bool is not a number here)."""
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def read_point(name: str, what: str, value: object) -> Point:
    """``value`` (a snapshot's ``[x, y, z]``) as a point, or ValueError naming plugin
    ``name`` and the snapshot key ``what``."""
    if isinstance(value, list | tuple) and len(value) == 3 and all(map(finite, value)):
        return (float(value[0]), float(value[1]), float(value[2]))
    raise ValueError(f"{name}: a snapshot's {what!r} must be [x, y, z] (numbers), not {value!r}")


def read_flag(name: str, state: Mapping[str, Any], key: str) -> bool:
    """``state[key]`` when it is a bool, else ValueError naming plugin ``name``."""
    value = state.get(key)
    if not isinstance(value, bool):
        raise ValueError(f"{name}: a snapshot's {key!r} must be true or false, not {value!r}")
    return value


def read_time(name: str, state: Mapping[str, Any], key: str) -> float | None:
    """``state[key]`` as seconds when it is a finite number, None when it is missing or
    null, else ValueError naming plugin ``name``."""
    value = state.get(key)
    if value is None:
        return None
    if not finite(value):
        raise ValueError(f"{name}: a snapshot's {key!r} must be seconds or null, not {value!r}")
    assert isinstance(value, int | float)
    return float(value)


def after_task(t: float | None, task_start: float | None) -> float | None:
    """``t``, a time on this platform's clock (``ctx.now``'s), counted from the task's
    start (``ctx.task_start``): what a snapshot keeps beside ``t`` so that a platform
    restored after a reboot — a new clock, on which ``t`` means nothing — finds the same
    moment of the task. None when either is unknown or ``t`` is not finite."""
    if t is None or task_start is None or not math.isfinite(t):
        return None
    return t - task_start


def on_this_clock(t: float, after: float | None, task_start: float | None) -> float:
    """A snapshot's time ``t`` on the clock of the platform restoring it: ``task_start +
    after`` when both are known (:func:`after_task`), else ``t`` as saved (a snapshot
    without it, or a host with no task clock: the same clock as the one that saved it)."""
    if after is None or task_start is None:
        return t
    return task_start + after


class TaskTime:
    """One time a plugin keeps in its snapshot (a time on ``ctx.now``'s clock), with what a
    robot that rebooted (a new clock) needs to find the same moment of the task.

    The plugin calls :meth:`start` and :meth:`activate` from its hooks of those names,
    writes :meth:`after` beside the time into its snapshot, and hands the snapshot's value
    to :meth:`restored`; :meth:`activate` returns the time on this platform's clock.
    """

    __slots__ = ("_restored", "task_start")

    def __init__(self) -> None:
        #: The task's start on this platform's clock (``ctx.task_start``; None: unknown).
        self.task_start: float | None = None
        self._restored: float | None = None  # a restored time's after-task, till activated

    def start(self, task_start: float | None) -> None:
        """A fresh start: the task's start from ``ctx.task_start``, nothing restored."""
        self.task_start, self._restored = task_start, None

    def after(self, t: float | None) -> float | None:
        """``t`` counted from the task's start, for the snapshot (None: not to be written);
        a restored time not yet activated keeps the value it was restored with."""
        if t is None:
            return None
        counted = after_task(t, self.task_start)
        return self._restored if counted is None else counted

    def restored(self, after: float | None) -> None:
        """What a snapshot held for :meth:`after` (None: nothing, an older snapshot)."""
        self._restored = after

    def activate(self, t: float | None, task_start: float | None) -> float | None:
        """``t`` (the snapshot's time, or the running one) on this platform's clock; from
        now on the task's start is ``task_start``."""
        self.task_start = task_start
        restored, self._restored = self._restored, None
        if t is None or restored is None or not math.isfinite(t):
            return t
        return on_this_clock(t, restored, task_start)
