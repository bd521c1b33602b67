"""What an engine keeps for its host to report (:class:`~actorswarm.engine.TaskEngine`'s
``transitions``, ``commands`` and ``fired`` lists, drained by the host): plain values,
one per switch, operator command or released transition group."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

__all__ = ["Cause", "CommandRecord", "FiredRecord", "TransitionRecord"]

#: Why a platform switched actors: a released barrier, a timeout, the operator, the start.
Cause = Literal["barrier", "timeout", "forced", "start"]


@dataclass(frozen=True, slots=True, kw_only=True)
class TransitionRecord:
    """One actor switch of one platform."""

    t: float
    platform: int
    src: str
    dst: str
    event: str
    cause: Cause


@dataclass(frozen=True, slots=True, kw_only=True)
class CommandRecord:
    """One operator command this platform carried out at ``t``: its name (``Inject``,
    ``Start``...), the event for an ``Inject`` ("" otherwise) and whether it succeeded."""

    t: float
    command: str
    event: str
    ok: bool


@dataclass(frozen=True, slots=True, kw_only=True)
class FiredRecord:
    """Master only: at ``t`` it released generation ``generation`` of the transition group
    ``key`` to the platforms ``chosen`` (``outcome``: ``complete`` or ``timeout``)."""

    t: float
    key: int
    generation: int
    outcome: str
    chosen: tuple[int, ...]
