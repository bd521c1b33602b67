"""The typed, immutable model of a task script (docs/design.md §4).

A :class:`TaskScript` is what the checker hands to the task engine once a script is valid:
the Actors with their OODA plugin groups, the transitions of the Actor state machine grouped
by the actor they leave, and the platform lines that say which actors each platform starts.

Every node is a frozen, slotted, keyword-only dataclass. Every node also remembers where it
came from (``pos``, and ``attr_pos`` for its attributes) so that any later stage — the
checker's cross-reference rules, the engine refusing a deployment — can point at the exact
``line:col`` of the script. Positions take no part in equality: two scripts that say the same
thing are equal wherever their text puts it, which is what makes the writer's round trip
(:func:`actorswarm.dsl.writer.to_xml`) testable.

The model holds valid values only (a ``sys_num`` is a positive ``int`` or ``"all"``, a bus
name is one of :data:`BUSES` ...); building one from XML is the job of
:mod:`actorswarm.dsl.builder`, which reports everything it cannot build.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Literal, TypeVar

BusName = Literal["observe_bus", "orient_bus", "decide_bus", "act_bus"]
#: The four OODA buses, in the order a running actor's step calls them.
BUSES: tuple[BusName, ...] = ("observe_bus", "orient_bus", "decide_bus", "act_bus")

#: ``sysNum``: how many holders of the actor take the transition together.
SysNum = int | Literal["all"]
#: ``branch cnt``: how many of them go to one successor; ``"rest"`` takes the remainder.
Count = int | Literal["rest"]


@dataclass(frozen=True, slots=True, order=True)
class Position:
    """A place in a script: 1-based ``line`` and 1-based ``col`` (in characters)."""

    line: int
    col: int

    def __str__(self) -> str:
        return f"{self.line}:{self.col}"


#: The position of nodes built in code rather than read from a file.
NOWHERE = Position(0, 0)

_K = TypeVar("_K")
_V = TypeVar("_V")


def frozen_map(items: Mapping[_K, _V]) -> Mapping[_K, _V]:
    """A read-only view of a copy of ``items`` (model mappings must not change under us)."""
    return MappingProxyType(dict(items))


def _empty_map() -> Mapping[Any, Any]:
    return MappingProxyType({})


@dataclass(frozen=True, slots=True, kw_only=True)
class Param:
    """A ``<param key value>``: a setting for a plugin, or for the successor's plugins."""

    key: str
    value: str
    pos: Position = field(default=NOWHERE, compare=False, repr=False)


def _param_map(params: tuple[Param, ...]) -> dict[str, str]:
    return {p.key: p.value for p in params}


@dataclass(frozen=True, slots=True, kw_only=True)
class PluginSpec:
    """One plugin an actor loads on a bus: an entry-point name (or ``module:Class``) and its
    params. ``pos`` is the plugin's ``<_P_Name>``."""

    name: str
    params: tuple[Param, ...] = ()
    pos: Position = field(default=NOWHERE, compare=False, repr=False)

    @property
    def param_map(self) -> dict[str, str]:
        """The params as a fresh ``{key: value}`` dict (keys are unique in a valid script)."""
        return _param_map(self.params)


@dataclass(frozen=True, slots=True, kw_only=True)
class Actor:
    """An ``<Actor>`` of ``<_ActorsConfig>``: a virtualized capability of a platform.

    ``id`` is ``_P_ID`` or, when absent, assigned by the builder (see
    :func:`actorswarm.dsl.builder.build`). ``priority`` is ``_P_Prio`` (default 0; a larger
    number is a higher priority). ``buses`` maps each configured bus to its plugins in the
    order they are listed.
    """

    name: str
    id: int
    priority: int = 0
    buses: Mapping[BusName, tuple[PluginSpec, ...]] = field(default_factory=_empty_map, hash=False)
    pos: Position = field(default=NOWHERE, compare=False, repr=False)
    attr_pos: Mapping[str, Position] = field(
        default_factory=_empty_map, compare=False, repr=False, hash=False
    )

    def plugins(self) -> Iterator[tuple[BusName, PluginSpec]]:
        """Every ``(bus, plugin)`` of this actor, buses in OODA order."""
        for bus in BUSES:
            for plugin in self.buses.get(bus, ()):
                yield bus, plugin


@dataclass(frozen=True, slots=True, kw_only=True)
class Branch:
    """Where ``count`` of a transition's participants go. ``count="rest"`` takes whatever
    the integer branches leave; a transition written with a bare ``<successor>`` has exactly
    one branch, ``Branch(count="rest", ...)``, which takes them all."""

    count: Count
    successor: str
    pos: Position = field(default=NOWHERE, compare=False, repr=False)
    #: Where the ``<successor actor=...>`` attribute is, for messages about the successor.
    successor_pos: Position = field(default=NOWHERE, compare=False, repr=False)


@dataclass(frozen=True, slots=True, kw_only=True)
class Transition:
    """A ``<transition>``: when ``event`` reaches holders of ``actor``, ``sys_num`` of them
    switch together to the successors of ``branches``.

    ``barrier_key`` (1..63) joins it to every other transition with the same key: they fire
    together on one release. ``timeout`` (seconds) and ``timeout_branch`` say what happens
    when the group cannot be completed in time. ``params`` go to the successor's plugins.
    ``attr_pos`` holds the position of each attribute written in the script, and under
    ``"actor"`` the ``name`` of the enclosing ``<actor>`` block.
    """

    actor: str
    event: str
    sys_num: SysNum
    branches: tuple[Branch, ...]
    barrier_key: int | None = None
    timeout: float | None = None
    timeout_branch: str | None = None
    params: tuple[Param, ...] = ()
    pos: Position = field(default=NOWHERE, compare=False, repr=False)
    attr_pos: Mapping[str, Position] = field(
        default_factory=_empty_map, compare=False, repr=False, hash=False
    )

    @property
    def param_map(self) -> dict[str, str]:
        """The params as a fresh ``{key: value}`` dict."""
        return _param_map(self.params)

    def at(self, attribute: str) -> Position:
        """Where ``attribute`` was written, or the transition itself when it was not."""
        return self.attr_pos.get(attribute, self.pos)

    @property
    def successors(self) -> tuple[str, ...]:
        """Every actor a participant can end up in when the group fires (not on timeout)."""
        return tuple(dict.fromkeys(b.successor for b in self.branches))


@dataclass(frozen=True, slots=True, kw_only=True)
class PlatformLine:
    """A ``<platform id actor>`` line: each platform in ``ids`` starts ``actor``."""

    ids: frozenset[int]
    actor: str
    pos: Position = field(default=NOWHERE, compare=False, repr=False)
    attr_pos: Mapping[str, Position] = field(
        default_factory=_empty_map, compare=False, repr=False, hash=False
    )

    def at(self, attribute: str) -> Position:
        """Where ``attribute`` was written, or the line itself when it was not."""
        return self.attr_pos.get(attribute, self.pos)


@dataclass(frozen=True, slots=True, kw_only=True)
class TaskScript:
    """A whole task script: ``<_ActorsConfig>``, ``<_TaskConfig>``, ``<_PlatformActorConfig>``.

    ``transitions`` maps an actor name to its transitions in script order (actors without
    transitions are absent). ``path`` is where the script was read from, for messages; it
    takes no part in equality.
    """

    name: str
    version: str
    actors: tuple[Actor, ...]
    transitions: Mapping[str, tuple[Transition, ...]] = field(
        default_factory=_empty_map, hash=False
    )
    platforms: tuple[PlatformLine, ...] = ()
    path: str | None = field(default=None, compare=False)
    pos: Position = field(default=NOWHERE, compare=False, repr=False)

    def actor(self, name: str) -> Actor:
        """The actor called ``name``; ``KeyError`` when there is none."""
        for actor in self.actors:
            if actor.name == name:
                return actor
        raise KeyError(name)

    def all_transitions(self) -> Iterator[Transition]:
        """Every transition, grouped by actor in script order."""
        for transitions in self.transitions.values():
            yield from transitions

    def platform_ids(self) -> frozenset[int]:
        """Every platform the script starts an actor on."""
        return frozenset().union(*(line.ids for line in self.platforms))

    def initial_actors(self) -> dict[str, frozenset[int]]:
        """``{actor: platforms that start it}``, actors in the order first started."""
        started: dict[str, frozenset[int]] = {}
        for line in self.platforms:
            started[line.actor] = started.get(line.actor, frozenset()) | line.ids
        return started
