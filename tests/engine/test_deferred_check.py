"""A deployed script checked later (as a daemon does, in a child process off its loop): the
acknowledgement waits for the verdict, retransmissions meanwhile start no second check, and
a refusal reaches the ground station as an in-line check's would."""

from __future__ import annotations

from pathlib import Path

from actorswarm.dsl import load
from actorswarm.dsl.isolated import ScriptRefused, check_in_process
from actorswarm.engine import commands as cmds
from actorswarm.sim.radio import LinkModel
from actorswarm.sim.tasksim import TaskSim

BRANCH = Path(__file__).resolve().parents[2] / "examples" / "branch_merge.xml"


def _deferred(text: bytes, loss: float) -> tuple[TaskSim, str, dict[int, list[str]]]:
    sim = TaskSim(load(BRANCH), seed=4, link=LinkModel(loss=loss), auto_start=False)
    owed: dict[int, list[str]] = {}
    for p, host in sim.hosts.items():
        owed[p] = []
        host.engine.check_later = lambda sha, _text, p=p: owed[p].append(sha)
    sim.swarm.run_until(1.0)
    sha = sim.operate(lambda gs, now: gs.deploy(text, range(1, 11), now))
    assert isinstance(sha, str)
    sim.swarm.run_until(3.0)  # long enough for many retransmissions of every chunk
    return sim, sha, owed


def test_the_ack_waits_for_the_verdict_and_one_check_is_started() -> None:
    text = BRANCH.read_bytes()
    sim, sha, owed = _deferred(text, loss=0.2)
    assert sim.ground is not None
    assert all(asked == [sha] for asked in owed.values()), owed
    assert sim.ground.missing(sha) == list(range(1, 11)), "no ack before the verdict"
    now = sim.swarm.now
    for host in sim.hosts.values():
        host.engine.checked(sha, check_in_process(text.decode(), "deploy"), now)
    sim.swarm.run_until(now + 2.0)
    assert sim.ground.missing(sha) == []


def test_a_refusal_given_later_reaches_the_ground_station() -> None:
    sim, sha, _ = _deferred(BRANCH.read_bytes(), loss=0.0)
    now = sim.swarm.now
    for host in sim.hosts.values():
        host.engine.checked(sha, ScriptRefused(f"deploy:{sha[:12]}:1:1: no"), now)
    sim.swarm.run_until(now + 1.0)
    assert sim.ground is not None
    refused = [r.reply for r in sim.ground.replies if isinstance(r.reply, cmds.Result)]
    assert len(refused) == 10 and all(not r.ok and "script refused" in r.message for r in refused)
    assert sim.ground.missing(sha) == list(range(1, 11))
