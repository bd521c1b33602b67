"""Task scripts in the simulated world: vehicles for the plugins, and a radio driven by
positions, so a platform that flies out of range really drops out of the swarm."""

from __future__ import annotations

import sys
import types
from collections.abc import Mapping
from typing import Any, ClassVar

import pytest

from actorswarm.dsl import check
from actorswarm.runtime.context import PluginContext
from actorswarm.runtime.plugin import Param, Plugin
from actorswarm.sim.tasksim import TaskSim
from actorswarm.world.config import loads_world
from actorswarm.world.separation import BREACH_PREFIX

WORLD = """
[radio]
range = 300.0
loss_at_range = 0.2
loss_exponent = 4.0
base_latency = 0.005
latency_per_km = 0.001
jitter = 0.0
"""


class FlyTo(Plugin):
    """Flies to (x, y, z) at start."""

    bus = "act_bus"
    needs_vehicle = True
    params: ClassVar[Mapping[str, Param]] = {
        "target": Param(kind="point", default=(0.0, 0.0, 20.0), doc="where to fly")
    }

    def on_start(self, ctx: PluginContext) -> None:
        x, y, z = ctx.params["target"]
        ctx.require_vehicle().goto(x, y, z)

    def step(self, ctx: PluginContext) -> None:
        pass

    def snapshot(self) -> dict[str, Any]:
        return {}

    def restore(self, state: Mapping[str, Any]) -> None:
        pass


@pytest.fixture(autouse=True)
def _module() -> Any:
    module = types.ModuleType("ws_plugins")
    module.FlyTo = FlyTo  # type: ignore[attr-defined]
    sys.modules["ws_plugins"] = module
    yield
    del sys.modules["ws_plugins"]


def test_a_platform_flying_out_of_range_drops_out_and_is_replaced() -> None:
    text = (
        '<TaskScript name="ws" version="1"><_ActorsConfig>'
        "<Actor><_P_Name>Scout</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>"
        "<Plugin><_P_Name>ws_plugins:FlyTo</_P_Name>"
        '<param key="target" value="1000 0 20"/></Plugin></Bus></OODAConfig></Actor>'
        "<Actor><_P_Name>Wait</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>"
        "<Plugin><_P_Name>ws_plugins:FlyTo</_P_Name>"
        '<param key="target" value="0 0 20"/></Plugin></Bus></OODAConfig></Actor>'
        '</_ActorsConfig><_TaskConfig><actor name="Wait">'
        '<transition name="Scout_lost" sysNum="1"><successor actor="Scout"/></transition>'
        "</actor></_TaskConfig><_PlatformActorConfig>"
        '<platform id="5" actor="Scout"/><platform id="1-4" actor="Wait"/>'
        "</_PlatformActorConfig></TaskScript>"
    )
    result = check(text, path="ws.xml")
    assert result.script is not None, [str(d) for d in result.diagnostics]
    sim = TaskSim(result.script, seed=1, world_config=loads_world(WORLD))
    report = sim.run(60.0)
    assert sim.world is not None
    x5 = sim.world.positions()[5][0]
    assert x5 > 400, f"the scout flew away (x = {x5:.0f} m)"
    assert 5 not in sim.swarm.node(1).members, "out of range: it left the others' view"
    promoted = [t for t in report["transitions"] if t["event"] == "Scout_lost"]
    assert len(promoted) == 1 and promoted[0]["to"] == "Scout", promoted
    assert sim.swarm.radio.drops["range"] > 0
    # Out of range is a component of its own: a master there too is no violation. (The
    # four that wait all wait at one point: separation breaches, not this test's subject.)
    assert [v for v in report["violations"] if not v.startswith(BREACH_PREFIX)] == []
    assert report["separation"]["breaches"]


def test_takeoff_ingress_return_example_flies_and_lands() -> None:
    from pathlib import Path

    from actorswarm.dsl import load
    from actorswarm.world.config import load_world

    root = Path(__file__).resolve().parents[2]
    sim = TaskSim(
        load(root / "examples" / "takeoff_ingress_return.xml"),
        seed=2,
        world_config=load_world(root / "examples" / "worlds" / "default.toml"),
    )
    report = sim.run(90.0)
    assert report["violations"] == []
    moves = [(t["from"], t["to"], t["cause"]) for t in report["transitions"] if t["from"]]
    assert moves.count(("Standby", "Ingress", "barrier")) == 10
    assert moves.count(("Ingress", "Return", "barrier")) == 10
    assert report["completed"] is True
    assert sim.world is not None
    assert all(sim.world.fleet.mode(p) == "landed" for p in range(1, 11))
    for p in range(1, 11):
        x, y, _ = sim.world.vehicle(p).position()
        hx, hy, _ = sim.world.vehicle(p).home()
        assert abs(x - hx) < 2.0 and abs(y - hy) < 2.0, f"platform {p} landed at home"


ASSIGN_WORLD = """
[[vehicles]]
platform = 1
home = [30.0, -20.0]
[[vehicles]]
platform = 2
home = [20.0, -20.0]
[[vehicles]]
platform = 3
home = [10.0, -20.0]
[[vehicles]]
platform = 4
home = [0.0, -20.0]
"""

ASSIGN_SCRIPT = """<TaskScript name="assign" version="1">
  <_ActorsConfig>
    <Actor><_P_Name>Wait</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>
      <Plugin><_P_Name>core.idle</_P_Name></Plugin></Bus></OODAConfig></Actor>
    <Actor><_P_Name>Line</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>
      <Plugin><_P_Name>formation.line</_P_Name>
        <param key="route" value="0 0; 0 100"/><param key="speed" value="1"/>
        <param key="spacing" value="10"/><param key="depart" value="0"/>
      </Plugin></Bus></OODAConfig></Actor>
  </_ActorsConfig>
  <_TaskConfig>
    <actor name="Wait">
      <transition name="go" barrierKey="1" sysNum="all"><successor actor="Line"/></transition>
    </actor>
  </_TaskConfig>
  <_PlatformActorConfig><platform id="1-4" actor="Wait"/></_PlatformActorConfig>
</TaskScript>"""


def test_the_master_hands_out_slots_by_least_total_distance() -> None:
    """Four vehicles in a row west to east (4, 3, 2, 1) and a line abreast facing north
    (slots west to east: 4, 2, 1, 3): the least total distance pairs them in order, which
    is not the bid order (platform k to slot k)."""
    from actorswarm.sim.tasksim import GroundEvent

    result = check(ASSIGN_SCRIPT)
    assert result.script is not None, result.diagnostics
    sim = TaskSim(result.script, world_config=loads_world(ASSIGN_WORLD))
    report = sim.run(3.0, events=[GroundEvent("go", 1.0)])
    assert report["violations"] == []
    slots = {p: h.engine.runtime.acbs()["Line"].context.slot for p, h in sim.hosts.items()}
    assert slots == {1: 3, 2: 1, 3: 2, 4: 4}
    # Every member also gets the one centre of the group (the mean of where they were),
    # the common reference of a group that moves together (flight.return_home's rally).
    centres = [h.engine.runtime.acbs()["Line"].context.data["centre"] for h in sim.hosts.values()]
    assert centres == [[15.0, -20.0]] * 4
