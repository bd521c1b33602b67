"""Who replaces a lost platform (actorswarm.engine.promotion): the reports of where watched
platforms are, the data of ``X_lost``, and the candidates' bids — the nearest wins."""

from __future__ import annotations

import math
from pathlib import Path

import msgspec
import pytest

from actorswarm.core.events import AppReceived
from actorswarm.dsl import load
from actorswarm.engine.machine import TOPIC_WHEREABOUTS
from actorswarm.engine.plan import Plan
from actorswarm.engine.promotion import (
    NO_POSITION_BID,
    REPORT_DISTANCE,
    REPORT_INTERVAL,
    Whereabouts,
    lost_bid,
    lost_data,
    lost_groups,
    watched_actors,
)
from actorswarm.missions import mission_file
from actorswarm.sim.tasksim import Fault, TaskSim

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.fixture(scope="module")
def search_track() -> Plan:
    return Plan.build(load(mission_file("search_track_10.xml")))


def test_the_watched_actors_are_those_a_script_s_x_lost_rule_names(search_track: Plan) -> None:
    assert watched_actors(search_track) == {"Track"}
    assert watched_actors(Plan.build(load(mission_file("formation_30.xml")))) == frozenset()


def test_the_groups_to_hold_are_those_with_a_transition_on_the_event(search_track: Plan) -> None:
    assert lost_groups(search_track, ["Track_lost"]) == {4}
    assert lost_groups(search_track, ["Range_lost", "Standby_lost"]) == set()


def test_the_nearest_candidate_bids_lowest() -> None:
    data = lost_data(9, (600.0, 50.0, 15.0))
    assert data == {"platform": 9, "at": [600.0, 50.0, 15.0], "roles": []}
    near = lost_bid("Track_lost", data, (660.0, 30.0, 35.0))
    far = lost_bid("Track_lost", data, (300.0, -200.0, 35.0))
    assert near == pytest.approx(math.hypot(60.0, 20.0))  # horizontal distance
    assert far is not None and near is not None and near < far
    assert lost_bid("Track_lost", data, None) == NO_POSITION_BID
    assert far < NO_POSITION_BID, "a candidate that knows where it is goes first"


@pytest.mark.parametrize(
    ("event", "data"),
    [
        ("Track_lost", {"platform": 9, "at": None, "roles": []}),  # never reported
        ("Track_lost", 9),  # the bare ID a master before positions sent
        ("Track_lost", {"at": [1.0, 2.0, 3.0]}),  # no platform: not X_lost data
        ("Track_lost", {"platform": 9, "at": ["a", 2.0]}),
        ("Track_lost", {"platform": 9, "at": [math.nan, 2.0, 0.0]}),
        ("seen_event", {"platform": 9, "at": [1.0, 2.0, 3.0]}),  # not an X_lost
    ],
)
def test_no_position_no_distance_bid(event: str, data: object) -> None:
    """Every candidate then keeps the default bid (its platform ID)."""
    assert lost_bid(event, data, (0.0, 0.0, 0.0)) is None


def test_a_watched_platform_reports_when_it_moved_or_its_roles_changed() -> None:
    w = Whereabouts()
    assert w.due(0.0, watched=False, position=(0.0, 0.0, 20.0), roles=()) is None
    assert w.next_check(watched=False) is None
    first = w.due(0.0, watched=True, position=(0.0, 0.0, 20.0), roles=())
    assert first is not None
    # Too soon, then not far enough, then far enough.
    far = (REPORT_DISTANCE + 1.0, 0.0, 20.0)
    assert w.due(REPORT_INTERVAL / 2, watched=True, position=far, roles=()) is None
    near = (REPORT_DISTANCE - 1.0, 0.0, 20.0)
    assert w.due(REPORT_INTERVAL, watched=True, position=near, roles=()) is None
    assert w.next_check(watched=True) == pytest.approx(2 * REPORT_INTERVAL)
    assert w.due(2 * REPORT_INTERVAL, watched=True, position=far, roles=()) is not None
    # Same place, a new role: reported.
    t = 3 * REPORT_INTERVAL
    assert w.due(t, watched=True, position=far, roles={"track:jeep"}) is not None
    # A new master has heard nothing: reported at once.
    w.reset()
    assert w.due(t + 0.1, watched=True, position=far, roles={"track:jeep"}) is not None
    # Watched again after a while unwatched: reported at once.
    assert w.due(t + 0.2, watched=False, position=far, roles=()) is None
    assert w.due(t + 0.3, watched=True, position=far, roles=()) is not None


def test_the_master_keeps_the_last_report_and_forgets_it_when_the_platform_is_lost() -> None:
    member, master = Whereabouts(), Whereabouts()
    body = member.due(1.0, watched=True, position=(625.7, 55.9, 15.0), roles={"track:jeep"})
    assert body is not None
    master.heard(9, body)
    assert master.lost(9) == {"platform": 9, "at": [625.7, 55.9, 15.0], "roles": ["track:jeep"]}
    assert master.lost(9) == {"platform": 9, "at": None, "roles": []}, "forgotten"


def test_a_platform_without_a_position_reports_none_and_its_roles() -> None:
    member, master = Whereabouts(), Whereabouts()
    body = member.due(0.0, watched=True, position=None, roles={"track:jeep"})
    assert body is not None
    master.heard(4, body)
    assert master.lost(4) == {"platform": 4, "at": None, "roles": ["track:jeep"]}


@pytest.mark.parametrize("body", [b"", b"\xc1", msgspec.msgpack.encode({"at": "here"})])
def test_a_report_that_is_not_one_is_refused(body: bytes) -> None:
    with pytest.raises(msgspec.DecodeError):
        Whereabouts().heard(3, body)


def test_the_engine_logs_an_undecodable_report_and_goes_on() -> None:
    sim = TaskSim(load(EXAMPLES / "reorganize_lost.xml"), seed=1)
    engine = sim.hosts[1].engine
    engine.on_core_event(AppReceived(sender=3, topic=TOPIC_WHEREABOUTS, body=b"\xc1"), 0.0)
    assert engine.ignored[-1][1:] == (TOPIC_WHEREABOUTS, "undecodable message from 3")


def test_x_lost_s_data_reaches_the_promoted_platform() -> None:
    """Without a world no platform knows where it is: the data says so, and the promoted
    platform (the lowest ID, the default bids) finds it in its context."""
    sim = TaskSim(load(EXAMPLES / "reorganize_lost.xml"), seed=7)
    report = sim.run(6, faults=[Fault("kill", 3.0, frozenset({1}))])
    promoted = [t for t in report["transitions"] if t["event"] == "Track_lost"]
    assert [t["platform"] for t in promoted] == [2]
    context = sim.hosts[2].engine.runtime.acbs()["Track"].context
    assert isinstance(context.data, dict)
    assert context.data["event"] == {"platform": 1, "at": None, "roles": []}


MASTER_SCOUT = (
    '<TaskScript name="scout" version="1"><_ActorsConfig>'
    "<Actor><_P_Name>Scout</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>"
    '<Plugin><_P_Name>flight.goto</_P_Name><param key="target" value="280 0 20"/>'
    "</Plugin>"
    "</Bus></OODAConfig></Actor>"
    "<Actor><_P_Name>Wait</_P_Name></Actor>"
    '</_ActorsConfig><_TaskConfig><actor name="Wait">'
    '<transition name="Scout_lost" sysNum="1"><successor actor="Scout"/></transition>'
    "</actor></_TaskConfig><_PlatformActorConfig>"
    '<platform id="1" actor="Scout"/><platform id="2-4" actor="Wait"/>'
    "</_PlatformActorConfig></TaskScript>"
)
# Homes 100 m apart along x: 1 at 0, 2 at 100, 3 at 200, 4 at 300.
ROW = """
[fleet]
platforms = "1-4"
spacing = 100.0
columns = 4
[radio]
range = 2000.0
"""


def test_a_lost_master_is_replaced_by_the_platform_nearest_to_where_it_was() -> None:
    """The master (platform 1) runs the watched actor and dies near platform 4's home: its
    successor (platform 2, the lowest ID left) relays Scout_lost from the position the
    master posted to everyone, and platform 4 is promoted, not the lowest ID."""
    from actorswarm.dsl import check
    from actorswarm.world.config import loads_world

    result = check(MASTER_SCOUT, path="scout.xml")
    assert result.script is not None, [str(d) for d in result.diagnostics]
    sim = TaskSim(result.script, seed=3, world_config=loads_world(ROW))
    report = sim.run(70.0, faults=[Fault("kill", 60.0, frozenset({1}))])
    assert report["violations"] == []
    assert [m["platform"] for m in report["masters"]] == [1, 2]
    promoted = [t for t in report["transitions"] if t["event"] == "Scout_lost"]
    assert [t["platform"] for t in promoted] == [4], promoted
    context = sim.hosts[4].engine.runtime.acbs()["Scout"].context
    assert isinstance(context.data, dict)
    lost = context.data["event"]
    assert lost["platform"] == 1 and lost["roles"] == []
    assert math.dist(lost["at"][:2], (280.0, 0.0)) < 20.0, lost
