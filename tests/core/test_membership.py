"""Membership: join after M heartbeats within t_join, leave by deadline, incarnations."""

from __future__ import annotations

import pytest

from actorswarm.core.config import CoreConfig
from actorswarm.core.events import MemberJoined, MemberLeft
from actorswarm.core.membership.view import Membership

CONFIG = CoreConfig()  # M = 3, t_join = 1.0, t_leave = 0.5
PEER = 7

Change = MemberJoined | MemberLeft


def _beats(
    members: Membership, times: list[float], *, peer: int = PEER, incarnation: int = 0
) -> list[tuple[float, Change]]:
    log: list[tuple[float, Change]] = []
    for t in times:
        out: list[Change] = []
        members.heartbeat(peer, incarnation, t, out)
        log.extend((t, change) for change in out)
    return log


def _joined(members: Membership, times: list[float]) -> Membership:
    _beats(members, times)
    assert PEER in members, f"setup: heartbeats at {times} should have joined"
    return members


@pytest.mark.parametrize(
    ("times", "join_at"),
    [
        ([0.0], None),
        ([0.0, 0.1], None),  # M - 1 heartbeats
        ([0.0, 0.1, 0.2], 0.2),  # M heartbeats, at the nominal rate
        ([0.0, 0.5, 1.0], 1.0),  # exactly M within t_join: the window is inclusive
        ([0.0, 0.5, 1.0001], None),  # M spread over just more than t_join
        ([0.0, 0.6, 1.2], None),  # M spread over more than t_join
        ([0.0, 0.6, 1.2, 1.3], 1.3),  # the last M (0.6, 1.2, 1.3) fit: a sliding window
        ([0.0, 2.0, 4.0, 6.0, 8.0], None),  # a slow sender never joins
        ([0.0, 0.05, 0.07, 0.09], 0.07),  # joins on the M-th, not later
    ],
)
def test_join_timeline(times: list[float], join_at: float | None) -> None:
    members = Membership(1, CONFIG)
    log = _beats(members, times)
    joins = [(t, e) for t, e in log if isinstance(e, MemberJoined)]
    if join_at is None:
        assert joins == [], f"heartbeats at {times} must not join, got {joins}"
        assert PEER not in members
        assert members.next_deadline() is None
    else:
        assert joins == [(join_at, MemberJoined(platform=PEER, incarnation=0))], (
            f"heartbeats at {times}: want one join at {join_at}, got {joins}"
        )
        assert PEER in members
        assert members.peers[PEER].joined_at == join_at


@pytest.mark.parametrize(("m", "t_join"), [(1, 1.0), (2, 0.2), (5, 0.5)])
def test_join_uses_configured_m(m: int, t_join: float) -> None:
    members = Membership(1, CoreConfig(join_heartbeats=m, t_join=t_join))
    log = _beats(members, [i * 0.1 for i in range(m)])
    assert [e for _, e in log] == [MemberJoined(platform=PEER, incarnation=0)]
    assert log[0][0] == pytest.approx((m - 1) * 0.1), f"M={m}: join on the M-th heartbeat"


def test_self_excluded_and_len() -> None:
    members = Membership(1, CONFIG)
    for peer in (2, 3, 4):
        _beats(members, [0.0, 0.1, 0.2], peer=peer)
    assert len(members) == 3
    assert 1 not in members


@pytest.mark.parametrize(
    ("expire_at", "suspected", "left"),
    [(0.69, False, False), (0.7, True, False), (0.759, True, False), (0.76, True, True)],
)
def test_suspected_after_t_leave_and_gone_after_the_probe_window(
    expire_at: float, suspected: bool, left: bool
) -> None:
    """Silent for t_leave (0.5 s): suspected; for t_leave + probe_window (0.56 s): gone."""
    members = _joined(Membership(1, CONFIG), [0.0, 0.1, 0.2])  # suspect at 0.7, leave 0.76
    assert members.next_deadline() == pytest.approx(0.7)
    out: list[Change] = []
    fresh: list[int] = []
    members.expire(0.7 if expire_at >= 0.7 else expire_at, out, fresh)
    members.expire(expire_at, out, fresh)
    assert fresh == ([PEER] if suspected else []), "suspected once, when its time came"
    if left:
        assert out == [MemberLeft(platform=PEER, incarnation=0, reason="timeout")], out
        assert PEER not in members and PEER not in members.suspects
        assert members.next_deadline() is None
    else:
        assert out == [], f"expire({expire_at}) before the leave time 0.76 removed {out}"
        assert PEER in members
        assert (PEER in members.suspects) is suspected


def test_a_suspect_that_answers_is_cleared() -> None:
    members = _joined(Membership(1, CONFIG), [0.0, 0.1, 0.2])
    out: list[Change] = []
    members.expire(0.72, out)
    assert PEER in members.suspects
    _beats(members, [0.73])  # the answer to a probe
    assert PEER not in members.suspects
    members.expire(0.9, out)
    assert out == [] and PEER in members, "cleared: its old leave time no longer applies"
    assert members.next_deadline() == pytest.approx(1.23)


def test_a_held_member_is_not_suspected_before_its_hold_ends() -> None:
    """Held until 2.0 (its packets queue behind a handshake): silent since 0.2, it is
    suspected at 2.0 + t_leave and gone a probe window later, not at 0.7 / 0.76; a heartbeat
    during the hold does not shorten it, and one after it counts as usual."""
    members = _joined(Membership(1, CONFIG), [0.0, 0.1, 0.2])
    members.hold(PEER, 2.0, 0.3)
    assert members.next_deadline() == pytest.approx(2.5)
    out: list[Change] = []
    members.expire(2.49, out)
    assert out == [] and not members.suspects
    _beats(members, [1.0])
    assert members.next_deadline() == pytest.approx(2.5), "heard in the hold: still 2.5"
    members.hold(PEER, 1.5, 1.0)  # a shorter hold changes nothing
    assert members.next_deadline() == pytest.approx(2.5)
    members.expire(2.5, out)
    assert PEER in members.suspects
    members.expire(2.56, out)
    assert out == [MemberLeft(platform=PEER, incarnation=0, reason="timeout")]
    members.hold(PEER, 9.0, 3.0)  # no longer a member: nothing to hold
    assert members.next_deadline() is None


def test_an_admitted_member_with_grace_is_watched_from_the_end_of_it() -> None:
    members = Membership(1, CONFIG)
    assert members.admit(PEER, 0, 10.0, grace=1.0)
    assert members.next_deadline() == pytest.approx(11.5)
    _beats(members, [11.8])
    assert members.next_deadline() == pytest.approx(12.3), "heard after the grace: as usual"


def test_heartbeat_just_before_deadline_keeps_member() -> None:
    members = _joined(Membership(1, CONFIG), [0.0, 0.1, 0.2])
    _beats(members, [0.69])
    out: list[Change] = []
    members.expire(0.7, out)
    assert out == [], "the heartbeat at 0.69 moved the suspicion to 1.19"
    assert members.next_deadline() == pytest.approx(1.19), "stale heap entries are skipped"
    members.expire(1.189, out)
    assert out == [] and not members.suspects
    members.expire(1.19, out)
    members.expire(1.25, out)
    assert out == [MemberLeft(platform=PEER, incarnation=0, reason="timeout")]


def test_leave_reason_is_suspected_with_phi() -> None:
    members = Membership(1, CoreConfig(detector="phi"))
    _beats(members, [0.0, 0.1, 0.2])
    out: list[Change] = []
    for _ in range(2):  # suspicion, then leave
        deadline = members.next_deadline()
        assert deadline is not None
        members.expire(deadline, out)
    assert out == [MemberLeft(platform=PEER, incarnation=0, reason="suspected")]


def test_phi_is_never_less_patient_than_the_fixed_timeout() -> None:
    """Phi's normal model expects no long gaps and, alone, declares ~100x more live peers
    gone under loss than the fixed timeout; its suspicion time is floored at t_leave."""
    members = Membership(1, CoreConfig(detector="phi"))
    _beats(members, [round(0.1 * i, 1) for i in range(50)])  # perfectly regular
    assert members.next_deadline() == pytest.approx(4.9 + 0.5)


def test_next_deadline_is_earliest_member() -> None:
    members = Membership(1, CONFIG)
    _beats(members, [0.0, 0.1, 0.2], peer=2)  # suspect at 0.7
    _beats(members, [0.05, 0.1, 0.15], peer=3)  # suspect at 0.65
    assert members.next_deadline() == pytest.approx(0.65)
    _beats(members, [0.6], peer=3)  # now 1.1
    assert members.next_deadline() == pytest.approx(0.7)
    out: list[Change] = []
    members.expire(0.7, out)
    assert members.next_deadline() == pytest.approx(0.76), "2 is suspected: its leave time"
    members.expire(0.76, out)
    assert out == [MemberLeft(platform=2, incarnation=0, reason="timeout")]
    assert members.next_deadline() == pytest.approx(1.1)


def test_left_member_must_join_again() -> None:
    members = _joined(Membership(1, CONFIG), [0.0, 0.1, 0.2])
    members.expire(1.0, [])
    log = _beats(members, [1.1, 1.2])
    assert log == [], "a peer that left needs M fresh heartbeats"
    log = _beats(members, [1.3])
    assert [e for _, e in log] == [MemberJoined(platform=PEER, incarnation=0)]


def test_restart_leaves_then_joins_fresh() -> None:
    members = _joined(Membership(1, CONFIG), [0.0, 0.1, 0.2])
    log = _beats(members, [0.3], incarnation=1)
    assert [e for _, e in log] == [MemberLeft(platform=PEER, incarnation=0, reason="restarted")]
    assert PEER not in members, "a restarted peer is out until it joins again"
    assert members.next_deadline() is None, "the old incarnation's deadline is gone"
    log = _beats(members, [0.4, 0.5], incarnation=1)
    assert [e for _, e in log] == [MemberJoined(platform=PEER, incarnation=1)], (
        "the heartbeat that revealed the restart counts toward the new join"
    )
    assert members.peers[PEER].incarnation == 1
    out: list[Change] = []
    members.expire(0.7, out)  # the old incarnation's deadline must not remove the new one
    assert out == []
    assert members.next_deadline() == pytest.approx(1.0)


def test_any_packet_of_a_new_incarnation_reveals_the_restart() -> None:
    """A rebooted peer's first packet may be a claim or a report, before its first
    heartbeat: the old member leaves on that packet, once, and the new incarnation joins
    with heartbeats as usual."""
    members = _joined(Membership(1, CONFIG), [0.0, 0.1, 0.2])
    assert members.is_newer(PEER, 1) and not members.is_newer(PEER, 0)
    out: list[Change] = []
    members.note_incarnation(PEER, 1, out)
    assert out == [MemberLeft(platform=PEER, incarnation=0, reason="restarted")]
    assert PEER not in members and not members.is_newer(PEER, 1)
    members.note_incarnation(PEER, 1, out)
    assert len(out) == 1, "told once"
    log = _beats(members, [0.3, 0.4, 0.5], incarnation=1)
    assert [e for _, e in log] == [MemberJoined(platform=PEER, incarnation=1)]


def test_restart_of_a_candidate_starts_counting_again() -> None:
    members = Membership(1, CONFIG)
    _beats(members, [0.0, 0.1])
    log = _beats(members, [0.2], incarnation=1)
    assert log == [], "heartbeats of the old incarnation do not count for the new one"
    log = _beats(members, [0.3, 0.4], incarnation=1)
    assert [e for _, e in log] == [MemberJoined(platform=PEER, incarnation=1)]


def test_lower_incarnation_ignored() -> None:
    members = Membership(1, CONFIG)
    _beats(members, [0.0, 0.1, 0.2], incarnation=3)
    before = members.next_deadline()
    log = _beats(members, [0.3, 0.4, 0.5], incarnation=2)
    assert log == [], "an older incarnation neither leaves nor joins"
    assert members.peers[PEER].incarnation == 3
    assert members.next_deadline() == before, "an older incarnation does not refresh the deadline"
    assert members.heartbeat(PEER, 2, 0.6, []) is None


@pytest.mark.parametrize(("incarnation", "current"), [(0, False), (2, False), (3, True), (4, True)])
def test_is_current(incarnation: int, current: bool) -> None:
    members = Membership(1, CONFIG)
    _beats(members, [0.0], incarnation=3)  # even a candidate's incarnation counts
    assert members.is_current(PEER, incarnation) is current
    assert members.is_current(99, 0), "an unknown peer's packets are current"


def test_heartbeat_returns_entry_when_in_view() -> None:
    members = Membership(1, CONFIG)
    assert members.heartbeat(PEER, 0, 0.0, []) is None
    assert members.heartbeat(PEER, 0, 0.1, []) is None
    entry = members.heartbeat(PEER, 0, 0.2, [])
    assert entry is not None and entry.incarnation == 0
    again = members.heartbeat(PEER, 0, 0.3, [])
    assert again is entry and again.last_heard == 0.3
