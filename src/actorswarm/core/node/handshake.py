"""A master's handshake, as bookkeeping: whom it waits for, until when, when the Syncs go
out, and who reported in its epoch (see :class:`~.leadership.Leadership`, which opens and
closes it, and :class:`~.duties.MasterDuties`, which feeds it the reports).

It sends nothing and reads no clock: every answer is for the caller to act on.
"""

from __future__ import annotations


class Handshake:
    """The handshake of one master's epoch. Closed (no deadline) outside a handshake."""

    def __init__(self) -> None:
        # Who has not reported yet; when the handshake ends at the latest; when the Syncs
        # go to those who have not reported by then.
        self._waiting: set[int] = set()
        self._deadline: float | None = None
        self._sync_at: float | None = None
        #: The first bulletin of the members of the claim (a Sync tells where it begins).
        self.bulletin = 0
        # Who reported in this epoch, and who did and was then declared gone.
        self._reported: set[int] = set()
        self._rejoining: set[int] = set()

    @property
    def awaited(self) -> int:
        """How many members have not reported yet."""
        return len(self._waiting)

    def deadlines(self) -> tuple[float | None, float | None]:
        """When the handshake ends at the latest, and when the Syncs are due (None: not)."""
        return self._deadline, self._sync_at

    def restart(self, bulletin: int) -> None:
        """A new epoch: nobody has reported in it; the members' bulletins begin at
        ``bulletin``."""
        self.bulletin = bulletin
        self._reported.clear()
        self._rejoining.clear()

    def open(self, waiting: set[int], deadline: float, sync_at: float) -> None:
        """Wait for the reports of ``waiting`` until ``deadline``, and send them a Sync at
        ``sync_at`` if they have not reported by then."""
        self._waiting = waiting
        self._deadline = deadline
        self._sync_at = sync_at

    def close(self) -> bool:
        """End the handshake (finished, or the master stepped down); True when someone
        was still awaited. Who reported stays known for the rest of the epoch."""
        incomplete = bool(self._waiting)
        self._deadline = None
        self._sync_at = None
        self._waiting.clear()
        return incomplete

    def wait_for(self, platform: int, now: float, timeout: float) -> None:
        """A newcomer must report too; a closed handshake opens again until ``now +
        timeout``."""
        self._waiting.add(platform)
        if self._deadline is None:
            self._deadline = now + timeout

    def has_reported(self, platform: int) -> bool:
        return platform in self._reported

    def forget_rejoining(self, platform: int) -> bool:
        """Whether ``platform`` reported in this epoch and was then declared gone (it is
        not any more once asked)."""
        rejoining = platform in self._rejoining
        self._rejoining.discard(platform)
        return rejoining

    def reported(self, platform: int) -> bool:
        """``platform`` reported; True when it was the last one awaited by an open
        handshake (which should now finish)."""
        self._reported.add(platform)
        if platform not in self._waiting:
            return False
        self._waiting.discard(platform)
        return not self._waiting and self._deadline is not None

    def left(self, platform: int, *, restarted: bool) -> None:
        """``platform`` left the view: not awaited any more; if it had reported (and did
        not restart), it is rejoining should it come back in this epoch."""
        self._waiting.discard(platform)
        if platform in self._reported and not restarted:
            self._rejoining.add(platform)
        self._reported.discard(platform)

    def settled(self) -> bool:
        """An open handshake that awaits nobody any more."""
        return self._deadline is not None and not self._waiting

    def expired(self, now: float) -> bool:
        """An open handshake whose deadline has passed."""
        return self._deadline is not None and now >= self._deadline

    def syncs_due(self, now: float) -> list[int]:
        """Those to send a Sync to now (once per handshake): who has not reported, in
        ascending order."""
        if self._sync_at is None or now < self._sync_at:
            return []
        self._sync_at = None
        return sorted(self._waiting)
