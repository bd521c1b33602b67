"""What the ground station tells the operator about platforms that did not answer, from
what it observed: verified heartbeats, acknowledgements, packets it could not verify."""

from __future__ import annotations

from collections.abc import Collection, Mapping
from pathlib import Path

from actorswarm.dsl.checker import check
from actorswarm.ground.silence import explain, platforms
from actorswarm.sim.tasksim import TaskSim

BRANCH_MERGE = Path(__file__).resolve().parents[2] / "examples" / "branch_merge.xml"


def _explain(
    *,
    targets: Collection[int] = (),
    answered: Collection[int] = (),
    heard: Collection[int] = (),
    acked: Collection[int] = (),
    rejected: Mapping[str, int] | None = None,
    refused_from: Mapping[str, Collection[int]] | None = None,
    listed: Collection[int] = (),
) -> list[str]:
    return explain(
        "field",
        targets=targets,
        answered=answered,
        heard=heard,
        acked=acked,
        rejected=rejected or {},
        refused_from=refused_from or {},
        listed=listed,
    )


def test_platform_lists_read_as_ranges() -> None:
    assert platforms([3]) == "platform 3"
    assert platforms([6, 1, 2, 3, 4, 5, 9]) == "platforms 1-6,9"


def test_every_target_answered_needs_no_explanation() -> None:
    assert _explain(targets=[1, 2], answered=[1, 2], heard=[1, 2], acked=[1, 2]) == []


def test_heard_but_never_acknowledging_platforms_are_said_to_refuse_the_packets() -> None:
    (line,) = _explain(targets=range(1, 7), heard=range(1, 7))
    assert line.startswith("no platform accepted the command: platforms 1-6 heard but ")
    assert "bad_signature" in line and "ground_station.pub" in line and "keys show" in line


def test_each_silent_platform_gets_the_reason_the_ground_station_can_see() -> None:
    lines = _explain(targets=[1, 2, 3, 4], answered=[1], heard=[1, 2, 3], acked=[1, 3])
    assert len(lines) == 3
    refused, slow, unheard = lines
    assert refused.startswith("platform 2 heard but acknowledged nothing")
    assert slow.startswith("platform 3 acknowledged but did not answer in time")
    assert unheard.startswith("platform 4 not heard") and "'field'" in unheard


def test_a_swarm_under_another_key_is_named_with_what_its_packets_claim() -> None:
    (line,) = _explain(rejected={"bad_tag": 12}, refused_from={"bad_tag": {1, 2, 3}})
    assert line.startswith(
        "heard 12 packet(s) of swarm 'field' (from platforms 1-3, as they claim) under a "
        "different swarm key (bad_tag)"
    )


def test_nothing_heard_at_all_says_so_and_where_a_platform_would_count_it() -> None:
    (line,) = _explain()
    assert line.startswith("no platform of swarm 'field' answered: nothing was heard")
    assert "bad_tag" in line and "--connect" in line


def test_members_behind_a_refusing_master_are_not_called_off() -> None:
    refused, unheard = _explain(targets=[1, 2, 3], heard=[1])
    assert refused.startswith("no platform accepted the command: platform 1 heard but")
    assert unheard.startswith("platforms 2-3 not heard: a star swarm's members are heard")


def test_a_member_known_from_the_roster_only_is_not_said_to_refuse() -> None:
    refused, behind = _explain(targets=[1, 2, 3], answered=[3], heard=[1, 2, 3], listed=[2])
    assert refused.startswith("platform 1 heard but acknowledged nothing")
    assert behind.startswith("platform 2 in the master's roster but acknowledged nothing")
    assert "no working link between here and them" in behind and "bad_signature" in behind


def test_a_star_swarm_members_are_listed_until_a_packet_of_their_own_comes() -> None:
    script = check(BRANCH_MERGE.read_text(), path=str(BRANCH_MERGE)).script
    assert script is not None
    sim = TaskSim(script, seed=3)
    sim.advance(6.0)
    station = sim.ground
    assert station is not None
    master = next(p for p, (_, is_master, _) in station.state.items() if is_master)
    assert set(station.heard) == set(range(1, 11))
    # Members heartbeat to their master only (some were heard on their own while the
    # first master was elected).
    assert master not in station.listed and len(station.listed) >= 5, station.listed
    sim.operate(lambda st, now: st.deploy(BRANCH_MERGE.read_bytes(), range(1, 11), now))
    sim.advance(12.0)
    assert not station.missing(station.deployed_sha)
    assert station.listed == set(), "each member's acknowledgements came straight here"
