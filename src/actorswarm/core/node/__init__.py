"""A platform's collective core, :class:`Node`, and the parts it is composed of.

* :mod:`.coordinator` — :class:`Node`: the host interface, the shared state, packet
  dispatch (one table from body type to handler), barrier and role messages;
* :mod:`.liveness` — :class:`~.liveness.Liveness`: heartbeats sent and heard, probes of
  suspects, local health, the master's roster, what a change of the view sets off;
* :mod:`.leadership` — :class:`~.leadership.Leadership`: claiming, following and stepping
  down, the loss of the master and its succession, the handshake, reports.
"""

from actorswarm.core.node.coordinator import Node, Outgoing, Ready

__all__ = ["Node", "Outgoing", "Ready"]
