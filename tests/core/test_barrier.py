"""Barriers: the master's firing decisions and releases, and a member's side of them."""

from __future__ import annotations

import itertools
from typing import Any

import pytest

from actorswarm.core.barrier import BarrierMaster, BarrierMember
from actorswarm.core.barrier.member import PASSED_KEPT
from actorswarm.core.barrier.shared import ASSIGNMENT_ALL_CARRY
from actorswarm.core.config import CoreConfig
from actorswarm.core.events import BarrierFired, BarrierReleased, BarrierStaleNotice
from actorswarm.core.wire import (
    COMPLETE,
    NEED_ALL,
    TIMEOUT,
    BarrierRequest,
    BarrierStale,
    Release,
    ReleaseEntry,
    ReleaseRecord,
)

KEY = 7
EPOCH = 3


def _req(
    need: int | dict[int, int] = 2,
    *,
    generation: int = 0,
    part: int = 0,
    bid: float = 0.0,
    data: Any = None,
    timeout: float | None = None,
    age: float = 0.0,
    key: int = KEY,
    epoch: int = 0,
) -> BarrierRequest:
    return BarrierRequest(
        key=key,
        epoch=epoch,
        generation=generation,
        need={part: need} if isinstance(need, int) else need,
        part=part,
        bid=bid,
        data=data,
        timeout=timeout,
        age=age,
    )


class Recorder:
    """A :class:`~actorswarm.core.barrier.BarrierOutput` that keeps what it is given."""

    def __init__(self) -> None:
        self.events: list[BarrierFired] = []
        self.notices: list[tuple[int, BarrierStale]] = []
        self.broadcasts: list[Release] = []
        self.failed: list[tuple[int, int, set[int]]] = []

    def fired(self, event: BarrierFired) -> None:
        self.events.append(event)

    def stale(self, platform: int, notice: BarrierStale) -> None:
        self.notices.append((platform, notice))

    def release(self, packet: Release) -> None:
        self.broadcasts.append(packet)

    def gave_up(self, key: int, generation: int, unacked: set[int]) -> None:
        self.failed.append((key, generation, unacked))


class Harness:
    """A BarrierMaster plus helpers to drain what it decided. ``hooks``: the master's
    other keyword arguments (``platform``, ``scatter``, ``gathers``, ``live``,
    ``first_retry``)."""

    def __init__(
        self,
        *,
        live: int = 10,
        ready: bool = True,
        hooks: dict[str, Any] | None = None,
        **config: Any,
    ) -> None:
        self.live = live
        self.out = Recorder()
        self.master = BarrierMaster(
            CoreConfig(**config),
            self.out,
            resolve_need=lambda k, p, n: self.live if n == NEED_ALL else n,
            **(hooks or {}),
        )
        if ready:
            self.master.become_ready(0.0, EPOCH)

    def broadcasts(self) -> list[Release]:
        out = list(self.out.broadcasts)
        self.out.broadcasts.clear()
        return out

    def entries(self) -> dict[int, tuple[int, int]]:
        """platform -> (part, index) over every broadcast so far (drained)."""
        return {e.platform: (e.part, e.index) for rel in self.broadcasts() for e in rel.entries}

    def notices(self) -> list[tuple[int, BarrierStale]]:
        out = list(self.out.notices)
        self.out.notices.clear()
        return out

    def events(self) -> list[BarrierFired]:
        out = list(self.out.events)
        self.out.events.clear()
        return out


# --- master: when to fire, whom to choose -------------------------------------------------


@pytest.mark.parametrize(
    ("need", "requests", "fires_after"),
    [
        ({0: 2}, [(1, 0), (2, 0)], 2),
        ({0: 3}, [(1, 0), (2, 0), (3, 0)], 3),
        ({0: 1, 1: 2}, [(1, 0), (2, 1), (3, 0), (4, 1)], 4),  # part 1 completes last
        ({0: 2, 1: 1}, [(1, 1), (2, 0), (3, 0)], 3),
        ({0: 2}, [(1, 0)], None),
        ({0: 1, 1: 1}, [(1, 0), (2, 0), (3, 0)], None),  # part 1 never asked for
    ],
)
def test_fires_when_every_part_has_its_count(
    need: dict[int, int], requests: list[tuple[int, int]], fires_after: int | None
) -> None:
    h = Harness()
    fired_at = None
    for n, (platform, part) in enumerate(requests, start=1):
        h.master.request(platform, _req(need, part=part), 0.0, EPOCH)
        if h.broadcasts():
            fired_at = n
            break
    assert fired_at == fires_after, f"need {need}: fired after {fired_at} requests"


def test_release_carries_every_candidate_with_indices_per_part() -> None:
    h = Harness()
    need = {0: 2, 1: 1}
    h.master.request(4, _req(need, part=0), 0.0, EPOCH)
    h.master.request(5, _req(need, part=1), 0.0, EPOCH)
    h.master.request(2, _req(need, part=0), 0.0, EPOCH)
    (rel,) = h.broadcasts()
    assert (rel.key, rel.generation, rel.epoch, rel.outcome) == (KEY, 0, EPOCH, COMPLETE)
    assert rel.sizes == {0: 2, 1: 1}
    assert {e.platform: (e.part, e.index) for e in rel.entries} == {
        2: (0, 1),
        4: (0, 2),
        5: (1, 1),
    }
    (event,) = h.events()
    assert event == BarrierFired(
        key=KEY,
        generation=0,
        epoch=EPOCH,
        outcome="complete",
        chosen={2: (0, 1), 4: (0, 2), 5: (1, 1)},
        not_chosen=(),
        completion=False,
    )


def test_chooses_best_bids_lower_bid_then_lower_id() -> None:
    """Part 0 collects more candidates than needed while part 1 is still empty."""
    h = Harness()
    need = {0: 2, 1: 1}
    for platform, bid in [(5, 1.0), (3, 2.0), (6, 1.0), (2, 2.0), (9, 0.5)]:
        h.master.request(platform, _req(need, part=0, bid=bid), 0.0, EPOCH)
    assert h.broadcasts() == []
    h.master.request(8, _req(need, part=1, bid=99.0), 0.0, EPOCH)
    entries = h.entries()
    assert entries == {
        9: (0, 1),  # bid 0.5
        5: (0, 2),  # bid 1.0, lower ID than 6
        6: (0, 0),
        2: (0, 0),
        3: (0, 0),
        8: (1, 1),
    }, entries
    (event,) = h.events()
    assert event.not_chosen == (2, 3, 6), "non-chosen candidates are released with index 0"


def test_requests_collected_during_handshake_choose_best_bids() -> None:
    h = Harness(ready=False)
    for platform, bid in [(5, 1.0), (3, 2.0), (4, 1.0), (2, 2.0)]:
        h.master.request(platform, _req(2, bid=bid), 0.0, EPOCH)
    assert h.broadcasts() == [], "nothing fires during the handshake"
    h.master.become_ready(0.1, EPOCH)
    entries = h.entries()
    assert entries == {4: (0, 1), 5: (0, 2), 2: (0, 0), 3: (0, 0)}, (
        f"all four wait together: the best bids (4, 5) pass, the others get index 0: {entries}"
    )
    assert h.notices() == []


def test_a_held_key_waits_for_its_bids_then_chooses_the_best() -> None:
    """Without the hold a need of 1 fires on the first request; with it the best bid among
    everything that arrived by then passes."""
    h = Harness()
    h.master.hold(KEY, 0.5)
    assert h.master.next_deadline() == 0.5
    for platform, t, bid in [(2, 0.0, 300.0), (7, 0.1, 40.0), (4, 0.3, 120.0)]:
        h.master.request(platform, _req(1, bid=bid), t, EPOCH)
        h.master.tick(t, EPOCH)
    assert h.broadcasts() == [], "held: nothing fires before 0.5 s"
    h.master.tick(0.5, EPOCH)
    assert h.entries() == {7: (0, 1), 2: (0, 0), 4: (0, 0)}
    # The hold is over: the next generation fires on its first request, as usual.
    h.master.request(2, _req(1, generation=1, bid=300.0), 0.6, EPOCH)
    assert h.entries() == {2: (0, 1)}


def test_an_unheld_key_fires_on_its_first_request() -> None:
    h = Harness()
    h.master.hold(KEY + 1, 0.5)  # another key
    h.master.request(2, _req(1, bid=300.0), 0.0, EPOCH)
    assert h.entries() == {2: (0, 1)}, "first come, first chosen: a better bid later is too late"


def test_gather_and_scatter() -> None:
    h = Harness(
        hooks={"scatter": lambda key, gen, chosen: {p: f"slot-{i}" for p, _, i, _ in chosen}}
    )
    h.master.request(1, _req(2, data="a"), 0.0, EPOCH)
    h.master.request(2, _req(2, data=None), 0.0, EPOCH)
    (rel,) = h.broadcasts()
    assert {e.platform: e.data for e in rel.entries} == {1: "slot-1", 2: "slot-2"}
    assert rel.gathered == [(1, "a")], "only data actually attached is gathered"


def test_a_key_that_does_not_gather_scatters_only() -> None:
    """The engine's transitions: request data is for the master's scatter, and the release
    (every chunk of it) does not carry every participant's data to all."""
    hooks = {
        "scatter": lambda key, gen, chosen: {p: f"slot-{i}" for p, _, i, _ in chosen},
        "gathers": lambda key: key != KEY,
    }
    h = Harness(hooks=hooks)
    h.master.request(1, _req(2, data="a"), 0.0, EPOCH)
    h.master.request(2, _req(2, data="b"), 0.0, EPOCH)
    (rel,) = h.broadcasts()
    assert {e.platform: e.data for e in rel.entries} == {1: "slot-1", 2: "slot-2"}
    assert rel.gathered == []


# --- master: generations -----------------------------------------------------------------


def _fire_once(h: Harness, platforms: tuple[int, ...] = (1, 2)) -> None:
    for p in platforms:
        h.master.request(p, _req(len(platforms)), 0.0, EPOCH)
    assert h.broadcasts(), "setup: the barrier fires"
    h.events()


def test_stale_generation_gets_notice() -> None:
    h = Harness()
    _fire_once(h)
    # (Asked in the master's own epoch: no firing of an older epoch can have chosen it.)
    h.master.request(3, _req(2, generation=0, epoch=EPOCH), 0.1, EPOCH)
    assert h.notices() == [(3, BarrierStale(key=KEY, generation=0, current=1))]
    assert h.broadcasts() == [], "a stale request is neither released nor counted"
    h.master.request(3, _req(2, generation=1), 0.2, EPOCH)
    h.master.request(1, _req(2, generation=1), 0.2, EPOCH)
    (rel,) = h.broadcasts()
    assert rel.generation == 1, "the stale request did not count toward generation 1"
    assert {e.platform for e in rel.entries} == {1, 3}


def test_stale_notice_names_the_open_generation() -> None:
    h = Harness()
    _fire_once(h)
    for p in (1, 2):
        h.master.request(p, _req(2, generation=1), 0.1, EPOCH)
    h.broadcasts()
    h.master.request(3, _req(2, generation=0, epoch=EPOCH), 0.2, EPOCH)
    assert h.notices() == [(3, BarrierStale(key=KEY, generation=0, current=2))]


def test_candidate_repeating_fired_request_gets_its_entry_again() -> None:
    h = Harness()
    _fire_once(h, (1, 2))
    h.master.request(2, _req(2, generation=0), 0.5, EPOCH)  # it missed the release
    assert h.notices() == []
    rels = h.broadcasts()
    assert [e.platform for rel in rels for e in rel.entries] == [2]
    assert all(rel.generation == 0 for rel in rels)


def test_newer_generation_moves_master_on() -> None:
    h = Harness()
    h.master.request(1, _req(2, generation=0, epoch=EPOCH), 0.0, EPOCH)
    h.master.request(2, _req(2, generation=3, epoch=EPOCH), 0.1, EPOCH)
    assert h.notices() == [(1, BarrierStale(key=KEY, generation=0, current=3))]
    assert h.broadcasts() == [], "the generation-0 request no longer counts"
    h.master.request(1, _req(2, generation=3), 0.2, EPOCH)
    (rel,) = h.broadcasts()
    assert rel.generation == 3
    h.master.request(4, _req(2, generation=2, epoch=EPOCH), 0.3, EPOCH)
    assert h.notices() == [(4, BarrierStale(key=KEY, generation=2, current=4))]


def test_keys_are_independent() -> None:
    h = Harness()
    h.master.request(1, _req(2, key=1), 0.0, EPOCH)
    h.master.request(2, _req(2, key=2), 0.0, EPOCH)
    assert h.broadcasts() == []
    h.master.request(2, _req(2, key=1), 0.0, EPOCH)
    (rel,) = h.broadcasts()
    assert rel.key == 1


# --- master: timeout, retransmission, NEED_ALL --------------------------------------------


def test_timeout_releases_everyone_waiting() -> None:
    h = Harness()
    h.master.request(3, _req(5, timeout=1.0, bid=2.0), 0.0, EPOCH)
    h.master.request(2, _req(5, timeout=1.0, bid=1.0), 0.5, EPOCH)
    assert h.master.next_deadline() == pytest.approx(1.0), "timeout counts from the first"
    h.master.tick(0.99, EPOCH)
    assert h.broadcasts() == []
    h.master.tick(1.0, EPOCH)
    (rel,) = h.broadcasts()
    assert rel.outcome == TIMEOUT
    assert {e.platform: e.index for e in rel.entries} == {2: 1, 3: 2}, "numbered in bid order"
    assert rel.sizes == {0: 2}
    (event,) = h.events()
    assert event.outcome == "timeout"
    assert event.not_chosen == ()


def test_timeout_counts_request_age() -> None:
    h = Harness()
    h.master.request(1, _req(5, timeout=1.0, age=0.75), 2.0, EPOCH)
    assert h.master.next_deadline() == pytest.approx(2.25)
    h.master.tick(2.25, EPOCH)
    assert [rel.outcome for rel in h.broadcasts()] == [TIMEOUT]


def test_timeout_then_next_generation_opens() -> None:
    h = Harness()
    h.master.request(1, _req(5, timeout=1.0), 0.0, EPOCH)
    h.master.tick(1.0, EPOCH)
    h.broadcasts()
    h.master.request(2, _req(5, generation=0, epoch=EPOCH), 1.1, EPOCH)
    assert h.notices() == [(2, BarrierStale(key=KEY, generation=0, current=1))]


def test_retransmission_only_to_unacked_entries() -> None:
    h = Harness()
    for p in (1, 2, 3):
        h.master.request(p, _req(3), 0.0, EPOCH)
    (first,) = h.broadcasts()
    assert [e.platform for e in first.entries] == [1, 2, 3]
    h.master.on_ack(1, KEY, 0)
    due = h.master.next_deadline()
    assert due is not None and due == pytest.approx(CoreConfig().retry_base), "after retry_base"
    h.master.tick(due, EPOCH)
    (again,) = h.broadcasts()
    assert [e.platform for e in again.entries] == [2, 3], "acked entries are left out"
    assert again.generation == 0 and again.sizes == first.sizes
    h.master.on_ack(2, KEY, 0)
    h.master.on_ack(3, KEY, 0)
    assert h.master.next_deadline() is None, "nothing left in flight"
    h.master.tick(5.0, EPOCH)
    assert h.broadcasts() == []


def test_release_retransmission_backoff() -> None:
    h = Harness(delivery_deadline=2.0)
    h.master.request(1, _req(1), 0.0, EPOCH)
    h.broadcasts()
    times = [0.0]
    while (t := h.master.next_deadline()) is not None and t < 2.0:
        h.master.tick(t, EPOCH)
        if h.broadcasts():
            times.append(t)
    gaps = [b - a for a, b in itertools.pairwise(times)]
    config = CoreConfig()
    assert gaps[:4] == pytest.approx([config.retry_delay(k) for k in range(4)]), gaps


def test_release_fails_visibly_at_deadline() -> None:
    h = Harness(delivery_deadline=1.0)
    for p in (1, 2):
        h.master.request(p, _req(2), 0.0, EPOCH)
    h.master.on_ack(1, KEY, 0)
    while (t := h.master.next_deadline()) is not None and t <= 1.0:
        h.master.tick(t, EPOCH)
    assert h.out.failed == [(KEY, 0, {2})]
    assert h.master.next_deadline() is None


@pytest.mark.parametrize(
    ("chunk", "platforms", "sizes"),
    [(2, 5, [2, 2, 1]), (3, 3, [3]), (1, 3, [1, 1, 1]), (256, 40, [40])],
)
def test_chunking_respects_release_chunk(chunk: int, platforms: int, sizes: list[int]) -> None:
    h = Harness(release_chunk=chunk)
    for p in range(1, platforms + 1):
        h.master.request(p, _req(platforms), 0.0, EPOCH)
    rels = h.broadcasts()
    assert [len(rel.entries) for rel in rels] == sizes
    assert sorted(e.platform for rel in rels for e in rel.entries) == list(range(1, platforms + 1))
    assert all(rel.sizes == {0: platforms} for rel in rels), "every chunk carries the sizes"


def test_retransmission_is_chunked_too() -> None:
    h = Harness(release_chunk=2)
    for p in range(1, 6):
        h.master.request(p, _req(5), 0.0, EPOCH)
    h.broadcasts()
    for p in (1, 2, 4):
        h.master.on_ack(p, KEY, 0)
    h.master.tick(0.04, EPOCH)
    assert [[e.platform for e in rel.entries] for rel in h.broadcasts()] == [[3, 5]]


def test_need_all_resolves_via_resolver() -> None:
    h = Harness(live=3)
    h.master.request(1, _req(NEED_ALL), 0.0, EPOCH)
    h.master.request(2, _req(NEED_ALL), 0.0, EPOCH)
    assert h.broadcasts() == [], "3 live platforms: 2 requests are not enough"
    h.master.request(3, _req(NEED_ALL), 0.0, EPOCH)
    (rel,) = h.broadcasts()
    assert rel.sizes == {0: 3}


def test_need_all_does_not_count_a_request_from_beyond_the_view() -> None:
    """Every platform means every one in the view: a platform still joining (or one the
    master dropped) that requests does not stand in for a member that has not yet."""
    view = {1, 2, 3}
    h = Harness(live=3, hooks={"live": lambda platform: platform in view})
    for platform in (1, 2, 9):
        h.master.request(platform, _req(NEED_ALL), 0.0, EPOCH)
    assert h.broadcasts() == [], "member 3 has not asked: 9 is not in the view"
    view.add(9)  # 9 joins: the view is 4, and 3 still has not asked
    h.live = 4
    h.master.needs_changed(0.5, EPOCH)
    assert h.broadcasts() == []
    h.master.request(3, _req(NEED_ALL), 0.6, EPOCH)
    assert {p: i > 0 for p, (_, i) in h.entries().items()} == dict.fromkeys((1, 2, 3, 9), True)


def test_need_all_takes_in_a_requester_from_beyond_the_view() -> None:
    """Once every member has asked, a request from beyond the view is chosen with them
    (a NEED_ALL part is never smaller than its candidates)."""
    h = Harness(live=2, hooks={"live": lambda platform: platform in {1, 2}})
    for platform in (9, 1, 2):
        h.master.request(platform, _req(NEED_ALL), 0.0, EPOCH)
    (rel,) = h.broadcasts()
    assert rel.sizes == {0: 3}
    assert {e.platform for e in rel.entries if e.index > 0} == {1, 2, 9}


def test_the_master_names_the_few_members_a_barrier_of_all_awaits() -> None:
    view = {1, 2, 3, 4, 5}
    h = Harness(
        live=5, hooks={"live": lambda platform: platform in view, "first_retry": lambda: 0.1}
    )
    for platform in (1, 2, 4):
        h.master.request(platform, _req(NEED_ALL), 0.0, EPOCH)
    assert h.master.awaited(0.05, lambda: view) == [], "before a first retry's time"
    assert h.master.awaited(0.2, lambda: view) == [3, 5]
    h.master.request(9, _req(NEED_ALL), 0.3, EPOCH)  # from beyond the view: no help
    assert h.master.awaited(0.4, lambda: view) == [3, 5]


def test_the_master_names_no_one_when_many_are_missing_or_the_need_is_not_all() -> None:
    many = Harness(live=40, hooks={"first_retry": lambda: 0.0})
    view = set(range(1, 41))
    many.master.request(1, _req(NEED_ALL), 0.0, EPOCH)
    assert many.master.awaited(1.0, lambda: view) == [], "39 missing: more than a heartbeat names"
    counted = Harness(live=3, hooks={"first_retry": lambda: 0.0})
    counted.master.request(1, _req(3), 0.0, EPOCH)
    assert counted.master.awaited(1.0, lambda: {1, 2, 3}) == [], "a need of 3 awaits no one"


def test_leaving_member_completes_need_all() -> None:
    h = Harness(live=3)
    h.master.request(1, _req(NEED_ALL), 0.0, EPOCH)
    h.master.request(2, _req(NEED_ALL), 0.0, EPOCH)
    h.live = 2
    h.master.member_left(3, 0.5, EPOCH)
    (rel,) = h.broadcasts()
    assert {e.platform: e.index for e in rel.entries} == {1: 1, 2: 2}


def test_leaving_candidate_no_longer_counts() -> None:
    h = Harness()
    h.master.request(1, _req(2), 0.0, EPOCH)
    h.master.member_left(1, 0.1, EPOCH)
    h.master.request(2, _req(2), 0.2, EPOCH)
    assert h.broadcasts() == [], "the request of a platform that left is gone"


def test_leaving_member_stops_retransmission() -> None:
    h = Harness()
    h.master.request(1, _req(2), 0.0, EPOCH)
    h.master.request(2, _req(2), 0.0, EPOCH)
    h.broadcasts()
    h.master.on_ack(1, KEY, 0)
    h.master.member_left(2, 0.01, EPOCH)
    assert h.master.next_deadline() is None


# --- master: completion after failover ------------------------------------------------------


def _record(index: int, size: int = 3, generation: int = 4) -> ReleaseRecord:
    return ReleaseRecord(
        key=KEY, generation=generation, part=0, index=index, size=size, outcome=COMPLETE
    )


def _report(
    h: Harness,
    platform: int,
    known: int,
    record: ReleaseRecord | None,
    pending: BarrierRequest | None,
) -> None:
    """What a node does with one member's handshake report, in the same order."""
    h.master.known_generation(KEY, known, 0.0, EPOCH)
    if record is not None:
        h.master.record_released(platform, record)
    if pending is not None:
        h.master.request(platform, pending, 0.0, EPOCH)


@pytest.mark.parametrize(
    "order",
    [(1, 2, 3, 4), (3, 4, 1, 2), (3, 1, 4, 2), (4, 2, 3, 1)],
    ids=lambda o: "reports-" + "".join(map(str, o)),
)
def test_completion_after_failover(order: tuple[int, ...]) -> None:
    """The old master released 1 (index 1) and 2 (index 3) of generation 4, then crashed;
    3 and 4 still wait for generation 4. The new master must release them in generation 4
    with the index nobody reported, never with a stale notice."""
    h = Harness(ready=False)
    reports = {
        1: (5, _record(1), None),
        2: (5, _record(3), None),
        3: (4, _record(2, generation=3), _req(3, generation=4, bid=3.0)),
        4: (4, None, _req(3, generation=4, bid=4.0)),
    }
    for platform in order:
        _report(h, platform, *reports[platform])
    assert h.broadcasts() == [], "nothing is released during the handshake"
    h.master.become_ready(1.0, EPOCH)
    assert h.notices() == [], "waiting candidates of a fired generation are not stale"
    rels = h.broadcasts()
    assert rels and all(rel.generation == 4 for rel in rels), "same generation as the others"
    assert {e.platform: e.index for rel in rels for e in rel.entries} == {3: 2, 4: 0}, (
        "3 (better bid) gets the free index 2; 4 finds no slot and passes as not chosen"
    )
    events = h.events()
    assert events and all(e.completion and e.generation == 4 for e in events), events
    assert {p for e in events for p in (*e.chosen, *e.not_chosen)} == {3, 4}
    h.master.request(1, _req(2, generation=5), 1.1, EPOCH)
    h.master.request(3, _req(2, generation=5), 1.1, EPOCH)
    assert [rel.generation for rel in h.broadcasts()] == [5], "then generation 5 is open"
    assert h.notices() == []


def test_a_completion_does_not_pass_for_the_whole_firing() -> None:
    """A firing rebuilt from reports resends only the entries it completes: its packets
    must not tell a member they are the whole assignment (``total``), or that member would
    report it as such, and the next master would call any other candidate of the firing
    stale (campaign seed 2009944). A firing decided here says its total."""
    h = Harness(ready=False)
    _report(h, 1, 5, _record(1), None)
    _report(h, 3, 4, None, _req(3, generation=4, bid=3.0))
    h.master.become_ready(1.0, EPOCH)
    rels = h.broadcasts()
    assert {e.platform for rel in rels for e in rel.entries} == {3}
    assert all(rel.total == 0 for rel in rels), [rel.total for rel in rels]
    member = BarrierMember(3)
    member.known[KEY] = 4
    member.request(KEY, {0: 3}, 0.9, bid=3.0)
    for rel in rels:
        member.on_release(rel)
    assert [r.assignment for r in member.records()] == [{}], "not the whole assignment"

    fresh = Harness()
    for platform in (1, 2):
        fresh.master.request(platform, _req(2, generation=0), 0.0, EPOCH)
    decided = fresh.broadcasts()
    assert [rel.total for rel in decided] == [2], "a firing decided here knows its total"


def _first_firing(**kw: Any) -> ReleaseRecord:
    """Generation 4 as master 1 decided it in epoch 1: platforms 1 and 2 of 2."""
    return ReleaseRecord(
        key=KEY, generation=4, part=0, size=2, outcome=COMPLETE, origin=1, origin_master=1, **kw
    )


def test_a_completion_is_known_to_the_next_master_as_a_partial_assignment() -> None:
    """Campaign seed 7734060: a master completes a predecessor's firing for a candidate
    whose release is then lost, and steps down. Its successor learns the firing whole as it
    was first decided (a member's report): without the completion's entries it would take
    that candidate for one the firing never named and call its request stale, although it
    was chosen. The completing master and the members that passed the completion report
    those entries as a *partial* assignment, which names candidates without claiming all."""
    completing = Harness(ready=False, hooks={"platform": 5})
    completing.master.record_released(2, _first_firing(index=2))  # seen without the rest
    completing.master.request(3, _req(NEED_ALL, generation=4, bid=3.0, epoch=1), 0.0, 2)
    completing.master.request(4, _req(NEED_ALL, generation=4, bid=4.0, epoch=1), 0.0, 2)
    completing.master.become_ready(0.1, 2)
    rels = completing.broadcasts()
    added = {e.platform: (e.part, e.index) for rel in rels for e in rel.entries}
    assert set(added) == {3, 4} and all(rel.total == 0 for rel in rels)

    member = BarrierMember(4)
    member.known[KEY] = 4
    member.request(KEY, {0: NEED_ALL}, 0.0, bid=4.0, epoch=1)
    for rel in rels:
        member.on_release(rel)
    [kept] = member.records()
    assert (kept.assignment, kept.partial) == ({}, added), "the entries it saw, as partial"

    [handed] = completing.master.decided(5)
    assert handed.assignment == {} and handed.partial == {2: (0, 2), **added}
    assert handed.index == 0 and 5 not in handed.partial

    def successor(*records: tuple[int, ReleaseRecord]) -> Harness:
        h = Harness(ready=False)
        h.master.record_released(1, _first_firing(index=1, assignment={1: (0, 1), 2: (0, 2)}))
        for platform, rec in records:
            h.master.record_released(platform, rec)
        h.master.request(3, _req(NEED_ALL, generation=4, bid=3.0, epoch=1), 0.5, EPOCH)
        h.master.become_ready(0.6, EPOCH)
        h.master.tick(0.6 + CoreConfig().doubt_timeout, EPOCH)
        return h

    for records in ([(5, handed)], [(4, kept)]):
        h = successor(*records)
        assert h.notices() == [], records
        assert h.entries() == {3: added[3]}, "3's entry of the completion, sent again"
        assert 5 not in h.master.table.fired[KEY][4][0].assigned, "a former master is no candidate"
    alone = successor()
    assert [(p, n.generation) for p, n in alone.notices()] == [(3, 4)], (
        "without the completion's entries, 3 is taken for a late request"
    )
    assert alone.broadcasts() == []


def test_completion_of_timeout_firing_grows_it() -> None:
    h = Harness(ready=False)
    rec = ReleaseRecord(key=KEY, generation=0, part=0, index=1, size=1, outcome=TIMEOUT)
    h.master.record_released(1, rec)
    h.master.request(2, _req(5, generation=0), 0.0, EPOCH)
    h.master.become_ready(0.5, EPOCH)
    rels = h.broadcasts()
    assert [(rel.outcome, rel.generation) for rel in rels] == [(TIMEOUT, 0)]
    assert {e.platform: e.index for rel in rels for e in rel.entries} == {2: 2}, (
        "everyone waiting passes a timeout"
    )


def test_handshake_report_of_stale_request_still_gets_notice() -> None:
    h = Harness(ready=False)
    _report(h, 1, 6, None, None)  # 1 knows generation 6 is open
    _report(h, 2, 5, None, _req(2, generation=5))
    h.master.become_ready(0.5, EPOCH)
    # Asked under the previous master, for a generation nobody reported a firing of: that
    # firing (someone knows generation 6 is open) may have chosen it, so the request waits
    # ``doubt_timeout`` for a report that shows it, and is stale only then.
    assert h.notices() == [] and h.broadcasts() == []
    h.master.tick(0.5 + CoreConfig().doubt_timeout, EPOCH)
    assert h.notices() == [(2, BarrierStale(key=KEY, generation=5, current=6))]
    assert h.broadcasts() == []


# --- member ------------------------------------------------------------------------------


def _release(
    entries: list[tuple[int, int]], *, generation: int = 0, outcome: int = COMPLETE, **kw: Any
) -> Release:
    return Release(
        epoch=EPOCH,
        key=KEY,
        generation=generation,
        outcome=outcome,
        sizes={0: sum(1 for _, i in entries if i > 0)},
        entries=[ReleaseEntry(platform=p, part=0, index=i) for p, i in entries],
        **kw,
    )


@pytest.mark.parametrize(
    ("size", "carriers"),
    [(ASSIGNMENT_ALL_CARRY, set(range(3, ASSIGNMENT_ALL_CARRY + 3))), (40, {3, 4, 5, 6})],
)
def test_a_large_firing_is_kept_whole_by_its_lowest_ids_only(size: int, carriers: set[int]) -> None:
    """Every candidate of a small firing keeps its whole assignment for its reports; of a
    larger one only the lowest few IDs do (the master's successors), so that a new master's
    handshake does not carry the assignment once per member. Each keeps its own record."""
    platforms = list(range(3, size + 3))
    rel = _release([(p, i) for i, p in enumerate(platforms, 1)], total=size)
    kept = set()
    for p in platforms:
        member = BarrierMember(p)
        member.request(KEY, {0: size}, 0.0)
        event, ack = member.on_release(rel)
        assert event is not None and ack
        (record,) = member.records()
        assert record.index == platforms.index(p) + 1 and record.size == size
        if record.assignment:
            assert record.assignment == {q: (0, i) for i, q in enumerate(platforms, 1)}
            kept.add(p)
    assert kept == carriers


def test_member_request_uses_known_generation_and_default_bid() -> None:
    member = BarrierMember(5)
    req = member.request(KEY, {0: 3}, 1.0, data={"x": 1}, timeout=2.0)
    assert req == BarrierRequest(
        key=KEY, generation=0, need={0: 3}, part=0, bid=5.0, data={"x": 1}, timeout=2.0
    )
    member.known[KEY + 1] = 4
    assert member.request(KEY + 1, {0: 1}, 1.0, bid=0.5).generation == 4
    (restated, _) = member.restated(1.75)
    assert restated.age == pytest.approx(0.75), "a restated request carries its age"


@pytest.mark.parametrize(
    ("need", "part", "match"),
    [({0: 2}, 1, "part"), ({0: 0}, 0, "needs"), ({0: -5}, 0, "needs")],
)
def test_member_request_validation(need: dict[int, int], part: int, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        BarrierMember(1).request(KEY, need, 0.0, part=part)


def test_member_one_request_per_key() -> None:
    member = BarrierMember(1)
    member.request(KEY, {0: 2}, 0.0)
    with pytest.raises(ValueError, match="already waits"):
        member.request(KEY, {0: 2}, 0.1)
    member.request(KEY + 1, {0: 2}, 0.1)  # another key is fine


def test_member_passes_each_generation_once_and_acks_duplicates() -> None:
    member = BarrierMember(2)
    member.request(KEY, {0: 2}, 0.0)
    rel = _release([(1, 1), (2, 2)], gathered=[(1, "a")])
    event, ack = member.on_release(rel)
    assert ack is True
    assert event == BarrierReleased(
        key=KEY,
        generation=0,
        outcome="complete",
        chosen=True,
        part=0,
        index=2,
        size=2,
        data=None,
        gathered=((1, "a"),),
    )
    assert member.pending == {}
    assert member.known[KEY] == 1
    (record,) = member.records()
    assert (record.key, record.generation, record.index, record.size) == (KEY, 0, 2, 2), (
        "the pass is remembered for a later handshake report"
    )
    again, ack_again = member.on_release(rel)
    assert (again, ack_again) == (None, True), "a retransmission is acked, not passed again"


def test_a_member_that_passes_for_ever_keeps_a_bounded_memory_of_it() -> None:
    """A platform switching every second for a month passes millions of generations of one
    key: it remembers the last PASSED_KEPT, and a retransmission of any generation it
    passed, the oldest included, is still acknowledged and not passed again."""
    member = BarrierMember(2)
    releases = []
    for generation in range(1000):
        member.request(KEY, {0: 1}, float(generation))
        rel = _release([(2, 1)], generation=generation)
        releases.append(rel)
        event, ack = member.on_release(rel)
        assert event is not None and ack
    assert sum(len(kept) for kept in member._passed.values()) == PASSED_KEPT
    member.request(KEY, {0: 1}, 1000.0)  # a request pending meanwhile: generation 1000
    for rel in (releases[0], releases[500], releases[-PASSED_KEPT], releases[-1]):
        assert member.on_release(rel) == (None, True)
    assert member.pending[KEY][0].generation == 1000, "the pending request is untouched"


def test_member_not_chosen() -> None:
    member = BarrierMember(3)
    member.request(KEY, {0: 1}, 0.0)
    event, ack = member.on_release(_release([(1, 1), (3, 0)]))
    assert ack and event is not None
    assert (event.chosen, event.index) == (False, 0)


def test_member_timeout_outcome() -> None:
    member = BarrierMember(3)
    member.request(KEY, {0: 4}, 0.0, timeout=1.0)
    event, _ = member.on_release(_release([(3, 1)], outcome=TIMEOUT))
    assert event is not None and event.outcome == "timeout"


def test_member_learns_generation_from_release_it_is_not_part_of() -> None:
    member = BarrierMember(9)
    event, ack = member.on_release(_release([(1, 1), (2, 2)], generation=3))
    assert (event, ack) == (None, False), "not a candidate: nothing to pass, nothing to ack"
    assert member.known[KEY] == 4
    assert member.request(KEY, {0: 2}, 0.0).generation == 4


def test_member_with_pending_request_ignores_chunk_without_its_entry() -> None:
    member = BarrierMember(9)
    member.request(KEY, {0: 2}, 0.0)
    assert member.on_release(_release([(1, 1)], generation=0)) == (None, False)
    assert KEY in member.pending, "its own entry may come in another chunk"
    event, ack = member.on_release(_release([(9, 2)], generation=0))
    assert ack and event is not None and event.index == 2


def test_member_acks_release_for_request_it_no_longer_holds() -> None:
    member = BarrierMember(2)
    member.request(KEY, {0: 2}, 0.0)
    member.cancel(KEY)
    assert member.on_release(_release([(1, 1), (2, 2)])) == (None, True)


def test_member_on_stale_drops_pending_request() -> None:
    member = BarrierMember(2)
    member.request(KEY, {0: 2}, 0.0)
    notice = member.on_stale(BarrierStale(key=KEY, generation=0, current=3))
    assert notice == BarrierStaleNotice(key=KEY, generation=0, current=3)
    assert member.pending == {}
    assert member.known[KEY] == 3
    assert member.request(KEY, {0: 2}, 0.1).generation == 3, "the next request asks for 3"


def test_member_on_stale_for_other_generation_keeps_request() -> None:
    member = BarrierMember(2)
    member.known[KEY] = 3
    member.request(KEY, {0: 2}, 0.0)
    assert member.on_stale(BarrierStale(key=KEY, generation=1, current=2)) is None
    assert member.pending[KEY][0].generation == 3
    assert member.known[KEY] == 3, "known generations never go back"


def test_member_cancel() -> None:
    member = BarrierMember(2)
    assert member.cancel(KEY) is False
    member.request(KEY, {0: 2}, 0.0)
    assert member.cancel(KEY) is True
    assert member.restated(1.0) == []


def test_a_request_older_than_every_known_firing_waits_for_the_report_that_explains_it() -> None:
    """Campaign seed 3 (star): a master fired generation 0 choosing a platform the instant a
    partition cut it off; the other side's new master fired generation 0 without it. Told
    "stale" there, it would move on and the first firing could never be completed after the
    heal. Its request, made in an older epoch than every firing this master knows of, waits
    ``doubt_timeout`` for a report of the firing that may have chosen it."""
    h = Harness()
    for p in (1, 2):
        h.master.request(p, _req(2, epoch=EPOCH), 0.0, EPOCH)
    h.broadcasts()
    for p in (1, 2):
        h.master.on_ack(p, KEY, 0)
    late = _req(2, generation=0, epoch=EPOCH - 1)
    h.master.request(3, late, 0.1, EPOCH)
    assert h.notices() == [] and h.broadcasts() == [], "neither stale nor released yet"
    deadline = h.master.next_deadline()
    assert deadline == pytest.approx(0.1 + CoreConfig().doubt_timeout)
    # The report of a member that passed the old epoch's firing arrives: it is completed.
    record = ReleaseRecord(
        key=KEY,
        generation=0,
        part=0,
        index=1,
        size=2,
        outcome=COMPLETE,
        origin=EPOCH - 1,
        assignment={4: (0, 1), 3: (0, 2)},
    )
    h.master.record_released(4, record)
    h.master.reported(0.5, EPOCH)
    (rel,) = h.broadcasts()
    assert [(e.platform, e.index) for e in rel.entries] == [(3, 2)], "its original entry"
    assert rel.origin == EPOCH - 1


def test_a_doubtful_request_is_stale_once_its_wait_is_over() -> None:
    h = Harness()
    for p in (1, 2):
        h.master.request(p, _req(2, epoch=EPOCH), 0.0, EPOCH)
    h.broadcasts()
    h.master.request(3, _req(2, generation=0, epoch=EPOCH - 1), 0.1, EPOCH)
    h.master.tick(0.1 + CoreConfig().doubt_timeout, EPOCH)
    assert h.notices() == [(3, BarrierStale(key=KEY, generation=0, current=1))]
