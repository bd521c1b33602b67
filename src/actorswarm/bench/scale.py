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

Optionally, ``member_crash_at`` (between the barrier and the master's crash): the member with
the highest ID crashes, and the cell measures how long the master takes to declare it gone.

On a shared channel (``Scenario.channel_bitrate``) the radio models airtime
(:class:`~actorswarm.sim.radio.Airtime`: every transmission, a broadcast once, occupies one
channel of that bitrate for its bytes plus ``overhead_bytes``; a packet that would wait more
than ``max_queue_s`` for the channel is dropped). A cell *with cadence* also gives the core
that bitrate (``CoreConfig.channel_bitrate``), so a star master slows its members'
heartbeats to fit their share of the channel; *without*, the members heartbeat at 10 Hz
whatever the channel. The channel's figures (:meth:`~actorswarm.sim.radio.SimRadio.
channel_stats`) are taken over the quiet window and over the whole run.

The report (Markdown, picture) is drawn by :mod:`actorswarm.bench.scale_report`.

Figures of a cell: :class:`ScaleCell`, whose fields say how each is taken.

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
from typing import Any

from actorswarm.bench.core import ACK_POLL, acknowledged_master
from actorswarm.bench.daemons.probe import read_status_kib
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
from actorswarm.sim.radio import Airtime, ChannelStats, LinkModel
from actorswarm.sim.swarm import SimSwarm

__all__ = [
    "MAX_SIZE",
    "SCHEMES",
    "ScaleCell",
    "ScaleReport",
    "Scenario",
    "bitrate_text",
    "cadence_text",
    "cell_json",
    "cell_seed",
    "protocol",
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
#: The packet kind of routine heartbeats in the radio's counters (a probe and its answer,
#: heartbeats too, count as "Probe").
_HEARTBEAT = "Heartbeat"
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

    ``member_crash_at`` (None: no member crashes): when the member with the highest ID
    crashes; ``barrier_at < member_crash_at < crash_at``. ``channel_bitrate`` (bit/s; None:
    no shared channel), ``overhead_bytes`` and ``max_queue_s``: the radio's
    :class:`~actorswarm.sim.radio.Airtime`; a bad value raises its ``ValueError``, naming
    the field.
    """

    quiet_from: float = 2.0
    barrier_at: float = 4.0
    crash_at: float = 6.0
    end: float = 8.0
    latency: float = 0.01
    slice: float = 0.1
    max_wall: float = 600.0
    member_crash_at: float | None = None
    channel_bitrate: float | None = None
    #: The Airtime default: the IPv4 and UDP headers a packet carries besides its payload.
    overhead_bytes: int = 28
    max_queue_s: float = 1.0

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
        member = self.member_crash_at
        if member is not None and not (
            math.isfinite(member) and self.barrier_at < member < self.crash_at
        ):
            raise ValueError(
                f"the member crash ({member:g} s) must come after the barrier "
                f"({self.barrier_at:g} s) and before the master's crash ({self.crash_at:g} s)"
            )
        self.airtime()  # its ValueError names the field

    def airtime(self) -> Airtime | None:
        """The radio's shared channel, or None without ``channel_bitrate``."""
        if self.channel_bitrate is None:
            return None
        return Airtime(
            bitrate=self.channel_bitrate,
            overhead_bytes=self.overhead_bytes,
            max_queue_s=self.max_queue_s,
        )

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
    #: The shared channel's bit/s (None: none modelled), and whether the core knew it (its
    #: ``channel_bitrate`` set: a star master slows its members' heartbeats to fit).
    channel_bitrate: float | None = None
    cadence: bool = False
    #: Wall-clock seconds of the whole run, booting the swarm included.
    wall_s: float = NAN
    #: The process's peak resident memory over the run, MiB (Linux's ``VmHWM``, reset
    #: before the run; NaN where ``/proc`` does not allow it).
    peak_rss_mib: float = NAN
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
    #: The master that crashed, the first new master every survivor acknowledged, and the
    #: time from the crash to that.
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
    #: The master at the end of the quiet window: the interval at which its members
    #: heartbeat (the cadence it asks for), and how long a member may be silent before this
    #: master declares it gone (its leave timeout then, with probing; see core.membership).
    member_cadence_ms: float = NAN
    leave_timeout_ms: float = NAN
    #: With ``Scenario.member_crash_at``: the member that crashed, and the crash → the
    #: master's ``MemberLeft`` of it (NaN: not before the master's own crash).
    crashed_member: int = -1
    member_leave_ms: float = NAN
    #: The mean heartbeat sent over the quiet window, bytes as encoded (sealed; the channel
    #: adds ``overhead_bytes``): what the core's ``heartbeat_bits`` estimates.
    heartbeat_bytes: float = NAN
    #: The channel over the quiet window (``SimRadio.channel_stats``): its busy share (NaN
    #: without airtime), packets and kbit/s carried (with ``overhead_bytes`` per packet when
    #: airtime is modelled), the packets dropped for want of airtime (each once, however many
    #: would have heard it; per packet kind too) and the longest wait for the channel (NaN
    #: without airtime).
    channel_utilisation: float = NAN
    channel_pps: float = NAN
    channel_kbps: float = NAN
    airtime_drops: int = 0
    airtime_drops_by_kind: dict[str, int] = field(default_factory=dict)
    max_wait_ms: float = NAN
    #: The same over the whole run (booting to the end, or to where it stopped).
    run_airtime_drops: int = 0
    run_max_wait_ms: float = NAN
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
        text = f"{self.membership} N={self.size} loss={self.loss:.0%}"
        if self.channel_bitrate is None:
            return text
        return f"{text} {bitrate_text(self.channel_bitrate)} {cadence_text(self.cadence)}"


def bitrate_text(bps: float) -> str:
    """A bitrate as people write it: ``1 Mbit/s``, ``250 kbit/s``, ``9600 bit/s``."""
    for scale, unit in ((1e9, "Gbit/s"), (1e6, "Mbit/s"), (1e3, "kbit/s")):
        if bps >= scale:
            return f"{bps / scale:g} {unit}"
    return f"{bps:g} bit/s"


def cadence_text(cadence: bool) -> str:
    """How a row's members heartbeat, in a few words."""
    return "cadence" if cadence else "no cadence"


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
        #: (when, who): the first new master every survivor acknowledged after the crash.
        self.acknowledged: tuple[float, int] | None = None
        self.before: dict[int, dict[str, Any]] = {}
        self.after: dict[int, dict[str, Any]] = {}
        self.masters_before: list[int] = []
        self.masters_after: list[int] = []
        self.alive_after: list[int] = []
        # The channel's figures: booting → the window, the window, the window → the end.
        self.channel: list[ChannelStats] = []
        self.heartbeats: list[tuple[int, int, int, int]] = []

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
            # The only platforms that die are the crashed ones: any other leave is false.
            if node.is_master and event.platform not in self.crashed:
                cell.run_false_leaves += 1
                if quiet:
                    cell.false_leaves += 1
            elif (
                node.is_master
                and event.platform == cell.crashed_member
                and math.isnan(cell.member_leave_ms)
                and scenario.member_crash_at is not None
                and now < scenario.crash_at
            ):
                cell.member_leave_ms = (now - scenario.member_crash_at) * 1000
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

    def channel_window(self) -> None:
        """Close a window of the channel's figures and open the next."""
        radio = self.swarm.radio
        self.channel.append(radio.channel_stats())
        radio.reset_channel_stats()
        self.heartbeats.append(radio.traffic.kind_totals(_HEARTBEAT))

    def window_start(self) -> None:
        self.before = self.swarm.radio.traffic.snapshot()
        self.masters_before = self.swarm.current_masters()
        self.channel_window()

    def window_end(self) -> None:
        swarm = self.swarm
        self.after = swarm.radio.traffic.snapshot()
        self.masters_after = swarm.current_masters()
        self.alive_after = sorted(swarm.nodes)
        self.channel_window()
        if len(self.masters_after) == 1:
            view = swarm.node(self.masters_after[0]).members
            self.cell.member_cadence_ms = view.cadence * 1000
            self.cell.leave_timeout_ms = view.silence() * 1000

    def crash_member(self) -> None:
        """Crash the member with the highest ID (in star, the last a succession list names).
        A barrier of all no longer waits for a platform that left: if it had not been
        released yet, it is no longer expected."""
        masters = set(self.swarm.current_masters())
        members = [p for p in self.swarm.nodes if p not in masters]
        if not members:
            self.cell.errors.append("no member to crash")
            return
        victim = max(members)
        self.cell.crashed_member = victim
        self.crashed.add(victim)
        if victim not in self.released:
            self.cell.expected -= 1
        self.swarm.crash(victim)

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
        self.swarm.at(self.swarm.now + ACK_POLL, self.poll_acknowledged)

    def poll_acknowledged(self) -> None:
        """Every :data:`ACK_POLL` after the master's crash, until a new master is
        acknowledged by every survivor (the last report shows in no event)."""
        swarm = self.swarm
        new = acknowledged_master(swarm, self.scenario.crash_at, self.crash_epoch)
        if new is not None:
            self.acknowledged = (swarm.now, new)
        elif swarm.now + ACK_POLL <= self.scenario.end:
            swarm.at(swarm.now + ACK_POLL, self.poll_acknowledged)


def run_cell(
    membership: MembershipKind,
    size: int,
    loss: float,
    *,
    seed: int,
    scenario: Scenario | None = None,
    cadence: bool = False,
    progress: Callable[[str], None] | None = None,
) -> ScaleCell:
    """Run the scenario once on a fresh swarm of ``size`` platforms; the figures.

    ``cadence``: the core is given the scenario's channel bitrate (``ValueError`` without
    one), so a star master asks its members for a heartbeat interval that fits the channel.

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
    bitrate = scenario.channel_bitrate
    if cadence and bitrate is None:
        raise ValueError("cadence needs a channel: the scenario has no channel_bitrate")
    cell = ScaleCell(
        membership=membership,
        size=size,
        loss=loss,
        seed=seed,
        channel_bitrate=bitrate,
        cadence=cadence,
    )
    peak_known = _reset_peak_rss()
    began = time.perf_counter()
    deadline = began + scenario.max_wall
    swarm = SimSwarm(
        size,
        seed=seed,
        config=CoreConfig(membership=membership, channel_bitrate=bitrate if cadence else None),
        link=LinkModel(latency=scenario.latency, loss=loss),
        log_membership=False,
    )
    # Set before the first event: every packet of the run goes through the channel.
    swarm.radio.airtime = scenario.airtime()
    watch = _Watch(swarm, cell, scenario)
    swarm.listeners.append(watch.on_event)
    # Same virtual time, scheduled in this order, run in this order: the window's traffic
    # is taken before the barrier's first packet.
    swarm.at(scenario.quiet_from, watch.window_start)
    swarm.at(scenario.barrier_at, watch.window_end)
    swarm.at(scenario.barrier_at, watch.request_barrier)
    if scenario.member_crash_at is not None:
        swarm.at(scenario.member_crash_at, watch.crash_member)
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
    if peak_known:
        cell.peak_rss_mib = _peak_rss_mib()
    watch.channel.append(swarm.radio.channel_stats())
    _figures(cell, watch, swarm, scenario)
    return cell


def _reset_peak_rss() -> bool:
    """Reset this process's peak resident memory (``VmHWM``) to its current size; False
    where the system does not allow it (not Linux, or no ``/proc``)."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
    except OSError:
        return False
    return True


def _peak_rss_mib() -> float:
    """This process's peak resident memory since the last reset, MiB (NaN if unknown)."""
    try:
        peak = read_status_kib("self", ("VmHWM",)).get("VmHWM")
    except (OSError, ValueError, IndexError):
        return NAN
    return NAN if peak is None else peak / 1024


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
        _channel(cell, watch.channel[1])
        (before_packets, before_bytes, *_), (after_packets, after_bytes, *_) = watch.heartbeats
        if after_packets > before_packets:
            cell.heartbeat_bytes = (after_bytes - before_bytes) / (after_packets - before_packets)
    cell.run_airtime_drops = sum(c.drops for c in watch.channel)
    if scenario.channel_bitrate is not None:
        cell.run_max_wait_ms = max(c.max_queue_delay_s for c in watch.channel) * 1000
    if cell.crashed_member >= 0 and math.isnan(cell.member_leave_ms) and not cell.over_budget:
        cell.errors.append(
            f"the master had not declared the crashed member {cell.crashed_member} gone by "
            f"its own crash at {scenario.crash_at:g} s"
        )
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
        if watch.acknowledged is not None:
            at, cell.new_master = watch.acknowledged
            cell.failover_ms = (at - scenario.crash_at) * 1000
        elif not cell.over_budget:
            cell.errors.append(
                f"no new master was acknowledged by every survivor by t = {reached:g} s"
            )
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


def _channel(cell: ScaleCell, stats: ChannelStats) -> None:
    """The quiet window's channel figures."""
    if stats.utilisation is not None:
        cell.channel_utilisation = stats.utilisation
    cell.channel_pps = stats.packets_per_s
    cell.channel_kbps = stats.bits_per_s / 1000
    cell.airtime_drops = stats.drops
    cell.airtime_drops_by_kind = dict(stats.drops_by_kind)
    if stats.bitrate is not None:
        cell.max_wait_ms = stats.max_queue_delay_s * 1000


def run_scale(
    memberships: Sequence[MembershipKind],
    sizes: Sequence[int],
    losses: Sequence[float],
    *,
    seed: int,
    scenario: Scenario,
    command: str,
    cadences: Sequence[bool] = (False,),
    progress: Callable[[str], None] | None = None,
    done: Callable[[ScaleReport, ScaleCell], None] | None = None,
) -> ScaleReport:
    """Every cell — losses outermost, then sizes, then schemes, then ``cadences`` (see
    :func:`run_cell`), so the rows of one size are measured one after the other, with the
    same seed — into one :class:`ScaleReport`. ``done`` is called with the report so far
    after every cell (to print it, to save it)."""
    from actorswarm.bench.daemons.probe import machine_info

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
                for cadence in cadences:
                    cell = run_cell(
                        membership,
                        size,
                        loss,
                        seed=cell_seed(seed, size, loss),
                        scenario=scenario,
                        cadence=cadence,
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
        "protocol": protocol(),
        "wall_s": report.wall_s,
        "cut_short": report.cut_short,
        "cells": [cell_json(c) for c in report.cells],
    }


def protocol() -> dict[str, Any]:
    """The core's timings every cell ran with: its defaults; only the scheme varies, and with
    cadence the channel's bitrate is given to the core (``heartbeat_share`` of it for the
    members' heartbeats, ``heartbeat_bits`` each)."""
    config = CoreConfig()
    return {
        "heartbeat_ms": config.heartbeat_interval * 1000,
        "t_leave_ms": config.t_leave * 1000,
        "t_join_ms": config.t_join * 1000,
        "join_heartbeats": config.join_heartbeats,
        "false_leave_rate_per_s": config.false_leave_rate,
        "heartbeat_share": config.heartbeat_share,
        "heartbeat_bits": config.heartbeat_bits,
    }
