"""The swarm primitives a plugin may use (``ctx.collective``), wired to the core.

Plugins synchronize and arbitrate through the same collective core as the task engine:
``barrier`` asks to pass a barrier (with gather data and a bid), ``claim_role`` and
``release_role`` arbitrate a role with a quota. Plugin barrier keys live in a range of their
own (:data:`PLUGIN_KEY_BASE` + key) so they never meet the engine's transition groups.

Answers come back asynchronously: :meth:`ActorRuntime.deliver` appends them, as plain dicts,
to the ``"collective"`` list on the blackboard of every running actor:

* ``{"kind": "barrier", "key": k, "generation": g, "chosen": bool, "index": i, "size": n,
  "data": scattered, "gathered": [[platform, data], ...], "outcome": "complete"|"timeout"}``
* ``{"kind": "barrier", "key": k, "generation": g, "outcome": "stale", "current": c, ...}``
  (``chosen`` False, ``index`` and ``size`` 0, no data): generation ``g`` had fired before
  the request reached the master, which waits for requests of ``c`` now; the plugin asks
  again to pass the next one (or asks with ``renew=True``, and the master may do that for
  it).
* ``{"kind": "role", "role": name, "state": "granted"|"denied"|"revoked"}``
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from actorswarm.core.events import (
    BarrierReleased,
    BarrierStaleNotice,
    CoreEvent,
    RoleDenied,
    RoleGranted,
    RoleRevoked,
)
from actorswarm.core.node import Node

#: Core barrier keys of plugin barriers start here (the engine uses 1..63 and 1000+).
PLUGIN_KEY_BASE = 10_000


class NodeCollective:
    """``ctx.collective`` backed by the platform's core :class:`~actorswarm.core.Node`;
    ``clock`` gives the time of the call (the runtime's current ``now``)."""

    def __init__(self, node: Node, clock: Callable[[], float]) -> None:
        self._node = node
        self._clock = clock

    def barrier(
        self,
        key: int,
        need: int,
        *,
        bid: float | None = None,
        data: Any = None,
        renew: bool = False,
    ) -> int:
        if not 0 <= key < 1_000_000:
            raise ValueError(f"plugin barrier key must be 0..999999, got {key}")
        return self._node.request_barrier(
            PLUGIN_KEY_BASE + key, need, self._clock(), bid=bid, data=data, renew=renew
        )

    def claim_role(self, role: str, quota: int, *, bid: float | None = None) -> None:
        self._node.claim_role(role, quota, self._clock(), bid=bid)

    def release_role(self, role: str) -> None:
        self._node.release_role(role, self._clock())


def plugin_view(event: CoreEvent) -> dict[str, Any] | None:
    """A core event as plugins see it on the blackboard; None when it is not theirs."""
    if isinstance(event, BarrierReleased) and event.key >= PLUGIN_KEY_BASE:
        return {
            "kind": "barrier",
            "key": event.key - PLUGIN_KEY_BASE,
            "generation": event.generation,
            "chosen": event.chosen,
            "index": event.index,
            "size": event.size,
            "data": event.data,
            "gathered": [list(pair) for pair in event.gathered],
            "outcome": event.outcome,
        }
    if isinstance(event, BarrierStaleNotice) and event.key >= PLUGIN_KEY_BASE:
        # Without it a plugin whose request crossed a firing waited for an answer that
        # never came.
        return {
            "kind": "barrier",
            "key": event.key - PLUGIN_KEY_BASE,
            "generation": event.generation,
            "chosen": False,
            "index": 0,
            "size": 0,
            "data": None,
            "gathered": [],
            "outcome": "stale",
            "current": event.current,
        }
    if isinstance(event, RoleGranted | RoleDenied | RoleRevoked):
        state = {RoleGranted: "granted", RoleDenied: "denied", RoleRevoked: "revoked"}
        return {"kind": "role", "role": event.role, "state": state[type(event)]}
    return None
