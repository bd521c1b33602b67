"""``actorswarm bench scale``: what the size of a swarm costs, in each membership scheme.

Each cell — a membership scheme (``CoreConfig.membership``), a swarm size N and a loss rate —
is one run of one scenario on a fresh simulated swarm, in virtual time, over a radio with a
10 ms one-way latency, no jitter and independent loss per packet and receiver:

* t = 0: N platforms boot (``SimSwarm(N, config=CoreConfig(membership=M), ...)``);
* ``quiet_from`` → ``barrier_at`` (2 → 4 s): the quiet steady state, over which traffic and
  false leaves are taken;
* ``barrier_at`` (4 s): every platform requests one barrier of the whole swarm
  (``NEED_ALL``);
* ``crash_at`` (6 s): the master crashes;
* ``end`` (8 s): the run stops.

Figures of a cell (:class:`ScaleCell`): the wall time of the whole run (booting included);
when the swarm formed (one master, every other platform in its view, its handshake done);
how many platforms the barrier released; the failover time (the crash → the first new
master whose handshake completed, from ``SimSwarm.masters``); over the quiet window, the
packets received per second by the median non-master and by the master, the packets and
bits per second sent on the air (a broadcast counts once: the radio counts a transmission
at its sender), and the master's false leaves — ``MemberLeft`` of a platform that was alive —
per member-hour (members watched × window).

Virtual-time figures depend on the protocol and the radio model only, and a cell is
replayed exactly from its seed (the same seed in either scheme, so two rows of one size
differ by the scheme alone). The wall time depends on the machine. A cell that has used
``max_wall`` seconds of wall time is abandoned ("over budget"): what it measured until then
is kept, with the virtual time it reached.
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from actorswarm.bench.tables import strict_json
from actorswarm.core.config import CoreConfig, MembershipKind
from actorswarm.core.events import (
    BarrierReleased,
    CoreEvent,
    HandshakeComplete,
    MemberJoined,
    MemberLeft,
)
from actorswarm.core.node import Node
from actorswarm.core.wire import NEED_ALL
from actorswarm.sim.radio import LinkModel
from actorswarm.sim.swarm import SimSwarm

__all__ = [
    "MAX_SIZE",
    "SCHEMES",
    "ScaleCell",
    "ScaleReport",
    "Scenario",
    "cell_json",
    "cell_seed",
    "markdown",
    "plot_scale",
    "problems",
    "run_cell",
    "run_scale",
    "to_json",
]

NAN = math.nan
#: The largest swarm the benchmark accepts (the project's headline scale target is 1000;
#: 10 000 is for the star scheme, whose per-platform work does not grow with N).
MAX_SIZE = 10_000
#: The barrier every platform requests.
KEY = 1
#: Virtual seconds between two looks at the wall clock inside a slice (see :func:`run_cell`).
_WATCHDOG = 0.001
#: What each membership scheme is, for the report.
SCHEMES = {
    "star": "members heartbeat to the master only, the master broadcasts",
    "broadcast": "every platform heartbeats to every other (the paper's scheme)",
}


@dataclass(frozen=True, slots=True)
class Scenario:
    """When things happen (virtual seconds) and how a cell is bounded.

    Contract: ``0 < quiet_from < barrier_at < crash_at < end``; ``latency``, ``slice`` and
    ``max_wall`` are positive (``ValueError`` otherwise). ``slice`` is the virtual time run
    between two progress reports; ``max_wall`` the wall-clock seconds a cell may use.
    """

    quiet_from: float = 2.0
    barrier_at: float = 4.0
    crash_at: float = 6.0
    end: float = 8.0
    latency: float = 0.01
    slice: float = 0.1
    max_wall: float = 600.0

    def __post_init__(self) -> None:
        times = (self.quiet_from, self.barrier_at, self.crash_at, self.end)
        if not all(math.isfinite(t) for t in times) or not (
            0 < self.quiet_from < self.barrier_at < self.crash_at < self.end
        ):
            raise ValueError(
                "the scenario needs 0 < quiet window start < barrier < crash < end, got "
                + ", ".join(f"{t:g}" for t in times)
            )
        for name in ("latency", "slice", "max_wall"):
            value = getattr(self, name)
            if not math.isfinite(value) or value <= 0:
                raise ValueError(f"{name}: must be a positive number, got {value!r}")

    @property
    def window(self) -> float:
        """Length of the quiet window, seconds."""
        return self.barrier_at - self.quiet_from


def cell_seed(seed: int, size: int, loss: float) -> int:
    """The seed of one cell: the run's seed, the size and the loss; not the scheme."""
    return seed * 1_000_003 + size * 101 + round(loss * 1000)


@dataclass(slots=True)
class ScaleCell:
    """One run of the scenario. Times in seconds unless the name says otherwise; NaN (null
    in JSON) where a figure was not measured — the run did not get there, or what it needs
    did not happen (say, no single master in the quiet window)."""

    membership: str
    size: int
    loss: float
    seed: int
    #: Wall-clock seconds of the whole run, booting the swarm included.
    wall_s: float = NAN
    #: The virtual time the run reached: the scenario's end, unless it went over budget.
    reached_s: float = 0.0
    over_budget: bool = False
    #: Virtual time the swarm first formed (NaN: not before the crash).
    formed_at_s: float = NAN
    #: The master at the end of the quiet window (-1: not exactly one).
    master: int = -1
    #: Platforms that requested the barrier, and those it released (chosen).
    expected: int = 0
    released: int = 0
    #: The barrier requested → the last platform released (NaN unless every one was).
    release_ms: float = NAN
    #: The master that crashed, the first new master whose handshake completed, and the
    #: time from the crash to that completion.
    old_master: int = -1
    new_master: int = -1
    failover_ms: float = NAN
    #: The quiet window's length and traffic (packets per second; kbit/s of sent bytes).
    window_s: float = NAN
    member_recv_pps: float = NAN  # median over the non-masters
    member_recv_pps_min: float = NAN
    member_recv_pps_max: float = NAN
    member_sent_pps: float = NAN  # median over the non-masters
    master_recv_pps: float = NAN
    master_sent_pps: float = NAN
    air_pps: float = NAN  # every platform's transmissions (a broadcast once)
    air_kbps: float = NAN
    #: The quiet window: the master's ``MemberLeft`` of live platforms, the member-hours it
    #: watched (members × window), their ratio, and the platforms that joined it again.
    false_leaves: int = 0
    member_hours: float = NAN
    false_leaves_per_member_hour: float = NAN
    window_joins: int = 0
    #: The whole run: any master's ``MemberLeft`` of a platform that had not crashed.
    run_false_leaves: int = 0
    #: Invariant violations found at the end of the run (-1: not checked, over budget).
    violations: int = -1
    errors: list[str] = field(default_factory=list)

    @property
    def all_released(self) -> bool:
        """The barrier released every platform that requested it."""
        return self.expected > 0 and self.released == self.expected

    @property
    def sim_per_wall(self) -> float:
        """Virtual seconds simulated per wall-clock second."""
        return self.reached_s / self.wall_s if self.wall_s > 0 else NAN

    @property
    def label(self) -> str:
        return f"{self.membership} N={self.size} loss={self.loss:.0%}"


@dataclass(slots=True)
class ScaleReport:
    """One run of ``actorswarm bench scale``: its cells in the order they were measured."""

    command: str
    started: str  # UTC, ISO 8601
    machine: dict[str, Any]
    scenario: Scenario
    cells: list[ScaleCell] = field(default_factory=list)
    wall_s: float = 0.0
    #: Empty for a finished run; otherwise why the cells stop where they do.
    cut_short: str = ""


class _OverBudget(Exception):
    """Raised from inside the scheduler when a cell has used its wall-clock budget."""


class _Watch:
    """The scenario's bookkeeping on one running swarm: a listener for the core's events and
    the callbacks the scenario schedules. Everything it keeps is read by :func:`run_cell`."""

    def __init__(self, swarm: SimSwarm, cell: ScaleCell, scenario: Scenario) -> None:
        self.swarm = swarm
        self.cell = cell
        self.scenario = scenario
        self.released: dict[int, float] = {}
        self.not_chosen: set[int] = set()
        self.crashed: set[int] = set()
        self.crash_epoch = -1
        self.before: dict[int, dict[str, Any]] = {}
        self.after: dict[int, dict[str, Any]] = {}
        self.masters_before: list[int] = []
        self.masters_after: list[int] = []
        self.alive_after: list[int] = []

    def on_event(self, now: float, node: Node, event: CoreEvent) -> None:
        """A listener (``SimSwarm.listeners``): called for every event of every platform,
        so it does as little as it can for the events it does not count."""
        cell, scenario = self.cell, self.scenario
        quiet = scenario.quiet_from <= now < scenario.barrier_at
        if isinstance(event, BarrierReleased):
            if event.key == KEY:
                if event.chosen:
                    self.released.setdefault(node.platform, now)
                else:
                    self.not_chosen.add(node.platform)
        elif isinstance(event, MemberLeft):
            # The only platform that dies is the crashed master: any other leave is false.
            if node.is_master and event.platform not in self.crashed:
                cell.run_false_leaves += 1
                if quiet:
                    cell.false_leaves += 1
        elif isinstance(event, MemberJoined | HandshakeComplete):
            if quiet and node.is_master and isinstance(event, MemberJoined):
                cell.window_joins += 1
            if (
                math.isnan(cell.formed_at_s)
                and node.is_master
                and node.handshake_complete
                and len(node.members) == cell.size - 1
                and not self.crashed
                and self.swarm.formed(cell.size)  # O(N): only when it may be so
            ):
                cell.formed_at_s = now

    def window_start(self) -> None:
        self.before = self.swarm.radio.traffic.snapshot()
        self.masters_before = self.swarm.current_masters()

    def window_end(self) -> None:
        self.after = self.swarm.radio.traffic.snapshot()
        self.masters_after = self.swarm.current_masters()
        self.alive_after = sorted(self.swarm.nodes)

    def request_barrier(self) -> None:
        swarm = self.swarm
        self.cell.expected = len(swarm.nodes)
        for p in sorted(swarm.nodes):
            swarm.call(p, lambda n: n.request_barrier(KEY, NEED_ALL, swarm.now))

    def crash_master(self) -> None:
        masters = self.swarm.current_masters()
        if len(masters) != 1:
            self.cell.errors.append(f"{len(masters)} masters at the crash: {masters[:10]}")
        if not masters:
            return
        old = masters[0]
        self.crash_epoch = self.swarm.node(old).epoch
        self.cell.old_master = old
        self.crashed.add(old)
        self.swarm.crash(old)


def run_cell(
    membership: MembershipKind,
    size: int,
    loss: float,
    *,
    seed: int,
    scenario: Scenario | None = None,
    progress: Callable[[str], None] | None = None,
) -> ScaleCell:
    """Run the scenario once on a fresh swarm of ``size`` platforms; the figures.

    ``progress`` is called after every slice of virtual time with a line of text. The wall
    clock is checked between slices and, within a slice, every millisecond of virtual time
    (a 0.1 s slice of a broadcast swarm of 10 000 is about 10⁷ deliveries: minutes of wall
    time); past ``scenario.max_wall`` the cell stops where it is and says so.
    """
    scenario = scenario or Scenario()
    if size < 2:
        raise ValueError(f"a swarm of {size}: at least 2 platforms (a master and a member)")
    if not 0.0 <= loss < 1.0:
        raise ValueError(f"loss must be in [0, 1), got {loss!r}")
    cell = ScaleCell(membership=membership, size=size, loss=loss, seed=seed)
    began = time.perf_counter()
    deadline = began + scenario.max_wall
    swarm = SimSwarm(
        size,
        seed=seed,
        config=CoreConfig(membership=membership),
        link=LinkModel(latency=scenario.latency, loss=loss),
        log_membership=False,
    )
    watch = _Watch(swarm, cell, scenario)
    swarm.listeners.append(watch.on_event)
    # Same virtual time, scheduled in this order, run in this order: the window's traffic
    # is taken before the barrier's first packet.
    swarm.at(scenario.quiet_from, watch.window_start)
    swarm.at(scenario.barrier_at, watch.window_end)
    swarm.at(scenario.barrier_at, watch.request_barrier)
    swarm.at(scenario.crash_at, watch.crash_master)

    def watchdog() -> None:
        if time.perf_counter() > deadline:
            raise _OverBudget
        swarm.at(swarm.now + _WATCHDOG, watchdog)

    swarm.at(_WATCHDOG, watchdog)
    try:
        while swarm.now < scenario.end:
            swarm.run_until(min(swarm.now + scenario.slice, scenario.end))
            # A formation no event of the master shows (a rival master stepped down).
            unformed = math.isnan(cell.formed_at_s) and swarm.now < scenario.crash_at
            if unformed and swarm.formed(size):
                cell.formed_at_s = swarm.now
            if progress is not None:
                wall = time.perf_counter() - began
                progress(
                    f"{cell.label}: t = {swarm.now:.1f} of {scenario.end:g} s, {wall:.0f} s wall"
                )
            if time.perf_counter() > deadline:
                raise _OverBudget
    except _OverBudget:
        cell.over_budget = True
    cell.reached_s = swarm.now
    cell.wall_s = time.perf_counter() - began
    _figures(cell, watch, swarm, scenario)
    return cell


def _figures(cell: ScaleCell, watch: _Watch, swarm: SimSwarm, scenario: Scenario) -> None:
    """Fill ``cell`` from what ``watch`` saw, and say what did not work."""
    reached = cell.reached_s
    if cell.over_budget:
        cell.errors.append(
            f"over budget: abandoned at t = {reached:.2f} s of virtual time after "
            f"{cell.wall_s:.1f} s of wall time"
        )
    formed = cell.formed_at_s
    if reached >= scenario.barrier_at:
        if math.isnan(formed) or formed > scenario.barrier_at:
            cell.errors.append(
                f"the swarm had not formed by the barrier ({scenario.barrier_at:g} s)"
            )
        elif formed > scenario.quiet_from:
            cell.errors.append(
                f"formed at {formed:.2f} s, after the quiet window began at "
                f"{scenario.quiet_from:g} s: its traffic includes the formation"
            )
    if watch.alive_after:  # the quiet window's end was reached
        _traffic(cell, watch, scenario)
    if cell.expected:
        cell.released = len(watch.released)
        if cell.all_released:
            cell.release_ms = (max(watch.released.values()) - scenario.barrier_at) * 1000
        elif not cell.over_budget:
            missing = sorted(set(watch.alive_after) - set(watch.released))
            cell.errors.append(
                f"the barrier released {cell.released} of {cell.expected} platforms "
                f"(not released: {missing[:10]}{' ...' if len(missing) > 10 else ''})"
            )
        if watch.not_chosen:
            cell.errors.append(f"not chosen by a barrier of all: {sorted(watch.not_chosen)[:10]}")
    if cell.old_master >= 0:
        done = [
            rec
            for rec in swarm.masters
            if rec.t >= scenario.crash_at
            and rec.platform != cell.old_master
            and rec.epoch > watch.crash_epoch
            and rec.handshake_done is not None
        ]
        if done:
            first = min(done, key=lambda rec: rec.handshake_done or math.inf)
            cell.new_master = first.platform
            cell.failover_ms = ((first.handshake_done or NAN) - scenario.crash_at) * 1000
        elif not cell.over_budget:
            cell.errors.append(f"no new master had completed its handshake by t = {reached:g} s")
    if not cell.over_budget:
        violations = swarm.finish()
        cell.violations = len(violations)
        cell.errors += [f"invariant violated: {v}" for v in violations[:5]]


def _traffic(cell: ScaleCell, watch: _Watch, scenario: Scenario) -> None:
    """The quiet window's figures, from the two snapshots of the radio's counters."""
    before, after = watch.before, watch.after
    span = scenario.window
    cell.window_s = span

    def moved(platform: int, counter: str) -> int:
        now = after.get(platform, {}).get(counter, 0)
        return int(now) - int(before.get(platform, {}).get(counter, 0))

    masters = watch.masters_after
    if len(masters) != 1:
        cell.errors.append(f"{len(masters)} masters at the end of the quiet window: {masters[:10]}")
    elif watch.masters_before != masters:
        cell.errors.append(
            f"the master changed during the quiet window: {watch.masters_before[:10]} → {masters}"
        )
    if len(masters) == 1:
        cell.master = masters[0]
        cell.master_recv_pps = moved(cell.master, "recv_packets") / span
        cell.master_sent_pps = moved(cell.master, "sent_packets") / span
    members = [p for p in watch.alive_after if p not in masters]
    if members:
        received = [moved(p, "recv_packets") / span for p in members]
        cell.member_recv_pps = statistics.median(received)
        cell.member_recv_pps_min = min(received)
        cell.member_recv_pps_max = max(received)
        cell.member_sent_pps = statistics.median(moved(p, "sent_packets") / span for p in members)
    cell.air_pps = sum(moved(p, "sent_packets") for p in after) / span
    cell.air_kbps = sum(moved(p, "sent_bytes") for p in after) * 8 / 1000 / span
    # The master watches every other platform: N - 1 members over the window.
    cell.member_hours = (len(watch.alive_after) - 1) * span / 3600
    if cell.member_hours > 0:
        cell.false_leaves_per_member_hour = cell.false_leaves / cell.member_hours


def run_scale(
    memberships: Sequence[MembershipKind],
    sizes: Sequence[int],
    losses: Sequence[float],
    *,
    seed: int,
    scenario: Scenario,
    command: str,
    progress: Callable[[str], None] | None = None,
    done: Callable[[ScaleReport, ScaleCell], None] | None = None,
) -> ScaleReport:
    """Every cell — losses outermost, then sizes, then schemes, so both schemes of one size
    are measured one after the other — into one :class:`ScaleReport`. ``done`` is called
    with the report so far after every cell (to print it, to save it)."""
    from actorswarm.bench.daemons import machine_info

    report = ScaleReport(
        command=command,
        started=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        machine=machine_info(),
        scenario=scenario,
    )
    began = time.perf_counter()
    for loss in losses:
        for size in sizes:
            for membership in memberships:
                cell = run_cell(
                    membership,
                    size,
                    loss,
                    seed=cell_seed(seed, size, loss),
                    scenario=scenario,
                    progress=progress,
                )
                report.cells.append(cell)
                report.wall_s = time.perf_counter() - began
                if done is not None:
                    done(report, cell)
    report.wall_s = time.perf_counter() - began
    return report


# --- JSON ----------------------------------------------------------------------------------


def cell_json(cell: ScaleCell) -> dict[str, Any]:
    """One cell as strict JSON: every field, and the derived ``all_released`` and
    ``sim_s_per_wall_s``."""
    data: dict[str, Any] = strict_json(asdict(cell))
    data["all_released"] = cell.all_released
    data["sim_s_per_wall_s"] = strict_json(cell.sim_per_wall)
    return data


def to_json(report: ScaleReport) -> dict[str, Any]:
    """The report as strict JSON (NaN written as null)."""
    return {
        "command": report.command,
        "started": report.started,
        "machine": strict_json(report.machine),
        "scenario": asdict(report.scenario),
        "protocol": _protocol(),
        "wall_s": report.wall_s,
        "cut_short": report.cut_short,
        "cells": [cell_json(c) for c in report.cells],
    }


def _protocol() -> dict[str, Any]:
    """The core's timings every cell ran with (its defaults; only the scheme varies)."""
    config = CoreConfig()
    return {
        "heartbeat_ms": config.heartbeat_interval * 1000,
        "t_leave_ms": config.t_leave * 1000,
        "t_join_ms": config.t_join * 1000,
        "join_heartbeats": config.join_heartbeats,
        "false_leave_rate_per_s": config.false_leave_rate,
    }


# --- Markdown ------------------------------------------------------------------------------


def _num(value: float, digits: int = 0) -> str:
    return "—" if math.isnan(value) else f"{value:,.{digits}f}"


def _rate(value: float) -> str:
    """A rate with the digits that matter: 3 significant ones below 100, none above."""
    if math.isnan(value):
        return "—"
    if value >= 100:
        return f"{value:,.0f}"
    return f"{value:.3g}"


def _wall(cell: ScaleCell) -> str:
    text = _rate(cell.wall_s)
    return f"{text} (over budget at {cell.reached_s:.1f} s)" if cell.over_budget else text


def _released(cell: ScaleCell) -> str:
    if not cell.expected:
        return "—"
    return "yes" if cell.all_released else f"no ({cell.released}/{cell.expected})"


def _formed(cell: ScaleCell) -> str:
    if not math.isnan(cell.formed_at_s):
        return f"{cell.formed_at_s:.2f}"
    return "—" if cell.over_budget else "no"


def _false_leaves(cell: ScaleCell) -> str:
    if math.isnan(cell.false_leaves_per_member_hour):
        return "—"
    return f"{cell.false_leaves_per_member_hour:.3g} ({cell.false_leaves})"


def problems(report: ScaleReport) -> list[str]:
    """Every error a cell recorded, prefixed with the cell: what did not work in the run."""
    out = [f"the run was cut short: {report.cut_short}"] if report.cut_short else []
    return out + [f"{c.label}: {e}" for c in report.cells for e in c.errors]


def markdown(report: ScaleReport) -> str:
    """The whole report: the command and the machine, the scenario, one table row per cell
    (sorted by loss, size, scheme), how each figure is taken, and what did not work."""
    s = report.scenario
    proto = _protocol()
    lines = [
        "# Benchmark: what the swarm size costs (`actorswarm bench scale`)",
        "",
        f"Command: `{report.command}`",
        "",
        f"Started {report.started}, took {report.wall_s:.0f} s. Machine: "
        + ", ".join(f"{k} {str(v).replace('|', '/')}" for k, v in report.machine.items())
        + ".",
        "",
        f"Scenario, in virtual time, on a fresh swarm per row: N platforms boot at 0 s; "
        f"{s.quiet_from:g}–{s.barrier_at:g} s is the quiet steady state over which traffic and "
        f"false leaves are taken; at {s.barrier_at:g} s every platform requests one barrier of "
        f"the whole swarm; at {s.crash_at:g} s the master crashes; the run ends at "
        f"{s.end:g} s. Radio: one-way latency {s.latency * 1000:g} ms, no jitter, each packet "
        "lost independently per receiver at the row's rate. Protocol: heartbeat "
        f"{proto['heartbeat_ms']:g} ms, T_leave {proto['t_leave_ms']:g} ms, T_join "
        f"{proto['t_join_ms']:g} ms. Membership `star`: {SCHEMES['star']}; `broadcast`: "
        f"{SCHEMES['broadcast']}. A row is abandoned after {s.max_wall:g} s of wall time "
        "(over budget, with the virtual time it reached).",
        "",
    ]
    if report.cut_short:
        lines += [f"**Not a complete run** ({report.cut_short}): only the rows below.", ""]
    lines += [
        "| membership | N | loss | wall s | sim s / wall s | formed at, s | all released "
        "| failover ms | non-master rx pkt/s: median (min–max) | master rx pkt/s "
        "| on-air pkt/s | on-air kbit/s | false leaves / member-hour (count) |",
        "|---" * 13 + "|",
    ]
    for c in sorted(report.cells, key=lambda c: (c.loss, c.size, c.membership)):
        member = _rate(c.member_recv_pps)
        if not math.isnan(c.member_recv_pps):
            member += f" ({_rate(c.member_recv_pps_min)}–{_rate(c.member_recv_pps_max)})"
        lines.append(
            f"| {c.membership} | {c.size} | {c.loss:.0%} | {_wall(c)} "
            f"| {c.sim_per_wall:.3g} | {_formed(c)} | {_released(c)} "
            f"| {_num(c.failover_ms)} | {member} | {_rate(c.master_recv_pps)} "
            f"| {_rate(c.air_pps)} | {_num(c.air_kbps, 1)} | {_false_leaves(c)} |"
        )
    lines += [
        "",
        "How each figure is taken (`src/actorswarm/bench/scale.py`):",
        "",
        "- *wall s*: wall-clock time of the whole run, booting the swarm included; *sim s / "
        "wall s*: virtual seconds reached per wall-clock second.",
        "- *formed at*: the first virtual time with one master that has every other platform "
        "in its view and its handshake done.",
        "- *all released*: every platform's `BarrierReleased` for the barrier of all, "
        "before the run ended (the master crashes two seconds after the request).",
        "- *failover*: the master crashes → the first new master whose handshake completed "
        "(every member in its view acknowledged it).",
        f"- *rx pkt/s, on air*: the radio's counters over {s.quiet_from:g}–{s.barrier_at:g} s: "
        "packets delivered per second to each non-master (median, and the range over them) "
        "and to the master; packets and kbit sent per second by every platform, a broadcast "
        "counted once (bytes as encoded, without radio framing).",
        "- *false leaves*: the master's `MemberLeft` of a platform that was alive, over the "
        "same window, per member-hour (N − 1 members watched for the window), the count in "
        "parentheses. The JSON adds the master's joins in the window and the false leaves "
        "over the whole run.",
        "",
        "## What did not work",
        "",
    ]
    issues = problems(report)
    lines += [f"- {p}" for p in issues] if issues else ["Every row ran to its end and worked."]
    return "\n".join(lines) + "\n"


# --- picture -------------------------------------------------------------------------------

_COLOUR = {"star": "tab:blue", "broadcast": "tab:orange"}


def plot_scale(report: ScaleReport, out: Path) -> None:
    """Draw the report as one PNG at ``out``: packets received per second against N
    (log-log; non-masters: the median, bars to the min and max; the master), and wall time
    against N (an over-budget row: a cross at the time it was abandoned). One line per
    scheme and loss."""
    import matplotlib

    matplotlib.use("Agg")  # no display: files only
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    fig, (rx, wall) = plt.subplots(1, 2, figsize=(13, 5), constrained_layout=True)
    several = len({c.loss for c in report.cells}) > 1
    groups: dict[tuple[str, float], list[ScaleCell]] = {}
    for c in sorted(report.cells, key=lambda c: c.size):
        groups.setdefault((c.membership, c.loss), []).append(c)
    for (scheme, loss), cells in sorted(groups.items()):
        colour = _COLOUR.get(scheme)
        name = scheme + (f", {loss:.0%} loss" if several else "")
        style = "-" if loss == min(k[1] for k in groups) else ":"
        # Non-positive values cannot sit on a log axis: they are left out.
        members = [c for c in cells if c.member_recv_pps > 0]
        if members:
            med = [c.member_recv_pps for c in members]
            rx.errorbar(
                [c.size for c in members],
                med,
                yerr=[
                    [m - c.member_recv_pps_min for m, c in zip(med, members, strict=True)],
                    [c.member_recv_pps_max - m for m, c in zip(med, members, strict=True)],
                ],
                marker="o",
                ls=style,
                color=colour,
                capsize=3,
                label=f"{name}: non-master (median)",
            )
        masters = [c for c in cells if c.master_recv_pps > 0]
        if masters:
            rx.plot(
                [c.size for c in masters],
                [c.master_recv_pps for c in masters],
                marker="s",
                ls="--" if style == "-" else "-.",
                color=colour,
                label=f"{name}: master",
            )
        timed = [c for c in cells if c.wall_s > 0]
        if timed:
            wall.plot(
                [c.size for c in timed],
                [c.wall_s for c in timed],
                marker="o",
                ls=style,
                color=colour,
                label=name,
            )
            over = [c for c in timed if c.over_budget]
            if over:
                wall.plot(
                    [c.size for c in over],
                    [c.wall_s for c in over],
                    "x",
                    color="red",
                    markersize=10,
                    label=f"{name}: over budget",
                )
    rx.set(
        xscale="log",
        yscale="log",
        xlabel="platforms",
        ylabel="packets received / s",
        title=f"quiet steady state ({report.scenario.quiet_from:g}–"
        f"{report.scenario.barrier_at:g} s): packets received per second",
    )
    wall.set(
        xscale="log",
        yscale="log",
        xlabel="platforms",
        ylabel="wall s",
        title=f"wall time of the whole {report.scenario.end:g} s run",
    )
    sizes = sorted({c.size for c in report.cells})
    for ax in (rx, wall):
        if sizes:  # the sizes measured, in plain numbers
            ax.set_xticks(sizes, [str(n) for n in sizes])
            ax.xaxis.set_minor_formatter(NullFormatter())
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize="small")
        else:
            ax.text(0.5, 0.5, "not measured", transform=ax.transAxes, ha="center")
    fig.suptitle("actorswarm: what the swarm size costs, star against broadcast membership")
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=100)
    plt.close(fig)
