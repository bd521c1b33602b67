"""A real swarm's recording, as its ground station sees it: what ``gs record`` writes.

A :class:`SwarmRecorder` turns what a listening ground station learns into the facts of a
recording (a :class:`~actorswarm.recording.recorder.Recorder`: the MCAP channels
``actorswarm sim --record`` writes, so Foxglove, ``actorswarm plot`` and ``actorswarm web
--replay`` take either):

* each platform's status reply (:class:`~actorswarm.engine.commands.StatusReply`) gives a
  pose when it carries a position (with the vehicle's battery when it reports one), and
  transitions when its running actors changed since the previous reply (:func:`observed`,
  cause ``observed``: a real swarm does not say when exactly it switched, so a switch is
  dated by the reply that showed it, as coarse as the polling); a change of the vehicle's
  ``link``, ``armed`` or ``mode`` gives an event ``vehicle`` (``fault`` for a link lost);
* the heartbeats (the station's ``heard`` and ``state``, through a
  :class:`~actorswarm.ground.membership.Membership`) give master changes when the platforms
  claiming mastership or the epoch change, and events when a platform joins or leaves;
  each look at them (:meth:`SwarmRecorder.membership`) also writes the scene
  (:meth:`~actorswarm.recording.recorder.Recorder.snapshot`) and how many platforms are up;
* every other reply is a platform's answer to an operator's command — another ``gs``
  command, or the web ground station, since the recorder itself only asks for status —
  and gives an event ``command`` (:func:`command_text`: the command, whether it
  was carried out, what the platform said).

What the recorder can know of the operator's commands is what the platforms answer, not
what was sent. A platform's replies go to the ground station's one key (``to/0``) as one
reliable stream, whichever session they answer, so every session listening hears them
all; the commands themselves go to each platform's own key and carry the sending
session's signature, so no other session hears them. Hence a command is recorded once per
platform that answered it, dated by the answer's arrival, as the platform worded it
(``Inject: event go_event delivered``; the targets, the ``--actors`` filter and a force's
params are not in an answer). A command no platform answered is not recorded; nor is an
operator's ``gs status`` (a status reply cannot be told from one to the recorder's own
request); and an answer the recorder missed on the radio while the session it answered
acknowledged it is not sent again (the reliable stream then skips it).

Times are seconds since the recording began (``t0`` on the station's clock). The recorder
is sans-IO: the caller polls and feeds it (:mod:`actorswarm.cli.gs_record`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any, Protocol

from actorswarm.engine import commands as cmds
from actorswarm.ground.membership import Membership

__all__ = ["FactSink", "SwarmRecorder", "command_text", "observed"]


class FactSink(Protocol):
    """Where a :class:`SwarmRecorder` writes (a
    :class:`~actorswarm.recording.recorder.Recorder` is one): stated here, so that the
    ground station imports nothing of the recording layer above it."""

    def pose(
        self,
        t: float,
        platform: int,
        x: float,
        y: float,
        z: float,
        heading: float = 0.0,
        mode: str = "",
        battery: float | None = None,
    ) -> None: ...

    def snapshot(self, t: float) -> None: ...

    def transition(self, record: Mapping[str, Any]) -> None: ...

    def master(self, t: float, masters: Iterable[int], epoch: int | None) -> None: ...

    def event(self, t: float, what: str, platform: int = 0, text: str = "") -> None: ...

    def metrics(self, t: float, **values: float | int) -> None: ...


def observed(
    t: float, platform: int, before: tuple[str, ...], after: tuple[str, ...]
) -> list[dict[str, Any]]:
    """Transition records for a platform whose running actors went from ``before`` to
    ``after``: stopped actors paired with started ones in order (``A -> B``), the rest
    from or to nothing."""
    gone = [a for a in before if a not in after]
    new = [a for a in after if a not in before]
    out = []
    for i in range(max(len(gone), len(new))):
        out.append(
            {
                "t": t,
                "platform": platform,
                "from": gone[i] if i < len(gone) else "",
                "to": new[i] if i < len(new) else "",
                "event": "",
                "cause": "observed",
            }
        )
    return out


def command_text(reply: cmds.Reply) -> str | None:
    """How a platform's answer to an operator's command reads in a recording: the command,
    ``FAILED`` when it was not carried out, and what the platform said (``Start: started
    script 3f2a9c01b7e4``, ``Inject: event go delivered``). None for a status reply."""
    if isinstance(reply, cmds.StatusReply):
        return None
    if isinstance(reply, cmds.DeployAck):
        return f"Deploy: confirmed {reply.sha256[:12]}"
    if isinstance(reply, cmds.BackupReply):
        return f"Backup: generation {reply.generation}, {reply.size} bytes"
    # A script refused is a failed chunk: the operator asked for a deployment.
    command = "Deploy" if reply.command == "DeployChunk" else reply.command
    return f"{command}{'' if reply.ok else ' FAILED'}: {reply.message}"


#: A platform that moved less than this (m) between two replies keeps its heading.
_MOVED = 0.3
#: What a vehicle adapter says of itself that a recording logs when it changes.
_VEHICLE_KEYS = ("link", "armed", "mode")


class SwarmRecorder:
    """Writes what the ground station learns to ``out``, times counted from ``t0``."""

    def __init__(self, out: FactSink, t0: float) -> None:
        self.out = out
        self.t0 = t0
        self._running: dict[int, tuple[str, ...]] = {}
        self._where: dict[int, tuple[float, float, float, float]] = {}
        self._masters: tuple[tuple[int, ...], int | None] | None = None
        self._states: dict[int, str] = {}
        self._vehicle: dict[int, dict[str, object]] = {}
        #: Answers to operator commands recorded.
        self.commands = 0

    def t(self, now: float) -> float:
        """The recording's time of station time ``now``."""
        return round(max(0.0, now - self.t0), 3)

    def reply(self, now: float, platform: int, reply: cmds.Reply) -> None:
        """Any reply of ``platform`` received at ``now``: a status reply (:meth:`status`),
        or an answer to an operator's command (an ``event`` line ``command``)."""
        if isinstance(reply, cmds.StatusReply):
            self.status(now, platform, reply)
            return
        text = command_text(reply)
        if text is not None:
            self.out.event(self.t(now), "command", platform, text)
            self.commands += 1

    def status(self, now: float, platform: int, reply: cmds.StatusReply) -> None:
        """A status reply of ``platform`` received at ``now`` (station clock)."""
        t = self.t(now)
        running = tuple(a for a, s in reply.actors.items() if s == "running")
        before = self._running.get(platform)
        if before is None:
            # The first reply: what already runs started before the recording, dated now.
            records = observed(t, platform, (), running)
        else:
            records = observed(t, platform, before, running) if before != running else []
        for record in records:
            self.out.transition(record)
        self._running[platform] = running
        self._vehicle_changes(t, platform, reply.vehicle)
        position = reply.position
        if position is None or len(position) < 2 or not all(map(math.isfinite, position)):
            return
        x, y = float(position[0]), float(position[1])
        z = float(position[2]) if len(position) > 2 else 0.0
        last = self._where.get(platform)
        heading = 0.0 if last is None else last[3]
        if last is not None and math.hypot(x - last[0], y - last[1]) > _MOVED:
            heading = math.atan2(y - last[1], x - last[0])
        self._where[platform] = (x, y, z, heading)
        battery = reply.vehicle.get("battery")
        charge = float(battery) if isinstance(battery, int | float) else None
        mode = str(reply.vehicle.get("mode", ""))
        self.out.pose(t, platform, x, y, z, heading, mode, charge)

    def _vehicle_changes(self, t: float, platform: int, vehicle: Mapping[str, object]) -> None:
        said = {k: vehicle[k] for k in _VEHICLE_KEYS if k in vehicle}
        before = self._vehicle.get(platform, {})
        for key, value in said.items():
            if before.get(key) != value:
                lost = key == "link" and value == "lost"
                self.out.event(t, "fault" if lost else "vehicle", platform, f"{key} {value}")
        self._vehicle[platform] = said

    def membership(self, now: float, membership: Membership) -> None:
        """Look at the heartbeats' view at ``now`` (after ``membership.update``): an event
        for each platform that joined or left since the last look, a master change when the
        masters or the epoch changed; then the scene at ``now`` and the platforms up."""
        t = self.t(now)
        for p, member in membership.members.items():
            was = self._states.get(p, "unheard")
            if member.state not in (was, "unheard"):
                self.out.event(t, member.state, p)
            self._states[p] = member.state
        _, epoch = membership.master()
        masters = (tuple(membership.masters()), epoch)
        if masters != self._masters and (masters[0] or self._masters is not None):
            self._masters = masters
            self.out.master(t, masters[0], epoch)
        self.out.snapshot(t)
        self.out.metrics(t, platforms_up=len(membership.alive()))
