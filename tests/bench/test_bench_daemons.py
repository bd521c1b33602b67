"""``bench daemons`` on a small swarm of real daemon processes: the measurements run end to
end and their results are well formed. No timing is asserted beyond generous plausibility
bounds: the machine running the tests is shared and its load varies."""

from __future__ import annotations

import asyncio
import json
import math
import os
import time
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from actorswarm.bench.daemons import (
    Settings,
    bench,
    daemons_env,
    from_json,
    markdown,
    read_cpu_ns,
    read_cpu_seconds,
    read_interface_packets,
    read_memory_kib,
    read_sleeps,
    same_processes,
    switch_cpu,
    switch_script,
    to_json,
)
from actorswarm.cli.app import app
from actorswarm.dsl import check_file


def test_proc_readers_see_this_process() -> None:
    rss, anon = read_memory_kib(os.getpid())
    assert 0 < anon <= rss
    assert read_cpu_seconds(os.getpid()) > 0
    first = read_cpu_ns(os.getpid())
    # The kernel updates a running thread's schedstat at its scheduler events (a tick, a
    # switch), not at every read: burn CPU until one has happened, within a bound.
    deadline = time.monotonic() + 5.0
    later = first
    while later == first and time.monotonic() < deadline:
        sum(range(200_000))
        later = read_cpu_ns(os.getpid())
    assert later > first > 0
    slept = read_sleeps(os.getpid())
    time.sleep(0.01)  # the main thread sleeps: one voluntary context switch at least
    assert read_sleeps(os.getpid()) > slept


def test_a_switch_costs_what_the_swarm_used_beyond_its_idle_rate() -> None:
    # Idle: 10 ms of CPU per second. Then 80 ms over the 0.5 s of the switch: 75 ms of it
    # was the switch.
    idle, before, after = (1_000_000_000, 10.0), (1_010_000_000, 11.0), (1_090_000_000, 11.5)
    assert math.isclose(switch_cpu(idle, before, after), 0.075)
    # Less than idle (a daemon slept through): negative, not hidden.
    assert switch_cpu(idle, before, (1_012_000_000, 11.5)) < 0
    with pytest.raises(ValueError, match="out of order"):
        switch_cpu(before, idle, after)


def test_a_switch_counts_only_the_daemons_that_ran_through_it() -> None:
    """A daemon restarted mid-switch (a new process near zero) or gone is left out of all
    three reads; counted, it made the cost negative (-1.4 s once, at 50 daemons)."""
    idle = {10: 5_000_000_000, 11: 1_000_000_000, 12: 2_000_000_000}
    before = {10: 5_010_000_000, 11: 1_010_000_000, 12: 2_010_000_000}
    after = {10: 5_050_000_000, 11: 1_050_000_000, 13: 3_000_000}  # 12 gone, 13 is new
    assert same_processes(idle, before, after) == [6_000_000_000, 6_020_000_000, 6_100_000_000]
    assert same_processes() == []
    c0, c1, c2 = same_processes(idle, before, after)
    assert switch_cpu((c0, 10.0), (c1, 11.0), (c2, 11.5)) > 0


def test_the_command_refuses_a_swarm_of_one_before_starting_anything() -> None:
    result = CliRunner().invoke(app, ["bench", "daemons", "--sizes", "1,5"])
    assert result.exit_code == 2
    assert "--sizes" in result.output


def test_interface_counters_are_read_from_proc_net_dev(tmp_path: Path) -> None:
    dev = tmp_path / "dev"
    dev.write_text(
        "Inter-|   Receive                                                |  Transmit\n"
        " face |bytes    packets errs drop fifo frame compressed multicast|bytes    packets\n"
        "    lo: 123456     789    0    0    0     0          0         0   123456     789\n"
        "  eth0: 5 6 0 0 0 0 0 0 7 8\n"
    )
    assert read_interface_packets("lo", dev) == 789
    assert read_interface_packets("eth0", dev) == 6
    assert read_interface_packets("wlan0", dev) == -1
    assert read_interface_packets() > 0  # this namespace's loopback


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--broadcast", "radio"], "--broadcast 'radio': mesh or multicast"),
        (["--broadcast", "multicast", "--group", "10.0.0.1:7448"], "not a multicast address"),
        (["--broadcast", "multicast", "--interface", "l o"], "interface 'l o'"),
    ],
)
def test_the_command_refuses_a_bad_broadcast_before_starting_anything(
    args: list[str], message: str
) -> None:
    result = CliRunner().invoke(app, ["bench", "daemons", "--sizes", "2", *args])
    assert result.exit_code == 2
    assert message in result.output


def test_daemons_from_another_checkout_run_its_source(tmp_path: Path) -> None:
    """``--daemons-from`` puts a checkout's ``src`` first on the daemons' path, and a
    directory without actorswarm's source is refused before anything starts."""
    checkout = Path(__file__).resolve().parents[2]
    env = daemons_env(checkout)
    assert env["PYTHONPATH"] == str(checkout / "src")
    assert env["PATH"] == os.environ["PATH"], "the rest of the environment is kept"
    with pytest.raises(ValueError, match="no actorswarm source"):
        daemons_env(tmp_path)
    result = CliRunner().invoke(
        app, ["bench", "daemons", "--sizes", "2", "--daemons-from", str(tmp_path)]
    )
    assert result.exit_code == 2
    assert "no actorswarm source" in result.output


def test_the_switch_script_is_valid(tmp_path: Path) -> None:
    path = tmp_path / "switch.xml"
    path.write_text(switch_script(30))
    result = check_file(path)
    assert result.ok, [str(d) for d in result.diagnostics]


def test_three_daemons_are_measured_end_to_end(tmp_path: Path) -> None:
    settings = Settings(
        window=1.0, failovers=1, switches=2, settle=0.5, boot_timeout=60.0, run_timeout=10.0
    )
    result = bench(tmp_path, [3], settings, command="test")
    (size,) = result.sizes
    assert size.size == 3
    assert size.errors == []
    assert 0 < size.boot_s < 60

    assert [r.phase for r in size.resources] == ["idle", "script"]
    for res in size.resources:
        assert res.platforms == [1, 2, 3]
        # Each view as the daemon wrote it at the end of the window: normally both peers,
        # but a daemon starved of CPU by a loaded machine may have dropped one for a moment.
        assert len(res.peers) == 3 and all(0 <= n <= 2 for n in res.peers), res.peers
        assert res.window_s >= 1.0
        assert all(v >= 0 for v in res.cpu_pct)
        # A Python process with Zenoh: more than a few MiB, less than a few GiB.
        assert all(4 < v < 4096 for v in res.rss_mib)
        assert all(0 < a <= r for a, r in zip(res.rss_anon_mib, res.rss_mib, strict=True))
        assert res.wire_packets_s > 0  # heartbeats at least, on this namespace's loopback
        # The master is reported apart from the members (their targets differ).
        assert res.master in {1, 2, 3}
        assert len(res.cpu_of("master")) == 1 and len(res.cpu_of("members")) == 2
        assert sorted(res.cpu_of("master") + res.cpu_of("members")) == sorted(res.cpu_pct)
        # Heartbeats alone wake every daemon's loop several times a second.
        assert len(res.sleeps_s) == 3 and all(s > 1 for s in res.sleeps_s), res.sleeps_s
        assert len(res.sleeps_of("master")) == 1 and len(res.sleeps_of("members")) == 2

    (failover,) = size.failover
    assert failover.error == ""
    assert failover.survivors == failover.followed == 2
    assert failover.new_master in {1, 2, 3} - {failover.killed}
    assert 0 < failover.to_claim_s <= failover.to_all_s < 10.0

    assert [(w.src, w.dst) for w in size.switch] == [("A", "B"), ("B", "A")]
    for w in size.switch:
        assert w.error == ""
        assert w.switched == w.expected == 3
        assert 0 < w.first_s <= w.last_s < 10.0
        assert math.isclose(w.spread_s, w.last_s - w.first_s, abs_tol=1e-9)
        assert sum(w.causes.values()) == 3
        assert math.isfinite(w.cpu_s), "the swarm's CPU is measured for every switch done"

    text = markdown(result)
    assert "Command: `test`" in text
    assert "## Against docs/design.md §8" in text
    assert "None: every run completed." in text
    assert "| swarm CPU, ms (per platform) |" in text
    assert "| CPU per member, idle, N=3" in text and "| CPU of the master, idle, N=3" in text
    data = json.loads(json.dumps(to_json(result), allow_nan=False))
    assert data["machine"]["cpus"] >= 1
    assert data["sizes"][0]["failover"][0]["killed"] == failover.killed
    assert markdown(from_json(data)) == text, "a saved run renders the same"


def test_a_short_window_waits_for_each_daemons_newer_counters(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Daemons rewrite their counters every 10 s when only those move: a window shorter
    than that ended before some had, and their rate was NaN. Now it waits for them."""
    from actorswarm.bench.daemons import measure
    from actorswarm.bench.daemons.measure import _sent_rate

    class Swarm:
        def __init__(self) -> None:
            self.reads = 0

        def status(self, p: int) -> dict[str, Any]:
            self.reads += 1
            # Platform 2's counters move only from the sixth read on.
            late = p == 2 and self.reads < 6
            t, sent = (100.0, 500) if late else (110.0, 600 + 100 * p)
            return {"t": t, "traffic": {"sent_packets": sent}}

    swarm = Swarm()
    start = {1: (100.0, 500), 2: (100.0, 500)}
    rate = asyncio.run(_sent_rate(swarm, start, poll=0.001))  # type: ignore[arg-type]
    assert rate == (200 + 300) / 10.0 and swarm.reads >= 6
    # One that never writes newer counters: NaN after waiting, not a partial sum.
    monkeypatch.setattr(measure, "COUNTERS_EVERY", 0.05)
    never = {1: (100.0, 500), 2: (110.0, 800)}
    assert math.isnan(asyncio.run(_sent_rate(swarm, never, poll=0.01)))  # type: ignore[arg-type]
