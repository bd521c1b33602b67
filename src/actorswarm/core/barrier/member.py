"""The member's side of barriers (see :mod:`actorswarm.core.barrier`): its pending
requests, the generations it knows, and the releases it passed, at most once each."""

from __future__ import annotations

import heapq
from collections import deque
from collections.abc import Sequence
from typing import Any

import msgspec

from actorswarm.core.barrier.shared import (
    ASSIGNMENT_ALL_CARRY,
    ASSIGNMENT_CARRIERS,
    OUTCOME_NAMES,
    RECENT_ASSIGNMENTS,
    RECENT_RELEASES,
)
from actorswarm.core.events import BarrierReleased, BarrierStaleNotice
from actorswarm.core.wire import (
    NEED_ALL,
    BarrierRequest,
    BarrierStale,
    Release,
    ReleaseEntry,
    ReleaseRecord,
)

#: Generations passed that a member remembers per key (see ``BarrierMember._passed``).
PASSED_KEPT = 64


class BarrierMember:
    """A platform's side: its pending requests, the generations it knows, what it passed."""

    def __init__(self, platform: int) -> None:
        self.platform = platform
        self.known: dict[int, int] = {}
        self.pending: dict[int, tuple[BarrierRequest, float]] = {}
        # The last few releases passed per key: a master rebuilding state after a partition
        # may need an older one than the last (the other side moved on meanwhile).
        self.recent: dict[int, deque[ReleaseRecord]] = {}
        # The generations passed per key, the last PASSED_KEPT: a retransmitted release of
        # one of them is acknowledged and not delivered again. An older one needs no entry:
        # passing raised ``known`` past it, so every request since names a later generation
        # and such a release is refused as for a request no longer held. (A set of every
        # generation ever passed grew by one a switch for as long as a platform ran.)
        self._passed: dict[int, deque[int]] = {}

    def request(
        self,
        key: int,
        need: dict[int, int],
        now: float,
        *,
        part: int = 0,
        bid: float | None = None,
        data: Any = None,
        timeout: float | None = None,
        epoch: int = 0,
        occasion: str = "",
        master: int = 0,
        renew: bool = False,
    ) -> BarrierRequest:
        """Record a request for the open generation of ``key`` and return it (to send).

        ``epoch`` is the master epoch this platform follows now, ``master`` its master;
        ``renew``: see :attr:`~actorswarm.core.wire.BarrierRequest.renew`."""
        if key in self.pending:
            raise ValueError(
                f"platform {self.platform} already waits on barrier key {key} "
                f"(generation {self.pending[key][0].generation}); one request per key at a time"
            )
        if part not in need:
            raise ValueError(f"part {part} is not among the barrier's parts {sorted(need)}")
        for p, n in need.items():
            if n < 1 and n != NEED_ALL:
                raise ValueError(f"part {p} needs {n} participants; need >= 1 or NEED_ALL")
        req = BarrierRequest(
            key=key,
            generation=self.known.get(key, 0),
            need=dict(need),
            part=part,
            bid=float(self.platform if bid is None else bid),
            data=data,
            timeout=timeout,
            epoch=epoch,
            occasion=occasion,
            master=master,
            renew=renew,
        )
        self.pending[key] = (req, now)
        return req

    def restated(self, now: float) -> list[BarrierRequest]:
        """Pending requests with their age, for a handshake report."""
        out = []
        for req, since in self.pending.values():
            out.append(
                BarrierRequest(
                    key=req.key,
                    generation=req.generation,
                    need=req.need,
                    part=req.part,
                    bid=req.bid,
                    data=req.data,
                    timeout=req.timeout,
                    age=max(0.0, now - since),
                    epoch=req.epoch,
                    occasion=req.occasion,
                    master=req.master,
                    renew=req.renew,
                )
            )
        return out

    def on_release(self, rel: Release) -> tuple[BarrierReleased | None, bool]:
        """Apply a release; return (event if this platform passes now, whether to acknowledge)."""
        mine = next((e for e in rel.entries if e.platform == self.platform), None)
        pending = self.pending.get(rel.key)
        if mine is None:
            if pending is None:
                # Not a candidate: only learn that this generation has fired. (A candidate
                # whose entry is in another chunk of the release waits for that chunk.)
                self.known[rel.key] = max(self.known.get(rel.key, 0), rel.generation + 1)
            return None, False
        passed = self._passed.get(rel.key)
        if passed is not None and rel.generation in passed:
            return None, True  # a retransmission: acknowledge again, deliver nothing
        if pending is None or pending[0].generation > rel.generation:
            # A release for a request this platform no longer holds (e.g. it was told the
            # request was stale): acknowledge so the master stops, deliver nothing. (A later
            # generation that names this platform is the master placing a late request.)
            return None, True
        del self.pending[rel.key]
        self._passed.setdefault(rel.key, deque(maxlen=PASSED_KEPT)).append(rel.generation)
        self.known[rel.key] = max(self.known.get(rel.key, 0), rel.generation + 1)
        size = rel.sizes.get(mine.part, 0)
        whole = self._carries(rel)
        seen = {e.platform: (e.part, e.index) for e in rel.entries}
        partial = not whole and not rel.total and self._keeps(rel.entries)
        self.recent.setdefault(rel.key, deque(maxlen=RECENT_RELEASES)).append(
            ReleaseRecord(
                key=rel.key,
                generation=rel.generation,
                part=mine.part,
                index=mine.index,
                size=size,
                outcome=rel.outcome,
                origin=rel.origin,
                origin_master=rel.origin_master,
                assignment=seen if whole else {},
                partial=seen if partial else {},
            )
        )
        event = BarrierReleased(
            key=rel.key,
            generation=rel.generation,
            outcome=OUTCOME_NAMES.get(rel.outcome, "complete"),  # type: ignore[arg-type]
            chosen=mine.index > 0,
            part=mine.part,
            index=mine.index,
            size=size,
            data=mine.data,
            gathered=tuple(rel.gathered),
        )
        return event, True

    def _carries(self, rel: Release) -> bool:
        """Whether this platform keeps ``rel``'s whole assignment for its reports: when it
        saw all of it (one packet) and the firing is small, or is one of its lowest
        :data:`ASSIGNMENT_CARRIERS` IDs. One carrier's report gives a new master complete
        knowledge of the firing; without any (all of them lost with the old master) it
        completes the firing from the reports' own entries, as for a release of several
        chunks, which no one sees whole."""
        if not rel.total or len(rel.entries) != rel.total:
            return False
        return self._keeps(rel.entries)

    def _keeps(self, entries: Sequence[ReleaseEntry]) -> bool:
        """Whether this platform keeps ``entries`` for its reports: all of few, or the
        lowest :data:`ASSIGNMENT_CARRIERS` IDs of many (a report stays small).

        Of a release its master could not send whole (it completes a predecessor's firing
        with what it adds, ``total`` 0), the entries are kept as a *partial* assignment:
        without them, a later master that knows the predecessor's firing whole from another
        report would take a candidate the completion added for one the firing never named,
        and refuse it as stale although it was chosen (campaign seed 7734060)."""
        if len(entries) <= ASSIGNMENT_ALL_CARRY:
            return True
        lowest = heapq.nsmallest(ASSIGNMENT_CARRIERS, (e.platform for e in entries))
        return self.platform in lowest

    def adopt_epoch(self, epoch: int, master: int = 0) -> None:
        """Requests made while no master was known belong to the first epoch followed."""
        for key, (req, since) in list(self.pending.items()):
            if req.epoch == 0:
                adopted = msgspec.structs.replace(req, epoch=epoch, master=master)
                self.pending[key] = (adopted, since)

    def records(self) -> list[ReleaseRecord]:
        """Every recent release this platform passed, for a handshake report (only the newest
        few per key with their whole assignment, to keep the report small)."""
        out = []
        for recs in self.recent.values():
            keep_from = len(recs) - RECENT_ASSIGNMENTS
            for i, rec in enumerate(recs):
                strip = i < keep_from and (rec.assignment or rec.partial)
                out.append(
                    msgspec.structs.replace(rec, assignment={}, partial={}) if strip else rec
                )
        return out

    def on_stale(self, notice: BarrierStale) -> BarrierStaleNotice | None:
        pending = self.pending.get(notice.key)
        self.known[notice.key] = max(self.known.get(notice.key, 0), notice.current)
        if pending is None or pending[0].generation != notice.generation:
            return None
        del self.pending[notice.key]
        return BarrierStaleNotice(
            key=notice.key, generation=notice.generation, current=notice.current
        )

    def cancel(self, key: int) -> bool:
        """Forget the pending request on ``key`` locally (e.g. the task moved on)."""
        return self.pending.pop(key, None) is not None


__all__ = ["BarrierMember"]
