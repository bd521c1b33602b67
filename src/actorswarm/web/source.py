"""A swarm source: what the web ground station shows and commands, simulated or real.

Theory of operation
-------------------
A :class:`SwarmSource` owns a ground station (:class:`~actorswarm.ground.station.
GroundStation`) and a background task that keeps it going — the simulator stepping in
virtual time paced to the wall clock (:class:`~actorswarm.web.sim_source.SimSource`), or a
Zenoh session polling the platforms' status (:class:`~actorswarm.web.real_source.
RealSource`). A subclass fills in a few hooks (the platforms' positions and actors, their
control blocks, the clock, how to act on the station); this class turns them into the same
JSON messages for either kind, so the page never knows which it is looking at (a
recording played back, :class:`~actorswarm.web.replay_source.ReplaySource`, is a third
kind: its frames carry ``replay``, ``{"playing", "end"}``, and it takes no command but the
pace, ``play`` and ``seek``):

``hello``
    Sent first and whenever the running script changes: the source's ``kind`` and
    ``title``, ``t0`` (the time the page counts from), the ``script`` (name, SHA-256,
    actors, events, the drawn state machine), the world's ``areas``, the timeline's
    ``steps`` so far, the recent ``outcomes``, ``trails`` (recent poses: ``t``, ``ids``,
    ``x``, ``y`` every half second) and ``failure`` (see ``notice``).
``frame``
    The map, several times a second, as parallel arrays so that 200 platforms stay a few
    kilobytes: ``ids``, ``x``, ``y``, ``hd`` (heading, radians counter-clockwise from east;
    all three None without positions), ``a`` (the index in ``names`` of the platform's
    running actor — its first, when it runs several — or of a paused one when none runs,
    -1 for none), ``f`` (flags: :data:`MASTER`, :data:`ALIVE`,
    :data:`SLEEPING`: nothing running, :data:`SEVERAL`: several running), ``targets`` and
    ``counts`` (platforms running each actor).
``swarm``
    About once a second: ``master``, ``epoch``, every platform's membership (joined, left,
    unheard; last heard; incarnation) with its actors' status and statistics, and the log of
    joins and leaves.
``steps``
    New or grown steps of the timeline (:mod:`actorswarm.web.timeline`).
``outcome``
    A command's progress and result (:mod:`actorswarm.web.operator`), to every page.
``acb``
    The control blocks of one platform, to the page that asked (``inspect``).
``notice``
    The source stopped working (``level``, ``message``); ``hello`` repeats it as
    ``failure``.

Messages go out through a :class:`Hub`; a page's connection subscribes to it.
"""

from __future__ import annotations

import abc
import asyncio
import contextlib
import logging
from collections import deque
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any, Literal, TypeVar

from actorswarm.dsl.model import TaskScript
from actorswarm.ground import vehicle as vehicles
from actorswarm.ground.membership import Membership
from actorswarm.ground.station import GroundStation, ReplyRecord
from actorswarm.web import protocol as proto
from actorswarm.web.graph_layout import layout
from actorswarm.web.operator import Operator, Outcome, Timeouts
from actorswarm.web.timeline import Timeline

__all__ = [
    "ALIVE",
    "MASTER",
    "SEVERAL",
    "SLEEPING",
    "Hub",
    "PlatformRow",
    "SwarmSource",
]

_T = TypeVar("_T")
_log = logging.getLogger(__name__)

#: Frame flags.
MASTER, ALIVE, SLEEPING, SEVERAL = 1, 2, 4, 8
#: Outcomes kept for pages that connect later.
KEEP_OUTCOMES = 50
#: Poses kept for the trails of pages that connect later: one every TRAIL_PERIOD seconds
#: (of the source's clock), the last TRAIL_SAMPLES of them.
TRAIL_PERIOD, TRAIL_SAMPLES = 0.5, 60


@dataclass(slots=True)
class PlatformRow:
    """One platform as a source sees it: its pose (None when unknown) and its actors
    (name -> status: running, sleeping, ...), in the order they were loaded."""

    platform: int
    alive: bool
    x: float | None = None
    y: float | None = None
    heading: float | None = None
    actors: dict[str, str] = field(default_factory=dict)


class Hub:
    """Fans messages out to subscribers' queues. A subscriber that falls
    :data:`BACKLOG` messages behind is dropped (its page reconnects and starts afresh)
    rather than let the server's memory grow."""

    BACKLOG = 2000

    def __init__(self) -> None:
        self._queues: set[asyncio.Queue[dict[str, Any] | None]] = set()

    def subscribe(self) -> asyncio.Queue[dict[str, Any] | None]:
        queue: asyncio.Queue[dict[str, Any] | None] = asyncio.Queue(self.BACKLOG)
        self._queues.add(queue)
        return queue

    def unsubscribe(self, queue: asyncio.Queue[dict[str, Any] | None]) -> None:
        self._queues.discard(queue)

    def publish(self, message: dict[str, Any]) -> None:
        for queue in list(self._queues):
            try:
                queue.put_nowait(message)
            except asyncio.QueueFull:
                self._queues.discard(queue)
                with contextlib.suppress(asyncio.QueueFull):
                    queue.get_nowait()
                    queue.put_nowait(None)  # None: "you were dropped"

    def __len__(self) -> int:
        return len(self._queues)


class SwarmSource(abc.ABC):
    """The web ground station's view of one swarm (see the module docstring).

    Subclasses implement the hooks below; :meth:`start` and :meth:`stop` bracket the
    background task (:meth:`_run`), which must call :meth:`record` with new transitions,
    and :meth:`pump` and :meth:`look` at every wake so that replies reach the operator and
    the membership log keeps up.
    """

    #: ``"sim"``, ``"real"`` or ``"replay"``.
    kind: Literal["sim", "real", "replay"]
    #: Whether the ground station hears the platforms' heartbeats (when each was last
    #: heard, its incarnation); a recording holds none, so a replay tells neither.
    hears_heartbeats = True

    def __init__(
        self,
        *,
        title: str,
        script: TaskScript | None,
        sha: str = "",
        t_leave: float,
        timeouts: Timeouts | None = None,
    ) -> None:
        self.title = title
        self.hub = Hub()
        self.script: TaskScript | None = None
        self.sha = ""
        self._script_json: dict[str, Any] | None = None
        self.timeline = Timeline()
        self.membership = Membership(t_leave)
        self.outcomes: list[dict[str, Any]] = []
        self.operator = Operator(
            self,
            now=self.now,
            heard=self._heard,
            publish=self._published,
            on_started=self.use_script,
            timeouts=timeouts,
            areas=self.area_names,
        )
        self._task: asyncio.Task[None] | None = None
        self._frame_cache: tuple[tuple[Any, ...], dict[str, Any]] | None = None
        #: Why the source stopped working, if it did (shown on every page).
        self.failure: str | None = None
        self._trails: deque[dict[str, Any]] = deque(maxlen=TRAIL_SAMPLES)
        self._sampled = -1e18
        self.use_script(script, sha)

    # --- hooks -------------------------------------------------------------------------

    @abc.abstractmethod
    def now(self) -> float:
        """The source's clock, seconds (virtual time for the simulator)."""

    @property
    @abc.abstractmethod
    def station(self) -> GroundStation:
        """The ground station this source drives."""

    @abc.abstractmethod
    def act(self, action: Callable[[GroundStation, float], _T]) -> _T:
        """Run ``action(station, now)`` and send what it produced."""

    @abc.abstractmethod
    def rows(self) -> list[PlatformRow]:
        """Every platform to show, ascending."""

    @abc.abstractmethod
    def acbs(self, platform: int) -> dict[str, Any] | None:
        """Every control block of ``platform`` (:meth:`ACB.to_status`), None if unknown."""

    @abc.abstractmethod
    async def _run(self) -> None:
        """The background task: keep the swarm (or the link to it) going until cancelled."""

    def origin(self) -> float:
        """The time the page counts from (the run's start, the session's opening)."""
        return 0.0

    def script_of(self, platform: int) -> str:
        """The SHA-256 of the script ``platform`` runs ("" when unknown)."""
        return ""

    def vehicle_of(self, platform: int) -> Mapping[str, object]:
        """What ``platform``'s vehicle adapter says of itself (a status reply's ``vehicle``:
        link, autopilot, mode...); empty when it says nothing or is unknown."""
        return {}

    def roles_of(self, platform: int) -> list[str]:
        """The roles ``platform`` holds (a status reply's ``roles``), sorted; empty when it
        holds none or it is unknown."""
        return []

    def targets(self) -> list[dict[str, Any]]:
        """Moving targets: ``{"name", "x", "y"}``."""
        return []

    def areas(self) -> dict[str, list[list[float]]]:
        """The world's areas: name -> polygon."""
        return {}

    def area_names(self) -> list[str] | None:
        """The names a script deployed from the page must give its ``area`` params: the
        world's areas, or None when no world is known (the names are then not checked)."""
        return None

    def expected(self) -> Iterable[int]:
        """Platforms to list even when never heard."""
        return () if self.script is None else self.script.platform_ids()

    def set_speed(self, speed: float) -> str:
        """Change the pace of a simulation; ValueError where there is none."""
        raise ValueError("the pace can only be set for a simulation")

    def speed(self) -> float | None:
        return None

    def replay_state(self) -> dict[str, Any] | None:
        """A replay's ``{"playing", "end"}`` (None for a live swarm)."""
        return None

    def set_playing(self, playing: bool) -> str:
        """Play or pause a replay; ValueError where there is none."""
        raise ValueError("only a replay can be paused or played")

    def seek(self, t: float) -> str:
        """Go to time ``t`` of a replay; ValueError where there is none."""
        raise ValueError("only a replay can be sought")

    # --- lifecycle ---------------------------------------------------------------------

    async def start(self) -> None:
        """Begin the background task."""
        self._task = asyncio.create_task(self._guarded(), name=f"{self.kind}-source")

    async def _guarded(self) -> None:
        try:
            await self._run()
        except Exception as exc:
            # A broken simulation (a plugin its world cannot serve) or a lost link: say so
            # on every page rather than freeze silently; the server stays up to show it.
            _log.exception("the %s source stopped", self.kind)
            self.fail(f"stopped at {self.now() - self.origin():.2f} s: {exc}")

    async def stop(self) -> None:
        """End the background task (and with it the simulation or the link)."""
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
            self._task = None

    # --- what subclasses call ------------------------------------------------------------

    def use_script(self, script: TaskScript | None, sha: str = "") -> None:
        """``script`` runs now: redraw the state machine, and tell every page."""
        self.script, self.sha = script, sha
        self.timeline.use_script(script)
        self._script_json = None if script is None else self._describe(script, sha)
        if self.hub:
            self.hub.publish(self.hello())

    def record(self, records: list[dict[str, Any]]) -> None:
        """New transition records (time order): publish the steps they make."""
        steps = self.timeline.add(records)
        if steps:
            self.hub.publish({"type": "steps", "steps": [s.to_json() for s in steps]})

    def fail(self, message: str) -> None:
        """Tell every page (now and later) that the source stopped working."""
        self.failure = message
        self.hub.publish({"type": "notice", "level": "error", "message": message})

    def look(self) -> None:
        """Refresh the membership (call it every wake, so joins and leaves are logged
        when they happen rather than when a page asks) and keep the recent poses that a
        page opened later draws as trails."""
        now = self.now()
        self.membership.update(self.station, now, self.expected())
        if now - self._sampled >= TRAIL_PERIOD or now < self._sampled:
            self._sampled = now
            frame = self.frame()
            if frame["x"] is not None:
                self._trails.append({k: frame[k] for k in ("t", "ids", "x", "y")})

    def pump(self) -> None:
        """Hand the ground station's new replies to the operator (and :meth:`on_reply`),
        then forget them: a long session must not keep every status reply."""
        replies = self.station.replies
        for record in replies:
            self.on_reply(record)
            self.operator.on_reply(record)
        replies.clear()

    def on_reply(self, record: ReplyRecord) -> None:  # noqa: B027 (a hook, empty by default)
        """Every reply, before the operator sees it (the real source reads statuses)."""

    # --- messages ------------------------------------------------------------------------

    @staticmethod
    def _describe(script: TaskScript, sha: str) -> dict[str, Any]:
        events = sorted({t.event for t in script.all_transitions()})
        return {
            "name": script.name,
            "sha": sha,
            "actors": [a.name for a in script.actors],
            "events": events,
            "graph": layout(script),
        }

    def hello(self) -> dict[str, Any]:
        return {
            "type": "hello",
            "kind": self.kind,
            "title": self.title,
            "swarm": self.station.swarm,
            "speed": self.speed(),
            "replay": self.replay_state(),
            "t0": round(self.origin(), 3),
            "script": self._script_json,
            "areas": self.areas(),
            "t_leave": self.membership.t_leave,
            "steps": [s.to_json() for s in self.timeline.steps],
            "outcomes": list(self.outcomes),
            "trails": list(self._trails),
            "failure": self.failure,
        }

    def frame(self) -> dict[str, Any]:
        now = self.now()
        replay = self.replay_state()
        key = (now, self.speed(), self.sha, None if replay is None else replay["playing"])
        cached = self._frame_cache
        if cached is not None and cached[0] == key:
            return cached[1]
        rows = self.rows()
        names = list(self._script_json["actors"]) if self._script_json else []
        index = {n: i for i, n in enumerate(names)}
        master, _ = self.membership.master()
        masters = set(self.membership.masters()) or ({master} if master else set())
        ids, xs, ys, hds, acts, flags = [], [], [], [], [], []
        counts: dict[str, int] = {}
        positioned = any(r.x is not None for r in rows)
        for r in rows:
            ids.append(r.platform)
            if positioned:
                xs.append(None if r.x is None else round(r.x, 1))
                ys.append(None if r.y is None else round(r.y, 1))
                hds.append(None if r.heading is None else round(r.heading, 3))
            running = [a for a, s in r.actors.items() if s == "running"]
            shown = running[0] if running else next(iter(r.actors), None)
            if shown is not None and shown not in index:
                index[shown] = len(names)
                names.append(shown)
            acts.append(-1 if shown is None else index[shown])
            flag = (MASTER if r.platform in masters else 0) | (ALIVE if r.alive else 0)
            if shown is not None and not running:
                flag |= SLEEPING
            if len(running) > 1:
                flag |= SEVERAL
            flags.append(flag)
            if r.alive:
                for name in running:
                    counts[name] = counts.get(name, 0) + 1
        frame = {
            "type": "frame",
            "t": round(now, 3),
            "speed": self.speed(),
            "replay": replay,
            "names": names,
            "ids": ids,
            "x": xs if positioned else None,
            "y": ys if positioned else None,
            "hd": hds if positioned else None,
            "a": acts,
            "f": flags,
            "targets": self.targets(),
            "counts": counts,
        }
        self._frame_cache = (key, frame)
        return frame

    def swarm_view(self) -> dict[str, Any]:
        """The ``swarm`` message (refreshes the membership first)."""
        now = self.now()
        self.membership.update(self.station, now, self.expected())
        master, epoch = self.membership.master()
        members = []
        for p, m in self.membership.members.items():
            acbs = self.acbs(p) or {}
            members.append(
                {
                    "id": p,
                    "state": m.state,
                    "heard": None
                    if m.heard_ago is None or not self.hears_heartbeats
                    else round(m.heard_ago, 2),
                    "inc": m.incarnation if self.hears_heartbeats else None,
                    "master": m.master,
                    "epoch": m.epoch,
                    "script": self.script_of(p)[:12],
                    "actors": [_summary(a) for a in acbs.values()],
                    **_vehicle(self.vehicle_of(p)),
                    "roles": self.roles_of(p),
                }
            )
        return {
            "type": "swarm",
            "t": round(now, 3),
            "master": master,
            "epoch": epoch,
            "masters": self.membership.masters(),
            "members": members,
            "log": self.membership.log[-50:],
        }

    def inspect(self, platform: int) -> dict[str, Any]:
        return {
            "type": "acb",
            "platform": platform,
            "t": round(self.now(), 3),
            "acbs": self.acbs(platform),
        }

    async def execute(self, request: proto.Command) -> dict[str, Any]:
        """Carry out one command from a page; returns the final ``outcome`` message (also
        published to every page)."""
        if isinstance(request, proto.Speed | proto.Play | proto.Seek):
            outcome = Outcome(id=request.id, op="", asked="", t=self.now())
            try:
                if isinstance(request, proto.Speed):
                    outcome.op, outcome.asked = "speed", f"pace ×{request.speed:g}"
                    outcome.finish(True, self.set_speed(request.speed))
                elif isinstance(request, proto.Play):
                    outcome.op = "play"
                    outcome.asked = "play" if request.playing else "pause"
                    outcome.finish(True, self.set_playing(request.playing))
                else:
                    outcome.op, outcome.asked = "seek", f"seek to {request.t:g} s"
                    outcome.finish(True, self.seek(request.t))
            except ValueError as exc:
                outcome.finish(False, str(exc))
            self._published(outcome)
            return outcome.to_json()
        return (await self.operator.execute(request)).to_json()

    # --- internals -----------------------------------------------------------------------

    def _heard(self) -> list[int]:
        self.membership.update(self.station, self.now(), self.expected())
        return self.membership.alive()

    def _published(self, outcome: Outcome) -> None:
        message = outcome.to_json()
        if outcome.state == "done":
            self.outcomes.append(message)
            del self.outcomes[:-KEEP_OUTCOMES]
        self.hub.publish(message)


def _summary(acb: dict[str, Any]) -> dict[str, Any]:
    """What the swarm table shows of one control block (``steps`` and ``errors`` None
    when it does not say, as a recorded one does not)."""
    stats = acb.get("stats", {})
    return {
        "name": acb.get("name", "?"),
        "status": acb.get("status", "?"),
        "switches": stats.get("switch_count", 0),
        "running_s": round(float(stats.get("time_running") or 0.0), 1),
        "steps": stats.get("steps"),
        "errors": stats.get("error_count"),
    }


def _vehicle(said: Mapping[str, object]) -> dict[str, Any]:
    """What the swarm table and the map's tooltip show of a platform's vehicle: the words
    of ``actorswarm gs status`` ("" when it said nothing), and whether it is an alarm (the
    link lost, its status failed)."""
    return {"vehicle": vehicles.describe(said), "vehicle_alarm": vehicles.alarm(said)}
