"""The web ground station's parts on their own: request codec, access rules, timeline,
state-machine layout, membership."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from actorswarm.core.config import CoreConfig
from actorswarm.dsl import load
from actorswarm.ground.membership import Membership
from actorswarm.ground.station import GroundStation
from actorswarm.web import SimSource, protocol
from actorswarm.web.access import Access, is_loopback, policy
from actorswarm.web.graph_layout import layout
from actorswarm.web.real_source import observed
from actorswarm.web.timeline import Timeline

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize(
    ("text", "kind"),
    [
        ('{"op": "event", "name": "go", "platforms": "1-3"}', protocol.Event),
        ('{"op": "force", "to": "B", "src": null, "params": {"k": "v"}}', protocol.Force),
        ('{"op": "deploy", "script": "<x/>", "name": "a.xml"}', protocol.Deploy),
        ('{"op": "start", "force": true, "id": "p-1"}', protocol.Start),
        ('{"op": "inspect", "platform": 7}', protocol.Inspect),
        ('{"op": "speed", "speed": 2.5}', protocol.Speed),
        ('{"op": "stop_actor", "actor": "A"}', protocol.StopActor),
    ],
)
def test_requests_decode(text: str, kind: type) -> None:
    assert isinstance(protocol.decode(text), kind)


@pytest.mark.parametrize(
    ("text", "says"),
    [
        ("not json", "not a JSON request"),
        ('{"op": "launch"}', "bad request"),
        ('{"op": "event"}', "name"),
        ('{"op": "event", "name": "x", "extra": 1}', "extra"),
        ('{"op": "inspect", "platform": 0}', "platform"),
        ('{"op": "speed", "speed": 0}', "speed"),
        ("[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[", "request"),
    ],
)
def test_bad_requests_say_what_is_wrong(text: str, says: str) -> None:
    with pytest.raises(protocol.ProtocolError, match=says):
        protocol.decode(text)


@pytest.mark.parametrize(
    ("host", "loopback"),
    [
        ("127.0.0.1", True),
        ("localhost", True),
        ("::1", True),
        ("[::1]", True),
        ("127.0.0.2", True),
        ("0.0.0.0", False),
        ("192.168.1.10", False),
        ("evil.example", False),
    ],
)
def test_loopback_names(host: str, loopback: bool) -> None:
    assert is_loopback(host) is loopback


def test_policy_asks_a_token_off_the_loopback() -> None:
    assert policy("127.0.0.1", None) == Access(token=None, local_only=True)
    remote = policy("0.0.0.0", None)
    assert remote.token and len(remote.token) >= 16 and not remote.local_only
    assert policy("0.0.0.0", "chosen-token-123").token == "chosen-token-123"


def test_token_host_and_origin_checks() -> None:
    access = Access(token="s3cret-token-x", local_only=True)
    assert access.token_ok(query="s3cret-token-x", cookie=None, authorization=None)
    assert access.token_ok(query=None, cookie="s3cret-token-x", authorization=None)
    assert access.token_ok(query=None, cookie=None, authorization="Bearer s3cret-token-x")
    assert not access.token_ok(query="wrong", cookie=None, authorization="Bearer nope")
    assert not access.token_ok(query=None, cookie=None, authorization=None)
    assert access.host_ok("127.0.0.1:8765") and access.host_ok("localhost")
    assert not access.host_ok("evil.example:8765") and not access.host_ok(None)
    assert Access.origin_ok(None, "127.0.0.1:8765")
    assert Access.origin_ok("http://127.0.0.1:8765", "127.0.0.1:8765")
    assert not Access.origin_ok("http://evil.example", "127.0.0.1:8765")


def _rec(
    t: float, p: int, src: str, dst: str, event: str = "go", cause: str = "barrier"
) -> dict[str, Any]:
    return {"t": t, "platform": p, "from": src, "to": dst, "event": event, "cause": cause}


def test_timeline_groups_switches_and_grows_steps() -> None:
    timeline = Timeline(load(ROOT / "examples" / "branch_merge.xml"))
    first = timeline.add(
        [_rec(0.0, 1, "", "A", "", "start"), _rec(5.0, 1, "A", "B", "AtoBC_branch_event")]
    )
    assert [s.platforms for s in first] == [[1]]
    later = timeline.add(
        [
            _rec(5.02, 2, "A", "B", "AtoBC_branch_event"),
            _rec(5.02, 3, "A", "C", "AtoBC_branch_event"),
            _rec(7.5, 4, "A", "B", "AtoBC_branch_event"),  # beyond the window: a new step
        ]
    )
    assert [(s.id, s.platforms) for s in later] == [(1, [1, 2]), (2, [3]), (3, [4])]
    step = timeline.steps[0].to_json()
    assert step["key"] == 4 and step["switch_ms"] == 20.0 and step["from"] == "A"


def test_layout_draws_the_task_graph_edges() -> None:
    script = load(ROOT / "examples" / "formation_30.xml")
    drawn = layout(script)
    nodes = {n["name"]: n for n in drawn["nodes"]}
    assert set(nodes) == {a.name for a in script.actors}
    assert nodes["Standby"]["initial"] == "1-30" and nodes["Standby"]["layer"] == 0
    assert nodes["A"]["layer"] < nodes["B"]["layer"] < nodes["C"]["layer"] < nodes["D"]["layer"]
    back = {(e["source"], e["target"]) for e in drawn["edges"] if e["back"]}
    assert ("E", "A") in back and ("B", "B") in back
    assert all(n["x"] >= 0 and n["x"] + n["w"] <= drawn["width"] for n in nodes.values())
    assert all(n["y"] + n["h"] <= drawn["height"] for n in nodes.values())


def _overlap(a: dict[str, float], b: dict[str, float]) -> bool:
    return (
        a["x"] < b["x"] + b["w"]
        and b["x"] < a["x"] + a["w"]
        and a["y"] < b["y"] + b["h"]
        and b["y"] < a["y"] + a["h"]
    )


@pytest.mark.parametrize(
    "path",
    [
        ROOT / "tests" / "web" / "recall_all.xml",
        ROOT / "examples" / "formation_30.xml",
        ROOT / "examples" / "search_track_10.xml",
        ROOT / "examples" / "branch_merge.xml",
    ],
    ids=lambda p: p.stem,
)
def test_layout_keeps_labels_and_actors_apart(path: Path) -> None:
    """No label box covers another or an actor, actors do not touch, every actor is as
    wide as its name, and every edge runs from its source's box to its target's."""
    from actorswarm.web.graph_layout import name_width

    drawn = layout(load(path))
    nodes = {n["name"]: n for n in drawn["nodes"]}
    labels = [e["box"] for e in drawn["edges"] if e["box"] is not None]
    boxes = labels + list(nodes.values())
    for i, a in enumerate(boxes):
        assert a["x"] >= 0 and a["x"] + a["w"] <= drawn["width"] + 0.5, a
        assert a["y"] >= 0 and a["y"] + a["h"] <= drawn["height"] + 0.5, a
        for b in boxes[i + 1 :]:
            assert not _overlap(a, b), (a, b)
    for n in nodes.values():
        assert n["w"] >= name_width(n["name"]) - 0.1
    for e in drawn["edges"]:
        a, b = nodes[e["source"]], nodes[e["target"]]
        (x0, y0), (x1, y1) = e["points"][0], e["points"][-1]
        if e["source"] == e["target"]:  # a loop, on the actor's right side
            assert x0 == x1 == pytest.approx(a["x"] + a["w"], abs=0.1), e
            assert a["y"] < y0 < y1 < a["y"] + a["h"], e
            continue
        assert a["x"] <= x0 <= a["x"] + a["w"] and y0 in (a["y"], a["y"] + a["h"]), e
        assert b["x"] <= x1 <= b["x"] + b["w"] and y1 in (b["y"], b["y"] + b["h"]), e


def test_layout_labels_a_recall_from_every_actor_once_each_and_a_branch_once() -> None:
    drawn = layout(load(ROOT / "tests" / "web" / "recall_all.xml"))
    recalls = [e for e in drawn["edges"] if e["event"] == "recall_event"]
    assert {e["source"] for e in recalls} == {
        "Standby", "Ingress", "Search", "Track", "Overwatch", "Relay"
    }  # fmt: skip
    assert all(e["target"] == "Return" and e["text"] == "recall_event" for e in recalls)
    # The edges into Return meet it at different places.
    ends = [e["points"][-1][0] for e in recalls]
    assert len(set(ends)) == len(ends)
    split = [e for e in drawn["edges"] if e["event"] == "split_event"]
    assert sorted(e["target"] for e in split) == ["Overwatch", "Track"]
    assert sorted(e["text"] for e in split) == ["", "split_event"], "a branch is labelled once"
    names = {n["name"]: n for n in drawn["nodes"]}
    assert names["Overwatch"]["w"] > names["Track"]["w"], "as wide as its name"


def test_membership_logs_joins_and_leaves() -> None:
    station = GroundStation(swarm="s")
    members = Membership(t_leave=0.5)
    station.heard, station.state = {1: 0.0, 2: 0.0}, {1: (0, True, 3), 2: (0, False, 3)}
    members.update(station, 0.1, expected=[1, 2, 3])
    assert [m.state for m in members.members.values()] == ["joined", "joined", "unheard"]
    assert members.master() == (1, 3)
    members.update(station, 2.0, expected=[1, 2, 3])
    assert members.alive() == [] and members.master() == (None, None)
    assert [(e["platform"], e["what"]) for e in members.log] == [
        (1, "joined"),
        (2, "joined"),
        (1, "left"),
        (2, "left"),
    ]


def test_a_quiet_star_platform_at_boot_has_not_left() -> None:
    """Before the first master, a star platform that hears a lower ID keeps quiet: heard
    once at boot, it waits for the election, and leaves only if still silent after it."""
    station = GroundStation(swarm="s")
    members = Membership(t_leave=0.5)
    station.heard = dict.fromkeys((1, 2, 3), 0.0)
    station.state = dict.fromkeys((1, 2, 3), (0, False, 0))
    members.update(station, 0.1)
    for now in (0.2, 0.3, 0.4):  # platform 1 heartbeats; 2 and 3 keep quiet
        station.heard[1] = now
        members.update(station, now + 0.3)
    assert members.alive() == [1, 2, 3]
    station.heard[1], station.state[1] = 1.0, (0, True, 1)  # 1 claims; 2 joins its roster
    station.heard[2] = 1.0
    for now in (1.0, 1.2):
        station.heard[1] = station.heard[2] = now
        members.update(station, now)
    assert members.alive() == [1, 2, 3], "quiet until 0.7 s, the last look without a master"
    station.heard[1] = station.heard[2] = 1.4
    members.update(station, 1.4)
    assert members.alive() == [1, 2], "3 was still silent a leave timeout after the claim"
    assert [(e["t"], e["platform"], e["what"]) for e in members.log] == [
        (0.1, 1, "joined"),
        (0.1, 2, "joined"),
        (0.1, 3, "joined"),
        (1.4, 3, "left"),
    ]
    # Everyone broadcasts in the paper's scheme: a silence is a silence.
    broadcast = GroundStation(swarm="s", config=CoreConfig(membership="broadcast"))
    broadcast.heard, broadcast.state = dict(station.heard), dict(station.state)
    broadcast.heard.update({1: 0.7, 2: 0.0, 3: 0.0})
    broadcast.state[1] = (0, False, 0)
    plain = Membership(t_leave=0.5)
    plain.update(broadcast, 0.1)
    plain.update(broadcast, 0.7)
    assert plain.alive() == [1]


def test_a_lossless_simulation_logs_no_leave_at_boot(
    branch_merge: Callable[..., SimSource],
) -> None:
    source = branch_merge()
    for _ in range(100):  # 2 s: the boot's quiet, the election, the roster
        source.step(0.02)
        source.look()
    assert [(e["platform"], e["what"]) for e in source.membership.log] == [
        (p, "joined") for p in range(1, 11)
    ]


def test_observed_switches_pair_old_and_new_actors() -> None:
    assert observed(1.0, 4, ("A",), ("B",)) == [
        {"t": 1.0, "platform": 4, "from": "A", "to": "B", "event": "", "cause": "observed"}
    ]
    assert [(r["from"], r["to"]) for r in observed(1.0, 4, ("A", "X"), ("B",))] == [
        ("A", "B"),
        ("X", ""),
    ]


def test_the_public_names_exist() -> None:
    from actorswarm import web

    assert sorted(web.__all__) == sorted(set(web.__all__))
    assert not [name for name in web.__all__ if not hasattr(web, name)]
