"""A recording as a swarm source: the web ground station plays a run back.

A :class:`ReplaySource` reads a recording (:mod:`actorswarm.sim.record`, from ``actorswarm
sim --record`` or ``actorswarm gs record``) and plays it on its own clock: ``speed``
recording seconds per wall second, paused or playing, and sought to any time. The page
shows it as it shows a live swarm — map, collective transitions, membership — from what
the recording holds at the replay's time:

* positions interpolated between a platform's recorded poses (none before its first), the
  heading of the latest pose; moving targets likewise;
* actors from the transitions (:func:`recorded_actors`): which ran and which a switch left
  paused, with their switches and time running, as a platform's control blocks count them
  — but no steps, errors or plugins, which a recording does not hold;
* no heartbeats: the swarm table's *heard* and *incarnation* are unknown ("—"), not 0;
* the script each platform ran: in a simulation's recording, the one it carries, which
  every platform ran; unknown ("") in a real swarm's;
* masters from the ``master`` lines, membership from the ``event`` lines (``joined``,
  ``left``): without them (a simulation's recording), a platform counts as joined from its
  first line on;
* the operator's commands from the ``event`` lines ``command`` (``gs record`` writes one
  per platform that answered a command, :mod:`actorswarm.ground.recorder`): on the
  timeline among the collective transitions, as steps of cause ``command`` named by the
  answer (``Inject: event go delivered``), one step for the platforms that answered alike
  within a second.

Nothing can be commanded: a recording is the past. Seeking backwards rebuilds the
timeline up to the new time and tells every page afresh (``hello``).
"""

from __future__ import annotations

import asyncio
import bisect
import hashlib
import time
from collections.abc import Callable
from typing import Any, Literal, TypeVar

import numpy as np

from actorswarm.dsl.model import TaskScript
from actorswarm.ground.membership import Membership
from actorswarm.ground.station import GroundStation
from actorswarm.sim.record import Recording
from actorswarm.web import protocol as proto
from actorswarm.web.operator import Outcome
from actorswarm.web.source import PlatformRow, SwarmSource
from actorswarm.web.timeline import Timeline

__all__ = ["MAX_SPEED", "ReplaySource", "recorded_actors"]

_T = TypeVar("_T")

#: The fastest pace (recording seconds per wall second).
MAX_SPEED = 100.0
_NO_PATH = (np.zeros(0), np.zeros((0, 3)))
#: The ``source`` of a simulation's recording begins with one of these: every platform
#: ran the script it carries.
_SIMULATIONS = ("actorswarm sim", "actorswarm demo")
#: How long a platform stays "joined" after its last line, without membership lines (s).
_T_LEAVE = 3.0


class ReplaySource(SwarmSource):
    """``recording`` played back, ``speed`` recording seconds per wall second; ``script``
    (optional) is the task script it ran, for the state machine."""

    kind: Literal["sim", "real", "replay"] = "replay"
    hears_heartbeats = False

    def __init__(
        self,
        recording: Recording,
        *,
        title: str = "",
        script: TaskScript | None = None,
        sha: str = "",
        speed: float = 1.0,
        playing: bool = True,
        period: float = 0.05,
    ) -> None:
        if not 0 < speed <= MAX_SPEED:
            raise ValueError(f"speed must be > 0 and <= {MAX_SPEED:g}, not {speed}")
        self.recording = recording
        self.end = recording.end_time()
        self.period = period
        self._speed = speed
        self.playing = playing
        self._t = 0.0
        self._transitions = sorted(recording.transitions, key=lambda tr: float(tr["t"]))
        self._events = sorted(recording.events, key=lambda e: float(e["t"]))
        self._master_lines = sorted(recording.masters, key=lambda m: float(m["t"]))
        #: What the timeline shows, in time order: the transitions and the commands.
        commands = [_command_record(e) for e in self._events if e["what"] == "command"]
        self._on_timeline = sorted([*self._transitions, *commands], key=lambda r: float(r["t"]))
        self._times = [float(r["t"]) for r in self._on_timeline]
        self._shown = 0  # records handed to the timeline
        self._by_platform: dict[int, list[dict[str, Any]]] = {}
        for tr in self._transitions:
            self._by_platform.setdefault(int(tr["platform"]), []).append(tr)
        self._by_platform_t = {
            p: [float(tr["t"]) for tr in trs] for p, trs in self._by_platform.items()
        }
        self._paths = {p: recording.path(p) for p in recording.platforms()}
        self._headings = {
            p: (recording.t[w], recording.heading[w])
            for p in self._paths
            for w in [np.flatnonzero(recording.platform == p)]
        }
        self._first = self._first_seen()
        meta = recording.meta
        text = meta.get("script_text")
        simulated = str(meta.get("source", "")).startswith(_SIMULATIONS)
        self._ran = (
            hashlib.sha256(text.encode()).hexdigest() if simulated and isinstance(text, str) else ""
        )
        self._station = GroundStation(swarm=str(recording.meta.get("swarm", "recording")))
        name = recording.meta.get("script") or recording.meta.get("name") or "a run"
        super().__init__(
            title=title or f"replay of {name}",
            script=script,
            sha=sha,
            t_leave=_T_LEAVE,
        )

    # --- hooks -------------------------------------------------------------------------

    def now(self) -> float:
        return self._t

    @property
    def station(self) -> GroundStation:
        return self._station

    def act(self, action: Callable[[GroundStation, float], _T]) -> _T:
        raise ValueError("a recording is played back: it cannot be commanded")

    def script_of(self, platform: int) -> str:
        return self._ran if platform in self._first else ""

    def expected(self) -> list[int]:
        return sorted(self._first)

    def speed(self) -> float:
        return self._speed

    def set_speed(self, speed: float) -> str:
        if not 0 < speed <= MAX_SPEED:
            raise ValueError(f"the pace must be > 0 and <= {MAX_SPEED:g}, not {speed}")
        self._speed = speed
        return f"the replay now plays at ×{speed:g}"

    def replay_state(self) -> dict[str, Any] | None:
        return {"playing": self.playing, "end": round(self.end, 3)}

    def set_playing(self, playing: bool) -> str:
        if playing and self._t >= self.end:
            self.seek(0.0)  # play after the end: from the beginning again
        self.playing = playing
        return "playing" if playing else f"paused at {self._t:.1f} s"

    def seek(self, t: float) -> str:
        if not 0 <= t <= self.end + 1e-9:
            raise ValueError(f"seek to a time from 0 to {self.end:.1f} s, not {t:g}")
        backwards = t < self._t
        self._t = min(t, self.end)
        if backwards:
            self._shown = 0
            self.timeline = Timeline()
            self.timeline.use_script(self.script)
            self.membership = Membership(_T_LEAVE)
            self._trails.clear()
            self._sampled = -1e18
        self._advance()
        if backwards:
            self.hub.publish(self.hello())
        return f"at {self._t:.1f} s of {self.end:.1f} s"

    def rows(self) -> list[PlatformRow]:
        t = self._t
        self._hear(t)
        self.membership.update(self.station, t, self.expected())
        rows = []
        for p, first in sorted(self._first.items()):
            if first > t:
                continue
            times, xyz = self._paths.get(p, _NO_PATH)
            member = self.membership.members.get(p)
            row = PlatformRow(
                platform=p,
                alive=member is not None and member.state == "joined",
                actors={name: acb["status"] for name, acb in self._actors(p, t).items()},
            )
            if len(times) and times[0] <= t and p in self._headings:
                row.x = float(np.interp(t, times, xyz[:, 0]))
                row.y = float(np.interp(t, times, xyz[:, 1]))
                when, heading = self._headings[p]
                at = int(np.searchsorted(when, t, side="right")) - 1
                row.heading = float(heading[max(at, 0)])
            rows.append(row)
        return rows

    def swarm_view(self) -> dict[str, Any]:
        # The joins and leaves as recorded, not as looked at: a replay sought back to 5 s
        # shows the platforms that joined at 0 s as joined at 0 s.
        return {**super().swarm_view(), "log": self._log_at(self._t)[-50:]}

    def acbs(self, platform: int) -> dict[str, Any] | None:
        if platform not in self._first:
            return None
        return self._actors(platform, self._t)

    def targets(self) -> list[dict[str, Any]]:
        out = []
        for name, (times, xyz) in self.recording.targets.items():
            if len(times) and times[0] <= self._t:
                x = float(np.interp(self._t, times, xyz[:, 0]))
                y = float(np.interp(self._t, times, xyz[:, 1]))
                out.append({"name": name, "x": round(x, 1), "y": round(y, 1)})
        return out

    def areas(self) -> dict[str, list[list[float]]]:
        return {k: [[x, y] for x, y in v] for k, v in self.recording.areas().items()}

    async def execute(self, request: proto.Command) -> dict[str, Any]:
        if isinstance(request, proto.Speed | proto.Play | proto.Seek):
            return await super().execute(request)
        op = str(request.__struct_config__.tag)
        outcome = Outcome(id=request.id, op=op, asked=op, t=self.now())
        outcome.finish(False, "a recording is played back: it cannot be commanded")
        self._published(outcome)
        return outcome.to_json()

    # --- playing -------------------------------------------------------------------------

    def _first_seen(self) -> dict[int, float]:
        """When each platform first appears in the recording."""
        first: dict[int, float] = {}
        for p, (times, _) in self._paths.items():
            if len(times):
                first[p] = float(times.min())
        for tr in self._transitions:
            p = int(tr["platform"])
            first[p] = min(first.get(p, float(tr["t"])), float(tr["t"]))
        for e in self._events:
            p = int(e["platform"])
            if p and e["what"] == "joined":
                first[p] = min(first.get(p, float(e["t"])), float(e["t"]))
        return first

    def _log_at(self, t: float) -> list[dict[str, Any]]:
        """The membership log up to ``t``: the ``joined`` and ``left`` lines, and a join at
        its first line for a platform the recording has no ``joined`` line of."""
        told = {int(e["platform"]) for e in self._events if e["what"] == "joined"}
        log = [
            {"t": round(first, 3), "platform": p, "what": "joined"}
            for p, first in self._first.items()
            if p not in told and first <= t
        ]
        log += [
            {"t": round(float(e["t"]), 3), "platform": int(e["platform"]), "what": e["what"]}
            for e in self._events
            if e["what"] in ("joined", "left") and float(e["t"]) <= t and int(e["platform"])
        ]
        return sorted(log, key=lambda e: (e["t"], e["platform"]))

    def _actors(self, platform: int, t: float) -> dict[str, dict[str, Any]]:
        """``platform``'s actors at ``t``, from its transitions up to then."""
        upto = bisect.bisect_right(self._by_platform_t.get(platform, []), t)
        return recorded_actors(self._by_platform.get(platform, [])[:upto], t)

    def _hear(self, t: float) -> None:
        """Fill the station's heartbeat view as it was at ``t``."""
        heard, state = self._station.heard, self._station.state
        heard.clear()
        state.clear()
        masters, epoch = self._masters_at(t)
        left: dict[int, float] = {}
        for e in self._events:
            if float(e["t"]) > t:
                break
            if e["what"] == "left":
                left[int(e["platform"])] = float(e["t"])
            elif e["what"] == "joined":
                left.pop(int(e["platform"]), None)
        for p, first in self._first.items():
            if first > t:
                continue
            heard[p] = left[p] - _T_LEAVE - 1.0 if p in left else t
            state[p] = (0, p in masters, epoch or 0)

    def _masters_at(self, t: float) -> tuple[set[int], int | None]:
        latest: dict[str, Any] | None = None
        for line in self._master_lines:
            if float(line["t"]) > t:
                break
            latest = line
        if latest is None:
            return set(), None
        return set(latest["masters"]), latest["epoch"]

    def _advance(self) -> None:
        """Hand the timeline the transitions and commands up to now."""
        upto = bisect.bisect_right(self._times, self._t)
        if upto > self._shown:
            self.record(self._on_timeline[self._shown : upto])
            self._shown = upto
        self._hear(self._t)

    def step(self, seconds: float) -> None:
        """Play ``seconds`` of the recording (stops at its end)."""
        self._t = min(self.end, self._t + seconds)
        self._advance()
        if self._t >= self.end:
            self.playing = False

    async def _run(self) -> None:
        last = time.monotonic()
        while True:
            woke = time.monotonic()
            if self.playing:
                self.step((woke - last) * self._speed)
            last = woke
            self._advance()
            self.look()
            await asyncio.sleep(self.period)


def recorded_actors(transitions: list[dict[str, Any]], now: float) -> dict[str, dict[str, Any]]:
    """One platform's actors at ``now`` after its ``transitions`` (time order, none after
    ``now``), as control blocks in the order they were loaded, with what a recording knows
    of them: ``status`` (``running``, or ``sleeping`` for one a switch left paused), and
    ``stats`` ``switch_count`` (the switches into or out of it, as the runtime counts them)
    and ``time_running`` (seconds, up to ``now``); ``recorded`` marks them as such.

    A transition with both ``from`` and ``to`` is a switch; an empty ``from`` starts an
    actor, an empty ``to`` stops one (it is unloaded, as the runtime does)."""
    actors: dict[str, dict[str, Any]] = {}
    since: dict[str, float] = {}

    def run(name: str, t: float) -> None:
        acb = actors.setdefault(
            name,
            {"name": name, "status": "", "recorded": True,
             "stats": {"switch_count": 0, "time_running": 0.0}},
        )  # fmt: skip
        if acb["status"] != "running":
            acb["status"], since[name] = "running", t

    def rest(name: str, t: float) -> None:
        acb = actors.get(name)
        if acb is not None and acb["status"] == "running":
            acb["status"] = "sleeping"
            acb["stats"]["time_running"] += t - since.pop(name)

    for tr in transitions:
        t, old, new = float(tr["t"]), str(tr["from"]), str(tr["to"])
        if old and new:  # a recall (old == new) too: paused, then activated again
            rest(old, t)
            if old in actors:
                actors[old]["stats"]["switch_count"] += 1
            run(new, t)
            actors[new]["stats"]["switch_count"] += 1
        elif new:
            run(new, t)
        elif old:
            rest(old, t)
            actors.pop(old, None)
    for name, t in since.items():
        actors[name]["stats"]["time_running"] += now - t
    return actors


def _command_record(event: dict[str, Any]) -> dict[str, Any]:
    """A ``command`` event line as a timeline record: no actor left or entered, the
    platform's answer as the event, cause ``command``."""
    return {
        "t": float(event["t"]),
        "platform": int(event["platform"]),
        "from": "",
        "to": "",
        "event": str(event["text"]),
        "cause": "command",
    }
