"""The Actor Control Block (docs/design.md §5, paper §IV.A.1): the runtime's record of one actor.

Theory of operation
-------------------
A platform's runtime keeps one :class:`ACB` per actor instance it knows, loaded or not. The
ACB is plain data: who the actor is (name, ID, priority, permission), what it is made of (its
plugin group, the hardware it binds), what it was asked to do (:class:`TaskContext`), how it
got there (:class:`Relations`) and what it has done (:class:`RuntimeStats`).

The ACB does not decide anything. Its ``status`` changes only through
:func:`actorswarm.runtime.operations.apply`, which owns the state table *and* the bookkeeping
that goes with each change (counts, ``time_running``), so the two can never disagree. Time is
never read here: every time stamp is a ``now`` the runtime passes in (virtual time in the
simulator, the daemon's clock on a robot), which keeps the runtime deterministic under test.

:meth:`ACB.to_status` renders the whole record as JSON-ready data for the ground station's
``status`` command.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from enum import Enum
from typing import Any, Final, Literal, get_args

__all__ = [
    "ACB",
    "PERMISSIONS",
    "ActorStatus",
    "Permission",
    "PluginStepStats",
    "Relations",
    "RuntimeStats",
    "TaskContext",
]


class ActorStatus(Enum):
    """The states of one actor (paper Fig. 2), plus ``ERROR`` for a plugin that raised.

    - ``UNLOADED``: no plugins loaded, no hardware bound (never started, or stopped).
    - ``RUNNING``: plugins loaded and stepped by the OODA buses.
    - ``SLEEPING``: plugins loaded but suspended; their state is kept for ``activate``.
    - ``ERROR``: a plugin raised; the actor is no longer stepped and waits for the operator
      (or the task) to stop or restart it. ``ACB.last_error`` says what went wrong.
    """

    UNLOADED = "unloaded"
    RUNNING = "running"
    SLEEPING = "sleeping"
    ERROR = "error"


#: Who may operate an actor.
#:
#: - ``"normal"``: the task engine drives it (start, switch, pause, activate, stop) as the
#:   task script says, and the operator may too.
#: - ``"operator-locked"``: the ground station took it over with a forced command (forced
#:   start/stop, pause/activate); the task engine must not switch it away or stop it until the
#:   operator hands it back. The runtime enforces this; the ACB only records it.
Permission = Literal["normal", "operator-locked"]
PERMISSIONS: Final[tuple[Permission, ...]] = get_args(Permission)


@dataclass(frozen=True, slots=True, kw_only=True)
class TaskContext:
    """What the actor was asked to do when it last started or was switched in.

    ``params`` are the transition's ``<param key value>`` pairs handed to the plugins;
    ``group_key`` and ``generation`` name the barrier firing that switched it in (None and 0
    for an actor started directly); ``index`` is its 1-based index in that group (0: none)
    and ``size`` the group's size; ``slot`` and ``slots`` are the same within the branch it
    went to; ``data`` is whatever the master scattered to it. Treat ``params`` as read-only.
    """

    params: dict[str, str] = field(default_factory=dict)
    group_key: int | None = None
    generation: int = 0
    index: int = 0
    data: Any = None
    size: int = 0
    slot: int = 0
    slots: int = 0


@dataclass(frozen=True, slots=True, kw_only=True)
class Relations:
    """The actor's place in the swarm: the group firing and transition that brought it.

    ``group_key``/``generation``/``index`` identify the barrier group it joined (the other
    participants of the same firing are its peers); ``transition`` is the event whose
    transition switched it in and ``predecessor`` the actor it replaced on this platform.
    All None/0 for an actor started from the script's initial assignment or by the operator.
    """

    group_key: int | None = None
    generation: int = 0
    index: int = 0
    transition: str | None = None
    predecessor: str | None = None


@dataclass(slots=True)
class PluginStepStats:
    """How long one plugin's steps took, in seconds as measured by the runtime."""

    count: int = 0
    total: float = 0.0
    max: float = 0.0
    last: float = 0.0

    @property
    def mean(self) -> float:
        """Average step time; 0.0 before the first step."""
        return self.total / self.count if self.count else 0.0

    def record(self, seconds: float) -> None:
        """Add one step that took ``seconds`` (finite, >= 0)."""
        if not math.isfinite(seconds) or seconds < 0:
            raise ValueError(
                f"a plugin step time must be a finite number of seconds >= 0, got {seconds!r}"
            )
        self.count += 1
        self.total += seconds
        self.max = max(self.max, seconds)
        self.last = seconds


@dataclass(slots=True, kw_only=True)
class RuntimeStats:
    """What an actor has done, from the ``now`` values the runtime passed in.

    The operation counters and the running-time fields are written only by
    :func:`actorswarm.runtime.operations.apply`; steps only by :meth:`ACB.record_step`.

    - ``time_running``: seconds spent RUNNING in *closed* periods; while the actor runs, the
      open period since ``running_since`` is not in it yet — use :meth:`running_time`.
    - ``running_since``: ``now`` of the change that made it RUNNING, None when not running.
    - ``started_at``: ``now`` of the last ``start``; None if never started.
    - ``changed_at``: ``now`` of the last operation; operations never go back before it.
    - ``switch_count``: switches this actor took part in, as the actor paused or as the actor
      started/re-activated (a switch target that was already running is not touched).
    - ``steps`` and ``plugins``: OODA steps taken, and per-plugin step times by plugin name.
    """

    time_running: float = 0.0
    running_since: float | None = None
    started_at: float | None = None
    changed_at: float | None = None
    start_count: int = 0
    stop_count: int = 0
    pause_count: int = 0
    activate_count: int = 0
    error_count: int = 0
    switch_count: int = 0
    steps: int = 0
    plugins: dict[str, PluginStepStats] = field(default_factory=dict)

    def running_time(self, now: float | None = None) -> float:
        """Seconds spent RUNNING up to ``now`` (the open period included when ``now`` is
        given; without it, only closed periods count)."""
        if now is None or self.running_since is None:
            return self.time_running
        return self.time_running + max(0.0, now - self.running_since)


@dataclass(slots=True, kw_only=True)
class ACB:
    """The Actor Control Block: the runtime's mutable record of one actor instance.

    ``priority``: larger is higher; it decides who wins an exclusive hardware resource.
    ``software`` is the plugin group as (bus, plugin name) pairs in bus order; ``hardware``
    the exclusive resources it binds while loaded (see :mod:`actorswarm.runtime.resources`).
    ``permission`` is one of :data:`PERMISSIONS`. ``last_error`` keeps the most recent plugin
    failure, also after a restart, so that the operator can still read it.

    Change ``status`` only through :func:`actorswarm.runtime.operations.apply`.
    """

    name: str
    actor_id: int
    status: ActorStatus = ActorStatus.UNLOADED
    priority: int = 0
    software: tuple[tuple[str, str], ...] = ()
    hardware: frozenset[str] = frozenset()
    permission: Permission = "normal"
    context: TaskContext = field(default_factory=TaskContext)
    relations: Relations = field(default_factory=Relations)
    stats: RuntimeStats = field(default_factory=RuntimeStats)
    last_error: str | None = None

    def __post_init__(self) -> None:
        if not self.name:
            raise ValueError("an actor needs a non-empty name (the script's <_P_Name>)")
        if self.actor_id < 0:
            raise ValueError(f"actor {self.name!r}: actor ID must be >= 0, got {self.actor_id}")
        if self.permission not in PERMISSIONS:
            raise ValueError(
                f"actor {self.name!r}: unknown permission {self.permission!r}; "
                f"use one of {', '.join(PERMISSIONS)}"
            )

    def record_step(self, plugin_seconds: Mapping[str, float]) -> None:
        """Count one OODA step and how long each plugin took in it (plugin name -> seconds).

        Only a RUNNING actor steps; anything else is a runtime bug and raises ValueError
        without recording anything.
        """
        if self.status is not ActorStatus.RUNNING:
            raise ValueError(
                f"actor {self.name!r} is {self.status.value}, not running: only running "
                "actors are stepped"
            )
        # Validate every time first so that a bad value records nothing at all.
        for plugin, seconds in plugin_seconds.items():
            if not math.isfinite(seconds) or seconds < 0:
                raise ValueError(
                    f"actor {self.name!r}: step time of plugin {plugin!r} must be a finite "
                    f"number of seconds >= 0, got {seconds!r}"
                )
        self.stats.steps += 1
        for plugin, seconds in plugin_seconds.items():
            self.stats.plugins.setdefault(plugin, PluginStepStats()).record(seconds)

    def to_status(self, now: float | None = None) -> dict[str, Any]:
        """Everything in this ACB as JSON-ready data (``json.dumps`` accepts it).

        ``status`` is the lowercase state name, ``hardware`` a sorted list, ``software`` a
        list of ``{"bus", "plugin"}``. With ``now``, ``stats.time_running`` includes the
        running period still open; without it, closed periods only. Scattered ``data`` that
        is not plain JSON is shown by its ``repr``.
        """
        stats = self.stats
        stats_out: dict[str, Any] = {
            f.name: getattr(stats, f.name) for f in fields(stats) if f.name != "plugins"
        }
        stats_out["time_running"] = stats.running_time(now)
        stats_out["plugins"] = {
            name: {
                "count": p.count,
                "total": p.total,
                "max": p.max,
                "last": p.last,
                "mean": p.mean,
            }
            for name, p in sorted(stats.plugins.items())
        }
        return {
            "name": self.name,
            "actor_id": self.actor_id,
            "status": self.status.value,
            "priority": self.priority,
            "software": [{"bus": bus, "plugin": plugin} for bus, plugin in self.software],
            "hardware": sorted(self.hardware),
            "permission": self.permission,
            "context": {
                "params": dict(self.context.params),
                "group_key": self.context.group_key,
                "generation": self.context.generation,
                "index": self.context.index,
                "size": self.context.size,
                "slot": self.context.slot,
                "slots": self.context.slots,
                "data": _jsonable(self.context.data),
            },
            "relations": {f.name: getattr(self.relations, f.name) for f in fields(Relations)},
            "stats": stats_out,
            "last_error": self.last_error,
        }


def _jsonable(value: Any) -> Any:
    """``value`` as JSON-ready data; what JSON cannot hold becomes its ``repr``, because a
    status report must never fail on a plugin's odd payload."""
    if value is None or isinstance(value, bool | int | str):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else repr(value)
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    return repr(value)
