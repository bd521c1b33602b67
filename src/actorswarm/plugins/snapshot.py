"""Checks the built-in plugins share for values read back from a snapshot (or a message):
plain data that may come from another version, a damaged backup or another host, so every
reader validates it and names what is wrong."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from actorswarm.runtime.plugin import Point

__all__ = ["after_task", "finite", "on_this_clock", "read_flag", "read_point", "read_time"]


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
