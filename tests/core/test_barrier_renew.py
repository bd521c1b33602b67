"""Renewable barrier requests (``BarrierRequest.renew``): a request that crossed a firing on
its way is counted for the open generation when it alone fires it, instead of being
refused as stale and asked again; in every other case it is refused as before."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from actorswarm.bench.scripts import table1_script
from actorswarm.core.barrier import BarrierMaster, BarrierMember
from actorswarm.core.config import CoreConfig
from actorswarm.core.events import BarrierFired, BarrierStaleNotice
from actorswarm.core.node import Node
from actorswarm.core.wire import BarrierRequest, BarrierStale, Release, ReleaseEntry
from actorswarm.dsl import check
from actorswarm.sim.campaign import make_case, run_case
from actorswarm.sim.tasksim import TaskSim

KEY = 9
EPOCH = 2


def _req(need: int, generation: int, *, renew: bool) -> BarrierRequest:
    return BarrierRequest(
        key=KEY, generation=generation, need={0: need}, bid=0.0, epoch=EPOCH, renew=renew
    )


class _Recorder:
    """What the master decided: its releases and stale notices (firings are not read)."""

    def __init__(self) -> None:
        self.broadcasts: list[Release] = []
        self.notices: list[tuple[int, BarrierStale]] = []

    def fired(self, event: BarrierFired) -> None:
        """Not read here."""

    def stale(self, platform: int, notice: BarrierStale) -> None:
        self.notices.append((platform, notice))

    def release(self, packet: Release) -> None:
        self.broadcasts.append(packet)

    def gave_up(self, key: int, generation: int, unacked: set[int]) -> None:
        raise AssertionError(f"release {key}/{generation} given up")


def _master() -> tuple[BarrierMaster, _Recorder]:
    out = _Recorder()
    master = BarrierMaster(CoreConfig(), out, resolve_need=lambda k, p, n: n)
    master.become_ready(0.0, EPOCH)
    return master, out


def _drain(out: _Recorder) -> tuple[list[Release], list[tuple[int, BarrierStale]]]:
    drained = (list(out.broadcasts), list(out.notices))
    out.broadcasts.clear()
    out.notices.clear()
    return drained


@pytest.mark.parametrize("renew", [True, False])
def test_a_request_that_crossed_a_firing_is_released_at_once_when_renewable(renew: bool) -> None:
    master, out = _master()
    master.request(1, _req(1, 0, renew=False), 0.0, EPOCH)
    assert _drain(out)[0], "setup: generation 0 fires for platform 1"
    # Platform 3 asked for generation 0 too: its request arrives after that firing.
    master.request(3, _req(1, 0, renew=renew), 0.1, EPOCH)
    releases, notices = _drain(out)
    if renew:
        assert notices == [], "a renewable request is not refused"
        (rel,) = releases
        assert (rel.generation, rel.entries) == (1, [ReleaseEntry(platform=3, part=0, index=1)])
        assert master.table.open[KEY].generation == 2
    else:
        assert releases == []
        assert notices == [(3, BarrierStale(key=KEY, generation=0, current=1))]
        assert master.table.open[KEY].generation == 1


def test_a_renewable_request_that_cannot_fire_alone_is_refused_and_not_kept() -> None:
    master, out = _master()
    for p in (1, 2):
        master.request(p, _req(2, 0, renew=False), 0.0, EPOCH)
    assert _drain(out)[0], "setup: generation 0 fires for 1 and 2"
    master.request(3, _req(2, 0, renew=True), 0.1, EPOCH)
    releases, notices = _drain(out)
    assert releases == []
    assert notices == [(3, BarrierStale(key=KEY, generation=0, current=1))]
    assert master.table.open[KEY].requests == {}, "refused, not kept in generation 1"
    # Generation 1 fires for the two that ask for it, without platform 3.
    for p in (4, 5):
        master.request(p, _req(2, 1, renew=False), 0.2, EPOCH)
    (rel,) = _drain(out)[0]
    assert {e.platform for e in rel.entries} == {4, 5}


def test_a_renewable_request_does_not_join_others_waiting_nor_a_held_key() -> None:
    """Renewed only into a release of its own platform: with another request waiting in
    the open generation, or the key held, it is refused as before."""
    master, out = _master()
    master.request(1, _req(1, 0, renew=False), 0.0, EPOCH)
    _drain(out)
    master.hold(KEY, 5.0)
    master.request(2, _req(1, 1, renew=False), 0.1, EPOCH)  # waits: the key is held
    master.request(3, _req(1, 0, renew=True), 0.2, EPOCH)
    releases, notices = _drain(out)
    assert releases == []
    assert notices == [(3, BarrierStale(key=KEY, generation=0, current=1))]
    assert set(master.table.open[KEY].requests) == {2}


def test_a_member_passes_a_later_generation_for_its_renewable_request() -> None:
    member = BarrierMember(3)
    req = member.request(KEY, {0: 1}, 0.0, epoch=EPOCH, renew=True)
    assert (req.generation, req.renew) == (0, True)
    assert member.restated(0.5)[0].renew, "a handshake report keeps the flag"
    rel = Release(
        key=KEY,
        generation=4,
        epoch=EPOCH,
        outcome=0,
        sizes={0: 1},
        entries=[ReleaseEntry(platform=3, part=0, index=1)],
        total=1,
    )
    event, ack = member.on_release(rel)
    assert ack and event is not None
    assert (event.generation, event.chosen) == (4, True)
    assert member.pending == {} and member.known[KEY] == 5


def _table1(size: int) -> TaskSim:
    result = check(table1_script(size, 1), path="t1.xml")
    assert result.script is not None
    return TaskSim(result.script, seed=3)


@pytest.fixture
def stale_notices(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[int]]:
    """Counts the stale notices members take (each one a round trip more)."""
    seen: list[int] = []
    original = BarrierMember.on_stale

    def counting(self: BarrierMember, notice: BarrierStale) -> BarrierStaleNotice | None:
        seen.append(self.platform)
        return original(self, notice)

    monkeypatch.setattr(BarrierMember, "on_stale", counting)
    yield seen


def test_the_engines_candidacies_are_renewable_so_table1_needs_no_stale_round_trip(
    stale_notices: list[int], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The paper's Table I: every platform alternates between two actors by a local event,
    one platform per firing of a key all of them share, so nearly every request crosses
    another platform's firing. With the engine's renewable requests no member is told
    stale; the control (the same run with requests not renewable) is, about once a switch."""

    def switches(sim: TaskSim) -> int:
        return len(sim.advance(8.0))

    renewed = switches(_table1(8))
    assert stale_notices == []
    assert renewed >= 8 * 5, f"every platform switches about once a second: {renewed}"

    original = Node.request_barrier

    def not_renewable(self: Node, *args: Any, **kw: Any) -> int:
        kw["renew"] = False
        return original(self, *args, **kw)

    monkeypatch.setattr(Node, "request_barrier", not_renewable)
    refused = switches(_table1(8))
    assert len(stale_notices) >= refused // 2, (len(stale_notices), refused)


def test_renewable_campaign_cases_replay_with_the_flag_and_pass() -> None:
    case = make_case(11, "star", renew=True)
    assert case.replay == "actorswarm swarm campaign --seed 11 --membership star --renew"
    assert "renewable requests" in case.describe()
    assert make_case(11).actions == case.actions, "the flag does not change the schedule"
    for seed in (11, 12, 13):
        for mode in ("star", "broadcast"):
            result = run_case(make_case(seed, mode, renew=True))  # type: ignore[arg-type]
            assert result.ok, result.explain()
