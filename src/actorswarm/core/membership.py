"""Membership: who is in this platform's view of the swarm (DESIGN.md §3.1).

Theory of operation
-------------------
Every heartbeat from a peer lands in :meth:`Membership.heartbeat`. A peer outside the view is
a *candidate*: it joins once ``join_heartbeats`` of its heartbeats arrived within ``t_join``.
A peer inside the view feeds its leave detector, which returns a deadline; deadlines sit in a
heap (stale entries are skipped when popped), so a heartbeat costs O(log N) and finding who
has left costs O(1) per tick unless someone actually left.

Incarnations tell a reboot from a late packet: a heartbeat with a higher incarnation means the
peer restarted (it leaves with reason ``restarted`` and must join again, fresh); one with a
lower incarnation is a leftover and is ignored.
"""

from __future__ import annotations

import heapq
from collections import deque
from dataclasses import dataclass, field

from actorswarm.core.config import CoreConfig
from actorswarm.core.detectors import LeaveDetector, make_detector
from actorswarm.core.events import MemberJoined, MemberLeft


@dataclass(slots=True)
class Peer:
    """A member of the view."""

    incarnation: int
    detector: LeaveDetector
    deadline: float
    joined_at: float
    last_heard: float
    last_seq: int = -1


@dataclass(slots=True)
class _Candidate:
    incarnation: int
    times: deque[float] = field(default_factory=deque)
    last_seq: int = -1


class Membership:
    """One platform's view of the live swarm (itself excluded)."""

    def __init__(self, self_id: int, config: CoreConfig) -> None:
        self.self_id = self_id
        self._config = config
        self.peers: dict[int, Peer] = {}
        self._candidates: dict[int, _Candidate] = {}
        self._deadlines: list[tuple[float, int, int]] = []
        self._latest_incarnation: dict[int, int] = {}
        self._next_candidate_sweep = 0.0

    def __contains__(self, peer: int) -> bool:
        return peer in self.peers

    def __len__(self) -> int:
        return len(self.peers)

    def is_current(self, peer: int, incarnation: int) -> bool:
        """False for packets of an incarnation older than the newest seen from ``peer``."""
        return incarnation >= self._latest_incarnation.get(peer, incarnation)

    def heartbeat(
        self,
        peer: int,
        incarnation: int,
        now: float,
        out: list[MemberJoined | MemberLeft],
        seq: int | None = None,
    ) -> Peer | None:
        """Account for one heartbeat; append join/leave events to ``out``.

        ``seq`` is the packet's sequence number: a copy the radio duplicated (or a late one
        overtaken by a newer heartbeat) is not counted again. Returns the peer's entry when
        it is (now) in the view, else None.
        """
        member = self.peers.get(peer)
        if member is not None and incarnation == member.incarnation:
            # The common case, kept short: a known member's next heartbeat.
            if seq is not None:
                if seq <= member.last_seq:
                    return member
                member.last_seq = seq
            deadline = member.detector.observe(now)
            member.deadline = deadline
            member.last_heard = now
            heapq.heappush(self._deadlines, (deadline, peer, incarnation))
            return member
        latest = self._latest_incarnation.get(peer, -1)
        if incarnation < latest:
            return None
        if incarnation > latest:
            self._latest_incarnation[peer] = incarnation
        if member is not None:
            # A higher incarnation: the peer rebooted and lost its state.
            del self.peers[peer]
            out.append(
                MemberLeft(platform=peer, incarnation=member.incarnation, reason="restarted")
            )
        cand = self._candidates.get(peer)
        if cand is None or cand.incarnation != incarnation:
            cand = _Candidate(incarnation, deque(maxlen=self._config.join_heartbeats))
            self._candidates[peer] = cand
        if seq is not None:
            if seq <= cand.last_seq:
                return None
            cand.last_seq = seq
        cand.times.append(now)
        if (
            len(cand.times) >= self._config.join_heartbeats
            and now - cand.times[0] <= self._config.t_join
        ):
            del self._candidates[peer]
            detector = make_detector(self._config)
            deadline = detector.observe(now)
            member = Peer(
                incarnation=incarnation,
                detector=detector,
                deadline=deadline,
                joined_at=now,
                last_heard=now,
                last_seq=-1 if seq is None else seq,
            )
            self.peers[peer] = member
            heapq.heappush(self._deadlines, (deadline, peer, incarnation))
            out.append(MemberJoined(platform=peer, incarnation=incarnation))
            return member
        return None

    def expire(self, now: float, out: list[MemberJoined | MemberLeft]) -> None:
        """Remove every peer whose deadline has passed; append MemberLeft events to ``out``."""
        heap = self._deadlines
        reason: str = "timeout" if self._config.detector == "timeout" else "suspected"
        while heap and heap[0][0] <= now:
            deadline, peer, incarnation = heapq.heappop(heap)
            member = self.peers.get(peer)
            if member is None or member.incarnation != incarnation or member.deadline != deadline:
                continue  # stale entry: a later heartbeat moved the deadline
            del self.peers[peer]
            out.append(
                MemberLeft(platform=peer, incarnation=incarnation, reason=reason)  # type: ignore[arg-type]
            )
        if now >= self._next_candidate_sweep and self._candidates:
            # Forget candidates that went quiet, so a burst of stray senders cannot grow state.
            horizon = now - self._config.t_join
            for peer in [p for p, c in self._candidates.items() if c.times[-1] < horizon]:
                del self._candidates[peer]
            self._next_candidate_sweep = now + self._config.t_join

    def next_deadline(self) -> float | None:
        """Earliest time :meth:`expire` could remove someone (a stale entry may make it early)."""
        while self._deadlines:
            deadline, peer, incarnation = self._deadlines[0]
            member = self.peers.get(peer)
            if (
                member is not None
                and member.incarnation == incarnation
                and member.deadline == deadline
            ):
                return deadline
            heapq.heappop(self._deadlines)
        return None
