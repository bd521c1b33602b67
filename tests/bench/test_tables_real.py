"""Tables I–III with real daemons: the instrumentation they read (traffic counters in the host
loop, the engine's records of commands and releases, the runtime's switch timings, the
plugin that keeps two actors alternating) and a small end-to-end run of each table. Timings
are not asserted: the machine running the tests is shared."""

from __future__ import annotations

import asyncio
import itertools
import json
import math
from collections.abc import Callable, Coroutine
from pathlib import Path
from typing import Any

import pytest

from actorswarm.bench.alternate import EMIT_ON_ENTRY, EmitOnEntry
from actorswarm.bench.scripts import table1_script, table2_script
from actorswarm.bench.tables import Table1Row, Table2Row, Table3Row, TableSettings, table1_units
from actorswarm.bench.tables_real import DaemonBackend, real_table1, real_table23, table23_units
from actorswarm.core.events import AppReceived
from actorswarm.core.node import Outgoing, Ready
from actorswarm.core.wire import GROUND_STATION, Heartbeat, Packet, encode
from actorswarm.daemon.endpoint import PlatformEndpoint
from actorswarm.daemon.loop import Inbox, Traffic, serve
from actorswarm.dsl import check
from actorswarm.engine import commands as cmds
from actorswarm.engine.runtime import ActorContext
from actorswarm.runtime.actor_runtime import ActorRuntime
from actorswarm.runtime.events import Emitted
from actorswarm.testing import check_plugin, make_context, run_plugin

#: The ``run_async`` fixture (tests/conftest.py): asyncio.run in a thread of its own.
RunAsync = Callable[[Coroutine[Any, Any, Any]], Any]

# --- the scripts and the alternating plugin ------------------------------------------------


@pytest.mark.parametrize("plugins", [1, 5])
def test_the_scripts_are_valid(plugins: int) -> None:
    for text in (table1_script(31, plugins), table2_script(30, plugins)):
        result = check(text, path="bench.xml")
        assert result.ok, [str(d) for d in result.diagnostics]
        assert result.script is not None
        for actor in result.script.actors:
            assert len(list(actor.plugins())) == plugins, actor.name


def test_emit_on_entry_keeps_the_plugin_contract() -> None:
    check_plugin(EmitOnEntry, params={"event": "go", "after": "0.3"})


def test_emit_on_entry_emits_again_after_every_activation() -> None:
    """What ``core.emit_after`` does not: an actor switched back to emits again."""
    ctx = make_context(EmitOnEntry, params={"event": "go", "after": "1"}, now=0.0)
    plugin = EmitOnEntry()
    plugin._drive_start(ctx)
    assert run_plugin(plugin, ctx, steps=8, dt=0.25) == [Emitted(event="go", actor="test")]
    plugin._drive_pause(ctx)
    ctx.now = 50.0
    plugin._drive_activate(ctx)
    assert plugin._drive_next_deadline() == 51.0
    assert run_plugin(plugin, ctx, steps=8, dt=0.25) == [Emitted(event="go", actor="test")]


def test_the_alternating_script_alternates_in_the_runtime() -> None:
    result = check(table1_script(1, 2), path="t1.xml")
    assert result.script is not None
    assert EMIT_ON_ENTRY in table1_script(1, 2)
    rt = ActorRuntime(1)
    rt.use_script(result.script)
    rt.start("A2", 0.0, ActorContext())
    emitted = []
    now = 0.0
    for _ in range(4):  # what the engine does on each event: switch to the other actor
        while not (out := rt.step(now)):
            now = rt.next_deadline() or now + 0.1
        emitted += [e.event for e in out]
        (actor,) = rt.running()
        rt.switch(actor, "B2" if actor == "A2" else "A2", now, ActorContext())
    assert emitted == ["to_b", "to_a", "to_b", "to_a"]


# --- the runtime's switch timings -----------------------------------------------------------


def _runtime() -> ActorRuntime:
    result = check(table2_script(2, 3), path="t2.xml")
    assert result.script is not None
    rt = ActorRuntime(1)
    rt.use_script(result.script)
    return rt


def test_a_switch_is_timed_once_at_the_end_of_the_new_actors_first_step() -> None:
    rt = _runtime()
    rt.start("A3", 0.0, ActorContext())
    rt.step(0.0)
    assert rt.drain_switches() == [], "a start is not a switch"
    rt.switch("A3", "B3", 1.0, ActorContext())
    assert list(rt.switch_timings) == [], "not stepped yet"
    rt.step(1.0)
    rt.step(1.5)
    (timing,) = rt.drain_switches()
    assert (timing.t, timing.src, timing.dst) == (1.0, "A3", "B3")
    assert 0.0 < timing.seconds < 5.0
    assert rt.drain_switches() == []
    rt.switch("B3", "A3", 2.0, ActorContext())  # warm: A3 was sleeping
    rt.step(2.0)
    (seconds,) = rt.drain_switch_times()
    assert seconds > 0.0


def test_a_switch_whose_actor_never_steps_leaves_no_timing() -> None:
    rt = _runtime()
    rt.start("A3", 0.0, ActorContext())
    rt.switch("A3", "B3", 1.0, ActorContext())
    rt.pause("B3", 1.0)
    rt.activate("B3", 2.0)
    rt.step(2.0)
    rt.switch("B3", "C3", 3.0, ActorContext())
    rt.stop("C3", 3.0)
    rt.start("C3", 4.0, ActorContext())
    rt.step(4.0)
    assert rt.drain_switches() == []


# --- the engine's records -------------------------------------------------------------------


def _command(endpoint: PlatformEndpoint, command: cmds.Command, now: float) -> None:
    body = cmds.encode(command)
    event = AppReceived(sender=GROUND_STATION, topic=cmds.TOPIC_COMMAND, body=body)
    endpoint.engine.on_core_event(event, now)


def test_the_engine_records_each_command_it_carries_out() -> None:
    endpoint = PlatformEndpoint(1, swarm="s", incarnation=0, now=0.0)
    engine = endpoint.engine
    _command(endpoint, cmds.Inject(event="go"), 5.0)
    _command(endpoint, cmds.Start(sha256="0" * 64), 6.0)  # never deployed: refused
    got = [(c.t, c.command, c.event, c.ok) for c in engine.commands]
    assert got == [(5.0, "Inject", "go", True), (6.0, "Start", "", False)]


def test_the_master_records_each_transition_group_it_releases() -> None:
    """A platform alone is its own master: the barrier of ``go`` fires at once. (Driven as
    a host does: its ``ready()`` taken after every tick, when the engine reacts.)"""
    endpoint = PlatformEndpoint(1, swarm="s", incarnation=0, now=0.0)
    now = 0.0
    while not endpoint.node.is_master and now < 10.0:
        now += 0.05
        endpoint.tick(now)
        endpoint.ready()
    assert endpoint.node.is_master
    engine = endpoint.engine
    sha = engine.adopt(table2_script(2, 1).encode())
    engine.rejoin(sha, now)
    _command(endpoint, cmds.Inject(event="go"), now)
    endpoint.tick(now)
    endpoint.ready()
    assert [(r.src, r.dst, r.event) for r in engine.transitions[-1:]] == [("A1", "B1", "go")]
    (fired,) = engine.fired
    assert (fired.t, fired.key, fired.outcome, fired.chosen) == (now, 1, "complete", (1,))
    assert [(c.command, c.event) for c in engine.commands] == [("Inject", "go")]


# --- the host loop's traffic counters -------------------------------------------------------


def _packet(sender: int, seq: int) -> bytes:
    return encode(
        swarm="t", sender=sender, incarnation=1, seq=seq,
        body=Heartbeat(is_master=False, epoch=0, master=0),
    )  # fmt: skip


class _Echo:
    """An endpoint that answers every packet it accepts with a broadcast of its own."""

    def __init__(self) -> None:
        self._out: list[Outgoing] = []
        self.seen: list[int] = []

    def receive_packet(self, packet: Packet, now: float) -> None:
        self.seen.append(packet.seq)
        answer = _packet(1, len(self.seen))
        self._out.append(Outgoing(dst=None, data=answer, kind="test", channel=0))

    def tick(self, now: float) -> None:
        pass

    def next_deadline(self) -> float | None:
        return None

    def ready(self) -> Ready:
        out, self._out = self._out, []
        return Ready(out)


class _Wire:
    def __init__(self) -> None:
        self.sent: list[bytes] = []

    def send(self, dst: int | None, data: bytes, *, urgent: bool = False, kind: str = "") -> None:
        self.sent.append(data)


def test_the_loop_counts_packets_and_bytes_both_ways(run_async: RunAsync) -> None:
    """Every packet the transport delivered counts as received (a refused one too), every
    packet handed to the transport as sent, in bytes as they travel."""
    traffic = Traffic()
    wire = _Wire()
    endpoint = _Echo()
    seen: list[tuple[tuple[int, int, int, int], tuple[int, int, int, int]]] = []
    batches = [[_packet(5, 1), b"not a packet"], [_packet(5, 2)]]
    received = [data for batch in batches for data in batch]

    async def main() -> None:
        inbox = Inbox(asyncio.get_running_loop())
        stop = asyncio.Event()

        def on_wake(now: float) -> None:
            seen.append((traffic.at_wake, traffic.counters()))
            if batches:
                for data in batches.pop(0):
                    inbox.put(data)
            elif traffic.recv_packets == 3:
                stop.set()

        await asyncio.wait_for(
            serve(endpoint, wire, inbox, stop, on_wake=on_wake, traffic=traffic), 5.0
        )

    run_async(main())
    assert endpoint.seen == [1, 2], "the garbage was refused before the endpoint"
    assert wire.sent == [_packet(1, 1), _packet(1, 2)]
    sent_bytes = sum(map(len, wire.sent))
    recv_bytes = sum(map(len, received))
    assert traffic.counters() == (2, sent_bytes, 3, recv_bytes)
    assert traffic.as_dict() == {
        "sent_packets": 2,
        "sent_bytes": sent_bytes,
        "recv_packets": 3,
        "recv_bytes": recv_bytes,
    }
    # Each wake's snapshot is what the counters were when it began.
    for (_, before), (at_wake, _) in itertools.pairwise(seen):
        assert at_wake == before


# --- end to end -----------------------------------------------------------------------------


class _Recorder:
    def __init__(self) -> None:
        self.messages: list[str] = []
        self.units = 0

    def __call__(self, message: str, *, advance: int = 0) -> None:
        self.messages.append(message)
        self.units += advance


# Windows of 1.5 s: each holds a switch of the 1 Hz alternation, whatever its phase.
SMALL = DaemonBackend(
    TableSettings(repeat=2, peers=2, window=1.5), boot_timeout=90.0, run_timeout=15.0, settle=0.5
)


def _finite(values: list[float]) -> bool:
    return all(math.isfinite(v) for v in values)


def test_table1_with_three_daemons(tmp_path: Path) -> None:
    progress = _Recorder()
    rows = real_table1(tmp_path, [1, 5], SMALL, progress)
    assert progress.units == table1_units([1, 5], SMALL.settings) == 4
    assert [(r.mode, r.plugins, r.peers) for r in rows] == [("real", 1, 2), ("real", 5, 2)]
    for row in rows:
        assert isinstance(row, Table1Row)
        assert row.errors == [], row.errors
        assert len(row.cpu_pct) == len(row.rss_mib) == 2
        assert _finite(row.cpu_pct) and all(v >= 0 for v in row.cpu_pct)
        assert all(4 < v < 4096 for v in row.rss_mib)
        assert len(row.switch_ms) >= 2 and all(0 < v < 1000 for v in row.switch_ms)
    status = json.loads((tmp_path / "table1" / "state-2" / "status.json").read_text())
    assert set(status["traffic"]) == {"sent_packets", "sent_bytes", "recv_packets", "recv_bytes"}
    assert status["traffic"]["recv_packets"] > 0 and status["traffic"]["sent_bytes"] > 0


def test_tables_2_and_3_with_three_daemons(tmp_path: Path) -> None:
    progress = _Recorder()
    tables = frozenset({"2", "3"})
    table2, table3 = real_table23(tmp_path, [3], [1], SMALL, tables, progress)
    assert progress.units == table23_units([3], [1], SMALL, tables) == 6
    assert [(r.mode, r.case, r.size, r.plugins) for r in table2] == [
        ("real", "switch", 3, 1),
        ("real", "branch", 3, 1),
    ]
    for row in table2:
        assert isinstance(row, Table2Row)
        assert row.errors == [], row.errors
        samples = [
            row.transition_ms,
            row.master_pps,
            row.member_pps,
            row.bytes_per_packet,
            row.master_packets,
            row.member_packets,
        ]
        assert all(len(values) == 2 and _finite(values) for values in samples), samples
        assert all(0 < v < 15_000 for v in row.transition_ms)
        assert all(v > 0 for v in row.master_pps + row.member_pps)
        assert all(v >= 1 for v in row.master_packets + row.member_packets)
        # Sealed packets: a header and an HMAC at least, less than a full datagram.
        assert all(40 < v < 65_536 for v in row.bytes_per_packet)
    (row3,) = table3
    assert isinstance(row3, Table3Row)
    assert (row3.mode, row3.size) == ("real", 3)
    assert row3.errors == [], row3.errors
    assert len(row3.election_ms) == 2 and _finite(row3.election_ms)
    assert all(0 < v < 15_000 for v in row3.election_ms)
    lines = [
        json.loads(line)
        for line in (tmp_path / "n3" / "daemon-1.log").read_text().splitlines()
        if line.startswith("{")
    ]
    kinds = {line["event"] for line in lines}
    assert {"command", "transition", "switched"} <= kinds
    for line in lines:
        if line["event"] in ("command", "transition", "fired"):
            assert len(line["traffic"]) == 4 and all(isinstance(v, int) for v in line["traffic"])
