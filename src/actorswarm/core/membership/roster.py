"""The star master's roster and its copy at the members (``membership="star"``,
docs/design.md §3.1).

Theory of operation
-------------------
In a star, members do not hear each other; they learn the swarm from their master. The
master keeps a :class:`RosterLog`: a *version* that grows with every join and leave in its
view (per epoch: a new master starts at 1), the last :data:`~actorswarm.core.wire.MAX_CHANGES`
changes, and the *succession list* — the next-lowest IDs of its view, who take over in that
order if the master is lost, without an election round or a broadcast storm.

Every master heartbeat carries the version, the member count, the recent changes and the
succession list. A member's :class:`RosterView` applies the changes when it is only a few
versions behind; when it is further behind (a new master, a lost run of heartbeats) it asks
for the whole roster, which comes in chunks of ``roster_chunk`` entries (a packet each, even
at 10 000 platforms). Until then it keeps acting on what it has and asks again — it never
applies changes that do not chain onto its own version, and a roster whose size disagrees
with the master's count is thrown away and fetched again. Nothing here is trusted beyond
being internally consistent: a forged or garbled roster makes a member ask again, never act
on a view the master did not send.
"""

from __future__ import annotations

import heapq
from collections import deque
from collections.abc import Iterable, Sequence

from actorswarm.core.wire import MAX_CHANGES, Heartbeat, RosterChunk

#: A change as heartbeats carry it: (platform, incarnation), incarnation -1 for a leave.
Change = tuple[int, int]


class RosterLog:
    """The master's roster: version, recent changes, succession list."""

    def __init__(self, succession: int) -> None:
        self._succession_len = succession
        self.epoch = 0
        self.version = 0
        self.changes: deque[Change] = deque(maxlen=MAX_CHANGES)
        self._succession: list[int] | None = []

    def reset(self, epoch: int) -> None:
        """A new epoch: version 1, no changes to tell (members fetch the whole roster)."""
        self.epoch = epoch
        self.version = 1
        self.changes.clear()
        self._succession = None

    def joined(self, platform: int, incarnation: int) -> None:
        self.version += 1
        self.changes.append((platform, incarnation))
        self._succession = None

    def left(self, platform: int) -> None:
        self.version += 1
        self.changes.append((platform, -1))
        self._succession = None

    def succession(self, peers: Iterable[int]) -> list[int]:
        """The next-lowest IDs of the view (``peers``: the master's members), cached until
        the roster changes."""
        if self._succession is None:
            self._succession = heapq.nsmallest(self._succession_len, peers)
        return self._succession

    @staticmethod
    def chunks(epoch: int, version: int, members: dict[int, int], size: int) -> list[RosterChunk]:
        """The whole roster (``members``: platform -> incarnation) as packets of at most
        ``size`` entries, in ascending platform order."""
        entries = sorted(members.items())
        count = max(1, -(-len(entries) // size))
        return [
            RosterChunk(
                epoch=epoch,
                version=version,
                index=i,
                count=count,
                members=entries[i * size : (i + 1) * size],
            )
            for i in range(count)
        ]


#: How many rosters a :class:`RosterPool` keeps (the newest per epoch, the newest epochs).
POOL_EPOCHS = 8


class RosterPool:
    """Rosters shared by the star members of one process (a simulated swarm): a member
    whose copy equals one the pool holds for the same epoch and version keeps the pool's,
    so 10 000 members hold one roster of 10 000 rather than 10 000 of them (about 1 MiB
    each). The copies are never changed in place, so sharing them is safe; they are
    compared whole before they are shared, so a forged roster, or a partition's master
    with the same epoch number, is never mistaken for another. A daemon, one member per
    process, has no use for one."""

    def __init__(self) -> None:
        self._held: dict[int, tuple[int, dict[int, int]]] = {}  # epoch -> (version, roster)
        # The chunks of the newest roster on its way ((epoch, version, count), and index ->
        # entries). Members gather a roster's chunks over a while, all at once at a boot:
        # 10 000 members each holding their own parts of a roster of 10 000 was most of
        # a boot's peak memory.
        self._gathering: tuple[int, int, int] | None = None
        self._parts: dict[int, Sequence[tuple[int, int]]] = {}
        # The roster those parts make, built for the first member that had them all.
        self._whole: dict[int, int] | None = None
        self.shared = 0  # copies replaced by the pool's (rosters and chunks)

    def share(self, epoch: int, version: int, members: dict[int, int]) -> dict[int, int]:
        """The roster to keep for ``epoch``/``version``: the pool's when it equals
        ``members``, else ``members`` (which the pool then holds, if newer)."""
        held = self._held.get(epoch)
        if held is not None and held[0] == version and (held[1] is members or held[1] == members):
            self.shared += 1
            return held[1]
        if held is None or version > held[0]:
            self._held[epoch] = (version, members)
            while len(self._held) > POOL_EPOCHS:
                del self._held[min(self._held)]
        return members

    def part(self, chunk: RosterChunk) -> Sequence[tuple[int, int]]:
        """The entries of ``chunk`` to keep until its roster is complete: the pool's copy
        when it holds an equal one for the same roster and index (the very same when the
        receivers were handed one decoded chunk)."""
        key = (chunk.epoch, chunk.version, chunk.count)
        entries = chunk.members
        if key != self._gathering:
            if self._gathering is not None and self._gathering > key:
                return entries  # an older roster than the one the pool gathers
            self._gathering, self._parts, self._whole = key, {}, None
        held = self._parts.get(chunk.index)
        if held is None:
            self._parts[chunk.index] = entries
            return entries
        if held is entries or held == entries:
            self.shared += 1
            return held
        return entries

    def whole(
        self, key: tuple[int, int, int], parts: dict[int, Sequence[tuple[int, int]]]
    ) -> dict[int, int] | None:
        """The roster (platform -> incarnation) that ``parts``, every chunk of roster
        ``key`` (epoch, version, count), make, when each is the pool's own (:meth:`part`):
        built once for all the members that gathered the same chunks. None otherwise."""
        own = self._parts
        if key != self._gathering or any(parts[i] is not own.get(i) for i in range(key[2])):
            return None
        if self._whole is None:
            self._whole = {p: incarnation for i in range(key[2]) for p, incarnation in own[i]}
        return self._whole


class RosterView:
    """A star member's copy of its master's roster.

    ``members`` maps platform to incarnation and is valid for ``epoch``/``version``; it is
    replaced, never changed in place (a :class:`RosterPool` may share it among members).
    ``succession`` and ``size`` are the master's latest word, whatever the version.
    """

    def __init__(self, pool: RosterPool | None = None) -> None:
        self._pool = pool
        self.epoch = -1
        self.version = 0
        self.members: dict[int, int] = {}
        self.succession: list[int] = []
        self.size = 0
        self.rejected = 0  # heartbeats or chunks that did not fit (counted by the node)
        #: Platforms the master's roster lost since the owner last looked (it drops its
        #: queues to them, as it would for a peer that left its own view).
        self.removed: list[int] = []
        self._pending: tuple[int, int, int] | None = None  # (epoch, version, count)
        self._parts: dict[int, Sequence[tuple[int, int]]] = {}

    @property
    def current(self) -> bool:
        """Whether the copy matches the master's last heartbeat."""
        return self.epoch >= 0 and self.version > 0

    def on_heartbeat(self, epoch: int, hb: Heartbeat) -> bool:
        """Apply a master heartbeat of ``epoch``; True when the member is behind and should
        ask for the whole roster."""
        self.succession = list(hb.succession)
        self.size = hb.size
        if hb.roster == 0:
            return False  # a master that keeps no roster (broadcast mode)
        if epoch != self.epoch:
            return True
        if hb.roster == self.version:
            return len(self.members) != hb.size
        missing = hb.roster - self.version
        if missing < 0:
            self.rejected += 1  # an older version than ours: a late or forged packet
            return False
        if missing > len(hb.changes):
            return True
        members = dict(self.members)
        removed = []
        for platform, incarnation in hb.changes[len(hb.changes) - missing :]:
            if incarnation < 0:
                if members.pop(platform, None) is not None:
                    removed.append(platform)
            else:
                members[platform] = incarnation
        if len(members) != hb.size:
            # The changes do not lead where the master is: keep the copy as it was (acting
            # on it would drop queues to live platforms) and fetch a full one.
            self.rejected += 1
            self.version = 0
            return True
        self.members = self._share(self.epoch, hb.roster, members)
        self.removed.extend(removed)
        self.version = hb.roster
        return False

    def _share(self, epoch: int, version: int, members: dict[int, int]) -> dict[int, int]:
        return members if self._pool is None else self._pool.share(epoch, version, members)

    def on_chunk(self, chunk: RosterChunk) -> bool:
        """Take one chunk of a full roster; True when the roster is complete and adopted."""
        key = (chunk.epoch, chunk.version, chunk.count)
        if (chunk.epoch, chunk.version) <= (self.epoch, self.version):
            return False  # a roster this member has (a broadcast meant for others), or older
        if chunk.index >= chunk.count:
            self.rejected += 1
            return False
        if self._pending != key:
            if self._pending is not None and (chunk.epoch, chunk.version) < self._pending[:2]:
                self.rejected += 1  # older than a roster already on its way
                return False
            self._pending = key
            self._parts = {}
        self._parts[chunk.index] = chunk.members if self._pool is None else self._pool.part(chunk)
        if len(self._parts) < chunk.count:
            return False
        if (chunk.epoch, chunk.version) < (self.epoch, self.version):
            # A complete roster older than the one adopted (a late copy): never go back.
            self.rejected += 1
            self._pending = None
            self._parts = {}
            return False
        members = None if self._pool is None else self._pool.whole(key, self._parts)
        if members is None:
            members = {}
            for i in range(chunk.count):
                for platform, incarnation in self._parts[i]:
                    members[platform] = incarnation
        self.epoch, self.version = chunk.epoch, chunk.version
        self.removed.extend(p for p in self.members if p not in members)
        self.members = self._share(chunk.epoch, chunk.version, members)
        self._pending = None
        self._parts = {}
        return True

    def forget(self) -> None:
        """Drop the copy (a member that follows no master any more keeps the succession list
        only, to know who takes over)."""
        self.epoch = -1
        self.version = 0
        self.members = {}
        self._pending = None
        self._parts = {}
