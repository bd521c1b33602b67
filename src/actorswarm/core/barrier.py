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


Layout: :mod:`~actorswarm.core.barrier_state` (the master's table and releases in flight),
:mod:`~actorswarm.core.barrier_master` (requests, firing, time),
:mod:`~actorswarm.core.barrier_completion` (late requests, failover completion),
:mod:`~actorswarm.core.barrier_member` (the member's side).
"""

from __future__ import annotations

from actorswarm.core.barrier_master import BarrierMaster
from actorswarm.core.barrier_member import BarrierMember
from actorswarm.core.barrier_state import (
    OUTCOME_NAMES,
    RECENT_ASSIGNMENTS,
    RECENT_RELEASES,
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
    "Gathers",
    "NeedResolver",
    "OutgoingRelease",
    "Scatter",
    "addressee",
]
