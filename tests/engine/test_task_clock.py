"""The task's clock: a start carries its instant on the clock the platforms share, every
platform's plugins count from it (``ctx.task_start``) whenever the command reached them, a
platform started later joins the same task, and a restarted platform keeps it."""

from __future__ import annotations

from pathlib import Path

import msgspec
import pytest

from actorswarm.core.config import CoreConfig
from actorswarm.dsl import load
from actorswarm.engine import commands as cmds
from actorswarm.engine.engine import TaskEngine
from actorswarm.engine.plan import Plan
from actorswarm.ground import GroundStation
from actorswarm.runtime.actor_runtime import ActorRuntime
from actorswarm.sim.radio import LinkModel
from actorswarm.sim.swarm import SimSwarm
from actorswarm.sim.tasksim import Fault, TaskSim

ROOT = Path(__file__).resolve().parents[2]
BRANCH = ROOT / "examples" / "branch_merge.xml"
#: A start on the shared clock (UTC seconds), far from the simulator's own times.
BEGAN = 1_796_000_000.25


def gs(sim: TaskSim) -> GroundStation:
    assert sim.ground is not None
    return sim.ground


def task_starts(sim: TaskSim) -> dict[int, float | None]:
    return {p: h.engine.runtime.task_start for p, h in sorted(sim.hosts.items())}


def deployed(platforms: range, *, loss: float = 0.0) -> TaskSim:
    sim = TaskSim(load(BRANCH), seed=4, link=LinkModel(loss=loss), auto_start=False)
    sim.swarm.run_until(1.0)
    sim.operate(lambda g, now: g.deploy(BRANCH.read_bytes(), platforms, now))
    sim.swarm.run_until(2.0)
    return sim


@pytest.mark.parametrize("loss", [0.0, 0.3])
def test_every_platform_counts_the_task_from_the_ground_stations_start(loss: float) -> None:
    """The simulator's clock is the shared one (offset 0): each platform's task_start is the
    start's instant, not when the command reached it (over a lossy radio, late for some)."""
    sim = deployed(range(1, 11), loss=loss)
    sent = sim.operate(lambda g, now: g.start(now, began=BEGAN))
    assert sent == BEGAN
    sim.swarm.run_until(4.0)
    assert task_starts(sim) == dict.fromkeys(range(1, 11), BEGAN)
    assert {h.engine.began for h in sim.hosts.values()} == {BEGAN}


def test_a_platform_started_later_joins_the_task_the_others_began() -> None:
    """Platform 10 misses the first start (deployed to 1-9 only); a second start, with a
    later clock, gives it the first start's instant, which the running platforms reported
    when they confirmed the script again — and they keep theirs."""
    sim = deployed(range(1, 10))
    sim.operate(lambda g, now: g.start(now, began=BEGAN))
    sim.swarm.run_until(3.0)
    assert task_starts(sim)[10] is None, "platform 10 was not started"
    sim.operate(lambda g, now: g.deploy(BRANCH.read_bytes(), range(1, 11), now))
    sim.swarm.run_until(4.0)
    sha = gs(sim).deployed_sha
    assert gs(sim).began[sha] == BEGAN, "the running platforms said when their task began"
    sent = sim.operate(lambda g, now: g.start(now, began=BEGAN + 600.0))
    assert sent == BEGAN
    sim.swarm.run_until(5.0)
    assert task_starts(sim) == dict.fromkeys(range(1, 11), BEGAN)


def test_a_platform_restarted_goes_on_in_its_task() -> None:
    sim = deployed(range(1, 11))
    sim.operate(lambda g, now: g.start(now, began=BEGAN))
    sim.swarm.run_until(3.0)
    sim.fault(Fault("restart", 3.5, frozenset({4})))
    sim.swarm.run_until(6.0)
    assert sim.swarm.node(4).incarnation == 1
    assert task_starts(sim)[4] == BEGAN


def test_a_task_started_by_the_simulator_begins_at_its_time_zero() -> None:
    """Without a ground station the task begins at 0, also for a platform restarted from
    nothing (its "disk" keeps the task's start as a daemon's state directory does)."""
    sim = TaskSim(load(BRANCH), seed=5)
    sim.swarm.run_until(2.0)
    assert set(task_starts(sim).values()) == {0.0}
    sim.fault(Fault("restart", 2.5, frozenset({7})))
    sim.swarm.run_until(4.0)
    assert task_starts(sim)[7] == 0.0


def engine_with_offset(offset: float) -> TaskEngine:
    swarm = SimSwarm([1], config=CoreConfig())
    script = load(BRANCH)
    engine = TaskEngine(swarm.node(1), Plan.build(script), ActorRuntime(1))
    engine.clock_offset = lambda: offset
    return engine


def test_the_start_is_turned_into_the_hosts_clock() -> None:
    """A daemon's clock is monotonic: the shared clock's instant minus the offset between
    them is when the task began on it."""
    engine = engine_with_offset(1_796_000_000.0)
    engine.start(12.0, began=BEGAN)
    assert engine.runtime.task_start == pytest.approx(0.25)
    assert engine.began == BEGAN


def test_without_an_instant_the_task_begins_when_the_start_arrives() -> None:
    """A ground station that sends none: the platform counts from its own receipt."""
    engine = engine_with_offset(1000.0)
    engine.start(12.0)
    assert engine.runtime.task_start == 12.0
    assert engine.began == 1012.0


def test_the_start_command_carries_its_instant_and_refuses_one_that_is_no_time() -> None:
    plain = cmds.Start(sha256="a" * 64)
    # Without an instant it is the same bytes as ever: an older platform still reads it.
    assert b"began" not in cmds.encode(plain)
    timed = cmds.decode_command(cmds.encode(cmds.Start(sha256="a" * 64, began=BEGAN)))
    assert isinstance(timed, cmds.Start) and timed.began == BEGAN
    ack = cmds.decode_reply(cmds.encode(cmds.DeployAck(sha256="a" * 64, began=BEGAN)))
    assert isinstance(ack, cmds.DeployAck) and ack.began == BEGAN
    for bad in (-1.0, float("inf"), 1e12):
        raw = msgspec.msgpack.encode({"type": "Start", "sha256": "a" * 64, "began": bad})
        with pytest.raises(cmds.CommandError):
            cmds.decode_command(raw)
