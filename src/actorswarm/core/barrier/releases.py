"""The master's releases in flight (see :mod:`actorswarm.core.barrier`): a firing's release
goes out as one broadcast and is retransmitted only to the candidates that have not
acknowledged, with only their entries, until they do, leave, or its deadline passes.
"""

from __future__ import annotations

from collections.abc import Callable

from actorswarm.core.barrier.shared import BarrierOutput, Firing, OutgoingRelease
from actorswarm.core.config import CoreConfig
from actorswarm.core.wire import ReleaseEntry

#: A release in flight is named by its key, generation, and the epoch and ID of the master
#: that decided the firing.
ReleaseId = tuple[int, int, int, int]


class Releases:
    """Releases in flight, keyed by :data:`ReleaseId`; what goes out goes to ``output``.

    ``first_retry`` gives the first retransmission delay (the node plugs in its measured
    RTT); ``retry_delay`` the wait before the next retransmission after k, from the first
    (the node plugs in its reliable layer's, which paces a shared channel): called with the
    retries so far, the first retry's delay and how many members the retransmission asks
    to acknowledge.
    """

    def __init__(
        self,
        config: CoreConfig,
        output: BarrierOutput,
        *,
        first_retry: Callable[[], float],
        retry_delay: Callable[[int, float, int], float],
    ) -> None:
        self._config = config
        self._output = output
        self._first_retry = first_retry
        self._retry_delay = retry_delay
        self.inflight: dict[ReleaseId, OutgoingRelease] = {}

    def launch(self, key: int, fired: Firing, targets: set[int], now: float, epoch: int) -> None:
        """Send ``fired``'s entries of ``targets`` now and retransmit them until acknowledged
        (joining a release of the same firing already in flight)."""
        ident = (key, fired.generation, fired.origin, fired.master)
        rel = self.inflight.get(ident)
        if rel is None:
            rel = OutgoingRelease(
                key=key,
                generation=fired.generation,
                origin=fired.origin,
                master=fired.master,
                epoch=epoch,
                outcome=fired.outcome,
                sizes=fired.sizes,
                entries=fired.entries,
                gathered=fired.gathered,
                unacked=set(),
                deadline=now + self._config.delivery_deadline,
            )
            self.inflight[ident] = rel
        rel.epoch = epoch
        rel.whole = fired.complete_knowledge and fired.entries.keys() == fired.assigned.keys()
        rel.unacked |= targets
        rel.due = now + self._retry_delay(0, self._first_retry(), len(rel.unacked))
        for packet in rel.packets(targets, self._config.release_chunk):
            self._output.release(packet)

    def resend(self, key: int, fired: Firing, platform: int, now: float, epoch: int) -> None:
        """Send ``platform`` its entry of ``fired`` again (it asked after missing it)."""
        if platform not in fired.entries:
            part, index = fired.assigned[platform]
            fired.entries[platform] = ReleaseEntry(platform=platform, part=part, index=index)
        self.launch(key, fired, {platform}, now, epoch)

    def on_ack(self, platform: int, key: int, generation: int) -> None:
        for ident, rel in list(self.inflight.items()):
            if ident[0] == key and ident[1] == generation:
                rel.unacked.discard(platform)
                if not rel.unacked:
                    del self.inflight[ident]

    def member_left(self, platform: int) -> None:
        """``platform`` left: it acknowledges nothing any more."""
        for rel in self.inflight.values():
            rel.unacked.discard(platform)
        for k in [k for k, r in self.inflight.items() if not r.unacked]:
            del self.inflight[k]

    def tick(self, now: float, epoch: int) -> None:
        """Give up the releases past their deadline; retransmit those due."""
        for rel in list(self.inflight.values()):
            if now >= rel.deadline:
                self._output.gave_up(rel.key, rel.generation, set(rel.unacked))
                del self.inflight[(rel.key, rel.generation, rel.origin, rel.master)]
            elif now >= rel.due and rel.unacked:
                rel.retries += 1
                rel.due = now + self._retry_delay(
                    rel.retries, self._first_retry(), len(rel.unacked)
                )
                rel.epoch = epoch
                for packet in rel.packets(rel.unacked, self._config.release_chunk):
                    self._output.release(packet)

    def next_deadline(self) -> float | None:
        """The next retransmission or deadline (None: nothing in flight)."""
        return min((min(rel.due, rel.deadline) for rel in self.inflight.values()), default=None)


__all__ = ["ReleaseId", "Releases"]
