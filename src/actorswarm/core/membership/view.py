"""Membership: who is in this platform's view of the swarm (docs/design.md §3.1).

Theory of operation
-------------------
Every heartbeat from a watched peer lands in :meth:`Membership.heartbeat`. A peer outside the
view is a *candidate*: it joins once ``join_heartbeats`` of its heartbeats arrived within
``t_join``. A peer inside the view feeds its leave detector.

Leaving takes two steps (suspicion before leave). The detector says when the peer's silence
becomes suspicious (``t_leave`` for the fixed timeout, the phi crossing for phi accrual); at
that moment the peer is *suspected*, reported by :meth:`expire` so the node probes it, and it
leaves only when it stays silent until its *leave* time. The leave time is what keeps false
leaves rare at scale: with ``n`` watched peers heartbeating at rate ``h`` and a measured loss
``p``, a live peer looks dead after ``T`` seconds of silence about ``n·h·(1-p)·p^(h·T-½)``
times a second, so ``T`` is chosen to keep that at ``false_leave_rate`` — which adds
``ln 10 / ln(1/p)`` heartbeats per tenfold growth of the view and nothing at all without
loss. It is never less than the suspicion time plus ``probe_window`` (time for the probes to
be answered), which is what bounds a failover on a clean radio.

The loss ``p`` is measured here, from the gaps in the heartbeat counters of the watched
peers (a decaying count of heartbeats lost and heard).

Deadlines (suspect and leave times) sit in one heap, stale entries skipped when popped, so a
heartbeat costs O(log N) and a tick costs O(1) unless someone's time has come.

A host that ticks late (a starved CPU) has not been listening: :meth:`expire` takes a
``grace`` the node derives from its own lateness (Lifeguard's local health), so a slow host
widens its own timeouts rather than declaring its peers gone.

Incarnations tell a reboot from a late packet: a heartbeat with a higher incarnation means the
peer restarted (it leaves with reason ``restarted`` and must join again, fresh); one with a
lower incarnation is a leftover and is ignored.
"""

from __future__ import annotations

import heapq
import math
from collections import deque
from dataclasses import dataclass, field

from actorswarm.core.config import CoreConfig
from actorswarm.core.events import MemberJoined, MemberLeft
from actorswarm.core.membership.detectors import LeaveDetector, make_detector

#: Heap entry stages.
_SUSPECT = 0
_LEAVE = 1
#: The loss estimate never goes beyond this: past it no timeout keeps false leaves rare, and
#: an unbounded one would let a terrible radio stall failure detection altogether.
MAX_LOSS_ESTIMATE = 0.5
#: A gap larger than this in a peer's heartbeat counter is not loss (a reboot, a long
#: partition, a peer that heartbeated elsewhere meanwhile): it is not counted.
_MAX_GAP = 20


@dataclass(slots=True)
class Peer:
    """A member of the view."""

    incarnation: int
    detector: LeaveDetector
    deadline: float  # when it becomes suspect (if nothing is heard)
    joined_at: float
    last_heard: float
    last_seq: int = -1
    leave_at: float = math.inf  # when it leaves, once suspected
    suspected: bool = False
    last_count: int = -1
    #: Not suspected before this time, however silent (:meth:`Membership.hold`).
    hold_until: float = -math.inf


@dataclass(slots=True)
class _Candidate:
    incarnation: int
    times: deque[float] = field(default_factory=deque)
    last_seq: int = -1


class LossEstimate:
    """The fraction of heartbeats lost on the way here, from counter gaps.

    Decaying counts (``decay`` per heartbeat heard) so the estimate follows a changing radio;
    the first heartbeats weigh fully, so a fresh platform learns the loss within a second.
    """

    __slots__ = ("_decay", "_heard", "_lost")

    def __init__(self, decay: float = 0.995) -> None:
        self._decay = decay
        self._lost = 0.0
        self._heard = 0.0

    def observe(self, gap: int) -> None:
        """One heartbeat heard after ``gap`` lost ones."""
        d = self._decay
        self._lost = self._lost * d + gap
        self._heard = self._heard * d + 1.0

    @property
    def value(self) -> float:
        total = self._lost + self._heard
        return 0.0 if total <= 0 else min(self._lost / total, MAX_LOSS_ESTIMATE)


def leave_silence(
    *, watched: int, interval: float, loss: float, rate: float, floor: float
) -> float:
    """How long a live peer may stay silent before it is declared gone.

    The silence ``T`` at which ``watched`` live peers heartbeating every ``interval`` with
    loss ``loss`` look dead ``rate`` times a second in all (``n·h·(1-p)·p^(h·T-½) = rate``),
    at least ``floor``.
    """
    if loss <= 0.0 or watched <= 0:
        return floor
    h = 1.0 / interval
    expected = watched * h * (1.0 - loss) / rate
    if expected <= 1.0:
        return floor
    beats = 0.5 + math.log(expected) / math.log(1.0 / loss)
    return max(floor, beats * interval)


class Membership:
    """One platform's view of the live swarm (itself excluded).

    ``cadence`` is the interval at which the watched peers heartbeat (a star master may ask
    its members for less than ``heartbeat_interval``); the suspicion time scales with it.
    """

    def __init__(self, self_id: int, config: CoreConfig) -> None:
        self.self_id = self_id
        self._config = config
        self.peers: dict[int, Peer] = {}
        #: Counts the changes to who is in :attr:`peers` (a peer added or dropped): a layer
        #: above may keep what it derives from the view for as long as this stays the same.
        self.version = 0
        #: Peers suspected now (silent past their suspicion time, not yet gone).
        self.suspects: set[int] = set()
        self.loss = LossEstimate()
        self.cadence = config.heartbeat_interval
        self._candidates: dict[int, _Candidate] = {}
        self._deadlines: list[tuple[float, int, int, int]] = []
        self._latest_incarnation: dict[int, int] = {}
        self._next_candidate_sweep = 0.0
        self._silence = config.t_leave + config.probe_window
        self._silence_for: tuple[int, float, float] = (-1, -1.0, -1.0)

    def __contains__(self, peer: int) -> bool:
        return peer in self.peers

    def __len__(self) -> int:
        return len(self.peers)

    @property
    def join_window(self) -> float:
        """How close together a candidate's ``join_heartbeats`` heartbeats must come: T_join,
        or longer when the members are asked to heartbeat slower (``cadence``): at a cadence
        of a second (a star swarm of 600 on a 1 Mbit/s channel) three heartbeats span two
        seconds, and a fixed T_join would let no platform join or come back at all. The
        slower window spans ``join_heartbeats`` + 1 intervals, so one heartbeat lost (or
        queued on the channel) among them does not send a candidate back to the start: at
        10 % loss, one platform in five needed that, and a swarm of 1000 on 1 Mbit/s had
        not formed 8 s after its boot."""
        cfg = self._config
        if self.cadence <= cfg.heartbeat_interval:
            return cfg.t_join
        return max(cfg.t_join, (cfg.join_heartbeats + 1) * self.cadence)

    def is_newer(self, peer: int, incarnation: int) -> bool:
        """Whether ``incarnation`` is newer than any seen from ``peer`` (see
        :meth:`note_incarnation`)."""
        return incarnation > self._latest_incarnation.get(peer, -1)

    def is_current(self, peer: int, incarnation: int) -> bool:
        """False for packets of an incarnation older than the newest seen from ``peer``."""
        return incarnation >= self._latest_incarnation.get(peer, incarnation)

    def recently_heard(self, horizon: float) -> list[int]:
        """Peers and candidates heard since ``horizon`` (for election decisions that must
        count a lower ID that is heard but has not joined yet)."""
        heard = [p for p, m in self.peers.items() if m.last_heard >= horizon]
        heard += [p for p, c in self._candidates.items() if c.times and c.times[-1] >= horizon]
        return heard

    # --- timeouts ---------------------------------------------------------------------------

    def _suspect_after(self) -> float:
        """The fixed part of the suspicion time: ``t_leave``, scaled with the cadence."""
        ratio = self.cadence / self._config.heartbeat_interval
        return self._config.t_leave * max(1.0, ratio)

    def silence(self) -> float:
        """How long a watched peer may be silent before it leaves (see :func:`leave_silence`).

        Cached: recomputed when the view's size moves by a tenth or the loss by 0.01.
        """
        n = len(self.peers)
        loss = self.loss.value
        cached_n, cached_loss, cached_cadence = self._silence_for
        if (
            abs(n - cached_n) * 10 > max(cached_n, 1)
            or abs(loss - cached_loss) > 0.01
            or cached_cadence != self.cadence
        ):
            cfg = self._config
            self._silence = leave_silence(
                watched=max(n, 1),
                interval=self.cadence,
                loss=loss,
                rate=cfg.false_leave_rate,
                floor=self._suspect_after() + cfg.probe_window,
            )
            self._silence_for = (n, loss, self.cadence)
        return self._silence

    # --- heartbeats -------------------------------------------------------------------------

    def note_incarnation(
        self, peer: int, incarnation: int, out: list[MemberJoined | MemberLeft]
    ) -> None:
        """A packet of ``peer``'s ``incarnation`` (any packet, before it is handled): one of
        a higher incarnation than the member in the view means the peer rebooted and lost
        its state, so the old member leaves (reason ``restarted``, appended to ``out``)
        before anything of the new one is acted on. (Left to the heartbeat, a report or
        claim of the new incarnation handled before it would be erased by the leave the
        heartbeat then causes.)"""
        if incarnation <= self._latest_incarnation.get(peer, -1):
            return
        self._latest_incarnation[peer] = incarnation
        member = self.peers.get(peer)
        if member is not None and member.incarnation < incarnation:
            self._drop(peer)
            out.append(
                MemberLeft(platform=peer, incarnation=member.incarnation, reason="restarted")
            )

    def heartbeat(
        self,
        peer: int,
        incarnation: int,
        now: float,
        out: list[MemberJoined | MemberLeft],
        seq: int | None = None,
        count: int | None = None,
    ) -> Peer | None:
        """Account for one heartbeat; append join/leave events to ``out``.

        ``seq`` is the packet's sequence number: a copy the radio duplicated (or a late one
        overtaken by a newer heartbeat) is not counted again. ``count`` is the heartbeat's
        own counter, whose gaps measure the loss. Returns the peer's entry when it is (now)
        in the view, else None.
        """
        member = self.peers.get(peer)
        if member is not None and incarnation == member.incarnation:
            # The common case, kept short: a known member's next heartbeat.
            if seq is not None:
                if seq <= member.last_seq:
                    return member
                member.last_seq = seq
            if count is not None and count > member.last_count:
                if member.last_count >= 0 and count - member.last_count - 1 <= _MAX_GAP:
                    self.loss.observe(count - member.last_count - 1)
                member.last_count = count
            self._refresh(peer, member, now)
            return member
        if incarnation < self._latest_incarnation.get(peer, -1):
            return None
        self.note_incarnation(peer, incarnation, out)
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
            and now - cand.times[0] <= self.join_window
        ):
            del self._candidates[peer]
            member = self._add(peer, incarnation, now, -1 if seq is None else seq)
            if count is not None:
                member.last_count = count
            out.append(MemberJoined(platform=peer, incarnation=incarnation))
            return member
        return None

    def admit(self, peer: int, incarnation: int, now: float, *, grace: float = 0.0) -> bool:
        """Take ``peer`` into the view without its heartbeats (a new star master inherits
        its predecessor's roster: those platforms were members a moment ago). It is watched
        from ``now`` like a peer just heard, its suspicion and leave ``grace`` seconds later
        still. False when it is already in (or a newer incarnation of it is known)."""
        if peer == self.self_id or peer in self.peers:
            return False
        if incarnation < self._latest_incarnation.get(peer, -1):
            return False
        self._latest_incarnation[peer] = incarnation
        self._candidates.pop(peer, None)
        self._add(peer, incarnation, now, -1)
        if grace > 0.0:
            self.hold(peer, now + grace, now)
        return True

    def hold(self, peer: int, until: float, now: float) -> None:
        """Suspect ``peer`` (a member of the view) no sooner than ``until``, however silent
        it is meanwhile, heard or not: its packets are known to be queued behind others (a
        new master's handshake on a shared channel). After ``until`` its usual times apply,
        counted from when it was last heard or from ``until``, whichever is later."""
        member = self.peers.get(peer)
        if member is None or until <= member.hold_until:
            return
        member.hold_until = until
        self._refresh(peer, member, max(now, member.last_heard), heard=False)

    def forget(self, peer: int) -> None:
        """Stop watching ``peer`` without a leave (a star member watches its master only)."""
        if peer in self.peers:
            self._drop(peer)
        self._candidates.pop(peer, None)

    def _add(self, peer: int, incarnation: int, now: float, seq: int) -> Peer:
        detector = make_detector(self._config)
        member = Peer(
            incarnation=incarnation,
            detector=detector,
            deadline=now,
            joined_at=now,
            last_heard=now,
            last_seq=seq,
        )
        self.peers[peer] = member
        self.version += 1
        self._refresh(peer, member, now)
        return member

    def _drop(self, peer: int) -> None:
        del self.peers[peer]
        self.version += 1
        self.suspects.discard(peer)

    def _refresh(self, peer: int, member: Peer, now: float, *, heard: bool = True) -> None:
        """``peer`` was heard at ``now`` (``heard`` False: its times are recomputed, as of
        ``now``, without a heartbeat): new suspicion and leave times, none before its hold."""
        observed = member.detector.observe(now) if heard else now
        start = max(now, member.hold_until)
        deadline = max(observed, start + self._suspect_after())
        member.deadline = deadline
        member.leave_at = max(start + self.silence(), deadline + self._config.probe_window)
        if heard:
            member.last_heard = now
        if member.suspected:
            member.suspected = False
            self.suspects.discard(peer)
        heapq.heappush(self._deadlines, (deadline, peer, member.incarnation, _SUSPECT))

    # --- timers -----------------------------------------------------------------------------

    def expire(
        self,
        now: float,
        out: list[MemberJoined | MemberLeft],
        suspected: list[int] | None = None,
        grace: float = 0.0,
    ) -> None:
        """Suspect and remove peers whose times have passed (``grace`` seconds late);
        append MemberLeft events to ``out`` and newly suspected peers to ``suspected``."""
        heap = self._deadlines
        horizon = now - grace
        reason: str = "timeout" if self._config.detector == "timeout" else "suspected"
        while heap and heap[0][0] <= horizon:
            t, peer, incarnation, stage = heapq.heappop(heap)
            member = self.peers.get(peer)
            if member is None or member.incarnation != incarnation:
                continue
            if stage == _SUSPECT:
                if member.deadline != t or member.suspected:
                    continue  # stale entry: a later heartbeat moved the deadline
                member.suspected = True
                self.suspects.add(peer)
                if suspected is not None:
                    suspected.append(peer)
                heapq.heappush(heap, (member.leave_at, peer, incarnation, _LEAVE))
                continue
            if not member.suspected or member.leave_at != t:
                continue
            self._drop(peer)
            out.append(
                MemberLeft(platform=peer, incarnation=incarnation, reason=reason)  # type: ignore[arg-type]
            )
        if now >= self._next_candidate_sweep and self._candidates:
            # Forget candidates that went quiet, so a burst of stray senders cannot grow state.
            old = now - self.join_window
            for peer in [p for p, c in self._candidates.items() if c.times[-1] < old]:
                del self._candidates[peer]
            self._next_candidate_sweep = now + self._config.t_join

    def next_deadline(self) -> float | None:
        """Earliest time :meth:`expire` could act (a stale entry may make it early)."""
        while self._deadlines:
            t, peer, incarnation, stage = self._deadlines[0]
            member = self.peers.get(peer)
            if member is not None and member.incarnation == incarnation:
                if stage == _SUSPECT and member.deadline == t and not member.suspected:
                    return t
                if stage == _LEAVE and member.suspected and member.leave_at == t:
                    return t
            heapq.heappop(self._deadlines)
        return None
