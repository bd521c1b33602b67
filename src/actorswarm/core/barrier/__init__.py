"""Barriers with gather/scatter, master side and member side (docs/design.md §3.4).

Theory of operation
-------------------
A barrier instance is a key plus a *generation*. A member asks to pass with a
:class:`~actorswarm.core.wire.BarrierRequest` for the generation it believes is open
(``known[key]``, the number of firings it has seen). The master keeps the open generation per
key; a request for an older one is refused with a stale notice (requests of an old generation
never count for a new one), a newer one moves the master forward.

A key may have several *parts* (the task engine maps a group of transitions that share a key
to parts); each part needs a number of participants. When every part has enough requests, the
master chooses the best bids of each part (lower bid first, then lower platform ID), numbers
them 1..n within their part, and releases everyone — chosen and not chosen — with **one**
broadcast :class:`~actorswarm.core.wire.Release`. It retransmits the release only to the
candidates that have not acknowledged, with only their entries, so master traffic grows
linearly with the swarm. A member passes each (key, generation) at most once.

Failover without losing state: a member reports its known generations, its pending request
and the last release it passed. A new master that learns from such reports that a generation
was already fired (some members passed it, others still wait for it) *completes* that firing:
the waiting candidates get the indices nobody reported, so every participant is released by
the same generation and none is released twice — the all-or-nothing property survives a
master crash in the middle of a release.

A timeout (seconds from the group's first request) releases every waiting candidate with
outcome ``timeout``.

A *hold* (:meth:`BarrierMaster.hold`) keeps a key from firing until a given time while its
requests gather, so that the best bids win rather than the first to arrive: a ``need`` of 1
would otherwise fire on the first request, whatever the bids of those still on their way.


Layout: :mod:`~.member` (the member's side); the master's side, :class:`BarrierMaster`
(:mod:`~.master`), a coordinator of four parts with one job each, composed, none derived
from another — :mod:`~.table` (the open generations and the firings known),
:mod:`~.firing` (when a key fires and whom it chooses), :mod:`~.releases` (releases in
flight, retransmitted until acknowledged) and :mod:`~.completion` (late requests and
failover completion); :mod:`~.shared` (what they share, and :class:`BarrierOutput`, where
the master's parts put what they decide).
"""

from __future__ import annotations

from actorswarm.core.barrier.master import BarrierMaster
from actorswarm.core.barrier.member import BarrierMember
from actorswarm.core.barrier.shared import (
    OUTCOME_NAMES,
    RECENT_ASSIGNMENTS,
    RECENT_RELEASES,
    BarrierOutput,
    Gathers,
    NeedResolver,
    OutgoingRelease,
    Scatter,
    addressee,
)

__all__ = [
    "OUTCOME_NAMES",
    "RECENT_ASSIGNMENTS",
    "RECENT_RELEASES",
    "BarrierMaster",
    "BarrierMember",
    "BarrierOutput",
    "Gathers",
    "NeedResolver",
    "OutgoingRelease",
    "Scatter",
    "addressee",
]
