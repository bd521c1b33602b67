"""Who is out there, as the ground station hears it: joined, left, last heard.

The ground station is not a member of the swarm; it learns of the platforms from their
heartbeats (:attr:`GroundStation.heard` and :attr:`GroundStation.state`: incarnation,
master flag, epoch). A platform counts as *joined* while it was heard within ``t_leave``
seconds (the core's own leave timeout, so the page agrees with the swarm about who is
gone), *left* after that, and *unheard* when the script names it but it was never heard.

A star swarm (the core's default membership) is quiet while it has no master: a platform
that hears a lower ID keeps its heartbeats to itself, since it could not become master
(:meth:`~actorswarm.core.node.liveness.Liveness.send_heartbeat`), and the ground
station hears it once at boot, then through the master's roster once one is elected. So in
a star swarm a silence is counted only from the last moment it was not such a quiet: while
no live master is heard and a lower ID is (heard within ``t_leave``), a platform that does
not claim the role is waiting for the election, not gone.
:meth:`Membership.update` compares with the previous look and logs every change, so the
page can list when each platform joined and left.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any, Literal

from actorswarm.ground.station import GroundStation

__all__ = ["KEEP", "Member", "Membership"]

State = Literal["joined", "left", "unheard"]
#: Membership changes kept in the log.
KEEP = 200


@dataclass(frozen=True, slots=True)
class Member:
    platform: int
    state: State
    heard_ago: float | None
    incarnation: int | None
    master: bool
    epoch: int | None


class Membership:
    """The ground station's view of the swarm, refreshed by :meth:`update`."""

    def __init__(self, t_leave: float) -> None:
        self.t_leave = t_leave
        self.members: dict[int, Member] = {}
        #: ``{"t", "platform", "what": "joined" | "left"}``, oldest first.
        self.log: list[dict[str, Any]] = []
        #: When each platform was last seen keeping the quiet of a masterless star swarm.
        self._quiet: dict[int, float] = {}

    def update(self, station: GroundStation, now: float, expected: Iterable[int] = ()) -> None:
        """Look at ``station`` at time ``now`` (its clock); ``expected``: platforms to list
        even when never heard."""
        members: dict[int, Member] = {}
        quiet_above = self._quiet_above(station, now)
        for p in sorted(set(station.heard) | set(expected)):
            heard = station.heard.get(p)
            if heard is None:
                members[p] = Member(p, "unheard", None, None, False, None)
                continue
            incarnation, master, epoch = station.state[p]
            if p > quiet_above and not master:
                self._quiet[p] = now
            ago = max(0.0, now - heard)
            silent = max(0.0, now - max(heard, self._quiet.get(p, heard)))
            state: State = "joined" if silent <= self.t_leave else "left"
            members[p] = Member(p, state, ago, incarnation, master and state == "joined", epoch)
            before = self.members.get(p)
            was = "unheard" if before is None else before.state
            if state != was and not (state == "left" and was == "unheard"):
                self.log.append({"t": round(now, 3), "platform": p, "what": state})
        self.members = members
        if len(self.log) > KEEP:
            del self.log[: len(self.log) - KEEP]

    def _quiet_above(self, station: GroundStation, now: float) -> float:
        """The platforms above this ID keep quiet now: the lowest ID heard lately when the
        swarm is a star without a live master, infinity otherwise (nobody keeps quiet)."""
        if station.config.membership != "star":
            return float("inf")
        lately = [p for p, t in station.heard.items() if now - t <= self.t_leave]
        if not lately or any(station.state[p][1] for p in lately):
            return float("inf")
        return min(lately)

    def alive(self) -> list[int]:
        """The platforms joined now, ascending."""
        return [p for p, m in self.members.items() if m.state == "joined"]

    def master(self) -> tuple[int | None, int | None]:
        """``(master, epoch)`` as the joined platforms' heartbeats say: the master that
        claims the highest epoch (two masters are possible while a partition lasts)."""
        claims = [(m.epoch or 0, m.platform) for m in self.members.values() if m.master]
        if not claims:
            epochs = [m.epoch for m in self.members.values() if m.state == "joined"]
            return None, max((e for e in epochs if e is not None), default=None)
        epoch, platform = max(claims)
        return platform, epoch

    def masters(self) -> list[int]:
        """Every joined platform that says it is master."""
        return sorted(p for p, m in self.members.items() if m.master)
