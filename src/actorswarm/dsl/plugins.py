"""Which plugins a task script may name, and the params of the built-in ones.

A plugin is found by name through the entry-point group :data:`ENTRY_POINT_GROUP`
(docs/design.md §5); :func:`installed_plugins` lists those names so the checker can refuse a
script that names a plugin this machine does not have, before it is deployed.

Two plugins need no vehicle and always exist (docs/design.md §6):

``core.idle``
    Does nothing; an actor that only waits for events. Takes no params.

``core.emit_after``
    Emits ``event`` once, ``after + spread_per_platform × platform ID`` seconds after the
    actor starts. Params: ``event`` (required, an event name), ``after`` (required, seconds
    ≥ 0), ``spread_per_platform`` (seconds, default 0) and ``scope`` (``local``, the default:
    only the emitting platform becomes a candidate; or ``swarm``).

They are registered as entry points like any third-party plugin
(:mod:`actorswarm.runtime.builtin`); the checker reads every installed plugin's params from
its class (:func:`param_rules`). The table below is the fallback for a machine where the
classes cannot be loaded, and is tested to read values as the classes do.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

from actorswarm.dsl import syntax

if TYPE_CHECKING:
    from actorswarm.runtime.entry_points import EntryPoint
    from actorswarm.runtime.plugin import Plugin

#: The entry-point group plugins register under.
ENTRY_POINT_GROUP = "actorswarm.plugins"


@dataclass(frozen=True, slots=True, kw_only=True)
class ParamRule:
    """One param of a built-in plugin: whether it must be given, and how its value reads
    (``parse`` raises ``ValueError`` with the reason)."""

    required: bool
    parse: Callable[[str], object]
    meaning: str


def _scope(text: str) -> str:
    if text.strip() not in ("local", "swarm"):
        raise ValueError(f'scope must be "local" or "swarm", not {text.strip()!r}')
    return text.strip()


def _after(text: str) -> float:
    seconds = syntax.number(text, what="after")
    if seconds < 0:
        raise ValueError(f"after must be a number of seconds ≥ 0, not {text.strip()!r}")
    return seconds


#: The params each built-in plugin accepts (a built-in refuses any other).
BUILTIN_PLUGINS: Mapping[str, Mapping[str, ParamRule]] = {
    "core.idle": {},
    "core.emit_after": {
        "event": ParamRule(
            required=True,
            parse=lambda text: syntax.name(text, what="event name"),
            meaning="the event to emit",
        ),
        "after": ParamRule(required=True, parse=_after, meaning="seconds after the start"),
        "spread_per_platform": ParamRule(
            required=False,
            parse=lambda text: syntax.number(text, what="spread_per_platform"),
            meaning="extra seconds per unit of platform ID",
        ),
        "scope": ParamRule(required=False, parse=_scope, meaning="local or swarm"),
    },
}


class _ParamLike(Protocol):
    """What the checker needs of a param declaration (a runtime ``Param`` or a rule above)."""

    @property
    def required(self) -> bool: ...

    @property
    def meaning(self) -> str: ...

    def parse(self, text: str) -> object: ...


def param_rules(name: str) -> Mapping[str, _ParamLike] | None:
    """The params plugin ``name`` declares, from its class (the registry) — so a wrong
    param of any installed plugin is a ``file:line:col`` error at check time; the table
    above when the class cannot be loaded; None for an unknown plugin."""
    from actorswarm.runtime.registry import RegistryError, param_schema

    try:
        return param_schema(name)
    except RegistryError:
        return BUILTIN_PLUGINS.get(name)


def plugin_class(name: str) -> type[Plugin] | None:
    """The class of the installed plugin ``name`` (what its bus, params and cross-param
    rules are read from), or None when it cannot be loaded here."""
    from actorswarm.runtime.registry import RegistryError, resolve

    try:
        return resolve(name)
    except RegistryError:
        return None


def entry_points(*, group: str) -> Iterable[EntryPoint]:
    """The installed entry points of ``group`` (:mod:`actorswarm.runtime.entry_points`,
    imported on the first call, not with this module: the checker lists plugins only when a
    script is checked, and a daemon without a script never does)."""
    from actorswarm.runtime.entry_points import entry_points as listed

    return listed(group=group)


def installed_plugins() -> frozenset[str]:
    """The names of every plugin a script may use on this machine: the entry points of
    :data:`ENTRY_POINT_GROUP` in the installed distributions, plus the built-ins."""
    names = {ep.name for ep in entry_points(group=ENTRY_POINT_GROUP)}
    return frozenset(names | set(BUILTIN_PLUGINS))
