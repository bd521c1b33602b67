"""Test doubles and a conformance kit for plugin authors.

Theory of operation
-------------------
A plugin is tested like any other code, without a swarm, a world or a clock:

* :func:`make_context` builds the :class:`~actorswarm.runtime.context.PluginContext` a
  hook receives — params validated as the runtime would, a :class:`FakeVehicle` if you pass
  one, a seeded ``rng`` — and you call the hooks and read ``ctx.emitted`` and
  ``vehicle.commands``. :func:`run_plugin` starts a plugin and steps it through time.
* :func:`check_plugin` is the conformance kit. Run it on your plugin class in your own test
  suite (``check_plugin(MyPlugin, params={"speed": "3"})``); it drives the plugin through
  its whole lifecycle and raises :class:`AssertionError` with a readable message on the
  first broken promise:

  1. the class declarations are well formed (bus, resources, params, defaults that read
     back), and the driver methods are the framework's;
  2. the params validate, and every declared key reaches ``ctx.params``;
  3. the lifecycle runs start → step* → pause → activate → step* → snapshot → stop without
     error, and every out-of-order call (a step before the start, an activate while
     running, anything after the stop) is refused with
     :class:`~actorswarm.runtime.plugin.LifecycleError`, changing nothing;
  4. the snapshot is plain data that survives JSON, is not an alias of live state, and a
     fresh instance restored from it snapshots the same and runs on;
  5. no hook reads the wall clock, sleeps, or draws from the global ``random``;
  6. every emitted event is well formed (a valid name, scope, bid, msgpack-able data);
  7. two identical runs give identical events, commands and snapshots (determinism).

How the clock is watched: while a hook runs, a profile hook (:func:`sys.setprofile`)
sees every call into C, and flags calls to the clock functions of :mod:`time`
(``time``, ``monotonic``, ``perf_counter``, their ``_ns`` forms, ``process_time``,
``sleep``) and to ``datetime.now``/``utcnow``/``today``, and calls on the global
``random`` instance. Unlike patching module attributes this catches ``from time import
monotonic`` and ``datetime.datetime.now`` (a C type that cannot be patched) alike. Calls made
by :mod:`logging` (which stamps its records) are allowed. A profiler already installed, and
the cyclic garbage collector (whose callbacks may time themselves), are suspended while a
hook runs and put back after.
"""

from __future__ import annotations

import copy
import gc
import inspect
import json
import math
import random
import re
import sys
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from types import FrameType, ModuleType
from typing import Any, Final

import msgspec

from actorswarm.runtime.context import Camera, Collective, Detection, PluginContext, Vehicle
from actorswarm.runtime.events import Emitted
from actorswarm.runtime.plugin import (
    Lifecycle,
    LifecycleError,
    LifecycleOp,
    ParamError,
    Plugin,
)

__all__ = ["FakeCamera", "FakeVehicle", "check_plugin", "make_context", "run_plugin"]

_EVENT_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_.\-]*")

Point = tuple[float, float, float]


class FakeVehicle:
    """A :class:`~actorswarm.runtime.context.Vehicle` for tests: it records every command in
    :attr:`commands` and moves in straight lines when the test calls :meth:`advance`.

    Kinematics are deliberately simple: the vehicle flies straight at its goal at the
    commanded speed (``cruise_speed`` when none), climbs and descends at ``climb_rate``
    for ``takeoff``/``land``, stops dead on ``hold``, and drains ``drain_per_second`` of
    battery while airborne. Commands check their arguments, so a plugin that sends a NaN or
    a negative speed fails its test.
    """

    def __init__(
        self,
        *,
        position: Point = (0.0, 0.0, 0.0),
        battery: float = 1.0,
        cruise_speed: float = 5.0,
        climb_rate: float = 2.0,
        drain_per_second: float = 0.0,
    ) -> None:
        #: Every command, oldest first: ``("goto", x, y, z, speed)``, ``("hold",)``,
        #: ``("land",)``, ``("takeoff", altitude)``.
        self.commands: list[tuple[Any, ...]] = []
        self._position = _point(position, "position")
        self._velocity: Point = (0.0, 0.0, 0.0)
        self._battery = float(battery)
        self.cruise_speed = cruise_speed
        self.climb_rate = climb_rate
        self.drain_per_second = drain_per_second
        self._goal: Point | None = None
        self._speed = cruise_speed
        #: ``landed``, ``holding``, ``goto``, ``takeoff`` or ``landing``.
        self.mode = "landed" if self._position[2] <= 0 else "holding"

    # --- the Vehicle interface ---------------------------------------------------------------

    def position(self) -> tuple[float, float, float]:
        return self._position

    def velocity(self) -> tuple[float, float, float]:
        return self._velocity

    def battery(self) -> float:
        return self._battery

    def goto(self, x: float, y: float, z: float, *, speed: float | None = None) -> None:
        goal = _point((x, y, z), "goto")
        if speed is not None and not (_finite(speed) and speed > 0):
            raise ValueError(f"goto: speed must be a positive number (m/s) or None, not {speed!r}")
        self.commands.append(("goto", goal[0], goal[1], goal[2], speed))
        self._goal, self._speed, self.mode = goal, speed or self.cruise_speed, "goto"

    def hold(self) -> None:
        self.commands.append(("hold",))
        self._goal, self._velocity = None, (0.0, 0.0, 0.0)
        self.mode = "landed" if self._position[2] <= 0 else "holding"

    def land(self) -> None:
        self.commands.append(("land",))
        x, y, _ = self._position
        self._goal, self._speed, self.mode = (x, y, 0.0), self.climb_rate, "landing"

    def takeoff(self, altitude: float) -> None:
        if not (_finite(altitude) and altitude > 0):
            raise ValueError(f"takeoff: altitude must be positive (metres), not {altitude!r}")
        self.commands.append(("takeoff", float(altitude)))
        x, y, _ = self._position
        self._goal, self._speed, self.mode = (x, y, float(altitude)), self.climb_rate, "takeoff"

    # --- for the test ------------------------------------------------------------------------

    @property
    def goal(self) -> Point | None:
        """Where the vehicle is heading (None: holding or landed)."""
        return self._goal

    def advance(self, dt: float) -> None:
        """Let ``dt`` seconds pass: move toward the goal, drain the battery."""
        if not (_finite(dt) and dt >= 0):
            raise ValueError(f"advance: dt must be a number of seconds ≥ 0, not {dt!r}")
        if self.mode != "landed":
            self._battery = max(0.0, self._battery - self.drain_per_second * dt)
        if self._goal is None or dt == 0:
            self._velocity = (0.0, 0.0, 0.0)
            return
        delta = tuple(g - p for g, p in zip(self._goal, self._position, strict=True))
        distance = math.sqrt(sum(d * d for d in delta))
        reach = self._speed * dt
        if distance <= reach:
            self._velocity = (delta[0] / dt, delta[1] / dt, delta[2] / dt)
            self._position, self._goal = self._goal, None
            self.mode = "landed" if self.mode == "landing" else "holding"
        else:
            f = reach / distance
            self._velocity = (delta[0] * f / dt, delta[1] * f / dt, delta[2] * f / dt)
            x, y, z = self._position
            self._position = (x + delta[0] * f, y + delta[1] * f, z + delta[2] * f)


def _finite(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _point(value: tuple[float, float, float], what: str) -> Point:
    if len(value) != 3 or not all(_finite(v) for v in value):
        raise ValueError(f"{what}: a point is three finite numbers (x, y, z), not {value!r}")
    return (float(value[0]), float(value[1]), float(value[2]))


class FakeCamera:
    """A :class:`~actorswarm.runtime.context.Camera` for tests: it sees the ``targets``
    (name → ``(x, y, z)``, or name → ``(kind, (x, y, z))``) from ``vehicle``'s position with
    the simulated world's geometry (:func:`actorswarm.world.sensors.detect`;
    ``field_of_view`` degrees, ``max_range`` and ``min_altitude`` metres). Move a target by
    assigning ``camera.targets[name]``."""

    def __init__(
        self,
        vehicle: Vehicle,
        targets: Mapping[str, Any] | None = None,
        *,
        field_of_view: float = 90.0,
        max_range: float = 200.0,
        min_altitude: float = 2.0,
    ) -> None:
        from actorswarm.world.config import CameraConfig

        self.vehicle = vehicle
        self.targets: dict[str, Any] = dict(targets or {})
        self.config = CameraConfig(
            field_of_view=field_of_view, max_range=max_range, min_altitude=min_altitude
        )

    def _targets(self) -> Iterator[tuple[str, str, Point]]:
        for name, value in self.targets.items():
            kind, where = value if isinstance(value[0], str) else ("target", value)
            yield name, kind, _point(where, f"FakeCamera target {name!r}")

    def detections(self) -> list[Detection]:
        from actorswarm.world.sensors import detect

        return detect(self.vehicle.position(), self._targets(), self.config)

    def footprint(self) -> float:
        from actorswarm.world.sensors import footprint_radius

        return footprint_radius(self.vehicle.position()[2], self.config)


def make_context(
    plugin: type[Plugin] | None = None,
    *,
    params: Mapping[str, Any] | None = None,
    transition_params: Mapping[str, str] | None = None,
    now: float = 0.0,
    platform: int = 1,
    actor: str = "test",
    vehicle: Vehicle | None = None,
    blackboard: dict[str, Any] | None = None,
    collective: Collective | None = None,
    seed: int | None = None,
    index: int = 0,
    data: Any = None,
    size: int = 0,
    slot: int = 0,
    slots: int = 0,
    camera: Camera | None = None,
    areas: Mapping[str, Sequence[tuple[float, float]]] | None = None,
    ros2: Any = None,
    task_start: float | None = None,
) -> PluginContext:
    """A :class:`PluginContext` for a plugin unit test.

    With ``plugin``, ``params`` are the script's texts (``{"after": "2"}``) and
    ``transition_params`` the switching transition's, validated and merged exactly as the
    runtime does (:meth:`Plugin.bind_params`; a bad value raises
    :class:`~actorswarm.runtime.plugin.ParamError`). Without it, ``params`` are used as
    given. ``seed`` seeds ``ctx.rng`` (default: the platform ID). The collective defaults to
    one that refuses every call; pass your own to test a coordinating plugin. ``index`` and
    ``size`` place the actor in the group that switched it in, ``slot`` and ``slots`` in its
    branch (give ``slot``/``slots`` 0 to copy ``index``/``size``, as a transition without
    branches does); ``camera`` (a :class:`FakeCamera`) and ``areas`` are what a
    detection or search plugin sees; ``ros2`` what a ROS 2 plugin's ``ctx.ros2`` is;
    ``task_start`` when the task started (``ctx.task_start``).
    """
    if slot == 0 and slots == 0:
        slot, slots = index, size
    if plugin is not None:
        values: Mapping[str, Any] = plugin.bind_params(dict(params or {}), transition_params)
    else:
        values = dict(params or {})
    return PluginContext(
        now=now,
        platform=platform,
        actor=actor,
        params=values,
        blackboard=blackboard,
        vehicle=vehicle,
        collective=collective,
        rng=random.Random(platform if seed is None else seed),
        index=index,
        data=data,
        size=size,
        slot=slot,
        slots=slots,
        camera=camera,
        areas=areas,
        ros2=ros2,
        task_start=task_start,
    )


def drive(
    plugin: Plugin, op: LifecycleOp, ctx: PluginContext, state: Mapping[str, Any] | None = None
) -> object:
    """Call the framework's driver for lifecycle operation ``op`` (as the runtime would);
    ``state`` is what ``restore`` gets (default: an empty snapshot)."""
    calls: dict[LifecycleOp, Callable[[], object]] = {
        "start": lambda: plugin._drive_start(ctx),
        "step": lambda: plugin._drive_step(ctx),
        "pause": lambda: plugin._drive_pause(ctx),
        "activate": lambda: plugin._drive_activate(ctx),
        "stop": lambda: plugin._drive_stop(ctx),
        "snapshot": plugin._drive_snapshot,
        "restore": lambda: plugin._drive_restore(state or {}),
    }
    return calls[op]()


def run_plugin(plugin: Plugin, ctx: PluginContext, *, steps: int, dt: float = 0.1) -> list[Emitted]:
    """Start ``plugin`` (unless it already runs), then step it ``steps`` times, ``dt``
    seconds apart: ``ctx.now`` moves on and a :class:`FakeVehicle` in ``ctx.vehicle`` is
    advanced before each step. Returns the events emitted, oldest first."""
    out: list[Emitted] = []
    if plugin.lifecycle == "new":
        plugin._drive_start(ctx)
        out.extend(ctx.drain())
    for _ in range(steps):
        ctx.now += dt
        if isinstance(ctx.vehicle, FakeVehicle):
            ctx.vehicle.advance(dt)
        plugin._drive_step(ctx)
        out.extend(ctx.drain())
    return out


# --- the conformance kit ---------------------------------------------------------------------

_TIME_FUNCS: Final = frozenset(
    {
        "time",
        "time_ns",
        "monotonic",
        "monotonic_ns",
        "perf_counter",
        "perf_counter_ns",
        "process_time",
        "process_time_ns",
        "thread_time",
        "thread_time_ns",
        "sleep",
    }
)
_DATETIME_FUNCS: Final = frozenset({"now", "utcnow", "today"})
_ALLOWED_CALLERS: Final = ("logging",)
_PASS_THROUGH: Final = frozenset({"random", "datetime", "time", "threading", "uuid"})


@dataclass(frozen=True, slots=True)
class _Violation:
    call: str
    where: str


class _Guard:
    """Watches hooks for clock reads, sleeps and global randomness (see the module doc)."""

    def __init__(self) -> None:
        self.violations: list[_Violation] = []
        self._global_random: object = getattr(random, "_inst", None)

    def _classify(self, fn: object) -> str | None:
        owner = getattr(fn, "__self__", None)
        name = getattr(fn, "__name__", "")
        if isinstance(owner, ModuleType) and owner.__name__ == "time" and name in _TIME_FUNCS:
            return f"time.{name}()"
        if isinstance(owner, type) and owner.__module__ == "datetime" and name in _DATETIME_FUNCS:
            return f"datetime.{owner.__name__}.{name}()"
        if owner is not None and owner is self._global_random:
            return f"random.{name}() (the global random generator)"
        return None

    def _profile(self, frame: FrameType, event: str, arg: object) -> None:
        if event != "c_call":
            return
        call = self._classify(arg)
        if call is None:
            return
        module = str(frame.f_globals.get("__name__", ""))
        if module.split(".", maxsplit=1)[0] in _ALLOWED_CALLERS:
            return
        # Point at the caller's code, not at the stdlib helper it went through.
        spot: FrameType | None = frame
        while spot is not None and spot.f_globals.get("__name__") in _PASS_THROUGH:
            spot = spot.f_back
        spot = spot or frame
        where = f"{spot.f_code.co_filename}:{spot.f_lineno} in {spot.f_code.co_name}"
        self.violations.append(_Violation(call, where))

    @contextmanager
    def watching(self) -> Iterator[None]:
        # The cyclic collector is paused too: a collection could start inside a hook and run
        # other libraries' gc callbacks there (some time themselves), which are not the
        # plugin's doing.
        previous, collecting = sys.getprofile(), gc.isenabled()
        gc.disable()
        sys.setprofile(self._profile)
        try:
            yield
        finally:
            sys.setprofile(previous)
            if collecting:
                gc.enable()


class _Kit:
    """One run of :func:`check_plugin`: the plugin class and how to complain about it."""

    def __init__(
        self,
        cls: type[Plugin],
        values: dict[str, Any],
        steps: int,
        dt: float,
        *,
        camera_targets: Mapping[str, Any] | None = None,
    ):
        self.cls = cls
        self.camera_targets = camera_targets
        self.name = f"{cls.__module__}.{cls.__qualname__}"
        self.values = values
        self.steps = steps
        self.dt = dt
        self.guard = _Guard()

    def fail(self, message: str) -> AssertionError:
        return AssertionError(f"check_plugin({self.name}): {message}")

    def call(self, what: str, fn: Callable[[], Any], now: float | None = None) -> Any:
        """Run one driver call under the guard; turn its exception or a clock read into a
        readable failure."""
        when = f" (now={now:g})" if now is not None else ""
        try:
            with self.guard.watching():
                result = fn()
        except AssertionError:
            raise
        except Exception as exc:
            hint = (
                "; a restored instance resumes with on_activate, never on_start: whatever its "
                "step needs must come back through restore()"
                if what.startswith(("restored", "activate after restore"))
                else ""
            )
            raise self.fail(f"{what}{when} raised {type(exc).__name__}: {exc}{hint}") from exc
        if self.guard.violations:
            v = self.guard.violations[0]
            if v.call.startswith("random."):
                advice = "draw from ctx.rng instead, which the host seeds so that a run replays"
            elif v.call == "time.sleep()":
                advice = "a hook must never block; wait by checking ctx.now in later steps"
            else:
                advice = (
                    "take the time from ctx.now instead: the host sets it (virtual time in "
                    "the simulator), and a plugin that reads the clock breaks replay"
                )
            raise self.fail(f"{what}{when} called {v.call} at {v.where}; {advice}")
        return result

    def check_event(self, event: object, what: str, ctx: PluginContext) -> None:
        if not isinstance(event, Emitted):
            raise self.fail(f"{what} emitted {event!r}, which is not an Emitted event")
        problem = None
        if not isinstance(event.event, str) or not _EVENT_NAME.fullmatch(event.event):
            problem = f"the event name {event.event!r} is not a valid name"
        elif event.scope not in ("local", "swarm"):
            problem = f'scope {event.scope!r} is neither "local" nor "swarm"'
        elif event.bid is not None and not _finite(event.bid):
            problem = f"bid {event.bid!r} is not a finite number"
        elif event.actor != ctx.actor:
            problem = f"it names actor {event.actor!r}, not {ctx.actor!r}"
        else:
            try:
                msgspec.msgpack.encode(event.data)
            except (TypeError, ValueError, OverflowError) as exc:
                problem = f"its data {event.data!r:.80} cannot be sent ({exc})"
        if problem:
            raise self.fail(f"{what} emitted {event.event!r}: {problem}")

    def refused(self, what: str, plugin: Plugin, op: LifecycleOp, ctx: PluginContext) -> None:
        """``op`` must raise LifecycleError and leave the plugin where it was."""
        before: Lifecycle = plugin.lifecycle
        try:
            with self.guard.watching():
                drive(plugin, op, ctx)
        except LifecycleError:
            pass
        except Exception as exc:
            raise self.fail(
                f"{what}: {op} while {before} must be refused with LifecycleError by the "
                f"driver before any hook runs, but it raised {type(exc).__name__}: {exc} "
                "(is a _drive_ method replaced?)"
            ) from exc
        else:
            raise self.fail(
                f"{what}: {op} while {before} was accepted; the driver must refuse it with "
                "LifecycleError (is a _drive_ method replaced?)"
            )
        ctx.drain()
        if plugin.lifecycle != before:
            raise self.fail(
                f"{what}: a refused {op} moved the plugin from {before} to {plugin.lifecycle}"
            )

    def plain(self, what: str, state: object) -> dict[str, Any]:
        """``state`` as it comes back from a JSON backup; it must come back equal."""
        try:
            text = json.dumps(state, allow_nan=False)
        except (TypeError, ValueError) as exc:
            raise self.fail(
                f"{what} returned {state!r:.120}, which is not plain data ({exc}); use str "
                "keys and str, int, float, bool, None, lists and dicts"
            ) from exc
        back = json.loads(text)
        if back != state:
            raise self.fail(
                f"{what} returned {state!r:.120}, which comes back from JSON as {back!r:.120}; "
                "use lists, not tuples or sets, and str keys"
            )
        try:
            msgspec.msgpack.encode(state)
        except (TypeError, ValueError, OverflowError) as exc:
            raise self.fail(f"{what} returned state that msgpack cannot encode: {exc}") from exc
        assert isinstance(back, dict)
        return back

    def context(self, vehicle: FakeVehicle | None, now: float) -> PluginContext:
        camera = None
        if self.camera_targets is not None:
            # A plugin without a vehicle looks down from a fixed point 20 m over the origin.
            eye = vehicle if vehicle is not None else FakeVehicle(position=(0.0, 0.0, 20.0))
            camera = FakeCamera(eye, self.camera_targets)
        return PluginContext(
            now=now,
            platform=3,
            actor="conformance",
            params=dict(self.values),
            vehicle=vehicle,
            rng=random.Random(1234),
            camera=camera,
        )

    def new(self) -> Plugin:
        try:
            with self.guard.watching():
                plugin = self.cls()
        except Exception as exc:
            raise self.fail(
                f"building it with no arguments raised {type(exc).__name__}: {exc}; the "
                "runtime builds plugins as Cls() and passes everything else through the context"
            ) from exc
        if self.guard.violations:
            v = self.guard.violations[0]
            raise self.fail(f"__init__ called {v.call} at {v.where}; plugins never read the clock")
        return plugin

    def run(self) -> list[object]:
        """The whole lifecycle once; returns a trace of what the plugin did, to compare."""
        trace: list[object] = []
        vehicle = FakeVehicle() if self.cls.needs_vehicle else None
        t0, dt = 100.0, self.dt  # not 0: catches plugins that confuse absolute and relative time
        ctx = self.context(vehicle, t0)
        plugin = self.new()

        def record(what: str, fn: Callable[[], Any]) -> Any:
            ctx.drain()
            result = self.call(what, fn, ctx.now)
            events = ctx.drain()
            for event in events:
                self.check_event(event, what, ctx)
            trace.append((what, ctx.now, [(e.event, e.scope, e.bid, e.data) for e in events]))
            return result

        def step_n(count: int, label: str, p: Plugin) -> None:
            for i in range(count):
                ctx.now += dt
                if vehicle is not None:
                    vehicle.advance(dt)
                record(f"{label} step {i + 1} of {count}", lambda: p._drive_step(ctx))
                deadline = self.call(
                    f"next_deadline after {label} step {i + 1}", p._drive_next_deadline, ctx.now
                )
                if deadline is not None and not _finite(deadline) and deadline != math.inf:
                    raise self.fail(f"next_deadline() returned {deadline!r}; a time or None")
                trace.append(("deadline", deadline))

        record("start", lambda: plugin._drive_start(ctx))
        self.refused("after start", plugin, "start", ctx)
        self.refused("after start", plugin, "activate", ctx)
        self.refused("after start", plugin, "restore", ctx)
        first = self.steps // 2
        step_n(first, "first", plugin)
        record("pause", lambda: plugin._drive_pause(ctx))
        paused_ops: tuple[LifecycleOp, ...] = ("step", "pause", "start")
        for op in paused_ops:
            self.refused("while paused", plugin, op, ctx)
        paused = record("snapshot while paused", plugin._drive_snapshot)
        sleeping = self.plain("snapshot() while paused", paused)
        trace.append(("snapshot while paused", sleeping))
        ctx.now += dt * max(3, self.steps // 10)  # time passes while paused
        record("activate", lambda: plugin._drive_activate(ctx))
        step_n(self.steps - first, "second", plugin)

        snap = record("snapshot", plugin._drive_snapshot)
        saved = self.plain("snapshot()", snap)
        kept = copy.deepcopy(snap)
        trace.append(("snapshot", saved))
        step_n(1, "after-snapshot", plugin)
        if snap != kept:
            raise self.fail(
                f"the dict snapshot() returned changed when the plugin stepped on (from "
                f"{kept!r:.100} to {snap!r:.100}); return a new dict, not live state"
            )
        record("stop", lambda: plugin._drive_stop(ctx))
        stopped_ops: tuple[LifecycleOp, ...] = ("step", "stop", "activate", "start", "snapshot")
        for op in stopped_ops:
            self.refused("after stop", plugin, op, ctx)

        fresh = self.new()
        record("restore", lambda: fresh._drive_restore(copy.deepcopy(saved)))
        restored = record("snapshot after restore", fresh._drive_snapshot)
        again = self.plain("snapshot() after restore", restored)
        if again != saved:
            raise self.fail(
                f"a fresh instance restored from the snapshot {saved!r:.120} snapshots "
                f"{again!r:.120}; restore() must rebuild everything snapshot() saves"
            )
        self.refused("after restore", fresh, "start", ctx)
        record("activate after restore", lambda: fresh._drive_activate(ctx))
        step_n(min(5, self.steps), "restored", fresh)
        record("stop after restore", lambda: fresh._drive_stop(ctx))
        if vehicle is not None:
            trace.append(("vehicle", list(vehicle.commands)))
        return trace


def check_plugin(
    plugin_cls: type[Plugin],
    *,
    params: Mapping[str, str] | None = None,
    steps: int = 50,
    dt: float = 0.1,
    camera_targets: Mapping[str, Any] | None = None,
) -> None:
    """Check that ``plugin_cls`` keeps the plugin contract; raise :class:`AssertionError`
    saying what is broken and how to fix it. ``params`` are the texts a script would give
    (required params must be among them); ``steps`` steps of ``dt`` seconds are run, half
    before a pause and half after. With ``camera_targets`` (what :class:`FakeCamera` takes)
    the contexts get a camera: on the kit's vehicle, or for a plugin that needs none, 20 m
    over the origin. See the module documentation for what is checked."""
    if not (isinstance(steps, int) and steps >= 2) or not (_finite(dt) and dt > 0):
        raise ValueError(
            f"check_plugin: steps must be an integer ≥ 2 and dt > 0, not {steps!r}, {dt!r}"
        )
    name = getattr(plugin_cls, "__qualname__", repr(plugin_cls))
    if not inspect.isclass(plugin_cls) or not issubclass(plugin_cls, Plugin):
        raise AssertionError(
            f"check_plugin({name}): not a class derived from actorswarm.runtime.plugin.Plugin"
        )
    label = f"check_plugin({plugin_cls.__module__}.{plugin_cls.__qualname__})"
    if inspect.isabstract(plugin_cls):
        missing = ", ".join(sorted(plugin_cls.__abstractmethods__))
        raise AssertionError(f"{label}: the class is abstract; implement {missing}")
    problems = plugin_cls.declaration_problems()
    replaced = [
        attr
        for attr in vars(Plugin)
        if attr.startswith("_drive_")
        and inspect.getattr_static(plugin_cls, attr) is not inspect.getattr_static(Plugin, attr)
    ]
    problems += [f"{attr} is replaced; the driver methods are the framework's" for attr in replaced]
    for key, param in plugin_cls.params.items():
        if param.default is not None:
            text = param.format(param.default)
            try:
                back = param.parse(text)
            except ValueError as exc:
                problems.append(
                    f"param {key}: its default {param.default!r} does not read back ({exc})"
                )
                continue
            if back != param.default:
                problems.append(
                    f"param {key}: its default {param.default!r} reads back as {back!r}"
                )
    if problems:
        raise AssertionError(f"{label}: declarations: " + "; ".join(problems))

    try:
        values = plugin_cls.validate_params(params or {})
    except ParamError as exc:
        required = [k for k, p in plugin_cls.params.items() if p.required]
        hint = (
            f"; pass the required params to the kit, e.g. params={{{required[0]!r}: '...'}}"
            if required
            else ""
        )
        raise AssertionError(f"{label}: the params do not validate: {exc}{hint}") from exc
    if list(values) != list(plugin_cls.params):
        raise AssertionError(
            f"{label}: validate_params returned keys {list(values)}, not the declared "
            f"{list(plugin_cls.params)}"
        )

    kit = _Kit(plugin_cls, values, steps, dt, camera_targets=camera_targets)
    fresh = kit.new()
    ctx = kit.context(FakeVehicle() if plugin_cls.needs_vehicle else None, 0.0)
    new_ops: tuple[LifecycleOp, ...] = ("step", "pause", "activate", "stop", "snapshot")
    for op in new_ops:
        kit.refused("before start", fresh, op, ctx)

    first = kit.run()
    second = _Kit(plugin_cls, values, steps, dt, camera_targets=camera_targets).run()
    if first != second:
        diff = next(
            (i for i, (a, b) in enumerate(zip(first, second, strict=False)) if a != b),
            min(len(first), len(second)),
        )
        a = first[diff] if diff < len(first) else "(nothing)"
        b = second[diff] if diff < len(second) else "(nothing)"
        raise AssertionError(
            f"{label}: two identical runs differ at {a!r:.160} vs {b!r:.160}; the plugin "
            "depends on something besides its context (the clock, global random, object ids, "
            "set order)"
        )
