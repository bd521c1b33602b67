"""What a daemon's engine records, logged and let go: :class:`EngineRecords`.

The task engine appends every actor switch to ``engine.transitions``, every event it
ignored to ``engine.ignored``, and its runtime every plugin that raised to
``runtime.failures``: lists a simulation reads at the end of a run. A daemon runs for
months: at one switch a second, kept transitions alone grew its memory by megabytes a day.
On each wake the daemon hands what is new to its log (one JSON line each: ``transition``,
``ignored``, ``plugin-failed``), keeps the last :data:`STATUS_TRANSITIONS` transitions for
``status.json`` and empties the lists.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from actorswarm.engine.engine import TaskEngine
    from actorswarm.engine.records import TransitionRecord
    from actorswarm.runtime.actor_runtime import ActorRuntime

__all__ = ["STATUS_TRANSITIONS", "EngineRecords"]

#: How many of its latest transitions a daemon shows in ``status.json`` (its log has all).
STATUS_TRANSITIONS = 50


class EngineRecords:
    """Drains the records of ``engine`` and its ``runtime`` into ``log(event, **fields)``
    (see the module's docstring); :attr:`recent` holds the last :data:`STATUS_TRANSITIONS`
    transitions, oldest first."""

    def __init__(self, engine: TaskEngine, runtime: ActorRuntime, log: Callable[..., None]) -> None:
        self.engine = engine
        self.runtime = runtime
        self.log = log
        self.recent: deque[TransitionRecord] = deque(maxlen=STATUS_TRANSITIONS)

    def drain(self, traffic: list[int] | None = None) -> bool:
        """Log and let go of what the engine recorded since the last call; ``traffic`` (the
        packet counters after this wake) goes on each ``transition`` line. True when the
        platform switched actors since (a new backup is due)."""
        engine = self.engine
        fresh = engine.transitions
        for r in fresh:
            fields: dict[str, Any] = {
                "at": r.t,
                "frm": r.src,
                "to": r.dst,
                "on": r.event,
                "cause": r.cause,
            }
            if traffic is not None:
                fields["traffic"] = traffic
            self.log("transition", **fields)
        self.recent.extend(fresh)
        switched = bool(fresh)
        fresh.clear()
        for t, event, why in engine.ignored:
            self.log("ignored", at=t, on=event, why=why)
        engine.ignored.clear()
        failures = self.runtime.failures
        for f in failures:
            self.log("plugin-failed", at=f.t, actor=f.actor, plugin=f.plugin, error=f.message)
        failures.clear()
        return switched
