"""The conformance kit: it passes the built-ins and a well-behaved vehicle plugin, and fails
deliberately broken plugins with messages that say what to fix."""

from __future__ import annotations

import datetime
import gc
import itertools
import logging
import random
import sys
import time
from collections.abc import Mapping
from time import monotonic
from types import FrameType
from typing import Any, ClassVar

import pytest

from actorswarm.runtime.builtin import EmitAfter, Idle
from actorswarm.runtime.context import PluginContext
from actorswarm.runtime.plugin import Param, Plugin
from actorswarm.testing import FakeVehicle, check_plugin, make_context, run_plugin

log = logging.getLogger(__name__)


def fails(plugin: type[Any], *fragments: str, **kwargs: Any) -> str:
    """Run the kit on ``plugin``; it must fail, naming the plugin and every fragment."""
    with pytest.raises(AssertionError) as info:
        check_plugin(plugin, **kwargs)
    message = str(info.value)
    assert message.startswith("check_plugin("), message
    for fragment in fragments:
        assert fragment in message, message
    return message


# --- plugins that keep the contract --------------------------------------------------------------


def test_the_builtins_pass() -> None:
    check_plugin(Idle)
    check_plugin(EmitAfter, params={"event": "go"})
    check_plugin(
        EmitAfter,
        params={"event": "go", "after": "1.5", "spread_per_platform": "0.5", "scope": "swarm"},
        steps=200,
        dt=0.05,
    )


class Patrol(Plugin):
    """Flies between two waypoints; a plugin that needs a vehicle."""

    bus = "act_bus"
    resources = frozenset({"autopilot"})
    needs_vehicle = True
    params: ClassVar[Mapping[str, Param]] = {
        "a": Param(kind="point", default=(0.0, 0.0, 10.0), doc="first waypoint"),
        "b": Param(kind="point", default=(2.0, 0.0, 10.0), doc="second waypoint"),
        "jitter": Param(kind="float", default=0.1, minimum=0.0, doc="random offset, m"),
    }

    def __init__(self) -> None:
        self.leg = 0

    def on_start(self, ctx: PluginContext) -> None:
        self._go(ctx)

    def step(self, ctx: PluginContext) -> None:
        vehicle = ctx.require_vehicle()
        if vehicle.position() == self._target(ctx):
            self.leg += 1
            ctx.emit("leg_done", data={"leg": self.leg})
            self._go(ctx)

    def on_pause(self, ctx: PluginContext) -> None:
        ctx.require_vehicle().hold()

    def on_activate(self, ctx: PluginContext) -> None:
        self._go(ctx)

    def snapshot(self) -> dict[str, Any]:
        return {"leg": self.leg}

    def restore(self, state: Mapping[str, Any]) -> None:
        self.leg = int(state["leg"])

    def _target(self, ctx: PluginContext) -> tuple[float, float, float]:
        point: tuple[float, float, float] = ctx.params["b" if self.leg % 2 else "a"]
        return point

    def _go(self, ctx: PluginContext) -> None:
        x, y, z = self._target(ctx)
        ctx.blackboard["jitter"] = ctx.rng.uniform(0, ctx.params["jitter"])
        ctx.require_vehicle().goto(x, y, z, speed=5.0)


def test_a_vehicle_plugin_passes_and_can_be_unit_tested() -> None:
    check_plugin(Patrol)
    vehicle = FakeVehicle(position=(0.0, 0.0, 10.0))
    ctx = make_context(Patrol, params={"b": "1 0 10"}, vehicle=vehicle)
    events = run_plugin(Patrol(), ctx, steps=10, dt=0.1)
    assert [e.event for e in events][:2] == ["leg_done", "leg_done"]
    assert vehicle.commands[0] == ("goto", 0.0, 0.0, 10.0, 5.0)


def test_logging_is_not_reading_the_clock() -> None:
    class Chatty(Plugin):
        def step(self, ctx: PluginContext) -> None:
            log.debug("step at %s", ctx.now)

    check_plugin(Chatty)


class NeedsStart(Plugin):
    """Its step crashes (AttributeError) if it ever runs before on_start."""

    def on_start(self, ctx: PluginContext) -> None:
        self.origin = ctx.now

    def step(self, ctx: PluginContext) -> None:
        ctx.blackboard["age"] = ctx.now - self.origin

    def snapshot(self) -> dict[str, Any]:
        return {"origin": self.origin}

    def restore(self, state: Mapping[str, Any]) -> None:
        self.origin = float(state["origin"])


def test_a_plugin_that_would_crash_before_start_is_protected_by_the_driver() -> None:
    check_plugin(NeedsStart)


def test_state_set_in_on_start_must_come_back_through_restore() -> None:
    class StartOnly(NeedsStart):
        def snapshot(self) -> dict[str, Any]:
            return {}

        def restore(self, state: Mapping[str, Any]) -> None:
            pass

    fails(
        StartOnly,
        "restored step 1 of 5 (now=",
        "raised AttributeError",
        "a restored instance resumes with on_activate, never on_start",
    )


def test_the_kit_puts_back_an_installed_profiler() -> None:
    def profiler(frame: FrameType, event: str, arg: object) -> None:
        return None

    previous = sys.getprofile()
    sys.setprofile(profiler)
    try:
        check_plugin(Idle)
        assert sys.getprofile() is profiler
    finally:
        sys.setprofile(previous)


def test_other_libraries_gc_callbacks_are_not_blamed() -> None:
    def timed_gc(phase: str, info: dict[str, int]) -> None:
        time.perf_counter()  # as some test libraries do

    class Cyclic(Plugin):
        def step(self, ctx: PluginContext) -> None:
            for _ in range(2000):  # enough garbage cycles to start a collection
                loop: list[object] = []
                loop.append(loop)

    gc.callbacks.append(timed_gc)
    try:
        check_plugin(Cyclic, steps=4)
    finally:
        gc.callbacks.remove(timed_gc)


# --- plugins that break it -----------------------------------------------------------------------


def test_reading_the_clock_fails() -> None:
    class WallClock(Plugin):
        def step(self, ctx: PluginContext) -> None:
            self.t = time.time()

    message = fails(
        WallClock,
        "test_conformance.test_reading_the_clock_fails.<locals>.WallClock)",
        "first step 1 of 25 (now=100.1) called time.time()",
        "test_conformance.py:",
        "in step; take the time from ctx.now instead",
    )
    assert "breaks replay" in message


@pytest.mark.parametrize(
    ("hook", "reader", "call", "phase"),
    [
        # monotonic was bound at import: patching time.monotonic would not see this call.
        ("on_start", monotonic, "time.monotonic()", "start (now=100)"),
        ("step", time.perf_counter, "time.perf_counter()", "first step 1 of 25"),
        ("on_pause", time.time_ns, "time.time_ns()", "pause (now="),
        ("on_activate", datetime.datetime.now, "datetime.datetime.now()", "activate (now="),
        ("on_stop", datetime.date.today, "datetime.date.today()", "stop (now="),
        ("snapshot", time.monotonic_ns, "time.monotonic_ns()", "snapshot while paused"),
    ],
)
def test_every_clock_in_every_hook_is_caught(hook: str, reader: Any, call: str, phase: str) -> None:
    def read(self: Plugin, *args: Any) -> Any:
        reader()
        return {} if hook == "snapshot" else None

    plugin = type("Reader", (Plugin,), {"step": lambda self, ctx: None, hook: read})
    fails(plugin, f"): {phase}", f"called {call} at {__file__}:")


def test_reading_the_clock_in_init_fails() -> None:
    class Stamped(Plugin):
        def __init__(self) -> None:
            self.born = time.monotonic()

        def step(self, ctx: PluginContext) -> None:
            pass

    fails(Stamped, "__init__ called time.monotonic()", "plugins never read the clock")


def test_sleeping_fails() -> None:
    class Sleepy(Plugin):
        def step(self, ctx: PluginContext) -> None:
            time.sleep(0)

    fails(Sleepy, "called time.sleep()", "a hook must never block")


def test_global_randomness_fails() -> None:
    class Dice(Plugin):
        def step(self, ctx: PluginContext) -> None:
            ctx.blackboard["roll"] = random.randint(1, 6)

    fails(Dice, "(the global random generator)", "test_conformance.py:", "draw from ctx.rng")


def test_a_snapshot_that_does_not_restore_fails() -> None:
    class Forgetful(Plugin):
        def __init__(self) -> None:
            self.count = 0

        def step(self, ctx: PluginContext) -> None:
            self.count += 1

        def snapshot(self) -> dict[str, Any]:
            return {"count": self.count}

    fails(
        Forgetful,
        "a fresh instance restored from the snapshot {'count': 50} snapshots {'count': 0}",
        "restore() must rebuild everything snapshot() saves",
    )


def test_a_restore_that_raises_fails() -> None:
    class Picky(Plugin):
        def step(self, ctx: PluginContext) -> None:
            pass

        def snapshot(self) -> dict[str, Any]:
            return {"v": 1}

        def restore(self, state: Mapping[str, Any]) -> None:
            raise KeyError("version")

    fails(Picky, "restore (now=", "raised KeyError: 'version'")


def test_a_snapshot_of_live_state_fails() -> None:
    class Leaky(Plugin):
        def __init__(self) -> None:
            self.state = {"n": 0}

        def step(self, ctx: PluginContext) -> None:
            self.state["n"] += 1

        def snapshot(self) -> dict[str, Any]:
            return self.state

        def restore(self, state: Mapping[str, Any]) -> None:
            self.state = dict(state)

    fails(Leaky, "changed when the plugin stepped on", "return a new dict, not live state")


@pytest.mark.parametrize(
    ("state", "fragment"),
    [
        ({"at": (1.0, 2.0)}, "comes back from JSON as {'at': [1.0, 2.0]}"),
        ({"seen": {1, 2}}, "which is not plain data"),
        ({"v": float("nan")}, "which is not plain data"),
        ({1: "x"}, "must return a dict with str keys"),
    ],
)
def test_a_snapshot_that_is_not_plain_data_fails(state: dict[Any, Any], fragment: str) -> None:
    class Fancy(Plugin):
        def step(self, ctx: PluginContext) -> None:
            pass

        def snapshot(self) -> dict[str, Any]:
            return dict(state)

    fails(Fancy, fragment)


def test_nondeterminism_fails() -> None:
    # Hidden state outside the context: a process-wide counter. (Not ``id(self)``: the
    # second run's instance can land at the first one's freed address, and then the two
    # runs agree by chance.)
    starts = itertools.count()

    class ByCounter(Plugin):
        def on_start(self, ctx: PluginContext) -> None:
            ctx.emit("hello", bid=float(next(starts)))

        def step(self, ctx: PluginContext) -> None:
            pass

    fails(ByCounter, "two identical runs differ at ('start', 100.0", "besides its context")


def test_malformed_events_fail() -> None:
    class Unsendable(Plugin):
        def step(self, ctx: PluginContext) -> None:
            ctx.emit("found", data=object())

    fails(Unsendable, "first step 1 of 25 emitted 'found': its data", "cannot be sent")

    class Forged(Plugin):
        def step(self, ctx: PluginContext) -> None:
            ctx._emitted.append("found")  # type: ignore[arg-type]

    fails(Forged, "emitted 'found', which is not an Emitted event")


def test_a_hook_that_raises_fails_saying_where() -> None:
    class Divides(Plugin):
        def step(self, ctx: PluginContext) -> None:
            if ctx.now > 101.05:
                _ = 1 / 0

    fails(Divides, "first step 11 of 25 (now=101.1)", "raised ZeroDivisionError: division by zero")


def test_a_driver_replaced_on_the_class_fails() -> None:
    class Plain(Plugin):
        def step(self, ctx: PluginContext) -> None:
            pass

    # Replacing the driver after the class is defined gets past the definition-time check
    # (and a type checker flags it: the drivers are final); the kit still finds it.
    Plain._drive_step = lambda self, ctx: self.step(ctx)  # type: ignore[misc, method-assign]
    fails(Plain, "declarations: _drive_step is replaced")


def test_out_of_order_calls_that_get_through_fail() -> None:
    class Shadowed(Plugin):
        def __init__(self) -> None:
            # An instance attribute hides the driver from any look at the class: only
            # trying a step before the start shows that it is not refused.
            setattr(self, "_drive_step", self.step)  # noqa: B010

        def step(self, ctx: PluginContext) -> None:
            pass

    fails(
        Shadowed,
        "before start: step while new was accepted",
        "the driver must refuse it with LifecycleError",
    )


def test_required_params_must_be_given_to_the_kit() -> None:
    fails(
        EmitAfter,
        "the params do not validate: EmitAfter: needs the param event",
        "pass the required params to the kit, e.g. params={'event': '...'}",
    )
    fails(EmitAfter, "after must be ≥ 0, not '-2'", params={"event": "go", "after": "-2"})


def test_classes_that_are_not_plugins_fail() -> None:
    class Abstract(Plugin):
        pass

    fails(Abstract, "the class is abstract; implement step")
    fails(dict, "not a class derived from actorswarm.runtime.plugin.Plugin")

    class NeedsArgs(Plugin):
        def __init__(self, speed: float) -> None:
            self.speed = speed

        def step(self, ctx: PluginContext) -> None:
            pass

    fails(NeedsArgs, "building it with no arguments raised TypeError", "as Cls()")


def test_kit_arguments_are_checked() -> None:
    with pytest.raises(ValueError, match="steps must be an integer ≥ 2 and dt > 0"):
        check_plugin(Idle, steps=1)
    with pytest.raises(ValueError, match="dt > 0"):
        check_plugin(Idle, dt=0)
