"""The Actor machine as a part on its own (actorswarm.engine.machine): driven on the core
without a TaskEngine, through the calls a host makes, and handing the application topics its
owner registered to the owner's handlers."""

from __future__ import annotations

import pytest

from actorswarm.core.events import AppReceived, CoreEvent
from actorswarm.core.node import Node
from actorswarm.dsl import check
from actorswarm.dsl.model import TaskScript
from actorswarm.engine.machine import TOPIC_ACTORS, TOPIC_EVENT, ActorMachine
from actorswarm.engine.plan import Plan
from actorswarm.runtime.actor_runtime import ActorRuntime
from actorswarm.sim.swarm import SimSwarm

IDLE = """<Actor><_P_Name>{}</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>
<Plugin><_P_Name>core.idle</_P_Name></Plugin></Bus></OODAConfig></Actor>"""


def script() -> TaskScript:
    """Three platforms run A; ``go`` takes all of them (one group) to B."""
    text = (
        '<TaskScript name="t" version="1"><_ActorsConfig>'
        + IDLE.format("A")
        + IDLE.format("B")
        + '</_ActorsConfig><_TaskConfig><actor name="A"><transition name="go" barrierKey="1" '
        'sysNum="all"><successor actor="B"/></transition></actor></_TaskConfig>'
        '<_PlatformActorConfig><platform id="1-3" actor="A"/></_PlatformActorConfig>'
        "</TaskScript>"
    )
    result = check(text, path="t.xml")
    assert result.ok, "\n".join(str(d) for d in result.diagnostics)
    assert result.script is not None
    return result.script


def test_machines_alone_pass_a_group_together_on_the_core() -> None:
    swarm = SimSwarm(3, seed=0)
    plan = Plan.build(script())
    machines = {p: ActorMachine(swarm.node(p), plan, ActorRuntime(p)) for p in (1, 2, 3)}

    def hand_on(t: float, node: Node, event: CoreEvent) -> None:
        machines[node.platform].on_core_event(event, t)

    swarm.listeners.append(hand_on)
    for p, machine in machines.items():
        swarm.call(p, lambda n, m=machine: m.start(swarm.now))
    swarm.run_until(8.0)  # a master, and every member's actors in its table
    for p, machine in machines.items():
        swarm.call(p, lambda n, m=machine: m.inject("go", swarm.now))
    swarm.run_until(10.0)
    for p, machine in machines.items():
        assert machine.runtime.running() == ("B",), (p, machine.ignored)
        moves = [(r.src, r.dst, r.event, r.cause) for r in machine.transitions]
        assert moves == [("", "A", "", "start"), ("A", "B", "go", "barrier")], (p, moves)
    # Only the master records the group it released, complete (nobody timed out).
    (master,) = swarm.current_masters()
    fired = {p: [(f.key, f.outcome, f.chosen) for f in m.fired] for p, m in machines.items()}
    assert fired == {p: [] for p in machines} | {master: [(1, "complete", (1, 2, 3))]}, fired


def test_a_topic_the_owner_registered_goes_to_its_handler_and_nowhere_else() -> None:
    swarm = SimSwarm(1, seed=0)
    heard: list[tuple[str, bytes, float]] = []
    machine = ActorMachine(
        swarm.node(1),
        Plan.build(script()),
        ActorRuntime(1),
        topics={"owner.topic": lambda msg, now: heard.append((msg.topic, msg.body, now))},
    )
    machine.on_core_event(AppReceived(sender=0, topic="owner.topic", body=b"\xc1"), 2.0)
    assert heard == [("owner.topic", b"\xc1", 2.0)]
    assert machine.ignored == []  # the owner's body, not the machine's to decode or log
    # A topic nobody answers is not for this platform: dropped without a word.
    machine.on_core_event(AppReceived(sender=0, topic="nobody.topic", body=b""), 3.0)
    assert heard == [("owner.topic", b"\xc1", 2.0)] and machine.ignored == []
    # The machine's own topics still decode, and say so when they cannot.
    machine.on_core_event(AppReceived(sender=2, topic=TOPIC_EVENT, body=b"\xc1"), 4.0)
    assert machine.ignored == [(4.0, TOPIC_EVENT, "undecodable message from 2")]


def test_an_owner_cannot_take_over_a_topic_of_the_machine() -> None:
    swarm = SimSwarm(1, seed=0)
    with pytest.raises(ValueError, match=r"engine\.actors' is the Actor machine's own"):
        ActorMachine(
            swarm.node(1),
            Plan.build(script()),
            ActorRuntime(1),
            topics={TOPIC_ACTORS: lambda msg, now: None},
        )
