"""The web ground station against a real swarm: three daemon processes on loopback over
Zenoh, and the page's protocol over a real server — deploy with every confirmation, start,
an event, and the switch seen in the platforms' status."""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from actorswarm.daemon.ground import GroundSession
from actorswarm.daemon.launch import LocalSwarm
from actorswarm.security.guard import PacketGuard
from actorswarm.transport.zenoh_transport import ZenohSettings
from actorswarm.web import RealSource, Server, Timeouts

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "tests" / "daemon" / "three.xml"


class Reader:
    """The socket's messages, kept: a step can arrive before the frame that shows it."""

    def __init__(self, ws: Any) -> None:
        self.ws = ws
        self.seen: list[dict[str, Any]] = []

    def until(
        self, wanted: Callable[[dict[str, Any]], bool], timeout: float = 30.0
    ) -> dict[str, Any]:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            message = json.loads(self.ws.recv(timeout=max(0.1, end - time.monotonic())))
            self.seen.append(message)
            if wanted(message):
                return message
        raise AssertionError(f"nothing wanted within {timeout} s")


def _done(request_id: str) -> Callable[[dict[str, Any]], bool]:
    return lambda m: m["type"] == "outcome" and m["id"] == request_id and m["state"] == "done"


def test_a_real_swarm_is_deployed_started_and_switched_from_the_page(tmp_path: Path) -> None:
    from websockets.sync.client import connect

    with LocalSwarm(tmp_path, 3, secure=False) as swarm:
        swarm.start_all()
        session = GroundSession(
            swarm.swarm,
            ZenohSettings(connect=tuple(swarm.endpoints), multicast=False),
            PacketGuard.insecure(),
        )
        source = RealSource(session, poll=0.5, timeouts=Timeouts(deploy=20.0, command=10.0))
        with (
            Server(source) as server,
            connect(
                server.url.replace("http", "ws", 1) + "ws", origin=server.url.rstrip("/")
            ) as ws,
        ):
            assert json.loads(ws.recv(timeout=10))["kind"] == "real"
            read = Reader(ws)
            # Formed: all three joined and a master elected (an event sent in the first
            # instants of a master, before the others joined its view, finds a
            # sysNum="all" of one: the master alone).
            read.until(
                lambda m: (
                    m["type"] == "swarm"
                    and m["master"] is not None
                    and sum(x["state"] == "joined" for x in m["members"]) == 3
                ),
                timeout=60.0,
            )
            text = SCRIPT.read_text()
            ws.send(json.dumps({"op": "deploy", "id": "d", "script": text, "name": "three.xml"}))
            deployed = read.until(_done("d"))
            assert deployed["ok"], deployed["message"]
            assert sorted(deployed["answers"]) == ["1", "2", "3"]
            ws.send(json.dumps({"op": "start", "id": "s"}))
            hello = read.until(lambda m: m["type"] == "hello")
            assert hello["script"]["name"] == "three"
            started = read.until(_done("s"))
            assert started["ok"], started["message"]
            read.until(lambda m: m["type"] == "frame" and m["counts"].get("A") == 3)
            ws.send(json.dumps({"op": "event", "id": "e", "name": "go_event"}))
            injected = read.until(_done("e"))
            assert injected["ok"], injected["message"]
            read.until(lambda m: m["type"] == "frame" and m["counts"].get("B") == 3)
            swarm_view = read.until(lambda m: m["type"] == "swarm")
    # The start and the switch, as the status replies showed them (a step is sent again
    # as it grows).
    steps = {s["id"]: s for m in read.seen if m["type"] == "steps" for s in m["steps"]}
    moved: dict[tuple[str, str], set[int]] = {}
    for s in steps.values():
        assert s["cause"] == "observed"
        moved.setdefault((s["from"], s["to"]), set()).update(s["platforms"])
    assert moved == {("", "A"): {1, 2, 3}, ("A", "B"): {1, 2, 3}}
    assert swarm_view["master"] in (1, 2, 3)
    assert all(m["script"] == hello["script"]["sha"][:12] for m in swarm_view["members"])
