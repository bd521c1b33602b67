"""What the node gave up delivering, told to the application: every message the reliable
streams or the bulletin board gave up on becomes a
:class:`~actorswarm.core.events.DeliveryFailed` event, and a master-bound message given up
makes the node report everything again (:meth:`Failures.take_restate`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from actorswarm.core.events import DeliveryFailed
from actorswarm.core.node.leadership import MASTER_BOUND

if TYPE_CHECKING:
    from actorswarm.core.config import CoreConfig
    from actorswarm.core.ready import Collector


class Failures:
    """The failures of one node, which its parts report into ``out``."""

    def __init__(self, out: Collector, config: CoreConfig) -> None:
        self._out = out
        self._config = config
        # A master-bound message was given up: report again at the next tick.
        self._restate = False

    def report(self) -> None:
        """Every message the reliable streams or the bulletin board gave up on becomes a
        DeliveryFailed event, in the order they gave up. Called at fixed points of a step
        (after the retransmission timers, after a view change), so each failure's event
        comes after the events of the step that caused it."""
        out = self._out
        if not out.failures:
            return
        for failure in out.failures:
            if failure.reason == "deadline" and isinstance(failure.payload, MASTER_BOUND):
                # A request or claim the master never acknowledged (on a lossy shared
                # channel a few retries span the whole deadline) would otherwise wait
                # unsent until the next master: the next tick reports again, and the
                # report restates everything still pending.
                self._restate = True
            reason = {
                "left": "the destination left the swarm",
                "stepped_down": "this platform stepped down as master before it was delivered",
            }.get(failure.reason, f"not acknowledged within {self._config.delivery_deadline} s")
            out.events.append(
                DeliveryFailed(dst=failure.dst, kind=type(failure.payload).__name__, reason=reason)
            )
        out.failures.clear()

    def take_restate(self) -> bool:
        """Whether a master-bound message was given up since the last call: everything
        still pending is then to be reported again."""
        restate, self._restate = self._restate, False
        return restate
