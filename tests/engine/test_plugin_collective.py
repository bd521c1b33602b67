"""Plugins use the collective core too: a plugin barrier with gather/scatter and a role."""

from __future__ import annotations

import sys
import types
from collections.abc import Mapping
from typing import Any, ClassVar

import pytest

from actorswarm.core.barrier import BarrierMember
from actorswarm.core.wire import Release
from actorswarm.dsl import check
from actorswarm.engine import commands as cmds
from actorswarm.runtime.collective import PLUGIN_KEY_BASE
from actorswarm.runtime.context import PluginContext
from actorswarm.runtime.plugin import Param, Plugin
from actorswarm.sim.tasksim import TaskSim
from actorswarm.web import SimSource


class Rendezvous(Plugin):
    """Asks every platform to meet at plugin barrier 7 with its ID as gather data; once
    released, records its slot and emits ``met``. Also claims the role ``leader``."""

    any_bus = True
    params: ClassVar[Mapping[str, Param]] = {"need": Param(kind="int", default=4)}

    def __init__(self) -> None:
        self.asked = False
        self.done = False

    def step(self, ctx: PluginContext) -> None:
        if not self.asked:
            self.asked = True
            ctx.collective.barrier(7, ctx.params["need"], data=ctx.platform)
            ctx.collective.claim_role("leader", 1)
        for answer in ctx.blackboard.pop("collective", []):
            if answer["kind"] == "barrier" and answer["key"] == 7 and not self.done:
                self.done = True
                ctx.blackboard["slot"] = answer["index"]
                ctx.blackboard["gathered"] = sorted(d for _, d in answer["gathered"])
                ctx.emit("met")
            elif answer["kind"] == "role":
                ctx.blackboard["leader"] = answer["state"]

    def snapshot(self) -> dict[str, Any]:
        return {"asked": self.asked, "done": self.done}

    def restore(self, state: Mapping[str, Any]) -> None:
        self.asked, self.done = bool(state["asked"]), bool(state["done"])


@pytest.fixture(autouse=True)
def _module() -> Any:
    module = types.ModuleType("pc_plugins")
    module.Rendezvous = Rendezvous  # type: ignore[attr-defined]
    sys.modules["pc_plugins"] = module
    yield
    del sys.modules["pc_plugins"]


def test_plugin_barrier_gathers_scatters_and_drives_a_transition(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    heard: list[Release] = []
    on_release = BarrierMember.on_release

    def spy(self: BarrierMember, rel: Release) -> Any:
        heard.append(rel)
        return on_release(self, rel)

    monkeypatch.setattr(BarrierMember, "on_release", spy)
    text = (
        '<TaskScript name="pc" version="1"><_ActorsConfig>'
        "<Actor><_P_Name>Meet</_P_Name><OODAConfig><Bus><_P_Name>decide_bus</_P_Name>"
        "<Plugin><_P_Name>pc_plugins:Rendezvous</_P_Name></Plugin></Bus></OODAConfig></Actor>"
        "<Actor><_P_Name>Go</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>"
        "<Plugin><_P_Name>core.idle</_P_Name></Plugin></Bus></OODAConfig></Actor>"
        '</_ActorsConfig><_TaskConfig><actor name="Meet"><transition name="met" sysNum="1">'
        '<successor actor="Go"/></transition></actor></_TaskConfig>'
        '<_PlatformActorConfig><platform id="1-4" actor="Meet"/></_PlatformActorConfig>'
        "</TaskScript>"
    )
    result = check(text, path="pc.xml")
    assert result.script is not None, [str(d) for d in result.diagnostics]
    sim = TaskSim(result.script, seed=3)
    report = sim.run(4.0)
    assert report["violations"] == []
    boards = {p: h.engine.runtime._loaded["Meet"].blackboard for p, h in sim.hosts.items()}
    assert sorted(b["slot"] for b in boards.values()) == [1, 2, 3, 4], "each learns its slot"
    assert all(b["gathered"] == [1, 2, 3, 4] for b in boards.values()), "everyone's data"
    leaders = [p for p, b in boards.items() if b.get("leader") == "granted"]
    assert len(leaders) == 1, f"one leader: {boards}"
    assert all(h.engine.runtime.running() == ("Go",) for h in sim.hosts.values())
    # The plugin's barrier gathers; the transition's release carries only each
    # participant's scattered share (its request data was for the master's slot assignment).
    plugin = [r for r in heard if r.key == PLUGIN_KEY_BASE + 7]
    engine = [r for r in heard if r.key < PLUGIN_KEY_BASE]
    assert plugin and all(sorted(d for _, d in r.gathered) == [1, 2, 3, 4] for r in plugin)
    assert engine and all(r.gathered == [] for r in engine)
    assert all(e.data["to"] == "Go" for r in engine for e in r.entries if e.index)
    # The operator's status reply says who holds the role.
    sim.operate(lambda g, now: g.send(cmds.Status(), [1, 2, 3, 4], now))
    sim.swarm.run_until(4.5)
    assert sim.ground is not None
    roles = {
        r.platform: r.reply.roles
        for r in sim.ground.replies
        if isinstance(r.reply, cmds.StatusReply)
    }
    assert roles == {p: ["leader"] if p in leaders else [] for p in (1, 2, 3, 4)}
    # The web page of the simulated run says the same.
    members = SimSource(sim).swarm_view()["members"]
    assert {m["id"]: m["roles"] for m in members} == roles


def test_status_reports_the_actor_control_blocks() -> None:
    text = (
        '<TaskScript name="st" version="1"><_ActorsConfig>'
        "<Actor><_P_Name>A</_P_Name><_P_Prio>3</_P_Prio><OODAConfig><Bus>"
        "<_P_Name>act_bus</_P_Name><Plugin><_P_Name>core.idle</_P_Name></Plugin></Bus>"
        "</OODAConfig></Actor></_ActorsConfig><_TaskConfig/>"
        '<_PlatformActorConfig><platform id="1-2" actor="A"/></_PlatformActorConfig>'
        "</TaskScript>"
    )
    result = check(text, path="st.xml")
    assert result.script is not None
    sim = TaskSim(result.script, seed=4)
    sim.swarm.run_until(1.0)
    sim.operate(lambda g, now: g.send(cmds.Status(), [2], now))
    sim.swarm.run_until(1.5)
    assert sim.ground is not None
    (status,) = [r.reply for r in sim.ground.replies if isinstance(r.reply, cmds.StatusReply)]
    acb = status.acbs["A"]
    for key in ("name", "actor_id", "status", "priority", "software", "hardware", "permission"):
        assert key in acb, key
    assert acb["status"] == "running" and acb["priority"] == 3


def test_a_stale_plugin_barrier_request_is_answered_on_the_blackboard() -> None:
    """Its generation fired before the request reached the master: the plugin is told so
    (it waited for nothing before), with the generation open now."""
    from actorswarm.core.events import BarrierStaleNotice
    from actorswarm.runtime.collective import plugin_view

    notice = BarrierStaleNotice(key=PLUGIN_KEY_BASE + 7, generation=3, current=5)
    assert plugin_view(notice) == {
        "kind": "barrier",
        "key": 7,
        "generation": 3,
        "chosen": False,
        "index": 0,
        "size": 0,
        "data": None,
        "gathered": [],
        "outcome": "stale",
        "current": 5,
    }
    # A transition group's notice is the engine's, not a plugin's.
    assert plugin_view(BarrierStaleNotice(key=7, generation=3, current=5)) is None


def test_a_plugin_barrier_may_be_renewable() -> None:
    from actorswarm.runtime.collective import NodeCollective

    calls: list[tuple[int, dict[str, Any]]] = []

    class FakeNode:
        def request_barrier(self, key: int, need: int, now: float, **kw: Any) -> int:
            calls.append((key, kw))
            return 0

    collective = NodeCollective(FakeNode(), lambda: 1.5)  # type: ignore[arg-type]
    collective.barrier(7, 2, renew=True)
    collective.barrier(8, 2)
    assert [(k - PLUGIN_KEY_BASE, kw["renew"]) for k, kw in calls] == [(7, True), (8, False)]
