"""A platform's collective core, :class:`Node`, and the parts it is composed of.

* :mod:`.coordinator` — :class:`Node`: the host interface (packets in, ``ready()`` out,
  ``tick``), the application's calls, the state its parts share;
* :mod:`.intake` — :class:`~.intake.Intake`: what a received packet's body is handed to
  (one table from body type to handler) and where each delivered message goes;
* :mod:`.liveness` — :class:`~.liveness.Liveness`: heartbeats sent and heard, probes of
  suspects, local health, what a change of the view sets off;
* :mod:`.rostersync` — :class:`~.rostersync.RosterSync`: a star master serving its roster,
  a member keeping its copy current;
* :mod:`.leadership` — :class:`~.leadership.Leadership`: claiming, following and stepping
  down, the loss of the master and its succession, the handshake, reports;
* :mod:`.duties` — :class:`~.duties.MasterDuties` and :class:`~.duties.MemberDuties`: what
  the node does as master or as member, one interface, swapped when the role changes.
"""

from actorswarm.core.node.coordinator import Node, Outgoing, Ready

__all__ = ["Node", "Outgoing", "Ready"]
