"""The star membership topology: the master's roster, its copy at the members, and the node.

What is tested here:

* :class:`RosterLog` and :class:`RosterView` on their own: versions and the chain of recent
  changes, catching up from changes versus fetching the whole roster, chunked rosters
  adopted only when complete, ``removed``, rejected inconsistent input, packet sizes at
  10 000 platforms and the succession list;
* star nodes on the simulated radio: who watches whom, who broadcasts, per-platform load as
  the swarm grows, a quiet boot, failover along the succession list;
* forged or garbled roster traffic fed straight to a node (counted, changes nothing);
* suspicion before leave, probes and their answers, false leaves that must not hold the
  master back;
* local health (grace of a host that ticks late) and the loss-aware leave time;
* that both membership modes still elect one master and pass a barrier of everyone.
"""

from __future__ import annotations

import math
import random
from collections import Counter
from dataclasses import dataclass
from itertools import pairwise
from typing import Any, TypeVar

import pytest

from actorswarm.core import wire
from actorswarm.core.config import CoreConfig, MembershipKind
from actorswarm.core.election import OnHeartbeat
from actorswarm.core.events import (
    BarrierReleased,
    BecameMaster,
    HandshakeComplete,
    MasterChanged,
    MemberJoined,
    MemberLeft,
)
from actorswarm.core.membership import airtime
from actorswarm.core.membership.roster import RosterLog, RosterPool, RosterView
from actorswarm.core.membership.view import Membership, leave_silence
from actorswarm.core.node import Node, Outgoing, Ready, leadership
from actorswarm.core.ready import PROBE
from actorswarm.core.wire import (
    MAX_CHANGES,
    MAX_SUCCESSION,
    MAX_SUSPECTS,
    NEED_ALL,
    Heartbeat,
    Packet,
    RosterChunk,
    RosterRequest,
    decode,
    encode,
)
from actorswarm.sim.radio import LinkModel, Transmission
from actorswarm.sim.swarm import SimSwarm

CONFIG = CoreConfig()
INTERVAL = CONFIG.heartbeat_interval
#: How long a silent peer stays in a view on a clean radio: suspicion, then the probe window.
LEAVE = CONFIG.t_leave + CONFIG.probe_window
EPOCH = 3
SIM_SWARM = "sim"  # SimSwarm's default swarm name
FORMED_AT = 2.0  # a simulated swarm of up to 30 platforms has formed well before this
#: A handshake's airtime per member, in heartbeats' worth of bits over the bit rate: its
#: packets (HANDSHAKE_PACKETS) in the half of the channel the heartbeats leave.
HANDSHAKE_SHARE = airtime.HANDSHAKE_PACKETS / (1 - CONFIG.heartbeat_share)

E = TypeVar("E")


# --- helpers --------------------------------------------------------------------------------


def master_heartbeat(
    *,
    epoch: int = EPOCH,
    roster: int,
    size: int,
    changes: list[tuple[int, int]] | None = None,
    succession: list[int] | None = None,
    master: int = 1,
    suspects: list[int] | None = None,
) -> Heartbeat:
    return Heartbeat(
        is_master=True,
        epoch=epoch,
        master=master,
        roster=roster,
        size=size,
        changes=changes or [],
        succession=succession or [],
        suspects=suspects or [],
    )


class MasterModel:
    """A master's side of the roster: its members and the log it tells them about."""

    def __init__(self, members: dict[int, int], *, epoch: int = EPOCH) -> None:
        self.members = dict(members)
        self.log = RosterLog(CONFIG.succession)
        self.log.reset(epoch)
        self.epoch = epoch
        self._next_id = max(members, default=1) + 1

    def join(self, platform: int | None = None, incarnation: int = 0) -> int:
        if platform is None:
            platform, self._next_id = self._next_id, self._next_id + 1
        self.members[platform] = incarnation
        self.log.joined(platform, incarnation)
        return platform

    def leave(self, platform: int) -> None:
        del self.members[platform]
        self.log.left(platform)

    def heartbeat(self) -> Heartbeat:
        return master_heartbeat(
            epoch=self.epoch,
            roster=self.log.version,
            size=len(self.members),
            changes=list(self.log.changes),
            succession=self.log.succession(self.members),
        )

    def chunks(self, size: int = CONFIG.roster_chunk) -> list[RosterChunk]:
        return RosterLog.chunks(self.epoch, self.log.version, self.members, size)


def synced_view(master: MasterModel) -> RosterView:
    """A member's copy that has fetched the master's whole roster."""
    view = RosterView()
    for chunk in master.chunks():
        view.on_chunk(chunk)
    assert view.members == master.members, "setup: the copy matches the master"
    assert (view.epoch, view.version) == (master.epoch, master.log.version)
    return view


def ten_members() -> dict[int, int]:
    return dict.fromkeys(range(2, 12), 0)


def packet(
    body: wire.Body, *, sender: int, seq: int = 1_000_000, incarnation: int = 0
) -> wire.Packet:
    """A packet as a node's pipeline hands it over (encoded, then checked and decoded)."""
    data = encode(swarm=SIM_SWARM, sender=sender, incarnation=incarnation, seq=seq, body=body)
    return decode(data)


def formed(n: int, *, seed: int = 1, config: CoreConfig | None = None) -> SimSwarm:
    """A simulated star (or broadcast) swarm of ``n`` that elected platform 1."""
    swarm = SimSwarm(n, seed=seed, config=config)
    swarm.run_until(FORMED_AT)
    assert swarm.current_masters() == [1], f"setup: masters {swarm.current_masters()}"
    assert swarm.formed(n), "setup: the swarm formed"
    return swarm


def bodies(out: list[Outgoing]) -> list[tuple[int | None, wire.Body]]:
    return [(o.dst, decode(o.data).body) for o in out]


@dataclass(frozen=True, slots=True)
class Sent:
    t: float
    dst: int | None
    body: wire.Body


def record_sent(monkeypatch: pytest.MonkeyPatch, swarm: SimSwarm, platform: int) -> list[Sent]:
    """Every packet ``platform`` hands the radio from now on, decoded, with its time."""
    node = swarm.node(platform)
    sent: list[Sent] = []
    ready = node.ready

    def recording() -> Ready:
        out = ready()
        sent.extend(Sent(swarm.now, o.dst, decode(o.data).body) for o in out.packets)
        return out

    monkeypatch.setattr(node, "ready", recording)
    return sent


class OneWayCut:
    """Drops every packet from ``src`` to ``dst`` while ``open`` (the other way works)."""

    def __init__(self, src: int, dst: int) -> None:
        self.link = (src, dst)
        self.open = True

    def __call__(self, src: int, dst: int) -> tuple[float, float]:
        """The radio's per-link model: (loss probability, extra latency)."""
        return (1.0, 0.0) if self.open and (src, dst) == self.link else (0.0, 0.0)


def cut_link(swarm: SimSwarm, src: int, dst: int) -> OneWayCut:
    cut = OneWayCut(src, dst)
    swarm.radio.link_fn = cut
    return cut


def log_of(
    swarm: SimSwarm, platform: int, kind: type[E], since: float = 0.0
) -> list[tuple[float, E]]:
    """``platform``'s events of type ``kind`` since ``since``, with their times."""
    return [
        (e.t, e.event)
        for e in swarm.log
        if e.platform == platform and isinstance(e.event, kind) and e.t >= since
    ]


# --- 1. RosterLog and RosterView --------------------------------------------------------------


def test_roster_log_versions_count_every_change_and_keep_the_newest() -> None:
    """Members catch up from the changes by version arithmetic: every join and leave must
    add exactly one version, and the log must keep the newest changes, newest last."""
    log = RosterLog(CONFIG.succession)
    log.reset(7)
    assert (log.epoch, log.version, list(log.changes)) == (7, 1, [])
    log.joined(20, 4)
    log.left(21)
    assert (log.version, list(log.changes)) == (3, [(20, 4), (21, -1)])
    for p in range(100, 130):
        log.joined(p, 0)
    assert log.version == 33
    assert len(log.changes) == MAX_CHANGES
    assert list(log.changes) == [(p, 0) for p in range(114, 130)], "the 16 newest, in order"
    log.reset(8)  # a new epoch starts again at version 1 with nothing to tell
    assert (log.epoch, log.version, list(log.changes)) == (8, 1, [])


@pytest.mark.parametrize(
    ("behind", "asks"),
    [
        (0, False),
        (1, False),
        (2, False),
        (9, False),
        (MAX_CHANGES, False),  # the oldest change carried is exactly the one missing
        (MAX_CHANGES + 1, True),  # one change more than a heartbeat carries
        (40, True),
    ],
)
def test_member_catches_up_from_changes_or_asks_for_the_roster(behind: int, asks: bool) -> None:
    """A member up to 16 versions behind applies the changes; further behind it cannot, and
    must ask for the whole roster without touching its copy."""
    master = MasterModel(ten_members())
    view = synced_view(master)
    before = (dict(view.members), view.version)
    rng = random.Random(behind)
    for i in range(behind):
        if i % 3 == 2 and len(master.members) > 1:
            master.leave(rng.choice(sorted(master.members)))
        else:
            master.join(incarnation=i)
    assert view.on_heartbeat(EPOCH, master.heartbeat()) is asks
    if asks:
        assert (view.members, view.version) == before, "a copy that cannot catch up is kept"
    else:
        assert view.members == master.members
        assert view.version == master.log.version
    assert view.rejected == 0


def test_a_new_epoch_makes_the_member_ask_for_the_whole_roster() -> None:
    """A new master's versions do not continue the old ones: nothing may be applied."""
    master = MasterModel(ten_members())
    view = synced_view(master)
    newer = MasterModel({**ten_members(), 50: 0}, epoch=EPOCH + 1)
    newer.join(51)
    assert view.on_heartbeat(EPOCH + 1, newer.heartbeat()) is True
    assert view.members == ten_members()
    assert (view.epoch, view.version) == (EPOCH, master.log.version)


@pytest.mark.parametrize(
    ("case", "version_delta", "size_delta", "asks", "rejected"),
    [
        ("same version, same size", 0, 0, False, 0),
        ("same version, master counts more", 0, 1, True, 0),
        ("older version than the copy", -1, 0, False, 1),
    ],
)
def test_heartbeat_at_or_below_the_members_version(
    case: str, version_delta: int, size_delta: int, asks: bool, rejected: int
) -> None:
    """A heartbeat of the member's own version only checks the count; an older one is a late
    or forged packet and is refused."""
    master = MasterModel(ten_members())
    master.join(30)
    master.join(31)
    view = synced_view(master)
    hb = master_heartbeat(
        roster=master.log.version + version_delta,
        size=len(master.members) + size_delta,
        changes=list(master.log.changes),
    )
    assert view.on_heartbeat(EPOCH, hb) is asks, case
    assert view.rejected == rejected, case
    assert view.members == master.members, case


def test_heartbeat_updates_succession_and_size_whatever_the_version() -> None:
    """The succession list is what a member acts on when the master is lost: it must follow
    the master's latest word even while the roster is being fetched."""
    view = RosterView()
    hb = master_heartbeat(roster=9, size=40, succession=[2, 5, 7])
    assert view.on_heartbeat(EPOCH, hb) is True  # no copy yet: asks
    assert (view.succession, view.size) == ([2, 5, 7], 40)
    assert not view.current


CHUNKED_MEMBERS = {p: p % 3 for p in range(2, 51)}  # 49 entries: 4 chunks of at most 16


@pytest.mark.parametrize(
    "order",
    [
        [0, 1, 2, 3],
        [3, 2, 1, 0],
        [2, 0, 3, 1],
        [1, 1, 3, 3, 0, 0, 2],  # copies of a chunk must not count as other chunks
    ],
    ids=["in-order", "reversed", "shuffled", "duplicates"],
)
def test_full_roster_is_adopted_only_when_every_chunk_arrived(order: list[int]) -> None:
    """Adopting part of a roster would drop the platforms of the missing chunks."""
    master = MasterModel(CHUNKED_MEMBERS)
    chunks = master.chunks(size=16)
    assert len(chunks) == 4
    view = RosterView()
    view.on_chunk(RosterChunk(epoch=EPOCH - 1, version=5, index=0, count=1, members=[(99, 0)]))
    old = dict(view.members)
    seen: set[int] = set()
    for i in order:
        seen.add(i)
        complete = len(seen) == len(chunks)
        assert view.on_chunk(chunks[i]) is complete, f"chunk {i} after {sorted(seen)}"
        if complete:
            break
        assert view.members == old, f"adopted with only chunks {sorted(seen)}"
    assert view.members == CHUNKED_MEMBERS
    assert (view.epoch, view.version) == (EPOCH, master.log.version)
    assert view.current
    assert view.rejected == 0


def test_members_of_one_process_share_equal_rosters_and_never_a_different_one() -> None:
    """A pool (the simulator's) hands every member the same roster object when their copies
    are equal; a member whose copy differs (a forged chunk, another partition's master with
    the same epoch number) keeps its own; a change makes a new roster, never edits the
    shared one."""
    pool = RosterPool()
    master = MasterModel(CHUNKED_MEMBERS)
    views = [RosterView(pool) for _ in range(3)]
    for view in views:
        for chunk in master.chunks(size=16):
            view.on_chunk(chunk)
    assert views[0].members is views[1].members is views[2].members
    assert views[0].members == CHUNKED_MEMBERS
    assert pool.shared == 2 * 4 + 2, "two members took the first's 4 chunks, then its roster"
    # Another master of the same epoch and version, with a different roster.
    other = RosterView(pool)
    forged = RosterLog.chunks(EPOCH, master.log.version, {2: 0, 3: 0}, 16)
    other.on_chunk(forged[0])
    assert other.members == {2: 0, 3: 0}
    assert views[0].members == CHUNKED_MEMBERS, "the shared roster is untouched"
    # A join: each member applies it to a copy; they share the result again.
    platform = master.join(incarnation=4)
    for view in views:
        assert view.on_heartbeat(EPOCH, master.heartbeat()) is False
    assert views[0].members is views[1].members is views[2].members
    assert views[0].members == {**CHUNKED_MEMBERS, platform: 4}
    assert CHUNKED_MEMBERS.keys() == set(range(2, 51)), "the original was not edited"


def test_an_incomplete_roster_is_never_adopted() -> None:
    master = MasterModel(CHUNKED_MEMBERS)
    chunks = master.chunks(size=16)
    view = RosterView()
    for chunk in chunks[:-1] * 3:
        assert view.on_chunk(chunk) is False
    assert view.members == {}
    assert not view.current


@pytest.mark.parametrize(
    ("case", "removed"),
    [
        ("a leave change", [4]),
        ("two leave changes", [4, 7]),
        ("a join change", []),
        ("a new full roster without 4 and 7", [4, 7]),
    ],
)
def test_removed_lists_platforms_the_masters_roster_lost(case: str, removed: list[int]) -> None:
    """``removed`` is how the node drops its queues to platforms that left: it must name
    exactly those, however the member learnt of it."""
    master = MasterModel(ten_members())
    view = synced_view(master)
    if case == "a new full roster without 4 and 7":
        kept = {p: i for p, i in ten_members().items() if p not in (4, 7)}
        newer = MasterModel(kept, epoch=EPOCH + 1)
        for chunk in newer.chunks(size=16):
            view.on_chunk(chunk)
    else:
        if case == "a join change":
            master.join(40)
        for p in removed:
            master.leave(p)
        assert view.on_heartbeat(EPOCH, master.heartbeat()) is False
    assert sorted(view.removed) == removed, case
    assert not set(view.members) & set(removed)


@pytest.mark.parametrize(
    ("case", "changes", "size_delta"),
    [
        ("a join the count does not show", [(99, 0)], 0),
        ("a leave the count does not show", [(4, -1)], 0),
        ("a count that grew by two for one join", [(99, 0)], 2),
    ],
)
def test_changes_that_do_not_lead_to_the_masters_count_are_rejected(
    case: str, changes: list[tuple[int, int]], size_delta: int
) -> None:
    """A garbled or forged heartbeat must not leave the member believing its copy is
    current: it is counted and the member asks for the whole roster, again and again until
    a full copy arrives."""
    master = MasterModel(ten_members())
    view = synced_view(master)
    version = view.version
    hb = master_heartbeat(roster=version + 1, size=len(view.members) + size_delta, changes=changes)
    assert view.on_heartbeat(EPOCH, hb) is True, case
    assert view.rejected == 1, case
    assert not view.current, case
    # The master's next heartbeat (same version) still finds the member behind.
    assert view.on_heartbeat(EPOCH, hb) is True, case
    # A full copy ends it.
    master.join(99)
    for chunk in master.chunks():
        view.on_chunk(chunk)
    assert view.on_heartbeat(EPOCH, master.heartbeat()) is False
    assert view.members == master.members


def test_rejected_changes_leave_the_copy_untouched() -> None:
    master = MasterModel(ten_members())
    view = synced_view(master)
    hb = master_heartbeat(roster=view.version + 1, size=len(view.members), changes=[(4, -1)])
    assert view.on_heartbeat(EPOCH, hb) is True
    assert view.members == ten_members(), "platform 4 dropped on a rejected heartbeat"
    assert view.removed == [], "the node would drop its queues to a live platform"


@pytest.mark.parametrize(
    ("case", "chunk"),
    [
        (
            "index equal to count",
            RosterChunk(epoch=EPOCH, version=9, index=1, count=1, members=[(99, 0)]),
        ),
        (
            "index beyond count",
            RosterChunk(epoch=EPOCH, version=9, index=7, count=2, members=[(99, 0)]),
        ),
    ],
)
def test_chunk_outside_its_roster_is_rejected(case: str, chunk: RosterChunk) -> None:
    """Such a chunk passes the wire's range checks; adopting it would complete a roster with
    a part that does not exist."""
    master = MasterModel(ten_members())
    view = synced_view(master)
    assert view.on_chunk(chunk) is False, case
    assert view.rejected == 1, case
    assert view.members == ten_members(), case


def test_chunk_older_than_the_roster_on_its_way_is_rejected() -> None:
    """A late chunk of an older roster must neither be adopted nor discard the parts of the
    newer roster being assembled."""
    view = RosterView()
    newer = [
        RosterChunk(epoch=EPOCH, version=9, index=i, count=2, members=[(2 + i, 0)])
        for i in range(2)
    ]
    assert view.on_chunk(newer[0]) is False
    older = RosterChunk(epoch=EPOCH, version=8, index=0, count=1, members=[(5, 0)])
    assert view.on_chunk(older) is False
    assert view.rejected == 1
    assert view.members == {}
    assert view.on_chunk(newer[1]) is True, "the first part of the newer roster was kept"
    assert (view.version, view.members) == (9, {2: 0, 3: 0})


def test_complete_roster_older_than_the_adopted_one_is_refused() -> None:
    view = RosterView()
    view.on_chunk(RosterChunk(epoch=EPOCH, version=9, index=0, count=1, members=[(2, 0), (3, 0)]))
    late = RosterChunk(epoch=EPOCH, version=8, index=0, count=1, members=[(2, 0)])
    assert view.on_chunk(late) is False
    assert (view.version, view.members, view.removed) == (9, {2: 0, 3: 0}, [])


@pytest.mark.parametrize("incarnation", [0, 2**62], ids=["small", "huge-incarnations"])
def test_roster_of_ten_thousand_fits_in_packets(incarnation: int) -> None:
    """Every chunk is sent as one packet: it must stay under the packet limit however large
    the swarm and its incarnations get, and the chunks together must be the whole roster."""
    members = dict.fromkeys(range(2, 10_002), incarnation)
    chunks = RosterLog.chunks(EPOCH, 12345, members, CONFIG.roster_chunk)
    assert len(chunks) == math.ceil(10_000 / CONFIG.roster_chunk)
    entries: list[tuple[int, int]] = []
    for i, chunk in enumerate(chunks):
        assert (chunk.index, chunk.count) == (i, len(chunks))
        assert len(chunk.members) <= CONFIG.roster_chunk
        data = encode(swarm="a-long-swarm-name", sender=1, incarnation=2**62, seq=2**62, body=chunk)
        assert len(data) < CONFIG.max_packet_bytes, f"chunk {i}: {len(data)} bytes"
        assert decode(data, max_bytes=CONFIG.max_packet_bytes).body == chunk
        entries.extend(chunk.members)
    assert entries == sorted(members.items()), "all of it, ascending, each once"
    view = RosterView()
    for chunk in reversed(chunks):
        view.on_chunk(chunk)
    assert view.members == members


def test_master_heartbeat_stays_small_at_its_fullest() -> None:
    """Changes, suspects and succession are bounded so that a heartbeat costs the same
    airtime at any swarm size."""
    hb = master_heartbeat(
        roster=2**62,
        size=wire.MAX_PLATFORM,
        changes=[(60_000 + i, 2**62) for i in range(MAX_CHANGES)],
        succession=list(range(60_000, 60_000 + MAX_SUCCESSION)),
        suspects=list(range(50_000, 50_000 + MAX_SUSPECTS)),
    )
    data = encode(swarm=SIM_SWARM, sender=1, incarnation=2**62, seq=2**62, body=hb)
    assert len(data) < 600
    assert decode(data).body == hb


@pytest.mark.parametrize("length", [1, 4, 16])
def test_succession_is_the_next_lowest_ids(length: int) -> None:
    """The succession list decides who takes over without an election: the next-lowest IDs,
    ascending, recomputed when the roster changes."""
    log = RosterLog(length)
    log.reset(1)
    peers = list(range(2, 10_002))
    random.Random(length).shuffle(peers)
    assert log.succession(peers) == list(range(2, 2 + length))
    log.left(2)
    peers.remove(2)
    assert log.succession(peers) == list(range(3, 3 + length))
    log.joined(2, 1)
    peers.append(2)
    assert log.succession(peers) == list(range(2, 2 + length))


# --- 2. A star on the simulated radio -----------------------------------------------------


@pytest.mark.parametrize("n", [10, 30])
def test_star_member_watches_its_master_and_sees_the_swarm_through_the_roster(n: int) -> None:
    swarm = formed(n)
    everyone = tuple(range(1, n + 1))
    master = swarm.node(1)
    assert master.view == everyone
    assert sorted(master.members.peers) == list(range(2, n + 1))
    for p in range(2, n + 1):
        node = swarm.node(p)
        assert list(node.members.peers) == [1], f"platform {p} watches {list(node.members.peers)}"
        assert node.view == everyone, f"platform {p} sees {node.view}"
        assert sorted(node.roster.members) == list(range(2, n + 1))
        assert node.roster.succession == [2, 3, 4, 5]
        assert node.errors == []


@pytest.mark.parametrize(
    ("membership", "n", "broadcasts_per_second"),
    [
        ("star", 10, 10),  # the master's heartbeats only
        ("star", 30, 10),
        ("broadcast", 10, 100),  # everyone's: shows that the count is not blind to members
    ],
)
def test_who_broadcasts_heartbeats_in_steady_state(
    membership: MembershipKind, n: int, broadcasts_per_second: int
) -> None:
    """In a star the members' heartbeats go to the master alone; only the master's are
    broadcast, whatever the swarm size."""
    config = CoreConfig(membership=membership)
    swarm = formed(n, config=config)
    heartbeats: list[tuple[int, int | None]] = []

    def tap(now: float, src: int, dst: int | None, kind: str, size: int) -> None:
        if kind == "Heartbeat":
            heartbeats.append((src, dst))

    swarm.radio.tap = tap
    swarm.run_until(FORMED_AT + 1.0)
    broadcast = [src for src, dst in heartbeats if dst is None]
    assert len(broadcast) == pytest.approx(broadcasts_per_second, rel=0.1)
    if membership == "star":
        assert set(broadcast) == {1}
        member_dsts = Counter(dst for src, dst in heartbeats if src != 1)
        assert set(member_dsts) == {1}, f"member heartbeats went to {dict(member_dsts)}"
        assert member_dsts[1] == pytest.approx(10 * (n - 1), rel=0.1)


def test_member_load_stays_flat_while_the_masters_grows() -> None:
    """Work per non-master is O(1) in N, per master O(N)."""
    received: dict[int, dict[int, int]] = {}
    for n in (10, 30):
        swarm = formed(n)
        before = swarm.radio.traffic.snapshot()
        swarm.run_until(FORMED_AT + 1.0)
        after = swarm.radio.traffic.snapshot()
        received[n] = {
            p: after[p]["recv_packets"] - before[p]["recv_packets"] for p in (1, 2, 5, 9)
        }
    for p in (2, 5, 9):
        small, large = received[10][p], received[30][p]
        assert small > 0
        assert abs(large - small) <= 0.2 * small, f"platform {p}: {small} -> {large} packets/s"
    assert received[30][1] >= 2.5 * received[10][1], f"master: {received}"


def test_a_candidate_at_a_slow_cadence_joins_and_is_not_swept_between_heartbeats() -> None:
    """Three heartbeats at the cadence a master asks of its members must make a join, even
    when they span more than T_join; at the normal cadence the T_join rule is unchanged."""
    config = CoreConfig()
    slow = Membership(1, config)
    slow.cadence = 1.6  # a star swarm of 1000 on a 1 Mbit/s channel
    assert slow.join_window == pytest.approx(4 * 1.6)
    out: list[MemberJoined | MemberLeft] = []
    for i in range(3):
        assert 7 not in slow
        slow.heartbeat(7, 0, 1.6 * i, out, seq=i + 1)
        slow.expire(1.6 * i + 1.2, out)  # the candidate sweep, between two heartbeats
    assert 7 in slow and out == [MemberJoined(platform=7, incarnation=0)]
    # One heartbeat of four lost, with a little queueing: still a join.
    lossy = Membership(1, config)
    lossy.cadence = 1.6
    for t in (0.0, 1.6, 4.8 + 0.05):
        assert 8 not in lossy
        lossy.heartbeat(8, 0, t, out, seq=round(t * 10) + 1)
    assert 8 in lossy
    normal = Membership(1, config)
    assert normal.join_window == config.t_join
    for i in range(3):
        normal.heartbeat(7, 0, 0.6 * i, out, seq=i + 1)  # 1.2 s apart in all: too slow
    assert 7 not in normal


def test_a_restarted_member_rejoins_a_master_that_asks_for_a_slow_cadence() -> None:
    """A channel so slow that the master asks its 9 members for one heartbeat every 1.2 s
    (three span 2.4 s, more than T_join): the swarm forms, and a member that restarts joins
    the view again."""
    config = CoreConfig(channel_bitrate=12_000)  # 9 × 800 bits / (0.5 × 12 kbit/s)
    swarm = SimSwarm(10, seed=1, config=config)
    swarm.run_until(8.0)
    master = swarm.node(1)
    assert swarm.current_masters() == [1] and len(master.members) == 9
    assert master.members.cadence == pytest.approx(1.2)
    swarm.restart(10)
    swarm.run_until(20.0)
    rejoined = [
        e.t
        for e in swarm.log
        if e.platform == 1 and e.event == MemberJoined(platform=10, incarnation=1)
    ]
    assert rejoined, "platform 10 came back but never rejoined the master's view"
    assert 10 in master.members


def test_on_a_shared_channel_the_boot_is_counted_and_the_first_claim_paces_everyone() -> None:
    """A swarm of 30 on a 48 kbit/s channel: at 10 Hz its members' heartbeats alone would
    need twice the channel. Every platform broadcasts its first heartbeat (on a shared
    channel a quiet boot would leave the first master ignorant of how many will report),
    so the claim already asks for the cadence of 29 members; and no member heartbeats to
    the master before its report was acknowledged — the report burst first."""
    config = CoreConfig(channel_bitrate=48_000)  # 29 × 800 bits / (0.5 × 48 kbit/s)
    expected = 29 * config.heartbeat_bits / (config.heartbeat_share * 48_000)
    swarm = SimSwarm(30, seed=1, config=config)
    cadence_at_claim: list[float] = []

    def on_event(now: float, node: Node, event: object) -> None:
        if isinstance(event, BecameMaster):
            cadence_at_claim.append(node.members.cadence)

    sent: list[tuple[float, int, int | None, str]] = []

    def tap(now: float, src: int, dst: int | None, kind: str, size: int) -> None:
        sent.append((now, src, dst, kind))

    swarm.listeners.append(on_event)
    swarm.radio.tap = tap
    swarm.run_until(8.0)
    claims = log_of(swarm, 1, BecameMaster)
    assert [e for _, e in claims] == [BecameMaster(epoch=1)]
    claimed_at = claims[0][0]
    broadcasters = {src for t, src, dst, kind in sent if dst is None and t < claimed_at}
    assert broadcasters == set(range(1, 31))
    assert cadence_at_claim == [pytest.approx(expected)]
    for p in range(2, 31):
        acked = min(t for t, src, dst, kind in sent if src == 1 and dst == p and kind == "Ack")
        beats = [t for t, src, dst, kind in sent if src == p and dst == 1 and kind == "Heartbeat"]
        assert beats and beats[0] > acked, f"platform {p} heartbeat before its report's ack"
    assert swarm.formed(30)
    assert swarm.node(30)._live.cadence == pytest.approx(expected)
    assert swarm.finish() == []


def test_on_a_shared_channel_only_successors_probe_a_silent_master() -> None:
    """The master of 30 on a shared channel crashes. Its members suspect it together; the
    successors probe it (they are the ones who would claim), the rest of the swarm does not
    put a probe each on the air ahead of the claim."""
    swarm = formed(30, config=CoreConfig(channel_bitrate=1e6))
    succession = swarm.node(30).roster.succession
    probes: list[int] = []

    def tap(now: float, src: int, dst: int | None, kind: str, size: int) -> None:
        if dst == 1 and kind == "Probe":
            probes.append(src)

    swarm.radio.tap = tap
    swarm.crash(1)
    swarm.run_until(swarm.now + 3.0)
    assert probes and set(probes) <= set(succession), (sorted(set(probes)), succession)
    assert swarm.current_masters() == [succession[0]]
    assert swarm.formed(29)
    assert swarm.finish() == []


def test_on_a_shared_channel_a_member_allows_for_the_queue_before_giving_its_master_up() -> None:
    """A member's master heartbeats queue behind the swarm's bursts on a shared channel: the
    member waits twice the swarm's channel time longer than its usual leave time before it
    declares the master gone (on a slow channel, so that the difference shows)."""
    config = CoreConfig(channel_bitrate=100_000)  # 30 × 800 bits: 0.24 s on the air
    swarm = SimSwarm(30, seed=1, config=config)
    swarm.run_until(8.0)
    assert swarm.current_masters() == [1] and swarm.formed(30)
    member = swarm.node(30)
    patience = 2 * member.reliable.channel_time
    assert patience == pytest.approx(2 * 30 * config.heartbeat_bits / 100_000)
    assert member.grace == pytest.approx(patience)
    assert swarm.node(1).grace == 0.0, "the master watches its members as usual"
    last_heard = member.members.peers[1].last_heard
    silence = member.members.silence()
    swarm.crash(1)
    swarm.run_until(swarm.now + 3.0)
    ((gone_at, _),) = [
        (t, e) for t, e in log_of(swarm, 30, MemberLeft, since=last_heard) if e.platform == 1
    ]
    assert gone_at - last_heard >= silence + patience - 1e-9
    assert gone_at - last_heard <= silence + patience + 2 * INTERVAL
    assert swarm.finish() == []


@pytest.mark.parametrize("membership", ["star", "broadcast"])
def test_a_request_the_master_never_acknowledged_is_restated(membership: MembershipKind) -> None:
    """A barrier request whose every transmission was lost fails at its delivery deadline
    (on a lossy shared channel a few retries span it). The member still follows the master,
    so it reports again, the report restates the request, and the barrier releases —
    before, the request waited unsent until the next master."""
    config = CoreConfig(membership=membership, delivery_deadline=1.0)
    swarm = formed(3, config=config)
    master_rx = swarm.radio._handlers[1]
    cut = True

    def lossy(tx: Transmission[Packet], now: float) -> None:
        if not (cut and tx.src == 3 and tx.kind == "Data"):
            master_rx(tx, now)

    swarm.radio._handlers[1] = lossy
    for p in (1, 2, 3):
        swarm.call(p, lambda n: n.request_barrier(9, NEED_ALL, swarm.now))
    swarm.run_until(swarm.now + 1.5)  # past the deadline: 3's request failed
    assert swarm.node(3).counters["restated"] >= 1
    assert not [e for e in swarm.log if isinstance(e.event, BarrierReleased)]
    cut = False
    swarm.run_until(swarm.now + 1.0)
    passed = {e.platform for e in swarm.log if isinstance(e.event, BarrierReleased)}
    assert passed == {1, 2, 3}
    assert swarm.node(3).counters["restated"] >= 1


def test_on_a_shared_channel_a_master_that_claims_again_holds_its_members() -> None:
    """A healed partition: the other side's master (16) claims a new epoch, platform 1
    claims above it while master. Its own members now report again and hold their
    heartbeats for the acknowledgement, as after any claim; the master holds them for the
    handshake's airtime, as it holds inherited members (at 500 on 1 Mbit/s, without this,
    a re-claim declared 384 live members gone)."""
    config = CoreConfig(channel_bitrate=100_000)
    swarm = SimSwarm(30, seed=1, config=config)
    swarm.run_until(8.0)
    swarm.partition([range(1, 16), range(16, 31)])
    swarm.run_until(16.0)
    assert swarm.current_masters() == [1, 16]
    swarm.heal()
    healed = swarm.now
    swarm.run_until(24.0)
    claims = log_of(swarm, 1, BecameMaster, since=healed)
    assert claims, "platform 1 did not claim again after the heal"
    claimed_at = claims[0][0]
    per_member = HANDSHAKE_SHARE * config.heartbeat_bits / 100_000
    master = swarm.node(1)
    for p in range(2, 16):
        hold = master.members.peers[p].hold_until
        assert claimed_at + 14 * per_member - 1e-9 <= hold <= claimed_at + 29 * per_member, p
    assert swarm.current_masters() == [1] and swarm.formed(30)
    assert swarm.finish() == []


def test_on_a_shared_channel_a_new_master_broadcasts_its_roster_unasked() -> None:
    """After a failover every member's copy of the roster is of the old epoch. On a shared
    channel the new master broadcasts the roster with its first heartbeats instead of
    waiting for 28 requests; a member still behind asks only after about a T_join."""
    swarm = formed(30, config=CoreConfig(channel_bitrate=1e6))
    sent: list[tuple[float, int, int | None, str]] = []

    def tap(now: float, src: int, dst: int | None, kind: str, size: int) -> None:
        sent.append((now, src, dst, kind))

    swarm.radio.tap = tap
    swarm.crash(1)
    crashed = swarm.now
    swarm.run_until(crashed + 3.0)
    (claimed_at, _), *_ = log_of(swarm, 2, BecameMaster, since=crashed)
    chunks = [t for t, src, dst, kind in sent if src == 2 and kind == "RosterChunk"]
    assert chunks and chunks[0] == pytest.approx(claimed_at)
    assert all(dst is None for t, src, dst, kind in sent if kind == "RosterChunk")
    requests = [src for t, src, dst, kind in sent if kind == "RosterRequest"]
    assert len(requests) <= 2, requests
    for p in range(3, 31):
        node = swarm.node(p)
        assert (node.roster.epoch, set(node.roster.members)) == (2, set(range(3, 31)))
    assert swarm.finish() == []


# --- 3. Boot ----------------------------------------------------------------------------


@pytest.mark.parametrize("n", [10, 30])
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_boot_is_quiet_and_elects_platform_one_once(n: int, seed: int) -> None:
    """Everyone broadcasting at boot is what a star avoids: a platform that hears a lower
    ID without a master keeps quiet. Only platforms whose first heartbeat went out before
    they could hear a lower one broadcast (once); the radio's latency is kept short here so
    that this is a handful at any of these sizes."""
    swarm = SimSwarm(n, seed=seed, link=LinkModel(latency=0.002))
    sent: list[tuple[float, int]] = []

    def tap(now: float, src: int, dst: int | None, kind: str, size: int) -> None:
        if dst is None and kind == "Heartbeat":
            sent.append((now, src))

    swarm.radio.tap = tap
    swarm.run_until(FORMED_AT)
    claims = log_of(swarm, 1, BecameMaster)
    assert [e for _, e in claims] == [BecameMaster(epoch=1)]
    assert [(m.platform, m.epoch) for m in swarm.masters] == [(1, 1)]
    claimed_at = claims[0][0]
    before_claim = Counter(src for t, src in sent if t < claimed_at)
    others = {p: k for p, k in before_claim.items() if p != 1}
    assert len(before_claim) <= 6, f"{len(before_claim)} broadcasters: {sorted(before_claim)}"
    assert all(k == 1 for k in others.values()), f"repeat broadcasters: {others}"
    assert swarm.node(1).counters["heartbeat_quiet"] == 0
    for p in range(2, n + 1):
        assert swarm.node(p).counters["heartbeat_quiet"] >= 2, f"platform {p} was not quiet"
    assert swarm.formed(n)
    assert swarm.finish() == []


# --- 4. Failover -------------------------------------------------------------------------


@pytest.mark.parametrize("n", [10, 30])
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_first_successor_takes_over_without_an_election_round(n: int, seed: int) -> None:
    swarm = formed(n, seed=seed)
    succession = swarm.node(n).roster.succession
    assert succession[:2] == [2, 3]
    swarm.crash(1)
    crashed = swarm.now
    swarm.run_until(crashed + 3.0)  # a settle window: no second claim may follow
    claims = [m for m in swarm.masters if m.t > crashed]
    assert [(m.platform, m.epoch) for m in claims] == [(succession[0], 2)]
    took = claims[0].t - crashed
    assert took <= CONFIG.t_leave + CONFIG.probe_window + 0.1, f"claim after {took:.3f} s"
    assert claims[0].handshake_done is not None
    assert claims[0].handshake_done - crashed <= LEAVE + 0.2
    new = swarm.node(succession[0])
    assert new.view == tuple(range(2, n + 1))
    assert new.handshake_complete
    for p, node in swarm.nodes.items():
        assert (node.master, node.epoch) == (succession[0], 2), f"platform {p}"
    assert swarm.finish() == []


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_second_successor_takes_over_when_the_first_died_too(seed: int) -> None:
    """The first successor is presumed alive for a while, so the second one waits that long
    and then claims, alone. The new master admits its predecessor's roster, the dead first
    successor included, and completes its handshake once that one leaves."""
    n = 12
    swarm = formed(n, seed=seed)
    assert swarm.node(n).roster.succession[:3] == [2, 3, 4]
    swarm.crash(1)
    swarm.crash(2)
    crashed = swarm.now
    swarm.run_until(crashed + 4.0)
    claims = [m for m in swarm.masters if m.t > crashed]
    assert [(m.platform, m.epoch) for m in claims] == [(3, 2)]
    took = claims[0].t - crashed
    assert took <= 1.5, f"claim after {took:.3f} s"
    assert claims[0].handshake_done is not None
    assert claims[0].handshake_done - claims[0].t <= LEAVE + 0.05
    assert swarm.node(3).view == tuple(range(3, n + 1))
    for p, node in swarm.nodes.items():
        assert (node.master, node.epoch) == (3, 2), f"platform {p}"
    assert swarm.finish() == []


def _follow_tail(swarm: SimSwarm) -> tuple[float, float]:
    """Crash master 1 of a settled swarm; return how long after the first claim the last
    survivor followed the claimant, and how long its handshake took."""
    followed: dict[int, float] = {}

    def on_event(t: float, node: Node, event: object) -> None:
        if isinstance(event, MasterChanged) and event.master not in (None, 1):
            followed.setdefault(node.platform, t)

    swarm.listeners.append(on_event)
    swarm.crash(1)
    crashed = swarm.now
    swarm.run_until(crashed + 3.0)
    claims = [m for m in swarm.masters if m.t > crashed]
    assert len(claims) == 1 and claims[0].handshake_done is not None, claims
    assert sorted(followed) == list(range(2, len(swarm.nodes) + 2)), "every survivor followed"
    assert swarm.finish() == []
    claim = claims[0]
    return max(followed.values()) - claim.t, claim.handshake_done - claim.t


@pytest.mark.parametrize("seed", [2, 3, 4, 5, 6])
def test_under_loss_a_member_that_suspects_its_master_follows_the_claim_at_once(
    seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """At 30 % loss a member gives its master up only after about nine silent heartbeats
    (its leave time keeps false leaves rare), but suspects it after five. A claim heard
    while it suspects its master confirms the suspicion (rule H5 gives way to H6): it
    follows the claimant at once instead of waiting out its own leave time, so the last of
    40 follows within a few of the new master's heartbeats, and the handshake is as short.
    Without the rule (the control, on the same seed) the last one trails by 0.25–0.45 s."""

    def settled() -> SimSwarm:
        # (At the ordinary heartbeat rate: a fast master, tested below, shortens the wait
        # for everyone alike.)
        config = CoreConfig(fast_master_loss=None)
        swarm = SimSwarm(40, seed=seed, link=LinkModel(loss=0.3), config=config)
        swarm.run_until(5.0)
        assert swarm.current_masters() == [1]
        assert all(len(node.view) == 40 for node in swarm.nodes.values()), "setup: settled"
        return swarm

    tail, handshake = _follow_tail(settled())
    assert tail <= 0.2, f"the last survivor followed {tail:.3f} s after the claim"
    assert handshake <= 0.3, f"handshake {handshake:.3f} s"

    unsuspecting = leadership.on_heartbeat

    def never_suspects(**hearing: Any) -> OnHeartbeat:
        return unsuspecting(**{**hearing, "master_suspected": False})

    monkeypatch.setattr(leadership, "on_heartbeat", never_suspects)
    control, _ = _follow_tail(settled())
    assert control > 0.2, f"control: {control:.3f} s"


def test_under_heavy_loss_the_master_beats_faster_and_a_failover_takes_less() -> None:
    """At 30 % loss the master measures the loss from its members' heartbeats and beats
    twice per interval, saying so in its heartbeats; its members, watching it alone, judge
    its silence in those heartbeats, and its successor claims sooner after a crash (on
    every seed tried; 0.51 s against 0.82 s on average over eight). On a clean radio it
    keeps the ordinary rate."""

    def settled(seed: int, loss: float, fast: float | None) -> SimSwarm:
        config = CoreConfig(fast_master_loss=fast)
        swarm = SimSwarm(30, seed=seed, link=LinkModel(loss=loss), config=config)
        swarm.run_until(4.0)
        assert swarm.current_masters() == [1]
        return swarm

    def master_rate(swarm: SimSwarm) -> float:
        # The count a heartbeat carries numbers the scheduled ones (probes repeat it).
        sent = swarm.node(1)._live.hb_count
        swarm.run_until(swarm.now + 2.0)
        return (swarm.node(1)._live.hb_count - sent) / 2.0

    def claim_after(swarm: SimSwarm) -> float:
        swarm.crash(1)
        crashed = swarm.now
        swarm.run_until(crashed + 3.0)
        claims = [m for m in swarm.masters if m.t > crashed]
        assert len(claims) == 1 and claims[0].handshake_done is not None, claims
        assert swarm.finish() == []
        return claims[0].t - crashed

    assert master_rate(settled(1, 0.0, 0.15)) == pytest.approx(1 / INTERVAL, abs=1)
    fast = settled(1, 0.3, 0.15)
    assert master_rate(fast) == pytest.approx(2 / INTERVAL, rel=0.1), "twice the rate"
    assert fast.node(7).members.cadence == pytest.approx(INTERVAL / 2), "its members know it"
    slow = settled(1, 0.3, None)
    assert master_rate(slow) == pytest.approx(1 / INTERVAL, abs=1)
    assert slow.node(7).members.cadence == INTERVAL
    for seed in (1, 2, 3, 4):
        quick = claim_after(settled(seed, 0.3, 0.15))
        unhurried = claim_after(settled(seed, 0.3, None))
        assert quick <= CONFIG.t_leave + CONFIG.probe_window + 0.05, f"claim after {quick:.3f} s"
        assert quick < unhurried, f"seed {seed}: {quick:.3f} s fast, {unhurried:.3f} s not"


@pytest.mark.parametrize("membership", ["star", "broadcast"])
def test_view_size_is_the_views_length_in_every_state(membership: MembershipKind) -> None:
    swarm = SimSwarm(12, seed=4, config=CoreConfig(membership=membership))
    for until, fault in ((0.2, None), (1.5, 1), (2.3, None), (4.0, 5), (6.0, None)):
        swarm.run_until(until)
        for node in swarm.nodes.values():
            assert node.view_size == len(node.view), (until, node.platform, node.view)
        if fault is not None:
            swarm.crash(fault)


# --- 5. Forged or garbled roster traffic -----------------------------------------------------

MEMBER = 3


def member_of_formed(n: int = 6) -> tuple[SimSwarm, Node]:
    swarm = formed(n)
    node = swarm.node(MEMBER)
    node.ready()
    return swarm, node


@pytest.mark.parametrize(
    ("case", "sender", "epoch_delta", "adopted"),
    [
        ("from a member, not the master", 4, 0, False),
        ("from the master, a later epoch", 1, 1, False),
        ("from the master, an earlier epoch", 1, -1, False),
        ("from the master, this epoch (control)", 1, 0, True),
    ],
)
def test_roster_chunk_only_from_the_master_of_this_epoch(
    case: str, sender: int, epoch_delta: int, adopted: bool
) -> None:
    swarm, node = member_of_formed()
    before = dict(node.roster.members)
    drops = node.counters["drop:roster"]
    chunk = RosterChunk(
        epoch=node.epoch + epoch_delta,
        version=node.roster.version + 1,
        index=0,
        count=1,
        members=[(2, 0), (99, 0)],
    )
    node.receive_packet(packet(chunk, sender=sender), swarm.now)
    if adopted:
        assert node.roster.members == {2: 0, 99: 0}, case
        assert node.counters["drop:roster"] == drops, case
    else:
        assert node.roster.members == before, case
        assert node.counters["drop:roster"] == drops + 1, case
    assert node.errors == []


@pytest.mark.parametrize(
    ("case", "to", "epoch_delta", "answered"),
    [
        ("to a member", MEMBER, 0, False),
        ("to the master, for another epoch", 1, 1, False),
        ("to the master, for its epoch (control)", 1, 0, True),
    ],
)
def test_roster_request_answered_by_the_master_of_that_epoch_only(
    case: str, to: int, epoch_delta: int, answered: bool
) -> None:
    """A member that answered roster requests would spread a copy the master never sent."""
    swarm = formed(6)
    node = swarm.node(to)
    node.ready()
    drops = node.counters["drop:roster"]
    request = RosterRequest(epoch=node.epoch + epoch_delta, version=0)
    node.receive_packet(packet(request, sender=4), swarm.now)
    out: list[Outgoing] = node.ready().packets
    until = swarm.now + 2 * INTERVAL  # the master serves requests with its next heartbeat
    while (deadline := node.next_deadline()) is not None and deadline <= until:
        node.tick(deadline)
        out += node.ready().packets
    chunks = [(dst, b) for dst, b in bodies(out) if isinstance(b, RosterChunk)]
    if answered:
        assert node.counters["drop:roster"] == drops, case
        assert chunks, case
        assert all(dst == 4 for dst, _ in chunks), case
        assert {p for _, c in chunks for p, _ in c.members} == {2, 3, 4, 5, 6}, case
    else:
        assert node.counters["drop:roster"] == drops + 1, case
        assert chunks == [], case


@pytest.mark.parametrize(
    ("case", "changes", "size_delta", "consistent"),
    [
        ("a join the count does not show", [(99, 0)], 0, False),
        ("a leave the count does not show", [(4, -1)], 0, False),
        ("a join and a count that add up (control)", [(99, 0)], 1, True),
    ],
)
def test_master_heartbeat_whose_changes_do_not_add_up(
    case: str, changes: list[tuple[int, int]], size_delta: int, consistent: bool
) -> None:
    """The member counts it and asks its master for the whole roster again."""
    swarm, node = member_of_formed()
    drops = node.counters["drop:roster"]
    requests = node.counters["roster_request"]
    hb = master_heartbeat(
        epoch=node.epoch,
        roster=node.roster.version + 1,
        size=len(node.roster.members) + size_delta,
        changes=changes,
        succession=[2, 3, 4, 5],
    )
    node.receive_packet(packet(hb, sender=1), swarm.now)
    sent = bodies(node.ready().packets)
    asked = [(dst, b) for dst, b in sent if isinstance(b, RosterRequest)]
    if consistent:
        assert 99 in node.roster.members, case
        assert node.counters["drop:roster"] == drops, case
        assert asked == [], case
    else:
        assert node.counters["drop:roster"] == drops + 1, case
        assert node.counters["roster_request"] == requests + 1, case
        assert asked == [(1, RosterRequest(epoch=node.epoch, version=0))], case
        assert not node.roster.current, case
    assert node.errors == []


@pytest.mark.parametrize("prober", [1, 4], ids=["master", "another-member"])
def test_a_platform_named_as_suspect_answers_the_prober_directly(prober: int) -> None:
    """The answer goes to whoever suspects this platform, not to its usual destination, and
    repeated naming within half a probe interval is answered once."""
    swarm, node = member_of_formed()
    answered = node.counters["probe_answered"]
    hb = Heartbeat(is_master=prober == 1, epoch=node.epoch, master=1, suspects=[7, MEMBER], count=0)
    node.receive_packet(packet(hb, sender=prober, seq=10**6), swarm.now)
    node.receive_packet(packet(hb, sender=prober, seq=10**6 + 1), swarm.now + 0.001)
    out = node.ready().packets
    heartbeats = [(dst, b) for dst, b in bodies(out) if isinstance(b, Heartbeat)]
    assert node.counters["probe_answered"] == answered + 1
    assert [dst for dst, _ in heartbeats] == [prober]
    # Labelled a probe, so that a transport never holds it back as a routine heartbeat.
    assert [o.kind for o in out if o.dst == prober] == [PROBE]


# --- 6. Suspicion, probes, false leaves -------------------------------------------------------


def test_silent_member_is_suspected_named_probed_then_leaves(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Suspicion comes first (after t_leave), the master names the suspect in its heartbeats
    and probes it directly, and it leaves only probe_window later. A probe window longer
    than a heartbeat interval makes sure a broadcast heartbeat falls inside it."""
    config = CoreConfig(probe_window=0.15)
    swarm = formed(8, config=config)
    master = swarm.node(1)
    sent = record_sent(monkeypatch, swarm, 1)
    quiet = 5
    swarm.crash(quiet)
    crashed = swarm.now
    first_seen_suspect: float | None = None
    while swarm.now < crashed + 1.5:
        swarm.run_until(swarm.now + 0.005)
        if first_seen_suspect is None and quiet in master.members.suspects:
            first_seen_suspect = swarm.now
    probes = [
        s.t
        for s in sent
        if s.dst == quiet and isinstance(s.body, Heartbeat) and s.body.suspects == [quiet]
    ]
    left = [t for t, e in log_of(swarm, 1, MemberLeft, crashed) if e.platform == quiet]
    assert probes and len(left) == 1
    suspected_at, left_at = probes[0], left[0]
    assert first_seen_suspect is not None and suspected_at <= first_seen_suspect < left_at
    assert CONFIG.t_leave - INTERVAL <= suspected_at - crashed <= CONFIG.t_leave + 0.02
    assert left_at - suspected_at == pytest.approx(config.probe_window, abs=1e-6)
    assert master.counters["suspected"] == 1
    broadcasts = [(s.t, s.body) for s in sent if s.dst is None and isinstance(s.body, Heartbeat)]
    named = [t for t, hb in broadcasts if quiet in hb.suspects]
    assert named, "no broadcast heartbeat named the suspect"
    assert all(suspected_at <= t < left_at for t in named)
    assert all(quiet in hb.suspects for t, hb in broadcasts if suspected_at <= t < left_at), (
        "every heartbeat of the window names the suspect"
    )
    assert quiet not in master.members.suspects and quiet not in master.members


def test_suspected_member_that_answers_stays_in_the_view() -> None:
    """Cut only the member's way to the master until the master suspects it: the master's
    direct probe reaches the member, whose answer (once the way is open) clears it."""
    swarm = formed(10)
    master = swarm.node(1)
    p = 8
    cut = cut_link(swarm, p, 1)
    start = swarm.now
    while p not in master.members.suspects:
        assert swarm.now < start + 1.0, "never suspected"
        swarm.run_until(swarm.now + 0.002)
    cut.open = False
    swarm.run_until(start + 2.0)
    assert swarm.node(p).counters["probe_answered"] >= 1
    assert master.counters["suspected"] == 1
    assert log_of(swarm, 1, MemberLeft, start) == []
    assert p in master.members and not master.members.suspects
    assert swarm.finish() == []


@pytest.mark.parametrize("cut", ["partition", "one-way"])
def test_false_leave_in_the_same_epoch_does_not_hold_the_master_back(cut: str) -> None:
    """A member the master declared gone and that comes back in its epoch knows nothing the
    master does not: the master must keep deciding. Its own barrier, asked the moment the
    member rejoins its view, fires at once (it would wait for the member's report if the
    rejoin restarted the handshake).

    ``partition``: the member loses the master too, follows it again and reports before its
    heartbeats rejoin it. ``one-way``: only the member's way to the master is cut; it still
    follows, and rejoins as a member of this epoch (counter ``rejoined``)."""
    swarm = formed(10)
    p = 8
    master = swarm.node(1)
    joined: list[float] = []
    released: list[float] = []

    def on_event(t: float, node: Node, event: object) -> None:
        if node.platform != 1:
            return
        if isinstance(event, MemberJoined) and event.platform == p and not joined:
            joined.append(t)
            node.request_barrier(77, 1, t)
        elif isinstance(event, BarrierReleased) and event.key == 77:
            released.append(t)

    swarm.listeners.append(on_event)
    start = swarm.now
    if cut == "partition":
        swarm.partition([[p]])
        swarm.run_until(start + 0.7)
        swarm.heal()
    else:
        link = cut_link(swarm, p, 1)
        swarm.run_until(start + 0.7)
        link.open = False
    swarm.run_until(start + 2.0)
    left = [e for _, e in log_of(swarm, 1, MemberLeft, start)]
    assert left == [MemberLeft(platform=p, incarnation=0, reason="timeout")]
    assert joined, "the member never rejoined the master's view"
    assert released == joined, "the master held its barrier back"
    assert master.handshake_complete
    assert master.counters["handshake_incomplete"] == 0
    assert log_of(swarm, 1, HandshakeComplete, start) == []
    refollowed = [e for _, e in log_of(swarm, p, MasterChanged, start)]
    if cut == "one-way":
        assert master.counters["rejoined"] == 1
        assert refollowed == [], "the member kept following the master"
    else:
        assert refollowed == [MasterChanged(master=None, epoch=1), MasterChanged(master=1, epoch=1)]
    assert swarm.node(p).master == 1 and p in master.members
    assert swarm.finish() == []


# --- 7. Local health ------------------------------------------------------------------------

PEER = 7
WATCHER = 9


class LonelyNode:
    """One node (broadcast membership) watching one peer, ticked by hand."""

    def __init__(self) -> None:
        self.node = Node(
            WATCHER, swarm=SIM_SWARM, config=CoreConfig(membership="broadcast"), now=0.0
        )
        self._count = 0
        self.last_heard = 0.0

    def heartbeat(self, now: float) -> None:
        self._count += 1
        hb = Heartbeat(is_master=False, epoch=0, master=0, count=self._count)
        self.node.receive_packet(packet(hb, sender=PEER, seq=self._count), now)
        self.last_heard = now

    def tick_punctually(self, until: float) -> list[float]:
        """Tick at every deadline up to ``until``; the grace after each tick."""
        graces = []
        while (deadline := self.node.next_deadline()) is not None and deadline <= until:
            self.node.tick(deadline)
            self.node.ready()
            graces.append(self.node.grace)
        return graces

    def starve(self) -> None:
        """The host wakes 1 s after the node's deadline; the peer's heartbeat waiting in the
        socket is read before the timers run."""
        deadline = self.node.next_deadline()
        assert deadline is not None
        late = deadline + 1.0
        self.heartbeat(late)
        self.node.tick(late)
        self.node.ready()


def lonely_node_watching_a_peer() -> LonelyNode:
    lonely = LonelyNode()
    t = 0.0
    while t <= 1.0:
        lonely.tick_punctually(t)
        lonely.heartbeat(t)
        t = round(t + INTERVAL, 9)
    assert PEER in lonely.node.members, "setup: the peer joined"
    assert lonely.node.grace == 0
    return lonely


@pytest.mark.parametrize(
    ("late_ticks", "grace", "leaves_after"),
    [
        (0, 0.0, LEAVE),
        (1, 0.1, LEAVE + 0.1),
        (3, 0.3, LEAVE + 0.3),
        # Capped at 8 intervals; one second after the last late tick an interval of grace
        # is given back, before the peer's 0.56 + 0.8 s are up.
        (12, 0.8, LEAVE + 0.7),
    ],
    ids=["punctual", "one-late", "three-late", "twelve-late"],
)
def test_late_ticks_widen_the_leave_time(
    late_ticks: int, grace: float, leaves_after: float
) -> None:
    """A host that was not listening must not blame its peers: each late tick adds a
    heartbeat interval of grace (at most 8), and a peer silent for less than its leave time
    plus the grace of the moment stays."""
    lonely = lonely_node_watching_a_peer()
    for _ in range(late_ticks):
        lonely.starve()
    node = lonely.node
    assert node.grace == pytest.approx(grace)
    assert node.counters["late_tick"] == min(late_ticks, 8)
    heard = lonely.last_heard
    lonely.tick_punctually(heard + leaves_after - 0.01)
    node.tick(heard + leaves_after - 0.01)
    assert PEER in node.members, f"gone after {leaves_after - 0.01:.2f} s of silence"
    lonely.tick_punctually(heard + leaves_after + 0.01)
    assert PEER not in node.members, f"still there after {leaves_after + 0.01:.2f} s"
    assert node.counters["late_tick"] == min(late_ticks, 8), "punctual ticks counted late"


def test_punctual_ticks_bring_the_grace_back_to_zero() -> None:
    lonely = lonely_node_watching_a_peer()
    for _ in range(3):
        lonely.starve()
    assert lonely.node.grace == pytest.approx(0.3)
    start = lonely.last_heard
    graces: list[float] = []
    # One interval of grace back per second of punctual ticks, not all of it at once.
    for after, grace in [(0.9, 0.3), (1.5, 0.2), (2.5, 0.1), (3.5, 0.0), (6.0, 0.0)]:
        graces += lonely.tick_punctually(start + after)
        assert lonely.node.grace == pytest.approx(grace), f"{after} s after the last late tick"
    assert all(a >= b for a, b in pairwise(graces)), "the grace grew while ticking on time"
    assert lonely.node.counters["late_tick"] == 3


# --- 8. Loss-aware leave time ---------------------------------------------------------------

FLOOR = CONFIG.t_leave + CONFIG.probe_window
RATE = CONFIG.false_leave_rate


def reference_silence(n: int, h: float, p: float, rate: float, floor: float) -> float:
    """The docstring's rule, solved by hand: n·h·(1-p)·p^(h·T-½) = rate, at least floor."""
    if p <= 0:
        return floor
    beats = 0.5 + math.log(n * h * (1 - p) / rate) / math.log(1 / p)
    return max(floor, beats / h)


@pytest.mark.parametrize(
    ("watched", "loss", "stated"),
    [
        (1, 0.3, 0.89),  # a member watching its master at 30 % loss
        (999, 0.3, 1.47),  # a master watching 999 members at 30 % loss
        (1, 0.1, 0.56),  # the floor: t_leave + probe_window
        (999, 0.1, 0.79),  # the formula gives 0.801 s: within 2 % of the stated value
    ],
)
def test_leave_silence_matches_the_stated_values(watched: int, loss: float, stated: float) -> None:
    got = leave_silence(watched=watched, interval=INTERVAL, loss=loss, rate=RATE, floor=FLOOR)
    assert got == pytest.approx(stated, rel=0.05)
    assert got == pytest.approx(reference_silence(watched, 1 / INTERVAL, loss, RATE, FLOOR))


@pytest.mark.parametrize("watched", [1, 10, 999, 10_000])
def test_leave_silence_is_the_floor_without_loss(watched: int) -> None:
    """On a clean radio failover must stay t_leave + probe_window flat in N."""
    got = leave_silence(watched=watched, interval=INTERVAL, loss=0.0, rate=RATE, floor=FLOOR)
    assert got == FLOOR


@pytest.mark.parametrize("loss", [0.2, 0.3, 0.5])
def test_leave_silence_grows_by_a_fixed_number_of_heartbeats_per_tenfold_view(loss: float) -> None:
    """ln 10 / ln(1/p) heartbeats more per tenfold growth of the watched view."""
    sizes = [10, 100, 1000, 10_000]
    times = [
        leave_silence(watched=n, interval=INTERVAL, loss=loss, rate=RATE, floor=FLOOR)
        for n in sizes
    ]
    assert all(t > FLOOR for t in times)
    step = INTERVAL * math.log(10) / math.log(1 / loss)
    for smaller, larger in pairwise(times):
        assert larger - smaller == pytest.approx(step, rel=1e-9)


# --- 9. Both modes --------------------------------------------------------------------------


@pytest.mark.parametrize("membership", ["star", "broadcast"])
def test_both_modes_elect_one_master_and_pass_a_barrier_of_everyone(
    membership: MembershipKind,
) -> None:
    n = 8
    config = CoreConfig(membership=membership)
    swarm = formed(n, config=config)
    assert [(m.platform, m.epoch) for m in swarm.masters] == [(1, 1)]
    for p in list(swarm.nodes):
        swarm.call(p, lambda node: node.request_barrier(5, NEED_ALL, swarm.now))
    swarm.run_until(FORMED_AT + 1.0)
    passed = {
        e.platform: e.event.index
        for e in swarm.log
        if isinstance(e.event, BarrierReleased) and e.event.key == 5
    }
    assert sorted(passed) == list(range(1, n + 1))
    assert sorted(passed.values()) == list(range(1, n + 1))
    assert swarm.current_masters() == [1]
    assert swarm.finish() == []
