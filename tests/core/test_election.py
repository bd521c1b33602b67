"""Election decisions as tables: reaction to a heartbeat, and when to claim the master role."""

from __future__ import annotations

from typing import NamedTuple

import pytest

from actorswarm.core.election import OnHeartbeat, on_heartbeat, should_claim

IGNORE, FOLLOW, STEP_DOWN, RECLAIM, DEMOTED = (
    OnHeartbeat.IGNORE,
    OnHeartbeat.FOLLOW,
    OnHeartbeat.STEP_DOWN,
    OnHeartbeat.RECLAIM,
    OnHeartbeat.DEMOTED,
)


class Hb(NamedTuple):
    """One row: this platform's state, the heartbeat heard, and the expected reaction."""

    name: str
    self_id: int
    is_master: bool
    epoch: int
    master: int | None
    master_alive: bool
    sender: int
    sender_is_master: bool
    sender_epoch: int
    expected: OnHeartbeat


HEARTBEAT_TABLE = [
    # --- I am master (my own ID is my epoch's master) ---
    Hb("master hears lower-ID master, lower epoch", 5, True, 4, 5, True, 2, True, 3, STEP_DOWN),
    Hb("master hears lower-ID master, same epoch", 5, True, 4, 5, True, 2, True, 4, STEP_DOWN),
    Hb("master hears lower-ID master, higher epoch", 5, True, 4, 5, True, 2, True, 9, STEP_DOWN),
    Hb("master hears higher-ID master, higher epoch", 2, True, 4, 2, True, 5, True, 6, RECLAIM),
    Hb("master hears higher-ID master, same epoch", 2, True, 4, 2, True, 5, True, 4, RECLAIM),
    Hb("master hears higher-ID master, lower epoch", 2, True, 4, 2, True, 5, True, 3, IGNORE),
    Hb("master hears member with higher epoch", 2, True, 4, 2, True, 5, False, 7, RECLAIM),
    Hb("master hears member with lower epoch", 2, True, 4, 2, True, 1, False, 3, IGNORE),
    Hb("master hears its follower", 2, True, 4, 2, True, 3, False, 4, IGNORE),
    # --- I follow a master ---
    Hb("follower: my master is master no more", 3, False, 4, 1, True, 1, False, 4, DEMOTED),
    Hb("follower: my master demoted, higher epoch", 3, False, 4, 1, True, 1, False, 5, DEMOTED),
    Hb("follower: my master late packet, old epoch", 3, False, 4, 1, True, 1, False, 3, IGNORE),
    Hb("follower: my master, same epoch, alive", 3, False, 4, 1, True, 1, True, 4, IGNORE),
    Hb("follower: my master back after false alarm", 3, False, 4, 1, False, 1, True, 4, FOLLOW),
    Hb("follower: my master reclaims higher epoch", 3, False, 4, 1, True, 1, True, 5, FOLLOW),
    Hb("follower: my master, older epoch packet", 3, False, 4, 1, True, 1, True, 3, IGNORE),
    Hb("higher epoch, higher-ID sender, my master alive", 4, False, 2, 1, True, 3, True, 3, IGNORE),
    Hb("higher epoch, sender outranks my live master", 4, False, 2, 3, True, 1, True, 3, FOLLOW),
    Hb("higher epoch, own master lost", 4, False, 2, 1, False, 3, True, 3, FOLLOW),
    Hb("higher epoch, no master at all", 4, False, 2, None, False, 3, True, 3, FOLLOW),
    Hb("fresh platform hears first master", 4, False, 0, None, False, 1, True, 1, FOLLOW),
    Hb("other master, lower epoch", 4, False, 5, 1, True, 2, True, 3, IGNORE),
    Hb("other master, same epoch, own master alive", 4, False, 5, 1, True, 2, True, 5, IGNORE),
    Hb("other master, same epoch, own master lost", 4, False, 5, 1, False, 2, True, 5, FOLLOW),
    Hb("other member, higher epoch", 4, False, 5, 1, True, 2, False, 9, IGNORE),
    Hb("other member, no master", 4, False, 0, None, False, 2, False, 0, IGNORE),
]


@pytest.mark.parametrize("row", HEARTBEAT_TABLE, ids=[row.name for row in HEARTBEAT_TABLE])
def test_on_heartbeat_decision_table(row: Hb) -> None:
    got = on_heartbeat(
        self_id=row.self_id,
        is_master=row.is_master,
        epoch=row.epoch,
        master=row.master,
        master_alive=row.master_alive,
        sender=row.sender,
        sender_is_master=row.sender_is_master,
        sender_epoch=row.sender_epoch,
    )
    assert got is row.expected, f"{row.name}: got {got.name}, want {row.expected.name}"


def test_two_masters_converge_on_lower_id() -> None:
    """The lower ID reclaims above the other's epoch, the higher ID steps down."""
    low = on_heartbeat(
        self_id=1,
        is_master=True,
        epoch=3,
        master=1,
        master_alive=True,
        sender=4,
        sender_is_master=True,
        sender_epoch=3,
    )
    high = on_heartbeat(
        self_id=4,
        is_master=True,
        epoch=3,
        master=4,
        master_alive=True,
        sender=1,
        sender_is_master=True,
        sender_epoch=3,
    )
    assert (low, high) == (RECLAIM, STEP_DOWN)


class Claim(NamedTuple):
    name: str
    self_id: int
    lowest_peer: int | None
    is_master: bool
    master: int | None
    master_alive: bool
    takeover_on_join: bool
    listened: float
    expected: bool


STARTUP = 0.4

CLAIM_TABLE = [
    Claim("alone, still in startup wait", 3, None, False, None, False, False, 0.39, False),
    Claim("alone, startup wait over", 3, None, False, None, False, False, 0.4, True),
    Claim("lowest in view, no master", 2, 5, False, None, False, False, 1.0, True),
    Claim("lowest in view, but still listening", 2, 5, False, None, False, False, 0.1, False),
    Claim("a lower peer exists", 4, 2, False, None, False, False, 1.0, False),
    Claim("a lower peer exists, master lost", 4, 2, False, 2, False, False, 1.0, False),
    Claim("already master", 1, 2, True, 1, True, False, 9.0, False),
    Claim("master alive (sticky)", 1, 2, False, 2, True, False, 9.0, False),
    Claim("master alive, takeover_on_join", 1, 2, False, 2, True, True, 9.0, True),
    Claim("takeover, master has lower ID", 3, None, False, 2, True, True, 9.0, False),
    Claim("takeover waits for startup too", 1, 2, False, 2, True, True, 0.2, False),
    Claim("master lost, lowest in view", 2, 3, False, 1, False, False, 5.0, True),
    Claim("master lost, alone", 2, None, False, 1, False, False, 5.0, True),
]


@pytest.mark.parametrize("row", CLAIM_TABLE, ids=[row.name for row in CLAIM_TABLE])
def test_should_claim_decision_table(row: Claim) -> None:
    got = should_claim(
        self_id=row.self_id,
        lowest_peer=row.lowest_peer,
        is_master=row.is_master,
        master=row.master,
        master_alive=row.master_alive,
        takeover_on_join=row.takeover_on_join,
        listened=row.listened,
        startup_wait=STARTUP,
    )
    assert got is row.expected, f"{row.name}: should_claim -> {got}, want {row.expected}"
