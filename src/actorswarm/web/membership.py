"""Who is out there, as the ground station hears it: joined, left, last heard.

The ground station is not a member of the swarm; it learns of the platforms from their
heartbeats (:attr:`GroundStation.heard` and :attr:`GroundStation.state`: incarnation,
master flag, epoch). A platform counts as *joined* while it was heard within ``t_leave``
seconds (the core's own leave timeout, so the page agrees with the swarm about who is
gone), *left* after that, and *unheard* when the script names it but it was never heard.
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

    def update(self, station: GroundStation, now: float, expected: Iterable[int] = ()) -> None:
        """Look at ``station`` at time ``now`` (its clock); ``expected``: platforms to list
        even when never heard."""
        members: dict[int, Member] = {}
        for p in sorted(set(station.heard) | set(expected)):
            heard = station.heard.get(p)
            if heard is None:
                members[p] = Member(p, "unheard", None, None, False, None)
                continue
            incarnation, master, epoch = station.state[p]
            ago = max(0.0, now - heard)
            state: State = "joined" if ago <= self.t_leave else "left"
            members[p] = Member(p, state, ago, incarnation, master and state == "joined", epoch)
            before = self.members.get(p)
            was = "unheard" if before is None else before.state
            if state != was and not (state == "left" and was == "unheard"):
                self.log.append({"t": round(now, 3), "platform": p, "what": state})
        self.members = members
        if len(self.log) > KEEP:
            del self.log[: len(self.log) - KEEP]

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
