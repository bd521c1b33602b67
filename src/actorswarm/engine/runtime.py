"""The engine's narrow interface to the actor runtime (docs/design.md §5).

The task engine only ever asks a runtime to *start*, *stop*, *switch*, *pause* and
*activate* actors, to *step* them to a given time and to *snapshot* them; whatever the
plugins emit comes back as :class:`Emitted` events. The runtime itself
(:class:`actorswarm.runtime.actor_runtime.ActorRuntime`: Actor Control Blocks, OODA buses,
plugins found by entry points, exclusive hardware) is its own layer, below the engine.
"""

from __future__ import annotations

from typing import Any, Protocol

# What plugins emit and what a starting actor is handed belong to the runtime layer below;
# they are named here too because they are the vocabulary of this interface.
from actorswarm.runtime.events import ActorContext, Emitted, Scope

__all__ = ["ActorContext", "ActorHost", "Emitted", "Scope"]


class ActorHost(Protocol):
    """What the task engine needs from an actor runtime."""

    #: When the task started, on the clock of the engine's ``now``: the same instant on
    #: every platform of the swarm (the ground station's start, on the clock they share).
    #: The plugins see it as ``ctx.task_start``; None until the task starts.
    task_start: float | None

    def use_script(self, script: Any) -> None:
        """The actors (and their plugins) of the task script from now on."""
        ...

    def start(self, actor: str, now: float, context: ActorContext) -> None: ...

    def stop(self, actor: str, now: float) -> None: ...

    def switch(self, old: str, new: str, now: float, context: ActorContext) -> None: ...

    def running(self) -> tuple[str, ...]: ...

    def pause(self, actor: str, now: float) -> None: ...

    def activate(self, actor: str, now: float) -> None: ...

    def loaded(self) -> dict[str, str]: ...

    def step(self, now: float) -> list[Emitted]: ...

    def next_deadline(self) -> float | None: ...

    def snapshot(self) -> bytes:
        """Every loaded actor and its plugin states, for a backup."""
        ...

    def deliver(self, answer: dict[str, Any]) -> None:
        """An answer of the collective core for the plugins (barrier release, role)."""
        ...

    def status(self, now: float | None = None) -> dict[str, Any]:
        """Every loaded actor's control block, JSON-ready."""
        ...

    def position(self) -> tuple[float, float, float] | None:
        """Where this platform's vehicle is (None without one): requests carry it, so the
        master can hand out slots by distance."""
        ...

    def vehicle_state(self) -> dict[str, str | int | float | bool | None]:
        """What the vehicle adapter says of itself (link, mode, ...), for the operator's
        status; empty when it says nothing."""
        ...

    def group_points(
        self, actor: str, count: int, now: float, params: dict[str, str]
    ) -> list[tuple[float, float]] | None:
        """Where ``count`` members switching into ``actor`` with the transition's
        ``params`` will go (slot 1 first), or None when its plugins give no places."""
        ...

    def group_in_step(self, actor: str, count: int, now: float, params: dict[str, str]) -> bool:
        """Whether those members close on their places in step (a formation), so that the
        places are handed out by least squared distance."""
        ...

    def drain_switch_times(self) -> list[float]:
        """Seconds each :meth:`switch` since the last call took, from the call to the end of
        the new actor's first step (oldest first); a benchmark reads them."""
        ...

    def restore(self, data: bytes, now: float) -> list[str]:
        """Bring back the actors of a :meth:`snapshot`; returns those running again."""
        ...
