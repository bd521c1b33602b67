"""Reading the structured texts of plugin params: areas and routes.

A ``<param>`` value is text; some texts have a shape of their own, and a wrong one should be
refused when the script is checked, in words a person reads, rather than when a vehicle is
already flying. Two shapes are common enough to be param kinds of their own
(:class:`~actorswarm.runtime.plugin.Param` ``kind="area"`` and ``kind="route"``):

``area``
    The name of one of the mission's areas (``ctx.areas``: the world file's ``[[areas]]``
    in the simulator), or a rectangle ``"x_min y_min x_max y_max"`` in metres. A text made
    only of numbers is a rectangle and must be a sound one (four finite numbers, each min
    below its max); any other text is a name, which only the world can judge.
``route``
    Waypoints ``"x1 y1; x2 y2; ..."`` in metres, at least one; a trailing ``;`` is allowed.

Each reader raises :class:`ValueError` with a message that names the param (``what``), says
what is wrong and what to write, and reads well after ``file:line:col:``.
"""

from __future__ import annotations

import math
import re
from typing import Final

_NUMBER: Final = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")

Rectangle = tuple[float, float, float, float]


def is_number(text: str) -> bool:
    """Whether ``text`` is one decimal number (``2``, ``-0.5``, ``1e3``)."""
    return _NUMBER.fullmatch(text) is not None


def read_rectangle(text: str, what: str = "area") -> Rectangle | None:
    """``"x_min y_min x_max y_max"`` as four floats; None when ``text`` is not made of
    numbers (it is then an area's name); ValueError when it is numbers but not a sound
    rectangle (not four of them, not finite, or a min not below its max)."""
    fields = text.split()
    if not fields or not all(is_number(f) for f in fields):
        return None
    values = [float(f) for f in fields]
    if len(values) != 4:
        raise ValueError(
            f"{what} {text.strip()!r} has {len(values)} numbers, but a rectangle is four, "
            '"x_min y_min x_max y_max" (metres); give all four, or the name of an area'
        )
    if not all(math.isfinite(v) for v in values):
        raise ValueError(f"{what} {text.strip()!r} has a number that is not finite")
    x0, y0, x1, y1 = values
    if not (x0 < x1 and y0 < y1):
        raise ValueError(
            f"{what} {text.strip()!r} is not a rectangle: x_min must be below x_max and y_min "
            'below y_max, as in "x_min y_min x_max y_max"'
        )
    return x0, y0, x1, y1


def area_name(text: str, what: str = "area") -> str | None:
    """The area name ``text`` stands for, or None when it is a rectangle. ValueError for an
    empty text or a malformed rectangle (:func:`read_rectangle`)."""
    value = text.strip()
    if not value:
        raise ValueError(f'{what} is empty; name an area or give "x_min y_min x_max y_max"')
    return None if read_rectangle(value, what) is not None else value


def read_route(text: str, what: str = "route") -> list[tuple[float, float]]:
    """The waypoints of ``"x1 y1; x2 y2; ..."`` (metres). ValueError naming the waypoint
    for anything else (a missing or extra number, a word, a number that is not finite)."""
    parts = [part.strip() for part in text.split(";")]
    if parts and not parts[-1]:
        parts.pop()
    if not parts:
        raise ValueError(f"{what}: give at least one waypoint, as 'x y' (metres)")
    out: list[tuple[float, float]] = []
    for i, part in enumerate(parts, start=1):
        fields = part.split()
        if len(fields) != 2 or not all(is_number(f) for f in fields):
            raise ValueError(
                f"{what}: waypoint {i} must be two numbers 'x y', not {part!r} (waypoints are "
                "separated by ';', as in '0 0; 100 50')"
            )
        x, y = float(fields[0]), float(fields[1])
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ValueError(f"{what}: waypoint {i} ({part!r}) is not finite")
        out.append((x, y))
    return out
