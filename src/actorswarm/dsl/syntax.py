"""The syntax of attribute values and element texts in a task script.

Each function takes the text as written and returns the typed value, or raises
:class:`ValueError` whose message says what is accepted, ready to be put after
``file:line:col:``. Numbers are ASCII digits only: Python's ``int()`` would also take
``1_000`` or ``٣``, which no other reader of the script would agree with.
"""

from __future__ import annotations

import math
import re
from typing import Literal

from actorswarm.dsl.model import Count, SysNum

#: The range of platform IDs (docs/design.md §3.1).
MIN_PLATFORM_ID, MAX_PLATFORM_ID = 1, 65535
#: The range of barrier keys (the paper: 1-63).
MIN_BARRIER_KEY, MAX_BARRIER_KEY = 1, 63
#: The range of actor IDs (``_P_ID``) and priorities (``_P_Prio``).
MIN_ACTOR_ID, MAX_ACTOR_ID = 1, 65535
MIN_PRIORITY, MAX_PRIORITY = 0, 255

_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_.\-]*")
_INTEGER = re.compile(r"[0-9]{1,12}")  # more digits than this is never a count
_NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_ID_ITEM = re.compile(r"([0-9]{1,12})(?:\s*-\s*([0-9]{1,12}))?")
_PLUGIN_PATH = re.compile(
    r"[A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z_][A-Za-z0-9_]*)*:[A-Za-z_][A-Za-z0-9_]*"
)


def name(text: str, *, what: str) -> str:
    """An actor or event name: letters, digits, ``_ . -``, starting with a letter or ``_``.

    Names end up in event names (``X_lost``), diagrams and command lines, so spaces and
    punctuation are kept out.
    """
    value = text.strip()
    if not value:
        raise ValueError(f"the {what} is empty; give it a name such as Search")
    if not _NAME.fullmatch(value):
        raise ValueError(
            f"the {what} {value!r} is not a valid name: use letters, digits, '_', '.' or '-', "
            "starting with a letter or '_'"
        )
    return value


def integer(text: str, *, what: str, low: int, high: int) -> int:
    """An integer in ``low..high`` written in ASCII digits."""
    value = text.strip()
    if not _INTEGER.fullmatch(value) or not low <= int(value) <= high:
        raise ValueError(f"{what} must be an integer from {low} to {high}, not {value!r}")
    return int(value)


def number(text: str, *, what: str) -> float:
    """A finite decimal number (``2``, ``0.5``, ``1e-3``)."""
    value = text.strip()
    if not _NUMBER.fullmatch(value) or not math.isfinite(float(value)):
        raise ValueError(f"{what} must be a number such as 2 or 0.5, not {value!r}")
    return float(value)


def timeout(text: str) -> float:
    """``timeout``: a positive number of seconds."""
    seconds = number(text, what="timeout")
    if seconds <= 0:
        raise ValueError(f"timeout must be a positive number of seconds, not {text.strip()!r}")
    return seconds


def sys_num(text: str) -> SysNum:
    """``sysNum``: a positive integer, or ``all``."""
    value = text.strip()
    if value == "all":
        return "all"
    if _INTEGER.fullmatch(value) and int(value) >= 1:
        return int(value)
    raise ValueError(
        f'sysNum must be a positive integer (how many platforms switch) or "all", not {value!r}'
    )


def count(text: str) -> Count:
    """``branch cnt``: a positive integer, or ``rest``."""
    value = text.strip()
    if value == "rest":
        return "rest"
    if _INTEGER.fullmatch(value) and int(value) >= 1:
        return int(value)
    raise ValueError(
        f'cnt must be a positive integer or "rest" (the participants the other branches '
        f"leave), not {value!r}"
    )


def barrier_key(text: str) -> int:
    """``barrierKey``: an integer in 1..63."""
    return integer(text, what="barrierKey", low=MIN_BARRIER_KEY, high=MAX_BARRIER_KEY)


def plugin_kind(text: str) -> Literal["entry-point", "path"]:
    """Whether a plugin name is an entry-point name or a ``module:Class`` path; raises for
    a malformed path or an empty name."""
    value = text.strip()
    if not value or any(c.isspace() for c in value):
        raise ValueError(f"the plugin name {value!r} is empty or contains spaces")
    if ":" not in value:
        return "entry-point"
    if not _PLUGIN_PATH.fullmatch(value):
        raise ValueError(f"the plugin path {value!r} must read package.module:ClassName")
    return "path"


def platform_ids(text: str) -> frozenset[int]:
    """A platform ID list: ``7``, ``1-10`` or ``1,3,5-7`` (IDs 1..65535, spaces allowed).

    A range must go up (``5-1`` is refused, not reversed: it is more likely a typo than an
    intent) and an ID may appear once in a list.
    """
    value = text.strip()
    if not value:
        raise ValueError(
            "the platform list is empty; write an ID (7), a range (1-10) or a list (1,3,5-7)"
        )
    ids: set[int] = set()
    for part in value.split(","):
        item = part.strip()
        m = _ID_ITEM.fullmatch(item)
        if m is None:
            raise ValueError(
                f"{item!r} in the platform list is not an ID or a range; "
                "write an ID (7), a range (1-10) or a list (1,3,5-7)"
            )
        first = int(m.group(1))
        last = int(m.group(2)) if m.group(2) is not None else first
        for bound in (first, last):
            if not MIN_PLATFORM_ID <= bound <= MAX_PLATFORM_ID:
                raise ValueError(
                    f"platform ID {bound} is out of range: IDs go from {MIN_PLATFORM_ID} "
                    f"to {MAX_PLATFORM_ID}"
                )
        if last < first:
            raise ValueError(f"the range {item!r} goes down; write it as {last}-{first}")
        # IDs are unique, so the scans below add up to at most 65535 steps per list.
        repeated = next((i for i in range(first, last + 1) if i in ids), None)
        if repeated is not None:
            raise ValueError(f"platform {repeated} is listed twice in {value!r}")
        ids.update(range(first, last + 1))
    return frozenset(ids)


def id_ranges(ids: frozenset[int]) -> str:
    """The shortest list for ``ids``: ``{1,2,3,5}`` -> ``'1-3,5'``."""
    parts: list[str] = []
    ordered = sorted(ids)
    i = 0
    while i < len(ordered):
        j = i
        while j + 1 < len(ordered) and ordered[j + 1] == ordered[j] + 1:
            j += 1
        parts.append(str(ordered[i]) if i == j else f"{ordered[i]}-{ordered[j]}")
        i = j + 1
    return ",".join(parts)
