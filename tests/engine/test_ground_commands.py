"""Ground-station commands over the simulated radio: deploy with SHA-256 confirmation, start,
events restricted to platforms or actors, forced transitions, forced start/stop,
pause/activate, backup, status, and a new script version while running."""

from __future__ import annotations

from pathlib import Path

import pytest

from actorswarm.core.wire import AppMessage
from actorswarm.dsl import load
from actorswarm.engine import commands as cmds
from actorswarm.ground import GroundStation, NotConfirmed
from actorswarm.sim.radio import LinkModel
from actorswarm.sim.tasksim import Fault, TaskSim

ROOT = Path(__file__).resolve().parents[2]
BRANCH = ROOT / "examples" / "branch_merge.xml"
READY = ROOT / "examples" / "ready_barrier.xml"


def deployed(loss: float = 0.0, seed: int = 1) -> tuple[TaskSim, str]:
    sim = TaskSim(load(BRANCH), seed=seed, link=LinkModel(loss=loss), auto_start=False)
    sim.swarm.run_until(1.0)
    text = BRANCH.read_bytes()
    sha = sim.operate(lambda gs, now: gs.deploy(text, range(1, 11), now))
    assert isinstance(sha, str)
    sim.swarm.run_until(2.0)
    return sim, sha


def gs(sim: TaskSim) -> GroundStation:
    assert sim.ground is not None
    return sim.ground


def results(sim: TaskSim, kind: type) -> list[tuple[int, cmds.Reply]]:
    return [(r.platform, r.reply) for r in gs(sim).replies if isinstance(r.reply, kind)]


def running(sim: TaskSim) -> dict[int, tuple[str, ...]]:
    return {p: h.engine.runtime.running() for p, h in sorted(sim.hosts.items())}


@pytest.mark.parametrize("loss", [0.0, 0.3])
def test_deploy_is_confirmed_by_every_platform_then_start(loss: float) -> None:
    sim, sha = deployed(loss=loss)
    assert gs(sim).missing(sha) == [], f"unconfirmed: {gs(sim).missing(sha)}"
    assert {p for p, r in results(sim, cmds.DeployAck) if isinstance(r, cmds.DeployAck)} == set(
        range(1, 11)
    )
    assert all(actors == () for actors in running(sim).values()), "nothing runs before start"
    sim.operate(lambda g, now: g.start(now))
    sim.swarm.run_until(3.0)
    assert all(actors == ("A",) for actors in running(sim).values())
    assert sim.report()["violations"] == []


def test_a_restarted_platform_resumes_its_last_switch_with_no_backup_asked() -> None:
    """As a daemon does, a simulated platform backs its actors up after every switch: a
    crash after the branch resumes C, not the task's start (where it would wait alone)."""
    sim = branched()
    sim.fault(Fault("restart", 4.0, frozenset({3})))
    sim.swarm.run_until(6.0)
    assert sim.swarm.node(3).incarnation == 1
    assert running(sim)[3] == ("C",)
    merged_cleanly(sim)


def test_start_is_refused_until_everyone_confirmed_unless_forced() -> None:
    sim = TaskSim(load(BRANCH), seed=2, auto_start=False)
    sim.swarm.run_until(1.0)
    sim.fault(Fault("kill", 1.0, frozenset({10})))
    sim.operate(lambda g, now: g.deploy(BRANCH.read_bytes(), range(1, 11), now))
    sim.swarm.run_until(2.0)
    with pytest.raises(NotConfirmed) as refused:
        sim.operate(lambda g, now: g.start(now))
    assert refused.value.missing == [10] and "[10]" in str(refused.value)
    sim.operate(lambda g, now: g.start(now, force=True))
    sim.swarm.run_until(3.0)
    assert all(actors == ("A",) for actors in running(sim).values())


def test_a_corrupted_script_is_refused_with_its_reason() -> None:
    sim = TaskSim(load(BRANCH), seed=3, auto_start=False)
    sim.swarm.run_until(1.0)
    bad = b"<TaskScript name='x'><oops/></TaskScript>"
    sim.operate(lambda g, now: g.deploy(bad, [1, 2], now))
    sim.swarm.run_until(2.0)
    refused = [r for _, r in results(sim, cmds.Result) if isinstance(r, cmds.Result)]
    assert len(refused) == 2 and not any(r.ok for r in refused)
    assert all("script refused" in r.message for r in refused)
    assert gs(sim).missing(gs(sim).deployed_sha) == [1, 2]


def test_events_restricted_to_platforms_or_actors() -> None:
    sim, _ = deployed()
    sim.operate(lambda g, now: g.start(now))
    sim.swarm.run_until(3.0)
    sim.operate(lambda g, now: g.event("AtoBC_branch_event", now, actors=["B"]))
    sim.swarm.run_until(4.0)
    skipped = [r for _, r in results(sim, cmds.Result) if isinstance(r, cmds.Result)]
    assert sum("skipped" in r.message for r in skipped) == 10, "nobody runs B yet"
    sim.operate(lambda g, now: g.event("AtoBC_branch_event", now, platforms=range(1, 11)))
    sim.swarm.run_until(6.0)
    assert sorted(a for actors in running(sim).values() for a in actors) == ["B"] * 2 + ["C"] * 8


def test_forced_transition_start_stop_pause_activate() -> None:
    sim, _ = deployed()
    sim.operate(lambda g, now: g.start(now))
    sim.swarm.run_until(3.0)
    sim.operate(lambda g, now: g.send(cmds.Force(to="C", params={"why": "operator"}), [1, 2], now))
    sim.swarm.run_until(3.5)
    assert running(sim)[1] == ("C",) and running(sim)[3] == ("A",)
    report = sim.report()
    forced = [t for t in report["transitions"] if t["cause"] == "forced"]
    assert sorted((t["platform"], t["from"], t["to"]) for t in forced) == [
        (1, "A", "C"),
        (2, "A", "C"),
    ]
    sim.operate(lambda g, now: g.send(cmds.Pause(actor="A"), [3], now))
    sim.operate(lambda g, now: g.send(cmds.ForceStart(actor="B"), [4], now))
    sim.operate(lambda g, now: g.send(cmds.ForceStop(actor="A"), [5], now))
    sim.operate(lambda g, now: g.send(cmds.Pause(actor="Z"), [6], now))
    sim.swarm.run_until(4.0)
    assert sim.hosts[3].engine.runtime.loaded() == {"A": "sleeping"}
    assert running(sim)[4] == ("A", "B") and running(sim)[5] == ()
    failures = [
        (p, r.message)
        for p, r in results(sim, cmds.Result)
        if isinstance(r, cmds.Result) and not r.ok
    ]
    assert failures and failures[0][0] == 6 and "not loaded" in failures[0][1]
    sim.operate(lambda g, now: g.send(cmds.Activate(actor="A"), [3], now))
    sim.swarm.run_until(4.5)
    assert running(sim)[3] == ("A",)


def test_status_and_backup_are_reported() -> None:
    sim, sha = deployed()
    sim.operate(lambda g, now: g.start(now))
    sim.swarm.run_until(3.0)
    sim.operate(lambda g, now: g.send(cmds.Status(), range(1, 11), now))
    sim.operate(lambda g, now: g.send(cmds.Backup(), [2], now))
    sim.swarm.run_until(3.5)
    status = {p: r for p, r in results(sim, cmds.StatusReply) if isinstance(r, cmds.StatusReply)}
    assert set(status) == set(range(1, 11))
    assert status[1].master and not status[2].master
    assert all(r.actors == {"A": "running"} and r.script == sha for r in status.values())
    backups = [r for p, r in results(sim, cmds.BackupReply) if p == 2]
    assert backups and isinstance(backups[0], cmds.BackupReply) and backups[0].size > 0
    assert sim.hosts[2].engine.store.latest() is not None


def test_a_new_script_version_while_running() -> None:
    sim, _ = deployed()
    sim.operate(lambda g, now: g.start(now))
    sim.swarm.run_until(3.0)
    new = READY.read_bytes()
    sim.operate(lambda g, now: g.deploy(new, range(1, 11), now))
    sim.swarm.run_until(4.0)
    sim.operate(lambda g, now: g.start(now))
    sim.swarm.run_until(4.5)
    # A is not in the new script: it stops, and every platform starts the new initial actor,
    # whose emit_after plugin drives the new ready barrier on its own.
    assert all(actors == ("Standby",) for actors in running(sim).values())
    sim.swarm.run_until(9.0)
    assert all(actors == ("Ingress",) for actors in running(sim).values())
    assert sim.report()["violations"] == []


def test_commands_from_anyone_but_the_ground_station_are_ignored() -> None:
    sim, _ = deployed()
    sim.operate(lambda g, now: g.start(now))
    sim.swarm.run_until(3.0)
    body = cmds.encode(cmds.Force(to="C"))
    sim.swarm.call(2, lambda n: n.send_app(3, cmds.TOPIC_COMMAND, body, sim.swarm.now))
    sim.swarm.run_until(3.5)
    assert running(sim)[3] == ("A",)


def test_garbage_commands_are_refused_without_harm() -> None:
    sim, _ = deployed()
    sim.operate(lambda g, now: g.start(now))
    sim.swarm.run_until(3.0)
    sim.operate(lambda g, now: g.reliable.send(4, cmds_message(b"\xc1junk"), now, 0, channel=0))
    sim.swarm.run_until(3.5)
    assert running(sim)[4] == ("A",)
    assert any("undecodable" in why for _, _, why in sim.hosts[4].engine.ignored) or any(
        e["platform"] == 4 for e in sim.report()["ignored_events"]
    )


def cmds_message(body: bytes) -> AppMessage:
    return AppMessage(topic=cmds.TOPIC_COMMAND, body=body)


def branched() -> TaskSim:
    """The deployed script started and branched: platform 3 runs C at 4 s."""
    sim, _ = deployed()
    sim.operate(lambda g, now: g.start(now))
    sim.swarm.run_until(3.0)
    sim.operate(lambda g, now: g.event("AtoBC_branch_event", now))
    sim.swarm.run_until(4.0)
    assert running(sim)[3] == ("C",)
    return sim


def merged_cleanly(sim: TaskSim) -> None:
    """The merge takes everyone back to A, with no invariant violated."""
    sim.operate(lambda g, now: g.event("finish_event", now))
    sim.swarm.run_until(8.0)
    assert all(actors == ("A",) for actors in running(sim).values())
    assert sim.report()["violations"] == []


def test_a_restarted_platform_resumes_from_its_latest_backup() -> None:
    sim = branched()
    sim.operate(lambda g, now: g.send(cmds.Backup(), [3], now))
    sim.swarm.run_until(4.5)
    sim.fault(Fault("restart", 4.5, frozenset({3})))
    sim.swarm.run_until(6.0)
    assert sim.swarm.node(3).incarnation == 1
    assert running(sim)[3] == ("C",), "resumed from the backup, not from the initial actor A"
    merged_cleanly(sim)  # it takes part in the merge as a C again
