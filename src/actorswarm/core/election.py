"""Master election rules (DESIGN.md §3.2), as pure decisions the node applies.

Theory of operation
-------------------
There is no voting round. The master is the live platform with the minimum ID ("directly
appointed"), and becomes it through a handshake:

1. A platform that has listened for ``startup_wait`` seconds, follows no live master, and has
   the lowest ID in its view *claims*: it takes an epoch greater than any it has seen and
   announces it in its heartbeats and in a reliable ``Sync`` to every member.
2. A member follows a master whose epoch is greater than the one it follows — unless it
   follows a live master with a lower ID (that one will out-bid the newcomer) — and answers
   ``Sync`` with a ``Report`` of its pending state. The handshake is complete when every
   member of the master's view has reported; only then does the master fire barriers or
   grant roles, so no state of the previous master is lost or contradicted.
3. When two masters hear each other (a healed partition), the one with the higher ID steps
   down at once; the lower one claims again with an epoch above both, so every member of both
   former partitions follows it.

*Sticky* (the default): a lower ID that joins does not take over a healthy master.
``takeover_on_join`` gives the paper's behaviour, where the lowest ID always claims.

Epochs only grow on a platform (within one incarnation), which the simulator checks.
"""

from __future__ import annotations

import enum


class OnHeartbeat(enum.Enum):
    """What a platform does on hearing a peer's heartbeat."""

    IGNORE = "ignore"
    FOLLOW = "follow"  # follow the sender, a master, in its epoch
    STEP_DOWN = "step_down"  # I am master, the sender is a master with a lower ID: give up
    RECLAIM = "reclaim"  # I am master and someone has an epoch >= mine: claim above it
    DEMOTED = "demoted"  # the master I follow is master no more: follow whom it follows


def on_heartbeat(
    *,
    self_id: int,
    is_master: bool,
    epoch: int,
    master: int | None,
    master_alive: bool,
    sender: int,
    sender_is_master: bool,
    sender_epoch: int,
) -> OnHeartbeat:
    """Decide how to react to ``sender``'s heartbeat (``sender_is_master``, ``sender_epoch``).

    ``master`` is the master of this platform's epoch (itself when it is master), and
    ``master_alive`` whether this platform still follows it (False after it left the view).
    A master must always hold the highest epoch of its component, so a master that hears an
    epoch at least as high as its own claims again.
    """
    if is_master:
        if sender_is_master and sender < self_id:
            return OnHeartbeat.STEP_DOWN
        if sender_epoch > epoch or (sender_is_master and sender_epoch == epoch):
            return OnHeartbeat.RECLAIM
        return OnHeartbeat.IGNORE
    if not sender_is_master:
        if sender == master and sender_epoch >= epoch:
            # (A heartbeat of an older epoch is a late packet from before its claim.)
            return OnHeartbeat.DEMOTED
        return OnHeartbeat.IGNORE
    if sender_epoch > epoch:
        if master is not None and master_alive and master < sender:
            # My master is alive and outranks the sender: it will claim above this epoch.
            return OnHeartbeat.IGNORE
        return OnHeartbeat.FOLLOW
    if sender_epoch == epoch and not master_alive:
        # I lost my master (or it came back after a false alarm): a master of my own epoch
        # is as good as any; following it keeps epochs monotonic.
        return OnHeartbeat.FOLLOW
    return OnHeartbeat.IGNORE


def should_claim(
    *,
    self_id: int,
    lowest_peer: int | None,
    is_master: bool,
    master: int | None,
    master_alive: bool,
    takeover_on_join: bool,
    listened: float,
    startup_wait: float,
) -> bool:
    """Whether this platform should claim the master role now.

    ``lowest_peer`` is the lowest ID in the view (None when alone); ``listened`` is how long
    this incarnation has been up.
    """
    if is_master or listened < startup_wait:
        return False
    if lowest_peer is not None and lowest_peer < self_id:
        return False
    if master is None or not master_alive:
        return True
    return takeover_on_join and self_id < master
