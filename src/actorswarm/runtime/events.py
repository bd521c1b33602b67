"""What flows between plugins, the actor runtime and the task engine above it.

:class:`Emitted` is an event a plugin raised (``ctx.emit``); :class:`ActorContext` is what an
actor is started with (the switching transition's params, its index in the group, the data
the master scattered to it). They live in the runtime layer because plugins produce and
consume them; the task engine uses them through :class:`~actorswarm.engine.runtime.ActorHost`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

Scope = Literal["local", "swarm"]


@dataclass(frozen=True, slots=True, kw_only=True)
class Emitted:
    """An event a plugin emitted: ``scope`` local (only this platform is a candidate) or
    swarm (every platform whose actor has a transition for it). ``bid`` None: the
    platform ID."""

    event: str
    scope: Scope = "local"
    bid: float | None = None
    data: Any = None
    actor: str = ""


@dataclass(frozen=True, slots=True, kw_only=True)
class ActorContext:
    """What a starting actor is handed: transition params, its index in the group that
    switched it and the group's size, its slot in the branch it went to and the branch's
    size (all 0 when no group switched it in), and the data the master scattered to it."""

    params: dict[str, str] = field(default_factory=dict)
    index: int = 0
    data: Any = None
    size: int = 0
    slot: int = 0
    slots: int = 0
