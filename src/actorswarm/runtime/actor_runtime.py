"""The actor runtime: actors as plugin groups on the OODA buses, one platform's worth.

Theory of operation
-------------------
:class:`ActorRuntime` is what the task engine drives through its narrow
:class:`~actorswarm.engine.runtime.ActorHost` interface. For every actor of the task script
it knows the plugin group (plugins found by name in the registry, their script params
validated), the exclusive hardware the group needs (the union of its plugins' declared
resources) and its priority.

* **Operations** go through the one transition table of :mod:`.operations`, so an illegal
  one raises :class:`~actorswarm.runtime.operations.IllegalOperation` and changes nothing.
  ``start`` builds fresh plugin instances and drives their ``start`` hooks in OODA order;
  ``pause`` suspends them (state kept) and gives the actor's hardware back; ``activate``
  takes the hardware again and resumes them; ``stop`` unloads them. ``switch`` pauses the
  current actor and re-activates the next if it is sleeping — or starts it.
* **Hardware** is arbitrated by :class:`~actorswarm.runtime.resources.ResourceArbiter`: an
  actor of higher priority pauses the holders it needs; they resume by themselves when the
  hardware is free again. An equal or lower priority is refused with the holder named.
* **Steps.** A running actor is stepped at ``rate`` Hz, and also whenever one of its plugins
  asked to be woken (its ``next_deadline``), calling observe → orient → decide → act with one
  shared blackboard; what the plugins emit is returned to the engine. A plugin that raises is
  isolated: its actor goes to ``error`` (its hardware is released), the error is kept with the
  plugin's name, and the platform and the other actors go on.
* **Step slack.** With ``step_slack`` a step due within two slacks runs at a
  :meth:`ActorRuntime.step` the host makes anyway (a packet woke it) and keeps its
  schedule's phase; a step that needed a wake of its own moves its schedule half a slack
  later. So the steps drift until they ride on wakes that come at their rate anyway (a
  daemon's heartbeats), then keep that phase: one wake of the host per period instead of
  two. The window is two slacks wide because those wakes come off their own schedule by up
  to a slack (a master sends its heartbeat up to a slack early on a wake it makes anyway, and
  a loaded host or a radio adds jitter); with one slack, a step lost the wakes at every early
  one and drifted round the period to find them again. The rate stays ``rate`` once they
  ride; a gap is off the period by at most two slacks, and grows by at most half a slack
  while they drift. The default, 0, steps every actor exactly ``1 / rate`` after its last
  step.
* **Switch times.** Each :meth:`ActorRuntime.switch` is timed from the call to the end of
  the new actor's first OODA step (pausing the old actor, starting or re-activating the new
  one, and whatever the host does before it steps it); the samples wait in a bounded buffer
  for the host to drain (:meth:`ActorRuntime.drain_switches`).
* **Snapshots.** :meth:`ActorRuntime.snapshot` captures every loaded actor's ACB and plugin
  states; :meth:`ActorRuntime.restore` brings them back (sleeping, then activated), so a
  restarted platform can resume from its latest backup.

The runtime reads time only from the ``now`` it is given; it measures how long each plugin
step and each switch takes with a performance counter, for statistics only.
"""

from __future__ import annotations

import dataclasses
import random
import time
from collections import deque
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import msgspec

from actorswarm.runtime.acb import ACB, ActorStatus, Relations, TaskContext
from actorswarm.runtime.context import (
    Camera,
    Collective,
    NullCollective,
    PluginContext,
    Vehicle,
)
from actorswarm.runtime.events import ActorContext, Emitted
from actorswarm.runtime.operations import Operation, apply
from actorswarm.runtime.plugin import BUSES, Plugin
from actorswarm.runtime.registry import resolve
from actorswarm.runtime.resources import ResourceArbiter

# What the runtime reads of a task script, stated here so that the layer above (the DSL's
# model, which satisfies these structurally) is never imported, not even for type checking.


class PluginDefinition(Protocol):
    """A plugin named on a bus of an actor: its registry name and its parameters."""

    @property
    def name(self) -> str: ...

    @property
    def param_map(self) -> dict[str, str]: ...


class ActorDefinition(Protocol):
    """An actor of a script: its name, ID, priority and plugins by bus."""

    @property
    def name(self) -> str: ...

    @property
    def id(self) -> int: ...

    @property
    def priority(self) -> int: ...

    def plugins(self) -> Iterable[tuple[str, PluginDefinition]]: ...


class ScriptDefinition(Protocol):
    """A task script as far as the runtime needs it: its actors."""

    @property
    def actors(self) -> Sequence[ActorDefinition]: ...


class UnsupportedPlugin(ValueError):
    """A plugin this platform cannot run (e.g. it needs a vehicle and there is none)."""


@dataclass(frozen=True, slots=True)
class _PluginDef:
    bus: str
    name: str
    cls: type[Plugin]
    params: dict[str, str]


@dataclass(frozen=True, slots=True)
class _ActorDef:
    name: str
    actor_id: int
    priority: int
    plugins: tuple[_PluginDef, ...]
    resources: frozenset[str]


@dataclass(slots=True)
class _Loaded:
    acb: ACB
    plugins: list[tuple[_PluginDef, Plugin, dict[str, Any]]]  # definition, instance, params
    blackboard: dict[str, Any] = field(default_factory=dict)
    next_step: float = 0.0
    #: ``plugins`` in step order (:meth:`ActorRuntime._ooda`), once asked for.
    ooda: list[tuple[_PluginDef, Plugin, dict[str, Any]]] | None = None


@dataclass(frozen=True, slots=True)
class PluginFailure:
    """A plugin raised: its actor went to ``error``."""

    t: float
    actor: str
    plugin: str
    message: str


@dataclass(frozen=True, slots=True)
class SwitchTiming:
    """One :meth:`ActorRuntime.switch` from ``src`` to ``dst`` at ``t`` (the ``now`` it was
    called with): ``seconds`` of wall time from the call to the end of ``dst``'s first
    OODA step (a performance counter, not ``now``)."""

    t: float
    src: str
    dst: str
    seconds: float


#: Switch timings a runtime keeps until its host drains them; older ones are dropped, so a
#: host that never asks costs a bounded amount of memory.
SWITCH_TIMINGS_KEPT = 256

# The OODA position of each bus (a plugin on a bus not listed steps last).
_BUS_ORDER: dict[str, int] = {bus: i for i, bus in enumerate(BUSES)}


class ActorRuntime:
    """The actors of platform ``platform`` (see the module docstring)."""

    def __init__(
        self,
        platform: int,
        *,
        vehicle: Vehicle | None = None,
        collective: Collective | None = None,
        rate: float = 10.0,
        seed: int = 0,
        camera: Camera | None = None,
        areas: Mapping[str, Sequence[tuple[float, float]]] | None = None,
        step_slack: float = 0.0,
    ) -> None:
        if rate <= 0:
            raise ValueError(f"rate must be > 0 Hz, got {rate}")
        if not 0.0 <= step_slack <= 0.5 / rate:
            raise ValueError(
                f"step_slack must be in [0, half the step period = {0.5 / rate:g} s], "
                f"got {step_slack}"
            )
        self.platform = platform
        self.vehicle = vehicle
        self.camera = camera
        self.areas: Mapping[str, Sequence[tuple[float, float]]] = dict(areas or {})
        #: The platform's ROS 2 node for the plugins (``ctx.ros2``), set by a daemon run
        #: with ``--ros2``; None otherwise.
        self.ros2: Any = None
        self.collective: Collective = collective or NullCollective()
        self.period = 1.0 / rate
        #: The slack of the steps' schedule (the module docstring).
        self.step_slack = step_slack
        self._rng = random.Random(f"runtime:{seed}:{platform}")
        self._defs: dict[str, _ActorDef] = {}
        self._loaded: dict[str, _Loaded] = {}
        self._arbiter = ResourceArbiter()
        self.failures: list[PluginFailure] = []
        #: Timed switches, oldest first (:meth:`drain_switches`).
        self.switch_timings: deque[SwitchTiming] = deque(maxlen=SWITCH_TIMINGS_KEPT)
        # Switched-to actors not stepped yet: actor -> (switched from, now, counter at call).
        self._switching: dict[str, tuple[str, float, float]] = {}
        #: The time of the call in progress (what ``ctx.collective`` stamps requests with).
        self.now = 0.0
        #: When the task started, on the clock of ``now`` (``ctx.task_start``); the task
        #: engine sets it when the task starts. None: not started.
        self.task_start: float | None = None

    # --- the script ----------------------------------------------------------------------

    def use_script(self, script: ScriptDefinition) -> None:
        """Learn the actors of ``script``: their plugins (resolved now, so a missing plugin
        fails here, not in flight), params, priorities and hardware."""
        defs: dict[str, _ActorDef] = {}
        for actor in script.actors:
            plugins = []
            for bus, spec in actor.plugins():
                cls = resolve(spec.name)
                if cls.needs_vehicle and self.vehicle is None:
                    raise UnsupportedPlugin(
                        f"actor {actor.name!r}: plugin {spec.name!r} needs a vehicle and "
                        f"platform {self.platform} has none (the simulator runs without a "
                        "world: only plugins that need no vehicle)"
                    )
                cls.validate_params(spec.param_map)  # refuse bad params before any start
                plugins.append(_PluginDef(bus, spec.name, cls, spec.param_map))
            resources = frozenset().union(*(p.cls.resources for p in plugins))
            defs[actor.name] = _ActorDef(
                actor.name, actor.id, actor.priority, tuple(plugins), resources
            )
        self._defs = defs

    # --- ActorHost ------------------------------------------------------------------------

    def running(self) -> tuple[str, ...]:
        return tuple(n for n, a in self._loaded.items() if a.acb.status is ActorStatus.RUNNING)

    def loaded(self) -> dict[str, str]:
        return {n: a.acb.status.value for n, a in self._loaded.items()}

    def position(self) -> tuple[float, float, float] | None:
        """Where the vehicle is (None without one)."""
        return None if self.vehicle is None else self.vehicle.position()

    def vehicle_state(self) -> dict[str, str | int | float | bool | None]:
        """The scalar entries of the vehicle adapter's ``status()`` (a MAVLink vehicle's
        link, autopilot, mode, arming, battery, override); empty for a vehicle without one
        (the simulated world's) or none. Never raises: a status that fails is reported as
        such, not propagated into a ground-station reply."""
        status = getattr(self.vehicle, "status", None)
        if not callable(status):
            return {}
        try:
            said = status()
        except Exception as exc:  # an adapter's bug must not cost the operator the reply
            return {"error": f"{type(exc).__name__}: {exc}"[:200]}
        if not isinstance(said, dict):
            return {}
        return {
            str(k)[:64]: v
            for k, v in said.items()
            if v is None or isinstance(v, str | int | float | bool)
        }

    def group_points(
        self, actor: str, count: int, now: float, params: Mapping[str, str]
    ) -> list[tuple[float, float]] | None:
        """The first answer of ``actor``'s plugins to :meth:`Plugin.group_points` that
        gives ``count`` points or more, or None. A plugin that raises is skipped: the
        master's release must not fail over a plugin's geometry."""
        answer = self._group_answer(actor, count, now, params)
        return None if answer is None else answer[0]

    def group_in_step(self, actor: str, count: int, now: float, params: Mapping[str, str]) -> bool:
        """Whether the plugin that gives ``actor``'s group points moves the group in step
        (:attr:`Plugin.group_in_step`)."""
        answer = self._group_answer(actor, count, now, params)
        return answer is not None and answer[1]

    def _group_answer(
        self, actor: str, count: int, now: float, params: Mapping[str, str]
    ) -> tuple[list[tuple[float, float]], bool] | None:
        definition = self._defs.get(actor)
        if definition is None or count < 1:
            return None
        for pdef in definition.plugins:
            try:
                bound = pdef.cls.bind_params(pdef.params, params)
                points = pdef.cls.group_points(
                    bound, count, now, self.areas, task_start=self.task_start
                )
                if points is None or len(points) < count:
                    continue
                return [(float(p[0]), float(p[1])) for p in points], pdef.cls.group_in_step
            except Exception:
                continue
        return None

    def plugins(self, actor: str) -> list[Plugin]:
        """The plugin instances of loaded ``actor``, in bus order (for tools and tests that
        inspect a running mission; empty when the actor is not loaded)."""
        entry = self._loaded.get(actor)
        return [] if entry is None else [plugin for _, plugin, _ in entry.plugins]

    def acbs(self) -> dict[str, ACB]:
        """Every loaded actor's control block (what the status command reports)."""
        return {n: a.acb for n, a in self._loaded.items()}

    def start(self, actor: str, now: float, context: ActorContext) -> None:
        loaded = self._loaded.get(actor)
        if loaded is not None and loaded.acb.status is ActorStatus.SLEEPING:
            # Switched back in: the plugins resume with their state and their params, but
            # the place in the group is the new firing's (a formation re-forms on its new
            # slot), so the context's group fields are updated before the activation.
            loaded.acb.context = dataclasses.replace(
                loaded.acb.context,
                index=context.index,
                data=context.data,
                size=context.size,
                slot=context.slot,
                slots=context.slots,
            )
            loaded.acb.relations = Relations(index=context.index)
            self.activate(actor, now)
            return
        if loaded is not None and loaded.acb.status is ActorStatus.RUNNING:
            apply(loaded.acb, Operation.START, now)  # raises IllegalOperation, changes nothing
        definition = self._defs.get(actor)
        if definition is None:
            raise ValueError(f"the task script has no actor {actor!r}")
        acb = loaded.acb if loaded is not None else self._new_acb(definition)
        grant = self._arbiter.acquire(actor, definition.priority, definition.resources)
        for victim in grant.preempted:
            self._suspend(victim, now)
        instances = []
        for pdef in definition.plugins:
            params = pdef.cls.bind_params(pdef.params, context.params)
            instances.append((pdef, pdef.cls(), params))
        self._loaded[actor] = entry = _Loaded(acb=acb, plugins=instances)
        acb.context = TaskContext(
            params=dict(context.params),
            index=context.index,
            data=context.data,
            size=context.size,
            slot=context.slot,
            slots=context.slots,
        )
        acb.relations = Relations(index=context.index)
        acb.hardware = definition.resources
        apply(acb, Operation.START, now)
        entry.next_step = now
        for pdef, plugin, params in instances:
            if not self._call(entry, pdef, plugin, "_drive_start", now, params):
                return

    def stop(self, actor: str, now: float) -> None:
        entry = self._require(actor)
        apply(entry.acb, Operation.STOP, now)
        self._switching.pop(actor, None)
        for pdef, plugin, params in entry.plugins:
            if plugin.lifecycle in ("running", "sleeping"):
                self._call(entry, pdef, plugin, "_drive_stop", now, params, fail=False)
        del self._loaded[actor]
        self._release(actor, now)

    def pause(self, actor: str, now: float) -> None:
        entry = self._require(actor)
        apply(entry.acb, Operation.PAUSE, now)
        self._switching.pop(actor, None)  # paused before its first step: no timing
        for pdef, plugin, params in entry.plugins:
            self._call(entry, pdef, plugin, "_drive_pause", now, params)
        self._release(actor, now)

    def activate(self, actor: str, now: float) -> None:
        entry = self._require(actor)
        definition = self._defs[actor]
        if entry.acb.status is not ActorStatus.SLEEPING:
            apply(entry.acb, Operation.ACTIVATE, now)  # raises the clear error
        grant = self._arbiter.acquire(actor, definition.priority, definition.resources)
        for victim in grant.preempted:
            self._suspend(victim, now)
        apply(entry.acb, Operation.ACTIVATE, now)
        entry.next_step = now
        for pdef, plugin, params in entry.plugins:
            if not self._call(entry, pdef, plugin, "_drive_activate", now, params):
                return

    def switch(self, old: str, new: str, now: float, context: ActorContext) -> None:
        """Pause ``old`` (state kept, hardware freed) and start or re-activate ``new``.

        The switch is timed until ``new`` ends its first step (:class:`SwitchTiming`); a
        switch whose new actor never steps (it failed, or was paused or stopped first)
        leaves no timing."""
        began = time.perf_counter()
        entry = self._loaded.get(old)
        if entry is not None and entry.acb.status is ActorStatus.RUNNING:
            self.pause(old, now)
            entry.acb.stats.switch_count += 1
        self.start(new, now, context)
        self._loaded[new].acb.stats.switch_count += 1
        if self._loaded[new].acb.status is ActorStatus.RUNNING:
            self._switching[new] = (old, now, began)

    def drain_switches(self) -> list[SwitchTiming]:
        """The switch timings recorded since the last drain, oldest first (at most
        :data:`SWITCH_TIMINGS_KEPT`: older ones were dropped)."""
        out = list(self.switch_timings)
        self.switch_timings.clear()
        return out

    def drain_switch_times(self) -> list[float]:
        """:meth:`drain_switches`, the seconds only."""
        return [s.seconds for s in self.drain_switches()]

    def step(self, now: float) -> list[Emitted]:
        """Step every running actor that is due; return what the plugins emitted."""
        out: list[Emitted] = []
        window = self.step_window
        for name, entry in list(self._loaded.items()):
            if entry.acb.status is not ActorStatus.RUNNING:
                continue
            if now < min(self._due(entry), entry.next_step - window):
                continue
            emitted: list[Emitted] = []
            timings: dict[str, float] = {}
            ok = True
            for pdef, plugin, params in self._ooda(entry):
                began = time.perf_counter()
                ok = self._call(entry, pdef, plugin, "_drive_step", now, params, out=emitted)
                timings[pdef.name] = time.perf_counter() - began
                if not ok:
                    break
            pending = self._switching.pop(name, None)
            if ok:
                entry.acb.record_step(timings)
                entry.next_step = self._next_step(entry.next_step, now)
                if pending is not None:
                    src, at, began = pending
                    self.switch_timings.append(
                        SwitchTiming(at, src, name, time.perf_counter() - began)
                    )
            out.extend(e if e.actor else dataclasses.replace(e, actor=name) for e in emitted)
        return out

    @property
    def step_window(self) -> float:
        """How early a step may run on a wake the host makes anyway: two slacks (the module
        docstring)."""
        return 2 * self.step_slack

    def _next_step(self, due: float, now: float) -> float:
        """When the actor whose step was due at ``due`` and ran at ``now`` steps next."""
        slack = self.step_slack
        if not slack:
            return now + self.period
        if due - self.step_window <= now < due:
            return due + self.period  # rode on a wake made anyway: keep the phase
        if now < due:
            return now + self.period  # a plugin's own deadline, well before the schedule
        # On time or late, at a wake of its own (or late for any reason): drift later,
        # towards the wakes the host makes anyway.
        return now + self.period + slack / 2

    @staticmethod
    def _ooda(entry: _Loaded) -> list[tuple[_PluginDef, Plugin, dict[str, Any]]]:
        """The actor's plugins in step order: observe, orient, decide, act (each bus in the
        order the script lists its plugins). Sorted once per loaded actor (an actor's
        plugins never change once loaded), not at every step."""
        ooda = entry.ooda
        if ooda is None:
            order = _BUS_ORDER
            ooda = entry.ooda = sorted(
                entry.plugins, key=lambda item: order.get(item[0].bus, len(order))
            )
        return ooda

    def next_deadline(self) -> float | None:
        """The latest time :meth:`step` must be called next (a running actor's step is
        due, or one of its plugins asked to be woken); None with no actor running."""
        times = [self._due(e) for e in self._loaded.values() if e.acb.status is ActorStatus.RUNNING]
        return min(times) if times else None

    # --- backup ---------------------------------------------------------------------------

    def snapshot(self) -> bytes:
        """Every loaded actor: its status, context and plugin states (msgpack)."""
        state = {
            name: {
                "status": e.acb.status.value,
                "params": dict(e.acb.context.params),
                "index": e.acb.context.index,
                "size": e.acb.context.size,
                "slot": e.acb.context.slot,
                "slots": e.acb.context.slots,
                "plugins": [
                    plugin._drive_snapshot() if plugin.lifecycle in ("running", "sleeping") else {}
                    for _, plugin, _ in e.plugins
                ],
            }
            for name, e in self._loaded.items()
            if e.acb.status in (ActorStatus.RUNNING, ActorStatus.SLEEPING)
        }
        return msgspec.msgpack.encode(state)

    def restore(self, data: bytes, now: float) -> list[str]:
        """Load the actors of a :meth:`snapshot` (restored sleeping, then the running ones
        activated); returns the actors brought back running."""
        state: Mapping[str, Any] = msgspec.msgpack.decode(data)
        resumed = []
        for name, saved in state.items():
            definition = self._defs.get(name)
            if definition is None or name in self._loaded:
                continue
            acb = self._new_acb(definition)
            instances = []
            for pdef, snap in zip(definition.plugins, saved["plugins"], strict=False):
                params = pdef.cls.bind_params(pdef.params, saved["params"])
                plugin = pdef.cls()
                plugin._drive_restore(snap)
                instances.append((pdef, plugin, params))
            acb.context = TaskContext(
                params=dict(saved["params"]),
                index=saved["index"],
                # Backups written before these keys existed restore without them.
                size=int(saved.get("size", 0)),
                slot=int(saved.get("slot", 0)),
                slots=int(saved.get("slots", 0)),
            )
            self._loaded[name] = _Loaded(acb=acb, plugins=instances)
            # Restored plugins sleep: bring the ACB to the same state, then activate.
            apply(acb, Operation.START, now)
            apply(acb, Operation.PAUSE, now)
            if saved["status"] == ActorStatus.RUNNING.value:
                self.activate(name, now)
                resumed.append(name)
        return resumed

    # --- internals ------------------------------------------------------------------------

    def _new_acb(self, definition: _ActorDef) -> ACB:
        return ACB(
            name=definition.name,
            actor_id=definition.actor_id,
            priority=definition.priority,
            software=tuple((p.bus, p.name) for p in definition.plugins),
            hardware=definition.resources,
        )

    def _require(self, actor: str) -> _Loaded:
        entry = self._loaded.get(actor)
        if entry is None:
            raise ValueError(
                f"actor {actor!r} is not loaded on platform {self.platform} "
                f"(loaded: {', '.join(self._loaded) or 'none'})"
            )
        return entry

    def _due(self, entry: _Loaded) -> float:
        due = entry.next_step
        for _, plugin, _ in entry.plugins:
            wake = plugin._drive_next_deadline()
            if wake is not None and wake < due:
                due = wake
        return due

    def deliver(self, answer: dict[str, Any]) -> None:
        """An answer of the collective (see :mod:`.collective`) for the plugins: appended to
        the ``"collective"`` list of every running actor's blackboard."""
        for entry in self._loaded.values():
            if entry.acb.status is ActorStatus.RUNNING:
                entry.blackboard.setdefault("collective", []).append(answer)

    def status(self, now: float | None = None) -> dict[str, Any]:
        """Every loaded actor's control block, JSON-ready (for the status command)."""
        return {name: e.acb.to_status(now) for name, e in self._loaded.items()}

    def _context(self, entry: _Loaded, params: dict[str, Any], now: float) -> PluginContext:
        self.now = now
        return PluginContext(
            now=now,
            platform=self.platform,
            actor=entry.acb.name,
            params=params,
            blackboard=entry.blackboard,
            vehicle=self.vehicle,
            collective=self.collective,
            rng=self._rng,
            index=entry.acb.context.index,
            data=entry.acb.context.data,
            size=entry.acb.context.size,
            slot=entry.acb.context.slot,
            slots=entry.acb.context.slots,
            camera=self.camera,
            areas=self.areas,
            ros2=self.ros2,
            task_start=self.task_start,
        )

    def _call(
        self,
        entry: _Loaded,
        pdef: _PluginDef,
        plugin: Plugin,
        driver: str,
        now: float,
        params: dict[str, Any],
        *,
        out: list[Emitted] | None = None,
        fail: bool = True,
    ) -> bool:
        """Run one lifecycle driver; a plugin that raises puts its actor in error."""
        ctx = self._context(entry, params, now)
        try:
            getattr(plugin, driver)(ctx)
        except Exception as exc:  # a plugin's bug must not take the platform down
            message = f"plugin {pdef.name!r} raised {type(exc).__name__}: {exc}"
            self.failures.append(PluginFailure(now, entry.acb.name, pdef.name, message))
            if fail and entry.acb.status in (ActorStatus.RUNNING, ActorStatus.SLEEPING):
                apply(entry.acb, Operation.FAIL, now, error=message)
                self._release(entry.acb.name, now)
            return False
        if out is not None:
            out.extend(ctx.drain())
        return True

    def _suspend(self, actor: str, now: float) -> None:
        """Pause an actor whose hardware a higher priority took (the arbiter resumes it)."""
        entry = self._loaded.get(actor)
        if entry is None or entry.acb.status is not ActorStatus.RUNNING:
            return
        apply(entry.acb, Operation.PAUSE, now)
        self._switching.pop(actor, None)
        for pdef, plugin, params in entry.plugins:
            self._call(entry, pdef, plugin, "_drive_pause", now, params)

    def _release(self, actor: str, now: float) -> None:
        for resumed in self._arbiter.release(actor):
            entry = self._loaded.get(resumed)
            if entry is None or entry.acb.status is not ActorStatus.SLEEPING:
                continue
            apply(entry.acb, Operation.ACTIVATE, now)
            entry.next_step = now
            for pdef, plugin, params in entry.plugins:
                self._call(entry, pdef, plugin, "_drive_activate", now, params)
