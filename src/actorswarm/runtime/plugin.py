"""The plugin contract: what an algorithm developer writes, and what the runtime promises.

Theory of operation
-------------------
A plugin is a class derived from :class:`Plugin`. It *declares* what it is at class level
and *implements* hooks that the runtime calls; it never drives itself.

Declarations (checked when the class is defined; a bad one raises
:class:`PluginDeclarationError` at import time, not in flight):

* :attr:`Plugin.bus` — the OODA stage the plugin is written for (``observe_bus``,
  ``orient_bus``, ``decide_bus`` or ``act_bus``); :attr:`Plugin.any_bus` says it fits any.
* :attr:`Plugin.resources` — the exclusive hardware it needs (``"autopilot"``, ``"camera"``);
  the runtime grants all of them or refuses the actor's start.
* :attr:`Plugin.needs_vehicle` — whether it cannot run without a vehicle (the simulator's
  ``--no-world`` mode refuses such plugins).
* :attr:`Plugin.params` — the ``<param key value>`` pairs it accepts, each a :class:`Param`.
  The same table serves the script checker (before deployment) and the runtime (at start),
  so both read a param the same way and report the same message.

Hooks (override the ones you need; each gets the :class:`~actorswarm.runtime.context.
PluginContext` of this start):

====================  ============================================================
``on_start(ctx)``     the actor starts: set up state from ``ctx.params``
``step(ctx)``         once per actor step while running, in bus order (abstract)
``on_pause(ctx)``     the actor goes to sleep: stop commanding, keep state
``on_activate(ctx)``  the actor wakes (after a pause, or after :meth:`restore`)
``on_stop(ctx)``      the actor is unloaded: release what ``on_start`` took
``snapshot()``        the plugin's state as plain data (data backup, migration)
``restore(state)``    rebuild that state in a fresh instance
``next_deadline()``   the earliest ``now`` at which ``step`` has something to do
====================  ============================================================

The runtime never calls a hook directly: it calls the *driver* methods
(``_drive_start``, ``_drive_step``, ...), which are the framework's and must not be
overridden (they are marked :func:`typing.final`, and overriding one is refused when the
class is defined). A driver checks the call against the lifecycle table :data:`LIFECYCLE`
and raises :class:`LifecycleError` for a call out of order (a step before the start, an
activate of a running plugin), *before* any hook runs, so a hook can rely on its
predecessors having run. One instance lives through one start::

    new --start--> running --pause--> sleeping --activate--> running --stop--> stopped
    new --restore--> sleeping                (then activate, never start)

``stopped`` is final: the runtime builds a fresh instance for every start, so a plugin
never has to reset itself. ``snapshot`` is allowed while running or sleeping; ``restore``
only on a fresh instance, which then resumes with ``on_activate`` (not ``on_start``, which
would begin over).

Rules every hook obeys (the conformance kit :func:`actorswarm.testing.check_plugin` checks
what can be checked):

* **Never block.** A hook runs inside the actor's step, which the whole platform shares;
  commands to the vehicle set a goal and return at once. Spread long work over steps.
* **Never read the clock, never draw global randomness.** Time is ``ctx.now`` (virtual in
  the simulator, wall time on a platform); randomness is ``ctx.rng``. This is what lets the
  same plugin run thousands of simulated seconds per real second and replay a seeded run.
* **Talk through the context.** Events go out with ``ctx.emit``; plugins of one actor share
  ``ctx.blackboard``; swarm coordination goes through ``ctx.collective``.

If a hook raises, the lifecycle state does not change (except ``stop``: the plugin is
stopped whatever happened) and the exception reaches the runtime, which reports it with the
actor and plugin names and puts the actor in its error state.
"""

from __future__ import annotations

import math
import re
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, ClassVar, Final, Literal, final, get_args

from actorswarm.runtime.shapes import area_name, read_route
from actorswarm.suggest import did_you_mean as _did_you_mean

if TYPE_CHECKING:
    from actorswarm.runtime.context import PluginContext

__all__ = [
    "BUSES",
    "LIFECYCLE",
    "PARAM_KINDS",
    "BusName",
    "Lifecycle",
    "LifecycleError",
    "LifecycleOp",
    "Param",
    "ParamError",
    "ParamKind",
    "ParamValue",
    "Plugin",
    "PluginDeclarationError",
    "Point",
]

#: The four OODA buses, in the order an actor step calls them.
BusName = Literal["observe_bus", "orient_bus", "decide_bus", "act_bus"]
BUSES: Final[tuple[BusName, ...]] = get_args(BusName)

#: How a param's text is read. ``point`` is three numbers ``"x y z"`` (metres); ``area``
#: (an area's name or a rectangle) and ``route`` (waypoints) stay text, checked for their
#: shape (:mod:`actorswarm.runtime.shapes`).
ParamKind = Literal["str", "int", "float", "bool", "point", "area", "route"]
PARAM_KINDS: Final[tuple[ParamKind, ...]] = get_args(ParamKind)

Point = tuple[float, float, float]
ParamValue = str | int | float | bool | Point

#: Where a plugin instance is in its life.
Lifecycle = Literal["new", "running", "sleeping", "stopped"]
#: What the runtime can do to a plugin instance.
LifecycleOp = Literal["start", "step", "pause", "activate", "stop", "snapshot", "restore"]

#: The plugin lifecycle: (state, operation) -> the state it leads to. A pair that is not
#: here is refused with :class:`LifecycleError`.
LIFECYCLE: Final[Mapping[tuple[Lifecycle, LifecycleOp], Lifecycle]] = MappingProxyType(
    {
        ("new", "start"): "running",
        ("new", "restore"): "sleeping",
        ("running", "step"): "running",
        ("running", "snapshot"): "running",
        ("running", "pause"): "sleeping",
        ("running", "stop"): "stopped",
        ("sleeping", "activate"): "running",
        ("sleeping", "snapshot"): "sleeping",
        ("sleeping", "stop"): "stopped",
    }
)

#: Advice for the out-of-order calls that actually happen.
_LIFECYCLE_HINTS: Final[Mapping[tuple[Lifecycle, LifecycleOp], str]] = MappingProxyType(
    {
        ("new", "step"): "start it first",
        ("new", "activate"): "start it (or restore a snapshot) first",
        ("new", "snapshot"): "it has no state before it starts",
        ("running", "start"): "it is already running",
        ("running", "activate"): "it is already running",
        ("running", "restore"): "restore only a fresh instance",
        ("sleeping", "start"): "it was started before; activate it instead",
        ("sleeping", "step"): "a sleeping plugin is not stepped; activate it first",
        ("sleeping", "pause"): "it is already sleeping",
        ("sleeping", "restore"): "restore only a fresh instance",
        ("stopped", "start"): "a stopped plugin is done; build a fresh instance to start again",
    }
)

_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_.\-]*")
_INTEGER = re.compile(r"[+-]?[0-9]{1,18}")
_NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_KIND_NAMES: Final[Mapping[ParamKind, str]] = MappingProxyType(
    {
        "str": "a str",
        "int": "an int",
        "float": "a finite float",
        "bool": "a bool",
        "point": "a point (three finite numbers)",
        "area": "an area (a name, or four numbers x_min y_min x_max y_max)",
        "route": "a route (waypoints 'x1 y1; x2 y2; ...')",
    }
)
_TRUE: Final = frozenset({"true", "yes", "on", "1"})
_FALSE: Final = frozenset({"false", "no", "off", "0"})


class PluginDeclarationError(TypeError):
    """A plugin class declares something the framework cannot use (an unknown bus, a param
    whose default does not fit its kind, an overridden driver method). Raised when the class
    is defined, so a broken plugin fails at import, never in flight."""


class LifecycleError(RuntimeError):
    """The runtime asked a plugin for an operation its lifecycle does not allow now (a step
    before the start, an activate of a running plugin). Nothing was called and nothing
    changed; ``legal`` lists what may be done instead."""

    def __init__(self, plugin: str, state: Lifecycle, operation: LifecycleOp) -> None:
        self.plugin = plugin
        self.state: Lifecycle = state
        self.operation: LifecycleOp = operation
        self.legal: tuple[LifecycleOp, ...] = tuple(op for (st, op) in LIFECYCLE if st == state)
        hint = _LIFECYCLE_HINTS.get((state, operation))
        legal = ", ".join(self.legal) or "nothing (build a fresh instance)"
        super().__init__(
            f"cannot {operation} plugin {plugin}: it is {state}"
            + (f" ({hint})" if hint else "")
            + f"; from {state} the legal operations are: {legal}"
        )


class ParamError(ValueError):
    """Params that do not fit a plugin's declaration. ``problems`` lists ``(key, message)``
    pairs, each message readable after ``file:line:col:`` (the key is named in it)."""

    def __init__(self, plugin: str, problems: Iterable[tuple[str, str]]) -> None:
        self.plugin = plugin
        self.problems: list[tuple[str, str]] = list(problems)
        lines = "; ".join(message for _, message in self.problems)
        super().__init__(f"{plugin}: {lines}")


@dataclass(frozen=True, slots=True, kw_only=True)
class Param:
    """One ``<param key value>`` a plugin accepts: how its text reads and what it means.

    ``kind`` is how the text is read: ``str`` (trimmed, not empty), ``int`` (ASCII digits,
    optional sign), ``float`` (a finite decimal such as ``2``, ``0.5`` or ``1e-3``),
    ``bool`` (``true/false``, ``yes/no``, ``on/off``, ``1/0``), ``point`` (three numbers
    ``"x y z"`` separated by spaces, in metres), ``area`` (the name of one of the mission's
    areas, or a rectangle ``"x_min y_min x_max y_max"``: the script checker also looks the
    name up when it is given the world) or ``route`` (waypoints ``"x1 y1; x2 y2; ..."``);
    an ``area`` or a ``route`` stays text, read with :mod:`~actorswarm.runtime.shapes`.
    ``required`` params have no default; an
    optional one takes ``default`` (which may be None: "not given") when the script leaves
    it out. ``choices`` limits a ``str``/``int``/``float`` to a set of values; ``minimum``
    bounds an ``int``/``float`` from below; ``pattern`` is a regular expression a ``str``
    must match in full, and ``form`` says in words what it accepts (messages show ``form``,
    not the pattern: "event must be an event name (a letter or _, then letters, digits, _ .
    -), not '3go'"). ``doc`` says what the param means, for messages and generated docs.

    ``key`` is filled in by :class:`Plugin` from the key the param is declared under, so
    messages name it; leave it out when declaring.

    A :class:`Param` is also what the script checker needs (``required``, ``parse``,
    ``meaning``), so the checker can take its table straight from the plugin classes.
    """

    kind: ParamKind
    default: ParamValue | None = None
    required: bool = False
    doc: str = ""
    choices: tuple[str | int | float, ...] | None = None
    minimum: float | None = None
    pattern: str | None = None
    form: str = ""
    key: str = ""
    _regex: re.Pattern[str] | None = field(default=None, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        problems = self._declaration_problems()
        if problems:
            label = f"param {self.key!r}" if self.key else f"Param(kind={self.kind!r})"
            raise PluginDeclarationError(f"{label}: " + "; ".join(problems))
        if self.pattern is not None:
            object.__setattr__(self, "_regex", re.compile(self.pattern))
        if self.choices is not None:
            object.__setattr__(self, "choices", tuple(self.choices))
        if self.default is not None:
            object.__setattr__(self, "default", self._normalize(self.default))

    @property
    def meaning(self) -> str:
        """What the param means (:attr:`doc`), under the name the script checker uses."""
        return self.doc

    @property
    def _what(self) -> str:
        return self.key or "the value"

    def _declaration_problems(self) -> list[str]:
        problems: list[str] = []
        if self.kind not in PARAM_KINDS:
            return [f"kind {self.kind!r} is not one of {', '.join(PARAM_KINDS)}"]
        if self.required and self.default is not None:
            problems.append("a required param cannot have a default; drop one of them")
        if self.choices is not None:
            if self.kind not in ("str", "int", "float"):
                problems.append(f"choices apply to str, int or float params, not {self.kind}")
            elif not tuple(self.choices):
                problems.append("choices is empty; leave it out to accept any value")
            else:
                for choice in self.choices:
                    problems.extend(self._value_problems(choice, "choice"))
        if self.minimum is not None and (
            self.kind not in ("int", "float")
            or isinstance(self.minimum, bool)
            or not isinstance(self.minimum, int | float)
            or not math.isfinite(self.minimum)
        ):
            problems.append("minimum must be a finite number, on an int or float param")
        if self.pattern is not None:
            if self.kind != "str":
                problems.append(f"pattern applies to str params, not {self.kind}")
            else:
                try:
                    re.compile(self.pattern)
                except re.error as exc:
                    problems.append(f"pattern {self.pattern!r} is not a regular expression: {exc}")
        if self.form and self.pattern is None:
            problems.append("form describes a pattern; give the pattern too, or drop form")
        if self.key and not _NAME.fullmatch(self.key):
            problems.append(f"key {self.key!r} is not a valid param name")
        if not problems and self.default is not None:
            problems.extend(self._value_problems(self.default, "default"))
            if not problems:
                try:
                    self._check_bounds(self._normalize(self.default), repr(self.default))
                except ValueError as exc:
                    problems.append(f"default {self.default!r} is refused: {exc}")
        return problems

    def _value_problems(self, value: object, what: str) -> list[str]:
        """Whether ``value`` is a Python value of this param's kind."""
        ok: bool
        if self.kind in ("str", "area", "route"):
            ok = isinstance(value, str)
        elif self.kind == "bool":
            ok = isinstance(value, bool)
        elif self.kind == "int":
            ok = isinstance(value, int) and not isinstance(value, bool)
        elif self.kind == "float":
            ok = (
                isinstance(value, int | float)
                and not isinstance(value, bool)
                and math.isfinite(value)
            )
        else:
            ok = (
                isinstance(value, tuple | list)
                and len(value) == 3
                and all(
                    isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
                    for v in value
                )
            )
        return [] if ok else [f"{what} {value!r} is not {_KIND_NAMES[self.kind]}"]

    def _normalize(self, value: Any) -> ParamValue:
        if self.kind == "float":
            return float(value)
        if self.kind == "point":
            x, y, z = (float(v) for v in value)
            return (x, y, z)
        result: ParamValue = value
        return result

    def parse(self, text: str) -> ParamValue:
        """The value ``text`` stands for, or :class:`ValueError` saying what is accepted
        (a message that names the param and reads well after ``file:line:col:``)."""
        value = text.strip()
        what = self._what
        parsed: ParamValue
        if self.kind == "str":
            if not value:
                raise ValueError(f"{what} is empty; give it a value or leave the param out")
            if self._regex is not None and not self._regex.fullmatch(value):
                if self.form:
                    raise ValueError(f"{what} must be {self.form}, not {value!r}")
                meaning = f" ({self.doc})" if self.doc else ""
                raise ValueError(
                    f"{what} must match the pattern {self.pattern}{meaning}, not {value!r}"
                )
            parsed = value
        elif self.kind == "area":
            area_name(value, what)
            parsed = value
        elif self.kind == "route":
            read_route(value, what)
            parsed = value
        elif self.kind == "int":
            if not _INTEGER.fullmatch(value):
                raise ValueError(f"{what} must be an integer such as 3, not {value!r}")
            parsed = int(value)
        elif self.kind == "float":
            if not _NUMBER.fullmatch(value) or not math.isfinite(float(value)):
                raise ValueError(f"{what} must be a number such as 2 or 0.5, not {value!r}")
            parsed = float(value)
        elif self.kind == "bool":
            if value.lower() in _TRUE:
                parsed = True
            elif value.lower() in _FALSE:
                parsed = False
            else:
                raise ValueError(f"{what} must be true or false, not {value!r}")
        else:
            parts = value.split()
            if len(parts) != 3 or not all(
                _NUMBER.fullmatch(p) and math.isfinite(float(p)) for p in parts
            ):
                raise ValueError(
                    f'{what} must be three numbers "x y z" such as "200 200 20", not {value!r}'
                )
            parsed = (float(parts[0]), float(parts[1]), float(parts[2]))
        self._check_bounds(parsed, repr(value))
        return parsed

    def _check_bounds(self, parsed: ParamValue, shown: str) -> None:
        what = self._what
        if self.choices is not None and parsed not in self.choices:
            options = ", ".join(f'"{c}"' for c in self.choices)
            hint = (
                _did_you_mean(parsed, [str(c) for c in self.choices])
                if isinstance(parsed, str)
                else ""
            )
            raise ValueError(f"{what} must be one of {options}, not {shown}{hint}")
        if (
            self.minimum is not None
            and isinstance(parsed, int | float)
            and not isinstance(parsed, bool)
            and parsed < self.minimum
        ):
            raise ValueError(f"{what} must be ≥ {_number_text(self.minimum)}, not {shown}")

    def format(self, value: ParamValue) -> str:
        """The text that :meth:`parse` reads back as ``value`` (for writers and docs)."""
        if isinstance(value, bool):
            return "true" if value else "false"
        if isinstance(value, tuple):
            return " ".join(_number_text(v) for v in value)
        if isinstance(value, float):
            return _number_text(value)
        return str(value)

    def describe(self) -> str:
        """One line for docs and listings, e.g. ``float ≥ 0, default 0: seconds to wait``."""
        parts: list[str] = [self.kind]
        if self.choices is not None:
            parts = ["|".join(str(c) for c in self.choices)]
        if self.minimum is not None:
            parts.append(f"≥ {_number_text(self.minimum)}")
        head = " ".join(parts)
        if self.required:
            head += ", required"
        elif self.default is not None:
            head += f", default {self.format(self.default)}"
        return f"{head}: {self.doc}" if self.doc else head


def _number_text(value: float) -> str:
    return str(int(value)) if float(value).is_integer() and abs(value) < 1e15 else repr(value)


#: The driver methods: the framework's, never a subclass's.
_DRIVERS: Final = (
    "_drive_start",
    "_drive_step",
    "_drive_pause",
    "_drive_activate",
    "_drive_stop",
    "_drive_snapshot",
    "_drive_restore",
    "_drive_next_deadline",
    "validate_params",
    "bind_params",
)


class Plugin(ABC):
    """Base class of every plugin: declare at class level, implement the hooks.

    A minimal plugin::

        class Hover(Plugin):
            \"\"\"Holds position at ``altitude`` metres.\"\"\"

            bus = "act_bus"
            resources = frozenset({"autopilot"})
            needs_vehicle = True
            params: ClassVar[Mapping[str, Param]] = {
                "altitude": Param(kind="float", default=10.0, minimum=0.0,
                                  doc="metres above home"),
            }

            def on_start(self, ctx: PluginContext) -> None:
                vehicle = ctx.require_vehicle()
                x, y, _ = vehicle.position()
                vehicle.goto(x, y, ctx.params["altitude"])

            def step(self, ctx: PluginContext) -> None:
                pass  # the autopilot holds the goal; nothing to do per step

    and its test: ``actorswarm.testing.check_plugin(Hover)``.

    The runtime builds a plugin with no arguments (``Hover()``); everything a start needs
    comes from the context. A subclass may define ``__init__`` for plain attribute set-up,
    but must not need arguments and must not touch the vehicle or the clock there.
    """

    #: The OODA stage this plugin is written for. ``decide_bus`` unless the plugin says
    #: otherwise: deciding (choosing a goal, emitting an event) is what most plugins do.
    bus: ClassVar[BusName] = "decide_bus"
    #: True when the plugin fits any bus (``core.idle``); the checker then accepts it on
    #: every ``<Bus>``.
    any_bus: ClassVar[bool] = False
    #: The exclusive hardware the plugin needs; its actor gets all of it or does not start.
    resources: ClassVar[frozenset[str]] = frozenset()
    #: True when the plugin cannot run with ``ctx.vehicle`` None.
    needs_vehicle: ClassVar[bool] = False
    #: The ``<param key value>`` pairs it accepts, by key. Every declared key is present in
    #: ``ctx.params`` (a value, or the default, which may be None).
    params: ClassVar[Mapping[str, Param]] = MappingProxyType({})
    #: True when a group's members close on their :meth:`group_points` in step, each the
    #: same fraction of the way at every moment (a formation): the master then hands the
    #: places out by least *squared* distance, which keeps such members apart on the way;
    #: False, by least total distance, which keeps their straight paths from crossing
    #: (:mod:`actorswarm.engine.assign`).
    group_in_step: ClassVar[bool] = False

    # The instance's place in :data:`LIFECYCLE`. A class attribute, so a subclass
    # ``__init__`` that forgets ``super().__init__()`` still starts out "new".
    _lifecycle: Lifecycle = "new"
    _in_hook: str | None = None

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        overridden = [name for name in _DRIVERS if name in cls.__dict__]
        problems = [
            f"{name} is the framework's driver and must not be overridden; put the behaviour "
            f"in the hook it calls"
            for name in overridden
        ]
        raw = cls.__dict__.get("params", cls.params)
        if isinstance(raw, Mapping):
            bound: dict[str, Param] = {}
            for key, param in raw.items():
                if not isinstance(key, str) or not _NAME.fullmatch(key):
                    problems.append(f"param key {key!r} is not a valid name")
                elif not isinstance(param, Param):
                    problems.append(f"param {key!r} is declared as {param!r}, not a Param")
                elif param.key not in ("", key):
                    problems.append(f"param {key!r} is declared with key={param.key!r}")
                else:
                    bound[key] = param if param.key == key else replace(param, key=key)
            cls.params = MappingProxyType(bound)
        problems.extend(cls.declaration_problems())
        if problems:
            raise PluginDeclarationError(
                f"plugin class {cls.__module__}.{cls.__qualname__}: " + "; ".join(problems)
            )

    @classmethod
    def declaration_problems(cls) -> list[str]:
        """What is wrong with the class-level declarations (empty when all is well)."""
        # Read as plain objects: a subclass may have declared anything at all.
        bus: object = cls.bus
        any_bus: object = cls.any_bus
        needs_vehicle: object = cls.needs_vehicle
        resources: object = cls.resources
        params: object = cls.params
        problems: list[str] = []
        if bus not in BUSES:
            problems.append(f"bus {bus!r} is not one of {', '.join(BUSES)}")
        if not isinstance(any_bus, bool):
            problems.append(f"any_bus must be True or False, not {any_bus!r}")
        if not isinstance(needs_vehicle, bool):
            problems.append(f"needs_vehicle must be True or False, not {needs_vehicle!r}")
        if not isinstance(resources, frozenset):
            problems.append(
                f"resources must be a frozenset of names such as frozenset({{'autopilot'}}), "
                f"not {resources!r}"
            )
        else:
            problems.extend(
                f"resource {r!r} is not a valid name"
                for r in sorted(resources, key=repr)
                if not isinstance(r, str) or not _NAME.fullmatch(r)
            )
        if not isinstance(params, Mapping):
            problems.append(f"params must be a mapping of key -> Param, not {params!r}")
        else:
            for key, param in params.items():
                if not isinstance(param, Param):
                    problems.append(f"param {key!r} is declared as {param!r}, not a Param")
                elif param.key != key:
                    problems.append(f"param {key!r} is bound to key {param.key!r}")
        return problems

    @classmethod
    def plugin_name(cls) -> str:
        """How messages name this plugin class (its qualified class name)."""
        return cls.__qualname__

    # --- params -----------------------------------------------------------------------------

    @final
    @classmethod
    def validate_params(cls, raw: Mapping[str, str]) -> dict[str, Any]:
        """Read the script's ``<param key value>`` texts into typed values.

        Returns every declared key: the given value, or the default (possibly None) when it
        is left out. Raises :class:`ParamError` listing every problem at once — an unknown
        key (with the closest known key), a required key left out, a value that does not
        read — so a script author fixes them in one go.
        """
        problems: list[tuple[str, str]] = []
        values: dict[str, Any] = {}
        declared = cls.params
        given: Mapping[str, object] = raw  # hosts may hand over anything: check it is text
        for key, text in given.items():
            param = declared.get(key)
            if param is None:
                accepted = f"it takes {', '.join(declared)}" if declared else "it takes no params"
                problems.append(
                    (key, f"no param {key!r}{_did_you_mean(key, declared)}; {accepted}")
                )
                continue
            if not isinstance(text, str):
                problems.append((key, f"{key} must be given as text, not {text!r}"))
                continue
            try:
                values[key] = param.parse(text)
            except ValueError as exc:
                problems.append((key, str(exc)))
        for key, param in declared.items():
            if key in raw:
                continue
            if param.required:
                meaning = f" ({param.doc})" if param.doc else ""
                problems.append(
                    (
                        key,
                        f'needs the param {key}{meaning}: add <param key="{key}" value="..."/>',
                    )
                )
            else:
                values[key] = param.default
        if not problems:
            problems.extend(cls.check_params(values))
        if problems:
            raise ParamError(cls.plugin_name(), problems)
        return {key: values[key] for key in declared}

    @classmethod
    def check_params(cls, values: Mapping[str, Any]) -> Iterable[tuple[str, str]]:
        """Rules that tie params together (``low`` below ``high``), as ``(key, message)``
        problems; called by :meth:`validate_params` once every param has read well. The
        default: none. Override it when one param's meaning depends on another."""
        return ()

    @final
    @classmethod
    def bind_params(
        cls, script: Mapping[str, str], transition: Mapping[str, str] | None = None
    ) -> dict[str, Any]:
        """The params of one start: the script's ``<Plugin>`` params, overridden by the
        params of the transition that switched the actor in, validated.

        A transition's params go to every plugin of the successor actor, so keys this plugin
        does not declare are left to the others rather than refused here; the script's own
        ``<param>`` children of this plugin must all be declared.
        """
        merged = dict(script)
        for key, text in (transition or {}).items():
            if key in cls.params:
                merged[key] = text
        return cls.validate_params(merged)

    @classmethod
    def group_points(
        cls,
        params: Mapping[str, Any],
        count: int,
        now: float,
        areas: Mapping[str, Sequence[tuple[float, float]]],
        *,
        task_start: float | None = None,
    ) -> Sequence[tuple[float, float]] | None:
        """Where the ``count`` members of a group switching into this plugin's actor at
        ``now`` will go, ``(x, y)`` metres, slot 1 first — or None (the default) when the
        plugin gives its members no places. ``params`` are validated (:meth:`bind_params`);
        ``areas`` are the mission's named areas (what ``ctx.areas`` holds); ``task_start``
        is when the task started, on the clock of ``now`` (what ``ctx.task_start`` holds).

        The master calls it when it releases a group and hands out the slots so that the
        sum of the distances from where the members are to where they go is least (a
        min-cost assignment, :mod:`actorswarm.engine.assign`): no member crosses the whole
        swarm to a slot a neighbour would reach sooner, and no two straight paths from
        members to their slots cross (were they to, swapping the two slots would be
        shorter, by the triangle inequality). A formation returns its slots'
        points; a search its strips' starting points. A class method, so it must not keep
        state; it is called on the master only.
        """
        return None

    # --- hooks: override these -------------------------------------------------------------

    def on_start(self, ctx: PluginContext) -> None:  # noqa: B027 (optional hook)
        """The actor starts (loaded, its hardware bound). Read ``ctx.params`` and set up
        state; commanding the vehicle (a take-off, a first goal) is fine. Called once, before
        any :meth:`step`. Must not block."""

    @abstractmethod
    def step(self, ctx: PluginContext) -> None:
        """One step of the running actor, called in bus order with the actor's other plugins
        (observe → orient → decide → act) at the rate the host chooses; ``ctx.now`` tells the
        time. Do a bounded amount of work and return: the platform's whole actor step aims
        at a millisecond.

        Abstract on purpose: stepping is a plugin's reason to exist, so a plugin states what
        it does per step, even when the answer is nothing (``pass``, as ``core.idle``).
        """

    def on_pause(self, ctx: PluginContext) -> None:  # noqa: B027 (optional hook)
        """The actor goes to sleep (preempted by a higher-priority actor, or paused by the
        operator). Stop commanding — another actor may own the vehicle next — and keep your
        state: :meth:`on_activate` resumes it. Must not block."""

    def on_activate(self, ctx: PluginContext) -> None:  # noqa: B027 (optional hook)
        """The actor wakes after a pause, or a fresh instance resumes after :meth:`restore`.
        Time has passed (``ctx.now``) and the world has moved: re-read it before commanding.
        Must not block."""

    def on_stop(self, ctx: PluginContext) -> None:  # noqa: B027 (optional hook)
        """The actor is unloaded (from running or sleeping). Release what :meth:`on_start`
        took; this instance is never called again. Must not block."""

    def snapshot(self) -> dict[str, Any]:
        """The plugin's state as plain data (str keys; str, int, float, bool, None, lists and
        dicts of those), for data backup and restart. Return a new dict, not an attribute the
        plugin keeps changing. The default: no state. Override with :meth:`restore`."""
        return {}

    def restore(self, state: Mapping[str, Any]) -> None:  # noqa: B027 (optional hook)
        """Rebuild the state a :meth:`snapshot` returned, in a fresh instance; the runtime
        then calls :meth:`on_activate` (never :meth:`on_start`). Raise :class:`ValueError`
        for a state this version cannot read. The default: nothing to restore."""

    def next_deadline(self) -> float | None:
        """The earliest ``now`` at which :meth:`step` has something to do (a timer), or None
        for none of its own. A simulator jumps virtual time to the nearest deadline, so a
        plugin that waits declares it here instead of being stepped at a fine rate."""
        return None

    # --- driver: the framework's, do not override --------------------------------------------

    @property
    def lifecycle(self) -> Lifecycle:
        """Where this instance is in :data:`LIFECYCLE`."""
        return self._lifecycle

    def _enter(self, op: LifecycleOp) -> Lifecycle:
        if self._in_hook is not None:
            raise LifecycleError(
                f"{self.plugin_name()} (called from inside its own {self._in_hook} hook)",
                self._lifecycle,
                op,
            )
        target = LIFECYCLE.get((self._lifecycle, op))
        if target is None:
            raise LifecycleError(self.plugin_name(), self._lifecycle, op)
        return target

    def _run(self, hook_name: str, hook: Callable[[], object]) -> object:
        self._in_hook = hook_name
        try:
            return hook()
        finally:
            self._in_hook = None

    @final
    def _drive_start(self, ctx: PluginContext) -> None:
        """Start the plugin: :meth:`on_start`. Do not override."""
        target = self._enter("start")
        self._run("start", lambda: self.on_start(ctx))
        self._lifecycle = target

    @final
    def _drive_step(self, ctx: PluginContext) -> None:
        """One step: :meth:`step`. Do not override."""
        self._enter("step")
        self._run("step", lambda: self.step(ctx))

    @final
    def _drive_pause(self, ctx: PluginContext) -> None:
        """Put the plugin to sleep: :meth:`on_pause`. Do not override."""
        target = self._enter("pause")
        self._run("pause", lambda: self.on_pause(ctx))
        self._lifecycle = target

    @final
    def _drive_activate(self, ctx: PluginContext) -> None:
        """Wake the plugin: :meth:`on_activate`. Do not override."""
        target = self._enter("activate")
        self._run("activate", lambda: self.on_activate(ctx))
        self._lifecycle = target

    @final
    def _drive_stop(self, ctx: PluginContext) -> None:
        """Unload the plugin: :meth:`on_stop`; it is stopped even if the hook raises. Do
        not override."""
        target = self._enter("stop")
        try:
            self._run("stop", lambda: self.on_stop(ctx))
        finally:
            self._lifecycle = target

    @final
    def _drive_snapshot(self) -> dict[str, Any]:
        """The plugin's state: :meth:`snapshot`, checked to be a dict with str keys. Do not
        override."""
        self._enter("snapshot")
        state = self._run("snapshot", self.snapshot)
        if not isinstance(state, dict) or not all(isinstance(k, str) for k in state):
            raise TypeError(
                f"{self.plugin_name()}.snapshot() returned {type(state).__name__} "
                f"{state!r:.80}; it must return a dict with str keys of plain data"
            )
        return state

    @final
    def _drive_restore(self, state: Mapping[str, Any]) -> None:
        """Restore a fresh instance from a snapshot: :meth:`restore`; the plugin is then
        sleeping, and resumes with :meth:`_drive_activate`. Do not override."""
        target = self._enter("restore")
        self._run("restore", lambda: self.restore(state))
        self._lifecycle = target

    @final
    def _drive_next_deadline(self) -> float | None:
        """:meth:`next_deadline` while running (a sleeping plugin has none). Do not
        override."""
        if self._lifecycle != "running":
            return None
        deadline = self._run("next_deadline", self.next_deadline)
        if deadline is None:
            return None
        if (
            not isinstance(deadline, int | float)
            or isinstance(deadline, bool)
            or math.isnan(deadline)
        ):
            raise TypeError(
                f"{self.plugin_name()}.next_deadline() returned {deadline!r}; it must return "
                "a time (float) or None"
            )
        return float(deadline)
