"""The actor runtime with real plugins: OODA order, switch re-activation, hardware
preemption and resumption, isolation of a failing plugin, snapshot/restore through a crash."""

from __future__ import annotations

import itertools
import random
import sys
import types
from collections.abc import Mapping
from typing import Any, ClassVar

import pytest

from actorswarm.dsl import check
from actorswarm.dsl.model import TaskScript
from actorswarm.engine.runtime import ActorContext
from actorswarm.runtime.actor_runtime import ActorRuntime, UnsupportedPlugin
from actorswarm.runtime.context import PluginContext
from actorswarm.runtime.operations import IllegalOperation
from actorswarm.runtime.plugin import Param, Plugin
from actorswarm.runtime.resources import ResourceBusy

LOG: list[str] = []


class Recorder(Plugin):
    """Writes every hook it gets to LOG (as "<bus>:<hook>") and counts its steps."""

    any_bus = True
    params: ClassVar[Mapping[str, Param]] = {"tag": Param(kind="str", default="x")}

    def __init__(self) -> None:
        self.steps = 0

    def _log(self, ctx: PluginContext, hook: str) -> None:
        LOG.append(f"{ctx.actor}:{ctx.params['tag']}:{hook}")

    def on_start(self, ctx: PluginContext) -> None:
        self._log(ctx, "start")

    def step(self, ctx: PluginContext) -> None:
        self.steps += 1
        ctx.blackboard.setdefault("order", []).append(ctx.params["tag"])
        self._log(ctx, "step")

    def on_pause(self, ctx: PluginContext) -> None:
        self._log(ctx, "pause")

    def on_activate(self, ctx: PluginContext) -> None:
        self._log(ctx, "activate")

    def on_stop(self, ctx: PluginContext) -> None:
        self._log(ctx, "stop")

    def snapshot(self) -> dict[str, Any]:
        return {"steps": self.steps}

    def restore(self, state: Mapping[str, Any]) -> None:
        self.steps = int(state["steps"])


class Pilot(Recorder):
    resources: ClassVar[frozenset[str]] = frozenset({"autopilot"})


class Broken(Plugin):
    any_bus = True

    def step(self, ctx: PluginContext) -> None:
        raise RuntimeError("sensor unplugged")


@pytest.fixture(autouse=True)
def _plugins() -> Any:
    module = types.ModuleType("rt_plugins")
    module.Recorder = Recorder  # type: ignore[attr-defined]
    module.Pilot = Pilot  # type: ignore[attr-defined]
    module.Broken = Broken  # type: ignore[attr-defined]
    sys.modules["rt_plugins"] = module
    LOG.clear()
    yield
    del sys.modules["rt_plugins"]


def plugin(name: str, bus: str, tag: str = "") -> str:
    param = f'<param key="tag" value="{tag}"/>' if tag else ""
    return (
        f"<Bus><_P_Name>{bus}</_P_Name><Plugin><_P_Name>rt_plugins:{name}</_P_Name>{param}"
        "</Plugin></Bus>"
    )


def actor(name: str, prio: int, *buses: str) -> str:
    return (
        f"<Actor><_P_Name>{name}</_P_Name><_P_Prio>{prio}</_P_Prio><OODAConfig>"
        + "".join(buses)
        + "</OODAConfig></Actor>"
    )


def script(*actors: str) -> TaskScript:
    text = (
        '<TaskScript name="rt" version="1"><_ActorsConfig>'
        + "".join(actors)
        + '</_ActorsConfig><_TaskConfig/><_PlatformActorConfig><platform id="1" actor="A"/>'
        "</_PlatformActorConfig></TaskScript>"
    )
    result = check(text, path="rt.xml")
    assert result.script is not None, [str(d) for d in result.diagnostics]
    return result.script


def runtime(s: TaskScript) -> ActorRuntime:
    rt = ActorRuntime(1, rate=10.0)
    rt.use_script(s)
    return rt


def test_ooda_order_and_shared_blackboard() -> None:
    rt = runtime(
        script(
            actor(
                "A",
                0,
                plugin("Recorder", "act_bus", "act"),
                plugin("Recorder", "observe_bus", "obs"),
                plugin("Recorder", "decide_bus", "dec"),
                plugin("Recorder", "orient_bus", "ori"),
            )
        )
    )
    rt.start("A", 0.0, ActorContext())
    rt.step(0.0)
    steps = [e.split(":")[1] for e in LOG if e.endswith(":step")]
    assert steps == ["obs", "ori", "dec", "act"], "observe -> orient -> decide -> act"
    acb = rt.acbs()["A"]
    assert acb.stats.steps == 1 and set(acb.stats.plugins) >= {"rt_plugins:Recorder"}


def test_steps_follow_the_rate() -> None:
    rt = runtime(script(actor("A", 0, plugin("Recorder", "act_bus", "a"))))
    rt.start("A", 0.0, ActorContext())
    for t in [0.0, 0.05, 0.1, 0.15, 0.2]:
        if (deadline := rt.next_deadline()) is not None and t >= deadline:
            rt.step(t)
    assert sum(e.endswith(":step") for e in LOG) == 3, LOG  # 0.0, 0.1, 0.2


def _host(rt: ActorRuntime, wakes: list[float], until: float) -> tuple[list[float], int]:
    """Drive ``rt`` as a daemon's loop does: wake at the next of ``wakes`` (packets) or at
    the runtime's deadline, whichever comes first, and step at every wake. Returns the
    times of the actor's steps and how many wakes the runtime's deadline caused itself."""
    steps: list[float] = []
    own = 0
    pending = sorted(wakes)
    t = 0.0
    while t < until:
        deadline = rt.next_deadline()
        assert deadline is not None
        if pending and pending[0] <= deadline:
            t = pending.pop(0)
        else:
            t, own = deadline, own + 1
        before = sum(e.endswith(":step") for e in LOG)
        rt.step(t)
        if sum(e.endswith(":step") for e in LOG) > before:
            steps.append(t)
    return steps, own


def _slack_runtime(slack: float) -> ActorRuntime:
    rt = ActorRuntime(1, rate=10.0, step_slack=slack)
    rt.use_script(script(actor("A", 0, plugin("Recorder", "act_bus", "a"))))
    rt.start("A", 0.0, ActorContext())
    return rt


def test_steps_with_slack_lock_onto_wakes_made_anyway() -> None:
    """With a 30 ms slack, steps drift until they ride on a 10 Hz series of wakes the host
    makes anyway (a master's heartbeats, 60 ms out of phase here), then keep its phase: no
    wake of their own, the rate unchanged. Without slack each step needs its own wake."""
    heartbeats = [0.06 + 0.1 * k + (0.004 if k % 3 else -0.003) for k in range(250)]
    steps, own = _host(_slack_runtime(0.03), heartbeats, until=20.0)
    late = [t for t in steps if t >= 5.0]
    assert own < 20, f"{own} own wakes: the steps never locked on"
    assert all(min(abs(t - h) for h in heartbeats) < 1e-9 for t in late), "a step woke alone"
    gaps = [b - a for a, b in itertools.pairwise(late)]
    assert min(gaps) > 0.09 and max(gaps) < 0.11, (min(gaps), max(gaps))
    assert len(late) in range(149, 152), len(late)  # 10 Hz over the last 15 s

    LOG.clear()
    steps, own = _host(_slack_runtime(0.0), heartbeats, until=20.0)
    assert own > 150, "without slack a step out of phase with the wakes needs its own"


def test_steps_with_slack_stay_on_wakes_that_come_up_to_a_slack_early() -> None:
    """The wakes a daemon's steps ride on are its master's heartbeats, and a busy master
    sends its heartbeat up to a slack early: wakes at 60 ms past each period, each up to
    30 ms early and up to 5 ms late, at random. The steps keep riding on them (a window of
    one slack lost them 72 times in 20 s here, drifting round the period each time to find
    them again), at the rate, no gap off the period by more than two slacks."""
    rng = random.Random(3)
    wakes = [0.06 + 0.1 * k - rng.uniform(0, 0.03) + rng.uniform(0, 0.005) for k in range(200)]
    steps, own = _host(_slack_runtime(0.03), wakes, until=20.0)
    assert own <= 10, f"{own} own wakes"
    late = [t for t in steps if t >= 5.0]
    assert len(late) in range(149, 152), len(late)
    gaps = [b - a for a, b in itertools.pairwise(late)]
    assert min(gaps) >= 0.1 - 0.06 - 1e-9 and max(gaps) <= 0.1 + 0.06 + 1e-9, gaps


def test_steps_with_slack_keep_their_rate_among_frequent_wakes() -> None:
    """A master woken every 7 ms by its members: a step due within the slack runs at the
    first wake, on its schedule's grid, so the rate is still 10 Hz, not 1 / (0.1 - slack)."""
    wakes = [0.007 * k for k in range(1, 2000)]
    steps, _ = _host(_slack_runtime(0.03), wakes, until=10.0)
    assert len(steps) in range(99, 102), len(steps)
    gaps = [b - a for a, b in itertools.pairwise(steps)]
    assert max(gaps) < 0.1 + 0.007 + 1e-9, max(gaps)


def test_steps_with_slack_drift_by_half_a_slack_when_nothing_else_wakes() -> None:
    steps, own = _host(_slack_runtime(0.03), [], until=2.0)
    gaps = {round(b - a, 9) for a, b in itertools.pairwise(steps)}
    assert gaps == {0.115} and own == len(steps)


def test_step_slack_is_at_most_half_a_period() -> None:
    with pytest.raises(ValueError, match="step_slack must be in"):
        ActorRuntime(1, rate=10.0, step_slack=0.06)
    with pytest.raises(ValueError, match="step_slack must be in"):
        ActorRuntime(1, rate=10.0, step_slack=-0.01)


def test_switch_back_reactivates_instead_of_reloading() -> None:
    rt = runtime(
        script(
            actor("A", 0, plugin("Recorder", "act_bus", "a")),
            actor("B", 0, plugin("Recorder", "act_bus", "b")),
        )
    )
    rt.start("A", 0.0, ActorContext())
    rt.step(0.0)
    rt.switch("A", "B", 1.0, ActorContext(params={"tag": "b2"}))
    assert rt.loaded() == {"A": "sleeping", "B": "running"}
    rt.switch("B", "A", 2.0, ActorContext())
    assert [e for e in LOG if e.startswith("A:")] == [
        "A:a:start",
        "A:a:step",
        "A:a:pause",
        "A:a:activate",
    ], "A was re-activated with its state, not started again"
    assert "B:b2:start" in LOG, "transition params reach the successor's plugins"
    assert rt.acbs()["A"].stats.switch_count >= 2


def test_a_switch_pauses_the_outgoing_actor_before_the_incoming_one_starts() -> None:
    """The order the Vehicle contract's "the latest command wins" relies on: whatever the
    outgoing actor commands as it pauses comes before the incoming actor's first command."""
    rt = runtime(
        script(
            actor("A", 0, plugin("Pilot", "act_bus", "a")),
            actor("B", 0, plugin("Pilot", "act_bus", "b")),
        )
    )
    rt.start("A", 0.0, ActorContext())
    rt.step(0.0)
    LOG.clear()
    rt.switch("A", "B", 1.0, ActorContext())
    rt.step(1.0)
    assert LOG == ["A:a:pause", "B:b:start", "B:b:step"]


def test_illegal_operations_change_nothing() -> None:
    rt = runtime(script(actor("A", 0, plugin("Recorder", "act_bus", "a"))))
    with pytest.raises(ValueError, match="not loaded"):
        rt.pause("A", 0.0)
    rt.start("A", 0.0, ActorContext())
    with pytest.raises(IllegalOperation):
        rt.start("A", 0.5, ActorContext())
    with pytest.raises(IllegalOperation):
        rt.activate("A", 0.5)
    assert rt.loaded() == {"A": "running"}


def test_higher_priority_preempts_hardware_and_the_holder_resumes() -> None:
    rt = runtime(
        script(
            actor("A", 1, plugin("Pilot", "act_bus", "cruise")),
            actor("Evade", 5, plugin("Pilot", "act_bus", "evade")),
            actor("Low", 0, plugin("Pilot", "act_bus", "low")),
        )
    )
    rt.start("A", 0.0, ActorContext())
    with pytest.raises(ResourceBusy, match="autopilot") as busy:
        rt.start("Low", 0.5, ActorContext())
    assert "A" in str(busy.value), "the refusal names the holder"
    rt.start("Evade", 1.0, ActorContext())
    assert rt.loaded()["A"] == "sleeping" and rt.running() == ("Evade",)
    rt.stop("Evade", 2.0)
    assert rt.running() == ("A",), "the preempted holder resumes when the hardware is free"
    assert "A:cruise:activate" in LOG


def test_actors_with_disjoint_hardware_run_together() -> None:
    rt = runtime(
        script(
            actor("A", 0, plugin("Pilot", "act_bus", "fly")),
            actor("Cam", 0, plugin("Recorder", "observe_bus", "look")),
        )
    )
    rt.start("A", 0.0, ActorContext())
    rt.start("Cam", 0.0, ActorContext())
    assert set(rt.running()) == {"A", "Cam"}


def test_a_failing_plugin_is_isolated() -> None:
    rt = runtime(
        script(
            actor("A", 0, plugin("Broken", "decide_bus")),
            actor("B", 0, plugin("Recorder", "act_bus", "b")),
        )
    )
    rt.start("A", 0.0, ActorContext())
    rt.start("B", 0.0, ActorContext())
    rt.step(0.0)
    assert rt.loaded() == {"A": "error", "B": "running"}
    (failure,) = rt.failures
    assert failure.actor == "A" and "rt_plugins:Broken" in failure.plugin
    assert "sensor unplugged" in failure.message
    assert rt.acbs()["A"].last_error is not None
    rt.step(0.1)
    assert sum(e == "B:b:step" for e in LOG) == 2, "the other actor keeps running"


def test_snapshot_restore_through_a_crash() -> None:
    s = script(
        actor("A", 0, plugin("Recorder", "act_bus", "a")),
        actor("B", 0, plugin("Recorder", "act_bus", "b")),
    )
    rt = runtime(s)
    rt.start("A", 0.0, ActorContext())
    for t in (0.0, 0.1, 0.2):
        rt.step(t)
    rt.switch("A", "B", 0.3, ActorContext())
    backup = rt.snapshot()
    # The platform crashes; a new runtime (a new incarnation) restores the backup.
    reborn = runtime(s)
    resumed = reborn.restore(backup, 10.0)
    assert resumed == ["B"] and reborn.loaded() == {"A": "sleeping", "B": "running"}
    a = reborn.acbs()["A"]
    assert a.status.value == "sleeping"
    restored_a = next(p for _, p, _ in reborn._loaded["A"].plugins)
    assert isinstance(restored_a, Recorder) and restored_a.steps == 3, "plugin state came back"
    assert reborn.snapshot() == backup, "a restored runtime snapshots the same state"


def test_vehicle_plugins_are_refused_without_a_vehicle() -> None:
    class NeedsVehicle(Plugin):
        needs_vehicle = True

        def step(self, ctx: PluginContext) -> None:
            ctx.require_vehicle()

    sys.modules["rt_plugins"].NeedsVehicle = NeedsVehicle  # type: ignore[attr-defined]
    with pytest.raises(UnsupportedPlugin, match="needs a vehicle"):
        runtime(script(actor("A", 0, plugin("NeedsVehicle", "act_bus"))))


class _ReportingVehicle:
    """A vehicle adapter that says something of itself (as the MAVLink one does)."""

    def __init__(self, said: object) -> None:
        self.said = said

    def position(self) -> tuple[float, float, float]:
        return (0.0, 0.0, 0.0)

    def status(self) -> object:
        if isinstance(self.said, Exception):
            raise self.said
        return self.said


def test_the_vehicle_s_own_state_reaches_the_status_scalars_only() -> None:
    said = {"link": "up", "mode": "GUIDED", "armed": True, "battery": 0.87, "failsafes": {}}
    rt = ActorRuntime(1, vehicle=_ReportingVehicle(said))  # type: ignore[arg-type]
    assert rt.vehicle_state() == {"link": "up", "mode": "GUIDED", "armed": True, "battery": 0.87}
    assert ActorRuntime(2).vehicle_state() == {}
    broken = ActorRuntime(3, vehicle=_ReportingVehicle(RuntimeError("no link")))  # type: ignore[arg-type]
    assert broken.vehicle_state() == {"error": "RuntimeError: no link"}
