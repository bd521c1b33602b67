"""The master's tables, as one node holds them: the barrier table
(:class:`~actorswarm.core.barrier.BarrierMaster`), the role table
(:class:`~actorswarm.core.roles.RoleMaster`) and the outbox their decisions wait in
(:mod:`.outbox`).

They outlive a change of role — a master that stepped down reports the firings it decided,
and keeps them should it claim again before it reported them — and start afresh with each
term (:meth:`MasterTables.new_term`).
"""

from __future__ import annotations

from collections.abc import Callable

from actorswarm.core.barrier import BarrierMaster
from actorswarm.core.node.outbox import MasterOutbox
from actorswarm.core.roles import RoleMaster


class MasterTables:
    """The barrier and role tables of platform ``platform`` as master; ``new_barriers``
    makes an empty barrier table that decides into the given outbox."""

    def __init__(
        self, platform: int, new_barriers: Callable[[MasterOutbox], BarrierMaster]
    ) -> None:
        self._platform = platform
        self._new_barriers = new_barriers
        #: What the tables decide, until the master's duties route it.
        self.outbox = MasterOutbox()
        self._barriers = new_barriers(self.outbox)
        self._roles = RoleMaster(self.outbox)

    @property
    def barriers(self) -> BarrierMaster:
        """The barrier table of the current (or last) term."""
        return self._barriers

    @property
    def roles(self) -> RoleMaster:
        """The role table of the current (or last) term."""
        return self._roles

    def new_term(self) -> None:
        """This platform claims again: empty tables, but for the firings it decided in an
        earlier term. It would have reported them to the master it stepped down to, and
        may claim again before it reported them to anyone (two masters settling after a
        heal): a candidate of one whose release was lost could then never be completed
        (campaign seed 7765517). What the tables of the earlier term decided and never
        routed (it stepped down before its next flush) goes with them."""
        decided = self._barriers.decided(self._platform)
        self.outbox.take()
        self._barriers = self._new_barriers(self.outbox)
        for record in decided:
            self._barriers.record_released(self._platform, record)
        self._roles = RoleMaster(self.outbox)

    def hold(self) -> None:
        """Decide nothing until :meth:`become_ready` (a handshake is on)."""
        self._barriers.ready = False
        self._roles.ready = False

    def become_ready(self, now: float, epoch: int) -> None:
        """The handshake is over: decide what waited for it."""
        self._barriers.become_ready(now, epoch)
        self._roles.become_ready()
