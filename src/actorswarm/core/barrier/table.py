"""The master's barrier table (see :mod:`actorswarm.core.barrier`): the open generation of
each key and the firings it knows. The master's other parts decide; this part only keeps
what they decided, and answers what a successor or the engine asks of it.
"""

from __future__ import annotations

from actorswarm.core.barrier.shared import (
    RECENT_ASSIGNMENTS,
    RECENT_RELEASES,
    Firing,
    OpenGeneration,
)
from actorswarm.core.wire import ReleaseRecord


class BarrierTable:
    """Open generations and known firings per key, and whether the master may fire.

    ``ready`` is False during the handshake: requests are collected but nothing fires until
    every member has reported, so a new master never fires a generation its predecessor
    already fired. ``holding`` is True while the staged requests are replayed at its end:
    they all count before anything fires, so the best bids win rather than the first
    replayed.
    """

    def __init__(self) -> None:
        self.open: dict[int, OpenGeneration] = {}
        #: Known firings per key and generation (a generation may have two: partitions that
        #: each fired it). Only the last :data:`RECENT_RELEASES` generations are kept.
        self.fired: dict[int, dict[int, list[Firing]]] = {}
        self.ready = False
        self.holding = False

    @property
    def may_fire(self) -> bool:
        """Whether a request may set off a firing now."""
        return self.ready and not self.holding

    def instance(self, key: int) -> OpenGeneration:
        """The open generation of ``key``, opened after the last firing known if none is."""
        inst = self.open.get(key)
        if inst is None:
            gens = self.fired.get(key)
            inst = self.open[key] = OpenGeneration(max(gens) + 1 if gens else 0)
        return inst

    def firings(self, key: int, generation: int) -> list[Firing] | None:
        """The firings known of ``key``'s ``generation`` (None or empty: none)."""
        return self.fired.get(key, {}).get(generation)

    def prune(self, key: int, keep: int = RECENT_RELEASES) -> None:
        """Forget all but the last ``keep`` generations fired of ``key``."""
        gens = self.fired.get(key, {})
        for old in sorted(gens)[:-keep]:
            del gens[old]

    def waiting_occasions(self, key: int) -> tuple[str, ...]:
        """The occasions of the requests waiting at the open generation of ``key``."""
        inst = self.open.get(key)
        if inst is None:
            return ()
        return tuple(sorted({r.occasion for r in inst.requests.values() if r.occasion}))

    def decided(self, platform: int) -> list[ReleaseRecord]:
        """The firings this master decided or knows in full, as records for a report to its
        successor: a master that steps down right after a firing may be the only one that
        knows it (its release may not have reached anyone yet), and without this record its
        successor could fire the generation again without the first firing's candidates.

        A predecessor's firing this master completed goes as a *partial* assignment (the
        candidates it knows, those it added among them): its successor may know that
        firing whole as it was first decided, from a member's report, and would refuse a
        candidate the completion added, whose release was lost, as late."""
        out = []
        for key, gens in self.fired.items():
            for generation in sorted(gens)[-RECENT_ASSIGNMENTS:]:
                for fired in gens[generation]:
                    whole = fired.complete_knowledge
                    if not fired.assigned or not (whole or fired.entries):
                        continue
                    part, index = fired.assigned.get(platform, (min(fired.sizes, default=0), 0))
                    known = dict(fired.assigned)
                    out.append(
                        ReleaseRecord(
                            key=key,
                            generation=generation,
                            part=part,
                            index=index,
                            size=fired.sizes.get(part, 0),
                            outcome=fired.outcome,
                            origin=fired.origin,
                            assignment=known if whole else {},
                            origin_master=fired.master,
                            partial={} if whole else known,
                        )
                    )
        return out


__all__ = ["BarrierTable"]
