"""The web ground station's HTTP and WebSocket protocol, against a simulated swarm, with
FastAPI's test client: what a page is sent, what its requests do, and who is let in."""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient
from starlette.websockets import WebSocketDisconnect

from actorswarm.dsl import check
from actorswarm.web import Access, SimSource, create_app

ROOT = Path(__file__).resolve().parents[2]
BRANCH_MERGE = ROOT / "examples" / "branch_merge.xml"
LOCAL = "http://127.0.0.1:8765"
TOKEN = "a-long-enough-token"

BROKEN = """<TaskScript name="broken" version="1">
  <_ActorsConfig>
    <Actor><_P_Name>A</_P_Name>
      <OODAConfig><Bus><_P_Name>act_bus</_P_Name><Plugin><_P_Name>core.idle</_P_Name></Plugin></Bus></OODAConfig>
    </Actor>
  </_ActorsConfig>
  <_TaskConfig>
    <actor name="A">
      <transition name="go" sysNum="2"><successor actor="Nowhere"/></transition>
    </actor>
  </_TaskConfig>
  <_PlatformActorConfig><platform id="1-2" actor="A"/></_PlatformActorConfig>
</TaskScript>
"""


@contextmanager
def served(
    source: SimSource, access: Access | None = None, base_url: str = LOCAL
) -> Iterator[TestClient]:
    with TestClient(create_app(source, access=access), base_url=base_url) as client:
        yield client


Socket = Any  # starlette's WebSocketTestSession


def connect(client: TestClient, path: str = "/ws", **options: Any) -> Socket:
    """A WebSocket to the client's own host (the test client's default host is
    "testserver", which a loopback-only server refuses)."""
    return client.websocket_connect(str(client.base_url).replace("http", "ws", 1) + path, **options)


def until(
    ws: Socket, wanted: Callable[[dict[str, Any]], bool], timeout: float = 20.0
) -> dict[str, Any]:
    """Read messages until one is ``wanted`` (frames come ten times a second, so this
    never waits long between looks at the clock)."""
    end = time.monotonic() + timeout
    seen: list[str] = []
    while time.monotonic() < end:
        message = json.loads(ws.receive_text())
        if wanted(message):
            return message
        seen.append(message["type"])
    raise AssertionError(f"nothing wanted within {timeout} s; saw {seen[-20:]}")


def all_joined(ws: Socket) -> None:
    """Wait until the ground station has heard every platform (a command without a
    platform list goes to those)."""
    until(
        ws,
        lambda m: (
            m["type"] == "swarm"
            and bool(m["members"])
            and all(x["state"] == "joined" for x in m["members"])
        ),
    )


def done(request_id: str) -> Callable[[dict[str, Any]], bool]:
    return lambda m: m["type"] == "outcome" and m["id"] == request_id and m["state"] == "done"


def test_a_page_gets_hello_swarm_and_frame_first(branch_merge: Callable[..., SimSource]) -> None:
    with served(branch_merge()) as client, connect(client) as ws:
        hello, swarm, frame = (json.loads(ws.receive_text()) for _ in range(3))
    assert hello["type"] == "hello" and hello["kind"] == "sim"
    assert hello["script"]["actors"] == ["A", "B", "C"]
    assert {"AtoBC_branch_event", "finish_event"} == set(hello["script"]["events"])
    assert {n["name"] for n in hello["script"]["graph"]["nodes"]} == {"A", "B", "C"}
    assert swarm["type"] == "swarm" and [m["id"] for m in swarm["members"]] == list(range(1, 11))
    assert frame["type"] == "frame" and frame["ids"] == list(range(1, 11))
    assert frame["x"] is None  # no world: no positions


def test_page_files_and_state_are_served(branch_merge: Callable[..., SimSource]) -> None:
    with served(branch_merge()) as client:
        page = client.get("/")
        assert page.status_code == 200 and 'id="map"' in page.text
        script = client.get("/static/main.js")
        assert script.status_code == 200 and "javascript" in script.headers["content-type"]
        state = client.get("/api/state").json()
    assert state["hello"]["kind"] == "sim" and len(state["frame"]["ids"]) == 10


def test_an_injected_event_switches_the_swarm(branch_merge: Callable[..., SimSource]) -> None:
    with served(branch_merge(speed=5.0)) as client, connect(client) as ws:
        all_joined(ws)
        ws.send_text(json.dumps({"op": "event", "id": "e1", "name": "AtoBC_branch_event"}))
        outcome = until(ws, done("e1"))
        assert outcome["ok"], outcome["message"]
        assert len(outcome["answers"]) == 10
        assert "10 of 10: event AtoBC_branch_event delivered" in outcome["message"]
        frame = until(ws, lambda m: m["type"] == "frame" and m["counts"].get("C") == 8)
        assert frame["counts"] == {"B": 2, "C": 8}


def test_steps_name_the_event_group_participants_and_switch_time(
    branch_merge: Callable[..., SimSource],
) -> None:
    with served(branch_merge(speed=5.0)) as client, connect(client) as ws:
        all_joined(ws)
        ws.send_text(json.dumps({"op": "event", "id": "e1", "name": "AtoBC_branch_event"}))
        seen: dict[str, dict[str, Any]] = {}

        def both(m: dict[str, Any]) -> bool:
            for s in m.get("steps", []) if m["type"] == "steps" else []:
                seen[s["to"]] = s
            return (
                len(seen.get("B", {}).get("platforms", [])) == 2
                and len(seen.get("C", {}).get("platforms", [])) == 8
            )

        until(ws, both)
    for to in ("B", "C"):
        step = seen[to]
        assert step["event"] == "AtoBC_branch_event" and step["from"] == "A"
        assert step["key"] == 4 and step["cause"] == "barrier"
        assert 0 <= step["switch_ms"] < 100


def test_a_broken_script_is_reported_with_line_and_column(
    branch_merge: Callable[..., SimSource],
) -> None:
    expected = [(d.line, d.col) for d in check(BROKEN, path="broken.xml").errors]
    assert expected, "the fixture script must be broken"
    with served(branch_merge()) as client, connect(client) as ws:
        ws.send_text(
            json.dumps({"op": "deploy", "id": "d1", "script": BROKEN, "name": "broken.xml"})
        )
        outcome = until(ws, done("d1"))
    assert outcome["ok"] is False
    got = [(d["line"], d["col"]) for d in outcome["diagnostics"] if d["severity"] == "error"]
    assert got == expected
    line, col = expected[0]
    assert f"line {line}, column {col}" in outcome["message"]
    assert "Nowhere" in outcome["diagnostics"][0]["message"]
    assert outcome["targets"] == []  # refused before anything was sent


def test_deploy_shows_each_confirmation_then_start_runs_it(
    branch_merge: Callable[..., SimSource],
) -> None:
    text = BRANCH_MERGE.read_text()
    with (
        served(branch_merge(auto_start=False, speed=5.0)) as client,
        connect(client) as ws,
    ):
        until(
            ws,
            lambda m: (
                m["type"] == "swarm"
                and len(m["members"]) == 10
                and all(x["state"] == "joined" for x in m["members"])
            ),
        )
        ws.send_text(json.dumps({"op": "start", "id": "s0"}))
        refused = until(ws, done("s0"))
        assert not refused["ok"] and "deploy a script first" in refused["message"]
        ws.send_text(json.dumps({"op": "deploy", "id": "d1", "script": text, "name": "bm.xml"}))
        deployed = until(ws, done("d1"))
        assert deployed["ok"], deployed["message"]
        assert sorted(int(p) for p in deployed["answers"]) == list(range(1, 11))
        assert all(a["message"].startswith("confirmed ") for a in deployed["answers"].values())
        ws.send_text(json.dumps({"op": "start", "id": "s1"}))
        hello = until(ws, lambda m: m["type"] == "hello")
        assert hello["script"]["sha"] and hello["script"]["name"] == "branch-merge"
        started = until(ws, done("s1"))
        assert started["ok"], started["message"]
        frame = until(ws, lambda m: m["type"] == "frame" and m["counts"].get("A") == 10)
        assert frame["a"] == [0] * 10


def test_operator_commands_report_their_outcome(branch_merge: Callable[..., SimSource]) -> None:
    with served(branch_merge(speed=5.0)) as client, connect(client) as ws:
        all_joined(ws)

        def ask(request: dict[str, Any]) -> dict[str, Any]:
            ws.send_text(json.dumps(request))
            return until(ws, done(request["id"]))

        paused = ask({"op": "pause", "id": "p", "actor": "A", "platforms": "1"})
        assert paused["ok"] and paused["answers"]["1"]["message"] == "paused A"
        ws.send_text(json.dumps({"op": "inspect", "platform": 1}))
        acb = until(ws, lambda m: m["type"] == "acb")
        assert acb["platform"] == 1 and acb["acbs"]["A"]["status"] == "sleeping"
        assert ask({"op": "activate", "id": "a", "actor": "A", "platforms": "1"})["ok"]
        forced = ask({"op": "force", "id": "f", "to": "C", "src": "A", "platforms": "2"})
        assert forced["ok"] and forced["answers"]["2"]["message"] == "A -> C"
        backup = ask({"op": "backup", "id": "b", "platforms": "1-3"})
        assert backup["ok"] and "backup generation" in backup["answers"]["3"]["message"]
        bad = ask({"op": "stop_actor", "id": "x", "actor": "Nope", "platforms": "4"})
        assert not bad["ok"] and "FAILED" in bad["message"]
        ids = ask({"op": "event", "id": "i", "name": "x", "platforms": "5-1"})
        assert not ids["ok"] and ids["message"].startswith("platforms:")
        paced = ask({"op": "speed", "id": "v", "speed": 8})
        assert paced["ok"]
        assert until(ws, lambda m: m["type"] == "frame")["speed"] == 8


def test_a_request_that_cannot_be_read_is_refused(branch_merge: Callable[..., SimSource]) -> None:
    with served(branch_merge()) as client, connect(client) as ws:
        ws.send_text('{"op": "launch", "id": "q1"}')
        outcome = until(ws, lambda m: m["type"] == "outcome")
        ws.send_text("not json at all")
        other = until(ws, lambda m: m["type"] == "outcome")
    assert outcome["id"] == "q1" and outcome["ok"] is False and "bad request" in outcome["message"]
    assert other["ok"] is False and "JSON" in other["message"]


def test_the_loopback_server_answers_only_to_loopback_names(
    branch_merge: Callable[..., SimSource],
) -> None:
    with served(branch_merge(), base_url="http://evil.example:8765") as client:
        assert client.get("/").status_code == 421
        with pytest.raises(WebSocketDisconnect), connect(client) as ws:
            ws.receive_text()


def test_a_foreign_page_cannot_open_the_socket(branch_merge: Callable[..., SimSource]) -> None:
    with served(branch_merge()) as client:
        with (
            pytest.raises(WebSocketDisconnect),
            connect(client, "/ws", headers={"origin": "http://evil.example"}) as ws,
        ):
            ws.receive_text()
        with connect(client, "/ws", headers={"origin": LOCAL}) as ws:
            assert json.loads(ws.receive_text())["type"] == "hello"


def test_off_the_loopback_every_request_needs_the_token(
    branch_merge: Callable[..., SimSource],
) -> None:
    access = Access(token=TOKEN, local_only=False)
    with served(branch_merge(), access, base_url="http://10.0.0.5:8765") as client:
        assert client.get("/").status_code == 401
        assert client.get("/static/main.js").status_code == 401
        assert client.get("/?token=wrong-token-value").status_code == 401
        with pytest.raises(WebSocketDisconnect), connect(client) as ws:
            ws.receive_text()
        page = client.get(f"/?token={TOKEN}")
        assert page.status_code == 200 and "actorswarm_token" in page.headers["set-cookie"]
        # The cookie set from the address lets the page's files and socket in.
        assert client.get("/static/main.js").status_code == 200
        with connect(client) as ws:
            assert json.loads(ws.receive_text())["type"] == "hello"
        client.cookies.clear()
        headers = {"authorization": f"Bearer {TOKEN}"}
        assert client.get("/api/state", headers=headers).status_code == 200
        with connect(client, f"/ws?token={TOKEN}") as ws:
            assert json.loads(ws.receive_text())["type"] == "hello"


def test_a_script_naming_an_area_the_world_lacks_is_refused_before_sending() -> None:
    """The simulation runs in a world with two areas: a script naming another is refused,
    checked or deployed, with task check --world's message; the same script is not judged
    where no world is known."""
    import dataclasses

    from actorswarm.dsl import load
    from actorswarm.sim.tasksim import TaskSim
    from actorswarm.web import Timeouts
    from actorswarm.world.config import Area, WorldConfig

    good = (ROOT / "examples" / "search_track_10.xml").read_text()
    bad = good.replace(
        '<param key="area" value="search"/><param key="altitude"',
        '<param key="area" value="serch"/><param key="altitude"',
    )
    assert bad != good
    areas = (Area.rect("field", -50, -50, 450, 450), Area.rect("search", 0, 0, 400, 400))
    world = dataclasses.replace(WorldConfig.defaults(range(1, 11)), areas=areas)
    expected = [
        (d.line, d.col, d.message)
        for d in check(bad, path="serch.xml", areas=["field", "search"]).errors
    ]
    assert len(expected) == 1 and "the world has no area 'serch'" in expected[0][2]
    sim = TaskSim(load(BRANCH_MERGE), seed=1, auto_start=False, world_config=world)
    source = SimSource(sim, speed=4.0, timeouts=Timeouts(deploy=5.0, command=4.0))
    with served(source) as client, connect(client) as ws:
        for op, text, name in [("check", good, "good.xml"), ("check", bad, "serch.xml"),
                               ("deploy", bad, "serch.xml")]:  # fmt: skip
            ws.send_text(json.dumps({"op": op, "id": op + name, "script": text, "name": name}))
            outcome = until(ws, done(op + name))
            if name == "good.xml":
                assert outcome["ok"], outcome["message"]
                continue
            assert outcome["ok"] is False
            got = [
                (d["line"], d["col"], d["message"])
                for d in outcome["diagnostics"]
                if d["severity"] == "error"
            ]
            assert got == expected
            assert f"line {expected[0][0]}, column {expected[0][1]}" in outcome["message"]
            assert outcome["targets"] == []
        assert source.station.deployed_sha == ""  # nothing was sent


def test_without_a_world_area_names_are_not_judged(
    branch_merge: Callable[..., SimSource],
) -> None:
    text = (
        (ROOT / "examples" / "search_track_10.xml")
        .read_text()
        .replace('value="search"', 'value="serch"')
    )
    with served(branch_merge()) as client, connect(client) as ws:
        ws.send_text(json.dumps({"op": "check", "id": "c", "script": text, "name": "s.xml"}))
        outcome = until(ws, done("c"))
    assert outcome["ok"], outcome["message"]
