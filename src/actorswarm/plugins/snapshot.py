"""Checks the built-in plugins share for values read back from a snapshot (or a message):
plain data that may come from another version, a damaged backup or another host, so every
reader validates it and names what is wrong."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from actorswarm.runtime.plugin import Point

__all__ = ["finite", "read_flag", "read_point"]


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
