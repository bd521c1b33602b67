"""Benchmark of the collective core in virtual time (docs/design.md §8).

For each swarm size it boots a simulated swarm, waits until the membership and the master's
handshake are settled, then measures, over several seeded repetitions:

* **barrier latency**: every platform requests one barrier (requests spread over 50 ms);
  the time from the *last request* to the *last release*; with no loss and with 5 % loss;
* **traffic during the barrier**: packets sent+received per second at the master and at an
  average non-master over the barrier window (first request to last release), heartbeats
  included, and the barrier's own packets (requests, acknowledgements, releases) at the master;
* **failover**: the master crashes at a random heartbeat phase; the time until a new master
  has been acknowledged by every survivor (its handshake completed), and until it claimed.

Virtual-time figures depend only on the protocol and the radio model, not on the machine;
the wall-clock time each size took is reported too (that one depends on the machine).
"""

from __future__ import annotations

import random
import statistics
import time
from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass, field
from typing import Any

from actorswarm.bench.tables import summarize
from actorswarm.core.config import CoreConfig
from actorswarm.core.events import BarrierReleased
from actorswarm.core.wire import NEED_ALL
from actorswarm.sim.radio import LinkModel
from actorswarm.sim.swarm import SimSwarm

BARRIER_KINDS = ("Data", "Ack", "Release", "ReleaseAck")
#: How often a failover run looks whether the new master is acknowledged (virtual seconds).
ACK_POLL = 0.005


@dataclass(slots=True)
class BarrierRun:
    latency: float  # last request -> last release (s)
    window: float  # first request -> last release (s)
    master_pps: float
    member_pps: float
    master_barrier_packets: int
    released: int
    expected: int


@dataclass(slots=True)
class FailoverRun:
    to_claim: float  # crash -> a survivor claims (s)
    #: crash -> a new master with every survivor in its view, each of them reported (s)
    to_acknowledged: float
    new_master: int


@dataclass(slots=True)
class SizeResult:
    size: int
    repeats: int
    barrier: list[BarrierRun] = field(default_factory=list)
    barrier_lossy: list[BarrierRun] = field(default_factory=list)
    failover: list[FailoverRun] = field(default_factory=list)
    wall_s: float = 0.0
    violations: list[str] = field(default_factory=list)


def _stable_swarm(size: int, seed: int, link: LinkModel, config: CoreConfig) -> SimSwarm:
    swarm = SimSwarm(size, seed=seed, config=config, link=link, log_membership=False)
    # Boot: the startup wait, then joins (M heartbeats), the claim and the handshake; poll
    # until one master has everyone in its view and its handshake is done.
    swarm.run_until(config.startup_wait)
    deadline = config.startup_wait + 10.0
    while swarm.now < deadline:
        swarm.run_until(swarm.now + 0.05)
        if swarm.formed(size):
            break
    else:
        raise RuntimeError(f"a swarm of {size} (seed {seed}) did not settle in 10 s")
    # Then until every platform has everyone in its view (a star member: its master's whole
    # roster, which comes after the handshake; a successor that took over without it would
    # wait for the reports of the few members it knew of, and the rest would join later).
    deadline = swarm.now + 10.0
    while not all(node.view_size == size for node in swarm.nodes.values()):
        if swarm.now >= deadline:
            raise RuntimeError(f"a swarm of {size} (seed {seed}): views incomplete after 10 s")
        swarm.run_until(swarm.now + 0.05)
    swarm.run_until(swarm.now + 2 * config.heartbeat_interval)
    return swarm


def _totals(swarm: SimSwarm, platform: int, kinds: Iterable[str] | None = None) -> int:
    traffic = swarm.radio.traffic
    if kinds is None:
        sent, _, recv, _ = traffic.totals(platform)
        return sent + recv
    snap = traffic.snapshot().get(platform, {}).get("by_kind", {})
    return sum(
        snap.get(k, {}).get("sent_packets", 0) + snap.get(k, {}).get("recv_packets", 0)
        for k in kinds
    )


def run_barrier(
    size: int, seed: int, link: LinkModel, config: CoreConfig
) -> tuple[BarrierRun, list[str]]:
    """One barrier of every platform of a settled swarm."""
    swarm = _stable_swarm(size, seed, link, config)
    masters = swarm.current_masters()
    master = masters[0] if masters else 1
    rng = random.Random(f"bench:{seed}")
    start = swarm.now + 0.05
    times = {p: start + rng.uniform(0.0, 0.05) for p in swarm.nodes}
    released: dict[int, float] = {}

    def on_event(t: float, node: Any, event: Any) -> None:
        if isinstance(event, BarrierReleased) and event.key == 7:
            released.setdefault(node.platform, t)

    swarm.listeners.append(on_event)
    for p, t in times.items():
        swarm.at(t, lambda p=p: swarm.call(p, lambda n: n.request_barrier(7, NEED_ALL, swarm.now)))
    swarm.run_until(start)
    before_all = {p: _totals(swarm, p) for p in swarm.nodes}
    before_barrier = _totals(swarm, master, BARRIER_KINDS)
    # Run until everyone passed (or a generous limit), in small steps.
    limit = start + 10.0
    while len(released) < size and swarm.now < limit:
        swarm.run_until(swarm.now + 0.01)
    last_release = max(released.values()) if released else float("nan")
    swarm.run_until(max(swarm.now, last_release) + 0.1)  # let acknowledgements land
    window = max(last_release - min(times.values()), 1e-9)
    after_all = {p: _totals(swarm, p) for p in swarm.nodes}
    # Rates over the window: packets counted until the acks landed, spread over the window
    # plus the tail we ran, to stay conservative.
    span = window + (swarm.now - last_release)
    deltas = {p: after_all[p] - before_all[p] for p in swarm.nodes}
    others = [d for p, d in deltas.items() if p != master]
    run = BarrierRun(
        latency=last_release - max(times.values()),
        window=window,
        master_pps=deltas[master] / span,
        member_pps=(statistics.fmean(others) / span) if others else 0.0,
        master_barrier_packets=_totals(swarm, master, BARRIER_KINDS) - before_barrier,
        released=len(released),
        expected=size,
    )
    return run, swarm.finish()


def acknowledged_master(swarm: SimSwarm, since: float, epoch: int) -> int | None:
    """A master that claimed after ``since`` in an epoch above ``epoch`` and is acknowledged
    by every live platform: all of them in its view, each reported in its handshake (which
    ``HandshakeComplete`` alone does not say: a member that joins its view after the first
    round is waited for too). None while there is none."""
    for rec in reversed(swarm.masters):
        if rec.t < since:
            break
        node = swarm.nodes.get(rec.platform)
        if (
            node is not None
            and node.is_master
            and node.epoch > epoch
            and node.handshake_complete
            and not node.reports_awaited
            and node.view_size == len(swarm.nodes)
        ):
            return rec.platform
    return None


def run_failover(
    size: int, seed: int, link: LinkModel, config: CoreConfig
) -> tuple[FailoverRun, list[str]]:
    """Crash the master of a settled swarm at a random phase; time the new master."""
    swarm = _stable_swarm(size, seed, link, config)
    old = swarm.current_masters()[0]
    old_epoch = swarm.node(old).epoch
    rng = random.Random(f"failover:{seed}")
    crash_at = swarm.now + rng.uniform(0.0, config.heartbeat_interval)
    claimed: list[tuple[float, int]] = []
    acked: list[tuple[float, int]] = []
    swarm.at(crash_at, swarm.crash, old)
    swarm.run_until(crash_at)
    limit = crash_at + 10 * config.t_leave
    while not acked and swarm.now < limit:
        # Polled (5 ms of virtual time: the figure is late by up to that): the last report
        # of a member that joined the new master's view after its first round of the
        # handshake shows in no event.
        swarm.run_until(swarm.now + ACK_POLL)
        new = acknowledged_master(swarm, crash_at, old_epoch)
        if new is not None:
            acked.append((swarm.now, new))
    for rec in swarm.masters:
        if rec.t >= crash_at and rec.epoch > old_epoch:
            claimed.append((rec.t, rec.platform))
            break
    swarm.run_until(swarm.now + 0.2)
    nan = float("nan")
    run = FailoverRun(
        to_claim=(claimed[0][0] - crash_at) if claimed else nan,
        to_acknowledged=(acked[0][0] - crash_at) if acked else nan,
        new_master=acked[0][1] if acked else -1,
    )
    return run, swarm.finish()


def bench_size(
    size: int,
    *,
    repeats: int,
    latency: float = 0.01,
    loss: float = 0.05,
    config: CoreConfig | None = None,
    progress: Callable[[str], None] | None = None,
) -> SizeResult:
    config = config or CoreConfig()
    result = SizeResult(size=size, repeats=repeats)
    t0 = time.perf_counter()
    clean = LinkModel(latency=latency)
    lossy = LinkModel(latency=latency, loss=loss)
    for r in range(repeats):
        seed = 1000 * size + r
        if progress:
            progress(f"N={size} repeat {r + 1}/{repeats}: barrier")
        run, v = run_barrier(size, seed, clean, config)
        result.barrier.append(run)
        result.violations += v
        if progress:
            progress(f"N={size} repeat {r + 1}/{repeats}: barrier, {loss:.0%} loss")
        run, v = run_barrier(size, seed, lossy, config)
        result.barrier_lossy.append(run)
        result.violations += v
        if progress:
            progress(f"N={size} repeat {r + 1}/{repeats}: failover")
        frun, v = run_failover(size, seed, clean, config)
        result.failover.append(frun)
        result.violations += v
    result.wall_s = time.perf_counter() - t0
    return result


def _fmt_ms(values: list[float]) -> str:
    s = summarize(values)
    return f"{s.median * 1000:.1f} ({s.lo * 1000:.1f}–{s.hi * 1000:.1f})"


def _fmt(values: list[float], digits: int = 0) -> str:
    s = summarize(values)
    return f"{s.median:.{digits}f} ({s.lo:.{digits}f}–{s.hi:.{digits}f})"


def markdown(results: list[SizeResult], *, latency: float, loss: float, config: CoreConfig) -> str:
    """The report: one row per size, medians with (min–max) over the repetitions."""
    target_barrier = 3 * latency + 0.005
    target_failover = config.t_leave + 0.1
    lines = [
        f"Radio: one-way latency {latency * 1000:.0f} ms, no jitter; lossy runs drop "
        f"{loss:.0%} of packets independently. "
        f"Heartbeat {config.heartbeat_interval * 1000:.0f} ms, "
        f"T_leave {config.t_leave * 1000:.0f} ms, retransmission "
        + (
            "after a measured RTT timeout"
            if config.adaptive_retry
            else f"{config.retry_base * 1000:.0f} ms"
        )
        + f" + k·{config.retry_step * 1000:.0f} ms (cap {config.retry_cap * 1000:.0f} ms).",
        "",
        "Targets (docs/design.md §8): "
        f"barrier ≤ 3 × latency + 5 ms = {target_barrier * 1000:.0f} ms; "
        f"failover ≤ T_leave + 100 ms = {target_failover * 1000:.0f} ms, flat in N; "
        "master traffic linear in N.",
        "",
        "| N | runs | barrier latency, ms | with "
        f"{loss:.0%} loss, ms | master pkt/s | non-master pkt/s | master barrier pkts "
        "| barrier pkts / N | failover: claim, ms | failover: all acked, ms | wall s |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in results:
        per_n = [b.master_barrier_packets / r.size for b in r.barrier]
        lines.append(
            f"| {r.size} | {r.repeats} | {_fmt_ms([b.latency for b in r.barrier])} "
            f"| {_fmt_ms([b.latency for b in r.barrier_lossy])} "
            f"| {_fmt([b.master_pps for b in r.barrier])} "
            f"| {_fmt([b.member_pps for b in r.barrier])} "
            f"| {_fmt([float(b.master_barrier_packets) for b in r.barrier])} "
            f"| {_fmt(per_n, 2)} "
            f"| {_fmt_ms([f.to_claim for f in r.failover])} "
            f"| {_fmt_ms([f.to_acknowledged for f in r.failover])} "
            f"| {r.wall_s:.1f} |"
        )
    lines.append("")
    verdicts = []
    for r in results:
        med = summarize([b.latency for b in r.barrier]).median
        lmed = summarize([b.latency for b in r.barrier_lossy]).median
        fhi = summarize([f.to_acknowledged for f in r.failover]).hi
        verdicts.append(
            f"- N={r.size}: barrier {'meets' if med <= target_barrier else 'MISSES'} the target "
            f"({med * 1000:.1f} ms); with loss {'meets' if lmed <= target_barrier else 'misses'} "
            f"it in the median ({lmed * 1000:.1f} ms); failover "
            f"{'meets' if fhi <= target_failover else 'MISSES'} the target at its worst "
            f"({fhi * 1000:.0f} ms); invariant violations: {len(r.violations)}"
        )
    lines += verdicts
    return "\n".join(lines) + "\n"


def to_json(results: list[SizeResult]) -> list[dict[str, Any]]:
    return [asdict(r) for r in results]


def from_json(rows: list[dict[str, Any]]) -> list[SizeResult]:
    """Results back from :func:`to_json` (to redraw a saved run)."""
    out = []
    for row in rows:
        out.append(
            SizeResult(
                size=row["size"],
                repeats=row["repeats"],
                barrier=[BarrierRun(**b) for b in row["barrier"]],
                barrier_lossy=[BarrierRun(**b) for b in row["barrier_lossy"]],
                failover=[FailoverRun(**f) for f in row["failover"]],
                wall_s=row["wall_s"],
                violations=list(row["violations"]),
            )
        )
    return out
