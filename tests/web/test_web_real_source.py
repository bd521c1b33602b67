"""The real-swarm source's logic — status polling, observed switches, commands — over a
stand-in for the Zenoh session whose "platforms" answer at once. (The session itself is
tested with real daemons in tests/daemon.)"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any, TypeVar

from actorswarm.daemon.loop import clock
from actorswarm.dsl import load
from actorswarm.engine import commands as cmds
from actorswarm.ground.station import GroundStation, ReplyRecord
from actorswarm.web import RealSource
from actorswarm.web import protocol as proto

ROOT = Path(__file__).resolve().parents[2]
_T = TypeVar("_T")


class FakeSwarm:
    """Three platforms running A; an ``AtoBC_branch_event`` sends them to B."""

    def __init__(self, station: GroundStation) -> None:
        self.station = station
        self.actors = {p: {"A": "running"} for p in (1, 2, 3)}
        #: What each platform's vehicle adapter says of itself (none: nothing).
        self.vehicles: dict[int, dict[str, Any]] = {}
        #: The roles each platform holds (none: none).
        self.roles: dict[int, list[str]] = {}
        station.send = self.answer  # type: ignore[method-assign]

    def beat(self) -> None:
        now = clock()
        for p in self.actors:
            self.station.heard[p] = now
            self.station.state[p] = (0, p == 1, 2)

    def answer(self, command: cmds.Command, platforms: Any, now: float) -> None:
        for p in sorted(set(platforms)):
            reply: cmds.Reply
            if isinstance(command, cmds.Status):
                acbs = {
                    a: {"name": a, "status": s, "stats": {"switch_count": 1}}
                    for a, s in self.actors[p].items()
                }
                reply = cmds.StatusReply(
                    actors=dict(self.actors[p]),
                    master=p == 1,
                    epoch=2,
                    incarnation=0,
                    acbs=acbs,
                    vehicle=self.vehicles.get(p, {}),
                    roles=self.roles.get(p, []),
                )
            elif isinstance(command, cmds.Inject):
                self.actors[p] = {"B": "running"}
                reply = cmds.Result(
                    command="Inject", ok=True, message=f"event {command.event} delivered"
                )
            else:
                reply = cmds.Result(command=type(command).__name__, ok=False, message="not here")
            self.station.replies.append(ReplyRecord(now, p, reply))


class FakeSession:
    swarm = "fake"

    def __init__(self) -> None:
        self.station = GroundStation(swarm=self.swarm, now=clock())
        self.platforms = FakeSwarm(self.station)
        self.entered = False

    async def __aenter__(self) -> FakeSession:
        self.entered = True
        return self

    async def __aexit__(self, *exc: object) -> None:
        self.entered = False

    def do(self, action: Callable[[GroundStation, float], _T]) -> _T:
        return action(self.station, clock())


async def _eventually(check: Callable[[], bool], timeout: float = 5.0) -> None:
    end = clock() + timeout
    while not check():
        assert clock() < end, "the condition never held"
        await asyncio.sleep(0.02)


def test_real_source_polls_status_and_sees_the_switch() -> None:
    async def scenario() -> dict[str, Any]:
        session = FakeSession()
        script = load(ROOT / "examples" / "branch_merge.xml")
        source = RealSource(session, script=script, poll=0.1)  # type: ignore[arg-type]
        await source.start()
        beating = True

        async def heartbeats() -> None:
            while beating:
                session.platforms.beat()
                await asyncio.sleep(0.05)

        beats = asyncio.create_task(heartbeats())
        try:
            await _eventually(lambda: session.entered and source.acbs(3) is not None)
            frame = source.frame()
            assert frame["ids"][:3] == [1, 2, 3] and frame["x"] is None
            assert frame["counts"] == {"A": 3} and frame["f"][0] & 1  # platform 1 is master
            outcome = await source.execute(proto.Event(name="AtoBC_branch_event", id="e"))
            assert outcome["ok"] and outcome["targets"] == [1, 2, 3]
            await _eventually(lambda: any(s.dst == "B" for s in source.timeline.steps))
            swarm = source.swarm_view()
            refused = await source.execute(proto.Speed(speed=2.0, id="s"))
            return {
                "steps": [s.to_json() for s in source.timeline.steps],
                "swarm": swarm,
                "refused": refused,
            }
        finally:
            beating = False
            await beats
            await source.stop()
            assert not session.entered, "stopping the source leaves the session"

    # A thread of its own: Playwright's sync API keeps an event loop in this one when the
    # browser tests ran first.
    with ThreadPoolExecutor(1) as thread:
        result = thread.submit(asyncio.run, scenario()).result()
    (step,) = result["steps"]
    assert (step["from"], step["to"], step["cause"]) == ("A", "B", "observed")
    assert step["platforms"] == [1, 2, 3]
    swarm = result["swarm"]
    assert swarm["master"] == 1 and swarm["epoch"] == 2
    assert [m["actors"][0]["name"] for m in swarm["members"][:3]] == ["B", "B", "B"]
    assert result["refused"]["ok"] is False and "simulation" in result["refused"]["message"]


def test_a_real_swarm_given_its_world_draws_its_areas_and_judges_area_names() -> None:
    from actorswarm.world.config import Area, WorldConfig

    world = WorldConfig(areas=(Area.rect("search", 0, 0, 100, 50),))
    good = (ROOT / "examples" / "search_track_10.xml").read_text()
    bad = good.replace('value="search"', 'value="serch"')

    async def scenario() -> tuple[dict[str, Any], dict[str, Any], dict[str, Any]]:
        source = RealSource(FakeSession(), world=world)  # type: ignore[arg-type]
        blind = RealSource(FakeSession())  # type: ignore[arg-type]
        refused = await source.execute(proto.Deploy(id="d", script=bad, name="serch.xml"))
        unjudged = await blind.execute(proto.Check(id="c", script=bad, name="serch.xml"))
        return source.hello(), refused, unjudged

    with ThreadPoolExecutor(1) as thread:
        hello, refused, unjudged = thread.submit(asyncio.run, scenario()).result()
    assert hello["areas"] == {"search": [[0.0, 0.0], [100.0, 0.0], [100.0, 50.0], [0.0, 50.0]]}
    assert refused["ok"] is False and refused["targets"] == []
    assert any("the world has no area 'serch'" in d["message"] for d in refused["diagnostics"])
    assert unjudged["ok"], unjudged["message"]


def test_the_swarm_view_says_what_each_vehicle_says_and_flags_a_lost_link() -> None:
    from actorswarm.ground.vehicle import describe

    up = {"link": "up", "autopilot": "ardupilot", "mode": "GUIDED", "armed": True,
          "battery": 0.5}  # fmt: skip
    lost = {"link": "lost", "autopilot": "px4", "mode": "", "armed": False, "battery": None}

    async def scenario() -> dict[str, Any]:
        session = FakeSession()
        session.platforms.vehicles = {1: up, 2: lost}
        session.platforms.roles = {2: ["tracker", "leader"]}
        source = RealSource(session, poll=0.1)  # type: ignore[arg-type]
        await source.start()
        try:
            for _ in range(200):
                session.platforms.beat()
                if all(source.acbs(p) is not None for p in (1, 2, 3)):
                    break
                await asyncio.sleep(0.02)
            return source.swarm_view()
        finally:
            await source.stop()

    with ThreadPoolExecutor(1) as thread:
        swarm = thread.submit(asyncio.run, scenario()).result()
    said = {m["id"]: (m["vehicle"], m["vehicle_alarm"]) for m in swarm["members"]}
    assert said == {
        1: ("link up, ardupilot GUIDED, armed, battery 50 %", False),
        2: ("link lost, px4, disarmed", True),
        3: ("", False),
    }
    assert said[1][0] == describe(up)  # the words of gs status, from the one builder
    roles = {m["id"]: m["roles"] for m in swarm["members"]}
    assert roles == {1: [], 2: ["leader", "tracker"], 3: []}
