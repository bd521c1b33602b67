"""The engine's narrow interface to the actor runtime, and a stand-in that runs the two
plugins that need no vehicle (DESIGN.md §6).

The task engine only ever asks a runtime to *start*, *stop* and *switch* actors and to
*step* them to a given time; whatever the plugins emit comes back as :class:`Emitted`
events. The full actor runtime (Actor Control Blocks, OODA buses, plugins found by entry
points, exclusive hardware resources) is its own layer; :class:`StandInRuntime` implements
the same interface for ``core.idle`` and ``core.emit_after`` so that task scripts using only
those run end to end in the simulator now. It refuses any other plugin with a clear error.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal, Protocol

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
    switched it, and the data the master scattered to it."""

    params: dict[str, str] = field(default_factory=dict)
    index: int = 0
    data: Any = None


class ActorHost(Protocol):
    """What the task engine needs from an actor runtime."""

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


class UnsupportedPlugin(ValueError):
    """The stand-in runtime cannot run this plugin (it needs the actor runtime)."""


@dataclass(slots=True)
class _EmitAfter:
    """``core.emit_after``: emits ``event`` ``after + spread_per_platform * ID`` seconds
    after its actor started (once per start)."""

    actor: str
    event: str
    at: float
    scope: Scope
    done: bool = False


class StandInRuntime:
    """Runs actors made of ``core.idle`` and ``core.emit_after`` plugins (no vehicle)."""

    def __init__(self, platform: int, plugins: dict[str, list[tuple[str, dict[str, str]]]]):
        """``plugins`` maps each actor to its (plugin name, params) list."""
        self.platform = platform
        self._plugins = plugins
        self._running: list[str] = []
        self._sleeping: list[str] = []
        #: What each actor was last started with (params, index, scattered data).
        self.contexts: dict[str, ActorContext] = {}
        self._timers: list[_EmitAfter] = []

    def use_script(self, script: Any) -> None:
        self._plugins = stand_in_plugins(script)

    def _load(self, actor: str, now: float) -> None:
        for name, params in self._plugins.get(actor, []):
            if name == "core.idle":
                continue
            if name == "core.emit_after":
                after = float(params.get("after", "0"))
                spread = float(params.get("spread_per_platform", "0"))
                scope: Scope = "swarm" if params.get("scope") == "swarm" else "local"
                self._timers.append(
                    _EmitAfter(actor, params["event"], now + after + spread * self.platform, scope)
                )
                continue
            raise UnsupportedPlugin(
                f"actor {actor!r}: plugin {name!r} needs the actor runtime; the simulator "
                "without a world runs only core.idle and core.emit_after"
            )

    def _unload(self, actor: str) -> None:
        self._timers = [t for t in self._timers if t.actor != actor]

    def start(self, actor: str, now: float, context: ActorContext) -> None:
        if actor in self._running:
            raise ValueError(f"actor {actor!r} is already running on platform {self.platform}")
        self._load(actor, now)
        self._running.append(actor)
        self.contexts[actor] = context

    def stop(self, actor: str, now: float) -> None:
        if actor in self._sleeping:
            self._sleeping.remove(actor)
        elif actor in self._running:
            self._running.remove(actor)
        else:
            raise ValueError(f"actor {actor!r} is not loaded on platform {self.platform}")
        self._unload(actor)

    def switch(self, old: str, new: str, now: float, context: ActorContext) -> None:
        self.stop(old, now)
        if new in self._sleeping:
            self.activate(new, now)
        elif new not in self._running:
            self.start(new, now, context)

    def pause(self, actor: str, now: float) -> None:
        if actor not in self._running:
            raise ValueError(f"actor {actor!r} is not running on platform {self.platform}")
        self._running.remove(actor)
        self._sleeping.append(actor)

    def activate(self, actor: str, now: float) -> None:
        if actor not in self._sleeping:
            raise ValueError(f"actor {actor!r} is not sleeping on platform {self.platform}")
        self._sleeping.remove(actor)
        self._running.append(actor)

    def running(self) -> tuple[str, ...]:
        return tuple(self._running)

    def loaded(self) -> dict[str, str]:
        """Every loaded actor and its state: ``running`` or ``sleeping``."""
        return {
            **dict.fromkeys(self._running, "running"),
            **dict.fromkeys(self._sleeping, "sleeping"),
        }

    def step(self, now: float) -> list[Emitted]:
        out = []
        for timer in self._timers:
            if timer.actor in self._sleeping:
                continue  # a sleeping actor's plugins are suspended
            if not timer.done and now >= timer.at:
                timer.done = True
                out.append(Emitted(event=timer.event, scope=timer.scope, actor=timer.actor))
        return out

    def next_deadline(self) -> float | None:
        pending = [t.at for t in self._timers if not t.done and t.actor not in self._sleeping]
        return min(pending) if pending else None


def stand_in_plugins(script: Any) -> dict[str, list[tuple[str, dict[str, str]]]]:
    """Every actor's plugins with their params, from a :class:`~actorswarm.dsl.TaskScript`."""
    return {
        actor.name: [(spec.name, spec.param_map) for _, spec in actor.plugins()]
        for actor in script.actors
    }
