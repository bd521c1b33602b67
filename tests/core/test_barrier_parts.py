"""The barrier master's parts, each alone: the table, the releases in flight, the firing
rules and the completion, given only the parts they are built on and an output that
records; and the node's outbox, which routes what the master's tables decided in a fixed
order."""

from __future__ import annotations

from typing import Any

import pytest

from actorswarm.core.barrier.completion import Completion
from actorswarm.core.barrier.firing import Trigger
from actorswarm.core.barrier.releases import Releases
from actorswarm.core.barrier.shared import Firing
from actorswarm.core.barrier.table import BarrierTable
from actorswarm.core.config import CoreConfig
from actorswarm.core.events import BarrierFired, DeliveryFailed
from actorswarm.core.node.outbox import MasterOutbox, ToMember
from actorswarm.core.wire import (
    COMPLETE,
    TIMEOUT,
    BarrierRequest,
    BarrierStale,
    Release,
    ReleaseEntry,
    RoleGrant,
)

KEY = 5
EPOCH = 2


class Recorder:
    """A :class:`~actorswarm.core.barrier.BarrierOutput` that keeps what it is given, in
    one list, in the order given."""

    def __init__(self) -> None:
        self.out: list[tuple[str, Any]] = []

    def fired(self, event: BarrierFired) -> None:
        self.out.append(("fired", event))

    def stale(self, platform: int, notice: BarrierStale) -> None:
        self.out.append(("stale", (platform, notice)))

    def release(self, packet: Release) -> None:
        self.out.append(("release", packet))

    def gave_up(self, key: int, generation: int, unacked: set[int]) -> None:
        self.out.append(("gave_up", (key, generation, unacked)))

    def take(self, kind: str) -> list[Any]:
        """What of ``kind`` was given since the last take of it."""
        mine = [item for k, item in self.out if k == kind]
        self.out = [(k, item) for k, item in self.out if k != kind]
        return mine


def _req(need: int = 2, *, generation: int = 0, bid: float = 0.0, **kw: Any) -> BarrierRequest:
    return BarrierRequest(key=KEY, generation=generation, need={0: need}, bid=bid, **kw)


def _firing(generation: int, assigned: dict[int, tuple[int, int]], **kw: Any) -> Firing:
    entries = {p: ReleaseEntry(platform=p, part=a[0], index=a[1]) for p, a in assigned.items()}
    return Firing(
        generation=generation,
        origin=EPOCH,
        master=1,
        outcome=COMPLETE,
        sizes={0: sum(1 for a in assigned.values() if a[1] > 0)},
        assigned=dict(assigned),
        complete_knowledge=True,
        entries=entries,
        **kw,
    )


# --- the table ---------------------------------------------------------------------------


def test_the_table_opens_the_generation_after_the_last_firing_it_knows() -> None:
    table = BarrierTable()
    assert table.instance(KEY).generation == 0
    del table.open[KEY]
    table.fired[KEY] = {3: [_firing(3, {1: (0, 1)})], 7: [_firing(7, {1: (0, 1)})]}
    assert table.instance(KEY).generation == 8
    assert table.firings(KEY, 7) and table.firings(KEY, 4) is None


def test_the_table_keeps_only_the_recent_generations() -> None:
    table = BarrierTable()
    table.fired[KEY] = {g: [_firing(g, {1: (0, 1)})] for g in range(10)}
    table.prune(KEY, keep=3)
    assert sorted(table.fired[KEY]) == [7, 8, 9]


def test_the_table_reports_what_it_knows_whole_and_what_it_only_completed() -> None:
    table = BarrierTable()
    table.fired[KEY] = {
        1: [_firing(1, {1: (0, 1), 2: (0, 2)})],
        2: [_firing(2, {3: (0, 1)})],
    }
    table.fired[KEY][2][0].complete_knowledge = False  # rebuilt from reports, completed
    whole, partial = table.decided(2)
    assert (whole.generation, whole.index, whole.assignment, whole.partial) == (
        1,
        2,
        {1: (0, 1), 2: (0, 2)},
        {},
    )
    assert (partial.generation, partial.index, partial.assignment) == (2, 0, {})
    assert partial.partial == {3: (0, 1)}, "a completed firing goes as a partial assignment"


def test_the_table_may_fire_only_when_ready_and_not_holding() -> None:
    table = BarrierTable()
    assert not table.may_fire
    table.ready = True
    assert table.may_fire
    table.holding = True
    assert not table.may_fire


# --- the releases in flight --------------------------------------------------------------


def _releases(out: Recorder, **config: Any) -> Releases:
    return Releases(
        CoreConfig(**config),
        out,
        first_retry=lambda: 0.1,
        retry_delay=lambda k, first, answers: first * (k + 1),
    )


def test_a_release_is_retransmitted_only_to_whoever_has_not_acknowledged() -> None:
    out = Recorder()
    releases = _releases(out)
    fired = _firing(0, {1: (0, 1), 2: (0, 2), 3: (0, 0)})
    releases.launch(KEY, fired, {1, 2, 3}, 0.0, EPOCH)
    (first,) = out.take("release")
    assert [e.platform for e in first.entries] == [1, 2, 3] and first.total == 3
    assert releases.next_deadline() == pytest.approx(0.1)
    releases.on_ack(1, KEY, 0)
    releases.tick(0.05, EPOCH)
    assert out.take("release") == [], "not due yet"
    releases.tick(0.1, EPOCH + 1)
    (retry,) = out.take("release")
    assert [e.platform for e in retry.entries] == [2, 3], "only the unacknowledged"
    assert retry.epoch == EPOCH + 1, "retransmitted in the master's epoch now"
    assert releases.next_deadline() == pytest.approx(0.1 + 0.2)
    releases.on_ack(2, KEY, 0)
    releases.member_left(3)
    assert releases.inflight == {} and releases.next_deadline() is None


def test_a_release_past_its_deadline_is_given_up() -> None:
    out = Recorder()
    releases = _releases(out, delivery_deadline=1.0)
    releases.launch(KEY, _firing(0, {1: (0, 1), 2: (0, 2)}), {1, 2}, 0.0, EPOCH)
    releases.on_ack(1, KEY, 0)
    releases.tick(1.0, EPOCH)
    assert out.take("gave_up") == [(KEY, 0, {2})]
    assert releases.inflight == {}


def test_a_release_goes_out_in_chunks() -> None:
    out = Recorder()
    releases = _releases(out, release_chunk=2)
    releases.launch(KEY, _firing(0, {p: (0, p) for p in range(1, 6)}), set(range(1, 6)), 0.0, 1)
    chunks = out.take("release")
    assert [[e.platform for e in c.entries] for c in chunks] == [[1, 2], [3, 4], [5]]


def test_a_missed_entry_is_sent_again_alone() -> None:
    out = Recorder()
    releases = _releases(out)
    fired = _firing(0, {1: (0, 1), 2: (0, 2)})
    fired.entries.pop(2)
    releases.resend(KEY, fired, 2, 0.0, EPOCH)
    (rel,) = out.take("release")
    assert rel.entries == [ReleaseEntry(platform=2, part=0, index=2)]


# --- the firing rules --------------------------------------------------------------------


def _trigger(out: Recorder, **hooks: Any) -> tuple[BarrierTable, Trigger]:
    table = BarrierTable()
    table.ready = True
    releases = _releases(out)
    args: dict[str, Any] = {
        "platform": 1,
        "resolve_need": lambda k, p, n: n,
        "scatter": None,
        "gathers": lambda key: True,
        "live": lambda platform: True,
        "first_retry": lambda: 0.1,
    }
    args.update(hooks)
    return table, Trigger(table, releases, out, **args)


def test_the_trigger_fires_when_the_part_has_its_candidates_best_bids_first() -> None:
    out = Recorder()
    table, trigger = _trigger(out)
    trigger.admit(3, _req(2, bid=3.0), 0.0)
    trigger.try_fire(KEY, 0.0, EPOCH)
    assert out.out == [], "one of two"
    trigger.admit(2, _req(2, bid=2.0), 0.1)
    trigger.admit(4, _req(2, bid=1.0), 0.1)
    trigger.try_fire(KEY, 0.1, EPOCH)
    (event,) = out.take("fired")
    assert event.chosen == {4: (0, 1), 2: (0, 2)} and event.not_chosen == (3,)
    assert len(out.take("release")) == 1
    assert table.instance(KEY).generation == 1 and table.firings(KEY, 0)


def test_the_trigger_does_not_fire_a_held_key_nor_before_the_table_is_ready() -> None:
    out = Recorder()
    table, trigger = _trigger(out)
    trigger.hold(KEY, 1.0)
    trigger.admit(1, _req(1), 0.0)
    trigger.try_fire(KEY, 0.5, EPOCH)
    assert out.out == [] and trigger.next_deadline() == 1.0
    table.ready = False
    trigger.tick_holds(1.0, EPOCH)
    assert out.out == [], "not ready: the hold ends, nothing fires"
    table.ready = True
    trigger.try_fire(KEY, 1.0, EPOCH)
    assert len(out.take("fired")) == 1


def test_the_trigger_releases_everyone_waiting_at_a_timeout() -> None:
    out = Recorder()
    _, trigger = _trigger(out)
    trigger.admit(2, _req(5, timeout=1.0), 0.0)
    trigger.admit(3, _req(5, timeout=2.0, bid=-1.0), 0.5)
    assert trigger.next_deadline() == 1.0, "the shortest timeout, from the first request"
    trigger.tick_timeouts(0.9, EPOCH)
    assert out.out == []
    trigger.tick_timeouts(1.0, EPOCH)
    (event,) = out.take("fired")
    assert event.outcome == "timeout" and event.chosen == {3: (0, 1), 2: (0, 2)}
    (rel,) = out.take("release")
    assert rel.outcome == TIMEOUT


def test_the_trigger_scatters_and_gathers_through_its_hooks() -> None:
    out = Recorder()
    _, trigger = _trigger(
        out,
        scatter=lambda key, gen, chosen: {p: f"slot-{i}" for p, _, i, _ in chosen},
        gathers=lambda key: False,
    )
    trigger.admit(1, _req(1, data="x"), 0.0)
    trigger.try_fire(KEY, 0.0, EPOCH)
    (rel,) = out.take("release")
    assert rel.entries[0].data == "slot-1" and rel.gathered == []


# --- the completion ----------------------------------------------------------------------


def _completion(out: Recorder) -> tuple[BarrierTable, Completion, list[int]]:
    config = CoreConfig()
    table, trigger = _trigger(out)
    releases = _releases(out)
    routed: list[int] = []
    completion = Completion(
        config,
        table,
        releases,
        trigger,
        out,
        platform=1,
        route=lambda platform, req, now, epoch: routed.append(platform),
    )
    return table, completion, routed


def test_a_late_request_is_refused_as_stale_once_the_swarm_is_settled() -> None:
    out = Recorder()
    table, completion, routed = _completion(out)
    table.fired[KEY] = {0: [_firing(0, {2: (0, 1)})]}
    completion.late_request(3, _req(1, epoch=EPOCH, master=1), table.fired[KEY][0], 5.0, EPOCH)
    assert out.take("stale") == [(3, BarrierStale(key=KEY, generation=0, current=1))]
    assert routed == []


def test_a_late_request_of_a_candidate_gets_its_entry_again() -> None:
    out = Recorder()
    table, completion, _ = _completion(out)
    table.fired[KEY] = {0: [_firing(0, {2: (0, 1), 3: (0, 0)})]}
    completion.late_request(3, _req(1, epoch=EPOCH), table.fired[KEY][0], 5.0, EPOCH)
    (rel,) = out.take("release")
    assert rel.entries == [ReleaseEntry(platform=3, part=0, index=0)]
    assert out.take("stale") == []


def test_a_refusal_right_after_a_change_of_the_swarm_waits_and_is_routed_again() -> None:
    """A report still on its way may show the request belongs to a firing to complete:
    for ``t_join`` after the change the refusal is only doubtful, then routed again."""
    out = Recorder()
    _, completion, routed = _completion(out)
    completion.topology_changed(1.0)
    completion.refuse(3, _req(1, epoch=EPOCH, master=1), 1, 1.2, EPOCH)
    assert out.take("stale") == []
    t_join = CoreConfig().t_join
    assert completion.next_deadline() == pytest.approx(1.0 + t_join)
    completion.recheck_doubtful(1.0 + t_join / 2, EPOCH)
    assert routed == []
    completion.recheck_doubtful(1.0 + t_join, EPOCH)
    assert routed == [3] and completion.next_deadline() is None


def test_a_completion_gives_the_waiting_candidates_the_free_indices() -> None:
    """A firing rebuilt from a report (platform 2 passed index 1 of 2): the request of 3,
    which waited for that generation, is completed with index 2, as a completion."""
    out = Recorder()
    table, completion, _ = _completion(out)
    table.ready = True
    fired = _firing(0, {2: (0, 1)}, occasions=frozenset())
    fired.sizes = {0: 2}
    fired.complete_knowledge = False
    table.fired[KEY] = {0: [fired]}
    completion.late_request(3, _req(2, epoch=EPOCH - 1), [fired], 0.0, EPOCH)
    (event,) = out.take("fired")
    assert event.completion and event.chosen == {3: (0, 2)}
    (rel,) = out.take("release")
    assert [(e.platform, e.index) for e in rel.entries] == [(3, 2)]


# --- the node's outbox -------------------------------------------------------------------


def test_the_outbox_hands_over_by_kind_in_a_fixed_order_each_kind_in_its_own() -> None:
    """Whatever order the tables decided in: firings, stale notices, role replies,
    releases, releases given up (the order the node has always routed them in)."""
    box = MasterOutbox()
    rel = Release(epoch=1, key=KEY, generation=0, outcome=0, sizes={0: 1}, entries=[])
    fired = [
        BarrierFired(
            key=k,
            generation=0,
            epoch=1,
            outcome="complete",
            chosen={},
            not_chosen=(),
            completion=False,
        )
        for k in (1, 2)
    ]
    notice = BarrierStale(key=KEY, generation=0, current=1)
    box.gave_up(KEY, 0, {4, 3})
    box.release(rel)
    box.reply(6, RoleGrant(role="r"))
    box.fired(fired[0])
    box.stale(5, notice)
    box.fired(fired[1])
    taken = box.take()
    assert taken[:4] == [fired[0], fired[1], ToMember(5, notice), ToMember(6, RoleGrant(role="r"))]
    assert taken[4] is rel
    assert taken[5] == DeliveryFailed(
        dst=None, kind="Release", reason=f"barrier {KEY}/0: no acknowledgement from [3, 4]"
    )
    assert box.take() == [], "empty once taken"
