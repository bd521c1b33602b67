"""A simulated swarm that spans several radio hops: one swarm when the radio relays, none
when it does not, and the run's report says how many hops it spanned."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from actorswarm.dsl import check_file
from actorswarm.sim.tasksim import TaskSim, parse_event
from actorswarm.world.config import loads_world

ROOT = Path(__file__).resolve().parents[2]

#: Ten quadrotors on a line 90 m apart with a 100 m radio: nine hops end to end.
LINE = """
[fleet]
kind = "quadrotor"
spacing = 90.0
columns = 10
[radio]
range = 100.0
loss_at_range = 0.05
relay = {relay}
"""


def _branch_merge(relay: bool) -> dict[str, Any]:
    script = check_file(ROOT / "examples" / "branch_merge.xml").script
    assert script is not None
    run = TaskSim(script, seed=3, world_config=loads_world(LINE.format(relay=str(relay).lower())))
    events = [parse_event("AtoBC_branch_event@5"), parse_event("finish_event@10")]
    return run.run(15.0, events=events)


def test_a_relayed_line_of_ten_branches_and_merges_as_one_swarm() -> None:
    report = _branch_merge(relay=True)
    assert report["violations"] == []
    assert [m["platform"] for m in report["masters"]][-1] == 1
    by_barrier = [r for r in report["transitions"] if r["cause"] == "barrier"]
    branched = [r["to"] for r in by_barrier if r["event"] == "AtoBC_branch_event"]
    assert sorted(branched) == ["B"] * 2 + ["C"] * 8
    assert sum(r["event"] == "finish_event" for r in by_barrier) == 10
    assert report["radio"] == {"relay": True, "hops_at_start": 9, "most_hops": 9,
                               "most_groups": 1, "split_s": 0.0, "samples": 15}  # fmt: skip


def test_without_relays_the_line_never_becomes_one_swarm() -> None:
    """Each platform hears only its neighbours: several masters, no barrier of ten. The
    invariants of one connected swarm are not asked of such a line (it is no stable
    network), and the summary says why."""
    report = _branch_merge(relay=False)
    assert report["violations"] == []
    assert len({m["platform"] for m in report["masters"]}) > 1
    assert not [r for r in report["transitions"] if r["cause"] == "barrier"]
    assert report["radio"]["relay"] is False and report["radio"]["most_hops"] == 9


def test_relays_sending_packets_on_are_counted_on_the_air() -> None:
    """The line of ten: most of the swarm is several hops from its master, so relays
    carry much of the air; the same run's packets without relaying are its own alone."""
    report = _branch_merge(relay=True)
    channel = report["channel"]
    assert channel["relayed"] > 0
    # Each broadcast from an end of the line is sent on by up to 8 relays: the relays'
    # share is a large part of the air, below what 9 relays per packet would give.
    share = channel["relayed"] / channel["packets"]
    assert 0.3 < share < 0.9, share
    assert _branch_merge(relay=False)["channel"]["relayed"] == 0
