"""A real swarm's recording, as its ground station sees it: what ``gs record`` writes.

A :class:`SwarmRecorder` turns what a listening ground station learns into the lines of a
recording (:mod:`actorswarm.sim.record`, the format ``actorswarm sim --record`` writes, so
``actorswarm plot`` and ``actorswarm web --replay`` take either):

* each platform's status reply (:class:`~actorswarm.engine.commands.StatusReply`) gives a
  ``pose`` line when it carries a position, and ``transition`` lines when its running
  actors changed since the previous reply (:func:`observed`, cause ``observed``: a real
  swarm does not say when exactly it switched, so a switch is dated by the reply that
  showed it, as coarse as the polling);
* the heartbeats (the station's ``heard`` and ``state``, through a
  :class:`~actorswarm.web.membership.Membership`) give ``master`` lines when the platforms
  claiming mastership or the epoch change, and ``event`` lines when a platform joins or
  leaves.

Times are seconds since the recording began (``t0`` on the station's clock). The recorder
is sans-IO: the caller polls and feeds it (:mod:`actorswarm.cli.gs_record`).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from actorswarm.engine import commands as cmds

if TYPE_CHECKING:
    from actorswarm.sim.record import RecordWriter
    from actorswarm.web.membership import Membership

__all__ = ["SwarmRecorder", "observed"]


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


#: A platform that moved less than this (m) between two replies keeps its heading.
_MOVED = 0.3


class SwarmRecorder:
    """Writes what the ground station learns to ``out``, times counted from ``t0``."""

    def __init__(self, out: RecordWriter, t0: float) -> None:
        self.out = out
        self.t0 = t0
        self._running: dict[int, tuple[str, ...]] = {}
        self._where: dict[int, tuple[float, float, float, float]] = {}
        self._masters: tuple[tuple[int, ...], int | None] | None = None
        self._states: dict[int, str] = {}

    def t(self, now: float) -> float:
        """The recording's time of station time ``now``."""
        return round(max(0.0, now - self.t0), 3)

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
        self.out.pose(t, platform, x, y, z, heading)

    def membership(self, now: float, membership: Membership) -> None:
        """Look at the heartbeats' view at ``now`` (after ``membership.update``): an
        ``event`` line for each platform that joined or left since the last look, a
        ``master`` line when the masters or the epoch changed."""
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
