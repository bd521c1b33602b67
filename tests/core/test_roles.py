"""Role arbitration: the master's quota table and a member's view of its roles."""

from __future__ import annotations

import pytest

from actorswarm.core.events import RoleDenied, RoleGranted, RoleRevoked
from actorswarm.core.roles import Reply, RoleMaster, RoleMember
from actorswarm.core.wire import RoleClaim, RoleDeny, RoleGrant, RoleRevoke

LEADER = "leader"


def _claim(quota: int = 1, bid: float = 0.0, role: str = LEADER) -> RoleClaim:
    return RoleClaim(role=role, quota=quota, bid=bid)


class _Replies:
    """A :class:`~actorswarm.core.roles.RoleOutput` that keeps the replies it is given."""

    def __init__(self) -> None:
        self.sent: list[tuple[int, Reply]] = []

    def reply(self, platform: int, reply: Reply) -> None:
        self.sent.append((platform, reply))


def _new() -> RoleMaster:
    return RoleMaster(_Replies())


def _ready() -> RoleMaster:
    master = _new()
    master.become_ready()
    return master


def _replies(master: RoleMaster) -> list[tuple[int, Reply]]:
    """The replies ``master`` sent since the last call."""
    out = master._output
    assert isinstance(out, _Replies)
    sent, out.sent = out.sent, []
    return sent


def _deny(holders: list[int], role: str = LEADER) -> RoleDeny:
    return RoleDeny(role=role, holders=holders)


# --- master -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("quota", "claimants", "granted", "denied"),
    [
        (1, [3], [3], []),
        (1, [3, 2], [3], [2]),  # first come, first served once ready
        (2, [5, 4, 6], [4, 5], [6]),
        (3, [1, 2, 3], [1, 2, 3], []),
        (2, [7, 8, 9, 10], [7, 8], [9, 10]),
    ],
)
def test_grant_within_quota_deny_above(
    quota: int, claimants: list[int], granted: list[int], denied: list[int]
) -> None:
    master = _ready()
    for platform in claimants:
        master.claim(platform, _claim(quota))
    replies = _replies(master)
    got_granted = sorted(p for p, r in replies if isinstance(r, RoleGrant))
    got_denied = sorted(p for p, r in replies if isinstance(r, RoleDeny))
    assert got_granted == granted, f"quota {quota}, claims {claimants}: granted {got_granted}"
    assert got_denied == denied, f"quota {quota}, claims {claimants}: denied {got_denied}"
    assert master.holders(LEADER) == tuple(granted)
    for p, reply in replies:
        if isinstance(reply, RoleDeny):
            assert reply == _deny(granted), f"the denial to {p} names the holders"


def test_denial_is_reported_once_per_claim() -> None:
    master = _ready()
    master.claim(1, _claim())
    master.claim(2, _claim())
    master.claim(3, _claim())
    assert _replies(master) == [(1, RoleGrant(role=LEADER)), (2, _deny([1])), (3, _deny([1]))]
    master.claim(4, _claim())
    assert _replies(master) == [(4, _deny([1]))], "2 and 3 are not told again"
    master.claim(2, _claim())
    assert _replies(master) == [(2, _deny([1]))], "a new claim is answered anew"


def test_nothing_granted_before_become_ready() -> None:
    master = _new()
    master.claim(3, _claim(bid=2.0))
    master.claim(2, _claim(bid=1.0))
    assert _replies(master) == [], "during the handshake claims are only recorded"
    assert master.holders(LEADER) == ()
    master.become_ready()
    assert _replies(master) == [(2, RoleGrant(role=LEADER)), (3, _deny([2]))], (
        "once ready, the best bid wins"
    )


@pytest.mark.parametrize(
    ("waiting", "winner"),
    [
        ({5: 3.0, 6: 1.0, 7: 2.0}, 6),  # lowest bid
        ({5: 1.0, 3: 1.0, 9: 1.0}, 3),  # tie: lowest ID
        ({8: -1.0, 2: 0.0}, 8),
    ],
)
def test_release_regrants_best_waiting_bid(waiting: dict[int, float], winner: int) -> None:
    master = _ready()
    master.claim(1, _claim(bid=0.0))
    for platform, bid in waiting.items():
        master.claim(platform, _claim(bid=bid))
    _replies(master)
    master.release(1, LEADER)
    assert _replies(master) == [(winner, RoleGrant(role=LEADER))]
    assert master.holders(LEADER) == (winner,)


def test_member_left_regrants() -> None:
    master = _ready()
    master.claim(1, _claim())
    master.claim(2, _claim(bid=5.0))
    master.claim(3, _claim(bid=4.0))
    _replies(master)
    master.member_left(2)
    assert _replies(master) == [], "a waiting claimant leaving frees nothing"
    master.member_left(1)
    assert _replies(master) == [(3, RoleGrant(role=LEADER))], "the leader lost: 3 takes over"
    master.member_left(3)
    assert master.holders(LEADER) == ()
    assert _replies(master) == []


def test_a_restarted_holder_is_told_to_drop_what_its_old_incarnation_held() -> None:
    """A grant to a platform's old incarnation may reach its new one (campaign seed
    7650551): when the master learns of the reboot, the new incarnation is told to drop
    the role, and the slot goes to whoever waits."""
    master = _ready()
    master.claim(1, _claim())
    master.claim(2, _claim(bid=5.0))
    master.claim(3, _claim(bid=6.0))
    _replies(master)
    master.member_left(1, restarted=True)
    assert _replies(master) == [(1, RoleRevoke(role=LEADER)), (2, RoleGrant(role=LEADER))]
    master.member_left(3, restarted=True)
    assert _replies(master) == [], "a claimant that only waited held nothing to drop"


def test_withdrawn_claim_is_not_granted() -> None:
    master = _ready()
    master.claim(1, _claim())
    master.claim(2, _claim())
    master.release(2, LEADER)  # withdraws the waiting claim
    _replies(master)
    master.release(1, LEADER)
    assert _replies(master) == []
    assert master.holders(LEADER) == ()


def test_release_of_unknown_role_is_harmless() -> None:
    master = _ready()
    master.release(1, "nobody-claimed-this")
    assert _replies(master) == []


def test_claim_by_holder_is_granted_again() -> None:
    master = _ready()
    master.claim(1, _claim())
    _replies(master)
    master.claim(1, _claim())
    assert _replies(master) == [(1, RoleGrant(role=LEADER))], "a re-sent claim is re-granted"
    assert master.holders(LEADER) == (1,)


@pytest.mark.parametrize(
    ("quota", "held", "kept", "revoked"),
    [
        (1, {4: 2.0, 6: 1.0}, (6,), [4]),  # multiple leaders after a heal: the best bid stays
        (1, {4: 1.0, 6: 1.0}, (4,), [6]),  # tie: lower ID
        (2, {1: 3.0, 2: 2.0, 3: 1.0}, (2, 3), [1]),
        (2, {1: 3.0, 2: 2.0}, (1, 2), []),
    ],
)
def test_report_with_more_holders_than_quota_revokes_worst(
    quota: int, held: dict[int, float], kept: tuple[int, ...], revoked: list[int]
) -> None:
    master = _new()
    for platform, bid in held.items():
        master.report(platform, held=[_claim(quota, bid)], claims=[])
    assert _replies(master) == []
    master.become_ready()
    replies = _replies(master)
    assert sorted(p for p, r in replies if isinstance(r, RoleRevoke)) == revoked, replies
    assert not any(isinstance(r, RoleGrant) for _, r in replies), "holders are not re-granted"
    assert master.holders(LEADER) == kept


def test_report_when_ready_settles_at_once() -> None:
    master = _ready()
    master.report(4, held=[_claim(bid=2.0)], claims=[])
    master.report(6, held=[_claim(bid=1.0)], claims=[])
    assert _replies(master) == [(4, RoleRevoke(role=LEADER))]
    assert master.holders(LEADER) == (6,)


def test_report_replaces_what_master_knew() -> None:
    master = _new()
    master.claim(3, _claim(role="track", quota=2))
    master.report(3, held=[], claims=[_claim(role=LEADER)])
    master.become_ready()
    assert _replies(master) == [(3, RoleGrant(role=LEADER))], "the old 'track' claim is gone"
    assert master.holders("track") == ()


def test_report_dropping_a_held_role_regrants_it() -> None:
    master = _ready()
    master.report(3, held=[_claim()], claims=[])
    master.claim(4, _claim())
    assert _replies(master) == [(4, _deny([3]))]
    master.report(3, held=[], claims=[])  # 3 no longer holds the role
    assert _replies(master) == [(4, RoleGrant(role=LEADER))]


def test_smallest_quota_wins() -> None:
    master = _ready()
    master.claim(1, _claim(quota=3))
    master.claim(2, _claim(quota=1))
    replies = _replies(master)
    assert replies == [(1, RoleGrant(role=LEADER)), (2, _deny([1]))], (
        "a claim with quota 1 makes the role exclusive"
    )


def test_roles_are_independent() -> None:
    master = _ready()
    master.claim(1, _claim(role="a"))
    master.claim(1, _claim(role="b"))
    master.claim(2, _claim(role="b"))
    assert _replies(master) == [
        (1, RoleGrant(role="a")),
        (1, RoleGrant(role="b")),
        (2, RoleDeny(role="b", holders=[1])),
    ]


# --- member -------------------------------------------------------------------------------


def test_member_claim_records_and_validates() -> None:
    member = RoleMember()
    claim = member.claim(LEADER, 1, 2.5)
    assert claim == RoleClaim(role=LEADER, quota=1, bid=2.5)
    assert member.claims == {LEADER: claim}
    with pytest.raises(ValueError, match="quota"):
        member.claim(LEADER, 0, 1.0)


@pytest.mark.parametrize(
    ("claimed", "held", "reply", "event", "holds_after"),
    [
        (True, False, RoleGrant(role=LEADER), RoleGranted(role=LEADER), True),
        (False, False, RoleGrant(role=LEADER), None, False),  # no longer wanted
        (False, True, RoleGrant(role=LEADER), None, True),  # duplicate grant
        (True, False, _deny([1, 2]), RoleDenied(role=LEADER, holders=(1, 2)), False),
        (False, False, _deny([1]), None, False),  # denial of a withdrawn claim
        (False, True, _deny([8]), RoleRevoked(role=LEADER), False),  # the master's table wins
        (False, True, RoleRevoke(role=LEADER), RoleRevoked(role=LEADER), False),
        (False, False, RoleRevoke(role=LEADER), None, False),  # revoke of a role not held
    ],
    ids=[
        "grant",
        "grant-unwanted",
        "grant-again",
        "deny",
        "deny-withdrawn",
        "deny-held",
        "revoke",
        "revoke-not-held",
    ],
)
def test_member_reactions(
    claimed: bool,
    held: bool,
    reply: Reply,
    event: RoleGranted | RoleDenied | RoleRevoked | None,
    holds_after: bool,
) -> None:
    member = RoleMember()
    if held:
        member.claim(LEADER, 1, 0.0)
        assert member.on_reply(RoleGrant(role=LEADER)) == RoleGranted(role=LEADER)
    if claimed:
        member.claim(LEADER, 1, 0.0)
    got = member.on_reply(reply)
    assert got == event, f"{type(reply).__name__}: event {got}, want {event}"
    assert (LEADER in member.held) is holds_after


def test_member_denial_reported_once() -> None:
    member = RoleMember()
    member.claim(LEADER, 1, 0.0)
    assert member.on_reply(_deny([1])) == RoleDenied(role=LEADER, holders=(1,))
    assert member.on_reply(_deny([1])) is None, "a re-stated denial is not reported again"
    assert member.on_reply(RoleGrant(role=LEADER)) == RoleGranted(role=LEADER)


def test_member_release() -> None:
    member = RoleMember()
    assert member.release(LEADER) is False, "nothing to release"
    member.claim(LEADER, 1, 0.0)
    assert member.release(LEADER) is True, "withdrawing a claim counts"
    member.claim(LEADER, 1, 0.0)
    member.on_reply(RoleGrant(role=LEADER))
    assert member.release(LEADER) is True
    assert member.held == {} and member.claims == {}


def test_claim_of_held_role_is_not_queued() -> None:
    member = RoleMember()
    member.claim(LEADER, 1, 0.0)
    member.on_reply(RoleGrant(role=LEADER))
    member.claim(LEADER, 1, 0.0)
    assert member.claims == {}, "a held role is not claimed again"


def test_new_claim_after_withdrawal_reports_denial_again() -> None:
    member = RoleMember()
    member.claim(LEADER, 1, 0.0)
    assert member.on_reply(_deny([1])) is not None
    member.release(LEADER)
    member.claim(LEADER, 1, 0.0)
    assert member.on_reply(_deny([1])) == RoleDenied(role=LEADER, holders=(1,))


def test_a_report_that_crossed_a_grant_keeps_the_slot() -> None:
    """A member reports a role as claimed while the grant is on its way to it: the slot
    stays its own (granted again, harmlessly) instead of going to a second claimant."""
    master = _new()
    master.become_ready()
    leader = RoleClaim(role="leader", quota=1, bid=4.0)
    master.claim(4, leader)
    assert master.holders("leader") == (4,)
    _replies(master)
    master.claim(1, RoleClaim(role="leader", quota=1, bid=1.0))  # denied: 4 holds it
    master.report(4, held=[], claims=[leader])  # written before the grant arrived
    assert master.holders("leader") == (4,)
    sent = _replies(master)
    assert (4, RoleGrant(role="leader")) in sent
    assert not any(p == 1 and isinstance(r, RoleGrant) for p, r in sent)


def test_a_report_without_the_role_frees_the_slot() -> None:
    master = _new()
    master.become_ready()
    master.claim(4, RoleClaim(role="leader", quota=1, bid=4.0))
    master.claim(1, RoleClaim(role="leader", quota=1, bid=1.0))
    _replies(master)
    master.report(4, held=[], claims=[])
    assert master.holders("leader") == (1,)
    assert (1, RoleGrant(role="leader")) in _replies(master)


def test_a_grant_that_arrives_after_the_master_dropped_its_platform_is_given_up() -> None:
    """Campaign seed 7671936: the master granted 7 a role while 7 was cut off, then took 7
    for gone and granted the slot to 8. The grant reached 7 after the heal, while 7's rejoin
    report (written before it) still said "claimed", so the master counts 7 as waiting and
    denies it. 7 must give the role up and wait again, or two hold a role of quota 1."""
    master, member = _new(), RoleMember()
    master.become_ready()
    claim = member.claim(LEADER, 1, 7.0)
    master.claim(7, claim)
    grant = _replies(master).pop()
    assert grant == (7, RoleGrant(role=LEADER))
    master.member_left(7)
    master.claim(8, RoleClaim(role=LEADER, quota=1, bid=8.0))
    master.report(7, held=[], claims=[claim])
    assert member.on_reply(grant[1]) == RoleGranted(role=LEADER), "the late grant arrives"
    deny = [r for p, r in _replies(master) if p == 7 and isinstance(r, RoleDeny)]
    assert master.holders(LEADER) == (8,) and len(deny) == 1
    assert member.on_reply(deny[0]) == RoleRevoked(role=LEADER)
    assert member.held == {} and member.claims == {LEADER: claim}, "it waits again"
    assert member.on_reply(deny[0]) is None, "a re-stated denial is not reported again"
    master.release(8, LEADER)
    regrant = [r for p, r in _replies(master) if p == 7 and isinstance(r, RoleGrant)]
    assert master.holders(LEADER) == (7,) and regrant
    assert member.on_reply(regrant[-1]) == RoleGranted(role=LEADER)
