"""Election decisions as tables: reaction to a heartbeat, and when to claim the master role."""

from __future__ import annotations

import itertools
from typing import Any, NamedTuple

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from actorswarm.core.election import (
    CLAIM_RULES,
    HEARTBEAT_RULES,
    Claimant,
    Hearing,
    OnHeartbeat,
    Role,
    Rule,
    by_role,
    first_match,
    on_heartbeat,
    role_of,
    should_claim,
)

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
    master_suspected: bool = False
    sender_master: int = 0


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
    Hb("master hears its follower", 2, True, 4, 2, True, 3, False, 4, IGNORE, sender_master=2),
    Hb(
        "master hears a member of its epoch following another master",
        *(2, True, 4, 2, True, 3, False, 4, RECLAIM),
        sender_master=5,
    ),
    Hb(
        "master hears a member of an older epoch following another master",
        *(2, True, 4, 2, True, 3, False, 3, IGNORE),
        sender_master=5,
    ),
    # --- I follow a master ---
    Hb("follower: my master is master no more", 3, False, 4, 1, True, 1, False, 4, DEMOTED),
    Hb("follower: my master demoted, higher epoch", 3, False, 4, 1, True, 1, False, 5, DEMOTED),
    Hb("follower: my master late packet, old epoch", 3, False, 4, 1, True, 1, False, 3, IGNORE),
    Hb("follower: my master, same epoch, alive", 3, False, 4, 1, True, 1, True, 4, IGNORE),
    Hb("follower: my master back after false alarm", 3, False, 4, 1, False, 1, True, 4, FOLLOW),
    Hb("follower: my master reclaims higher epoch", 3, False, 4, 1, True, 1, True, 5, FOLLOW),
    Hb("follower: my master, older epoch packet", 3, False, 4, 1, True, 1, True, 3, IGNORE),
    Hb("higher epoch, higher-ID sender, my master alive", 4, False, 2, 1, True, 3, True, 3, IGNORE),
    Hb(
        "higher epoch, higher-ID sender, my master suspected",
        *(4, False, 2, 1, True, 3, True, 3, FOLLOW),
        master_suspected=True,
    ),
    Hb(
        "same epoch, higher-ID sender, my master suspected",
        *(4, False, 2, 1, True, 3, True, 2, IGNORE),
        master_suspected=True,
    ),
    Hb(
        "higher epoch, member sender, my master suspected",
        *(4, False, 2, 1, True, 3, False, 3, IGNORE),
        master_suspected=True,
    ),
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
        master_suspected=row.master_suspected,
        sender_master=row.sender_master,
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


# --- The rule tables against the same decisions written as plain conditionals ---------------


def on_heartbeat_plain(
    *,
    self_id: int,
    is_master: bool,
    epoch: int,
    master: int | None,
    master_alive: bool,
    sender: int,
    sender_is_master: bool,
    sender_epoch: int,
    master_suspected: bool = False,
    sender_master: int = 0,
) -> OnHeartbeat:
    """``on_heartbeat`` as nested conditionals: an independent statement of the rules."""
    if is_master:
        if sender_is_master and sender < self_id:
            return OnHeartbeat.STEP_DOWN
        if sender_epoch > epoch or (sender_is_master and sender_epoch == epoch):
            return OnHeartbeat.RECLAIM
        if sender_epoch == epoch and sender_master not in (0, self_id):
            # Someone follows another master of my epoch number: two partitions claimed it.
            return OnHeartbeat.RECLAIM
        return OnHeartbeat.IGNORE
    if not sender_is_master:
        if sender == master and sender_epoch >= epoch:
            # (A heartbeat of an older epoch is a late packet from before its claim.)
            return OnHeartbeat.DEMOTED
        return OnHeartbeat.IGNORE
    if sender_epoch > epoch:
        if master is not None and master_alive and master < sender and not master_suspected:
            # My master is alive and outranks the sender: it will claim above this epoch.
            # (Suspected, it is likely dead: the claim confirms it.)
            return OnHeartbeat.IGNORE
        return OnHeartbeat.FOLLOW
    if sender_epoch == epoch and not master_alive:
        # I lost my master (or it came back after a false alarm): a master of my own epoch
        # is as good as any; following it keeps epochs monotonic.
        return OnHeartbeat.FOLLOW
    return OnHeartbeat.IGNORE


def should_claim_plain(
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
    """``should_claim`` as plain conditionals: an independent statement of the rules."""
    if is_master or listened < startup_wait:
        return False
    if lowest_peer is not None and lowest_peer < self_id:
        return False
    if master is None or not master_alive:
        return True
    return takeover_on_join and self_id < master


# Four values order up to three IDs (or two epochs) every way, ties included.
SMALL = range(4)
BOOLS = (False, True)
ids = st.integers(0, 3)
maybe_id = st.none() | ids

hearings = st.builds(
    Hearing,
    self_id=ids,
    is_master=st.booleans(),
    epoch=ids,
    master=maybe_id,
    master_alive=st.booleans(),
    sender=ids,
    sender_is_master=st.booleans(),
    sender_epoch=ids,
    master_suspected=st.booleans(),
    sender_master=ids,
)
claimants = st.builds(
    Claimant,
    self_id=ids,
    lowest_peer=maybe_id,
    is_master=st.booleans(),
    master=maybe_id,
    master_alive=st.booleans(),
    takeover_on_join=st.booleans(),
    listened=st.sampled_from([0.0, STARTUP / 2, STARTUP, 2 * STARTUP]),
    startup_wait=st.just(STARTUP),
)


@settings(max_examples=2000)
@given(hearings)
def test_heartbeat_table_matches_plain_conditionals(h: Hearing) -> None:
    assert on_heartbeat(**h._asdict()) is on_heartbeat_plain(**h._asdict())


@settings(max_examples=2000)
@given(claimants)
def test_claim_table_matches_plain_conditionals(c: Claimant) -> None:
    assert should_claim(**c._asdict()) is should_claim_plain(**c._asdict())


def all_hearings() -> list[Hearing]:
    """Every combination of small inputs (81 920 of them)."""
    maybe = (None, *SMALL)
    grid = itertools.product(SMALL, BOOLS, SMALL, maybe, BOOLS, SMALL, BOOLS, SMALL, BOOLS, SMALL)
    return [Hearing(*values) for values in grid]


def all_claimants() -> list[Claimant]:
    """Every combination of small inputs, listening just short of and just at the wait."""
    maybe = (None, *SMALL)
    grid = itertools.product(SMALL, maybe, BOOLS, maybe, BOOLS, BOOLS, (STARTUP / 2, STARTUP))
    return [Claimant(*values, startup_wait=STARTUP) for values in grid]


def test_heartbeat_table_matches_plain_conditionals_everywhere() -> None:
    for h in all_hearings():
        assert on_heartbeat(**h._asdict()) is on_heartbeat_plain(**h._asdict()), h


def test_claim_table_matches_plain_conditionals_everywhere() -> None:
    for c in all_claimants():
        assert should_claim(**c._asdict()) is should_claim_plain(**c._asdict()), c


def check_rows(rules: tuple[Rule[Any, Any], ...], inputs: list[Hearing] | list[Claimant]) -> None:
    """Every row decides some input (none is shadowed by the rows above it), and every role's
    last row matches whatever reaches it."""
    table = by_role(rules)
    used: set[str] = set()
    for given_ in inputs:
        rows = table[role_of(given_.is_master, given_.master, given_.master_alive)]
        used.add(first_match(rows, given_).name)
        assert rows[-1].test(given_), (rows[-1].name, given_)
    assert [rule.name for rule in rules if rule.name not in used] == []
    assert all(table[role] for role in Role)


def test_every_heartbeat_row_decides_some_case() -> None:
    check_rows(HEARTBEAT_RULES, all_hearings())


def test_every_claim_row_decides_some_case() -> None:
    check_rows(CLAIM_RULES, all_claimants())
