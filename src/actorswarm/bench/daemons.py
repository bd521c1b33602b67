"""Benchmark of real daemon processes on one machine (docs/design.md §8), over Zenoh on loopback.

For each swarm size it starts that many ``actorswarm daemon`` processes
(:class:`~actorswarm.daemon.launch.LocalSwarm`: a full mesh of TCP links on 127.0.0.1, packet
authentication on; with ``broadcast="multicast"``, every daemon and the ground station on
Zenoh's UDP multicast transport through ``lo`` instead), waits until every daemon has all
the others in its view and they agree on one master, and measures:

* **resources**: each daemon's resident memory (``VmRSS`` and its private part ``RssAnon``
  from ``/proc/PID/status``) and the CPU it used over a window (``utime + stime`` from
  ``/proc/PID/stat``, every thread of the process, Zenoh's included), as a percentage of one
  core; and the packets on the wire: those ``lo`` received over the window (``/proc/net/dev``
  of the network namespace the bench runs in: run it in a namespace of its own, ``ip netns
  exec``, to count the swarm's packets alone) per packet the daemons sent (one ``send`` of
  the core, a broadcast counted once, from their ``status.json``). Twice: *idle* — no
  script deployed, only heartbeats and membership — and *script* — every platform running
  actor A (one ``core.idle`` plugin, stepped at 10 Hz) with a ground station connected.
  A swarm of N daemons means N − 1 peers for each.
* **failover**: the agreed master's daemon gets SIGKILL; from the bench's clock just before
  the signal to each survivor's first ``master`` log line naming the new master. Reported:
  the new master's own line (its claim) and the *last* survivor's line (when the whole swarm
  follows the new master). The killed platform is restarted from its state directory and
  the swarm must agree again (every view full, one master) before the next repetition.
  Election is sticky, so the master killed is not always platform 1.
* **collective switch**: a ground station in this process deploys a two-actor script
  (A → B on ``go``, B → A on ``back``; each a barrier of every platform, ``sysNum="all"``),
  starts it and fires the events in turn. From the bench's clock just before the event is
  sent to the latest ``transition`` log line of the platforms (the switch time), and the
  spread between the first and the last platform switching. And the CPU the switch cost
  the swarm (:func:`switch_cpu`: every daemon's run time, less its idle rate); on a machine
  whose cores every daemon shares, that CPU divided by the cores is about the least time the
  switch can take (less the part spent after the last platform switched).

Every time compared is :func:`time.monotonic` (CLOCK_MONOTONIC), one clock for every process
on the machine: the daemons stamp their log lines and transitions with it. A run that does
not finish is recorded with its error and counted as failed, never dropped silently; a
swarm that never agrees (a machine too small for it) still has its CPU and memory measured,
marked ``idle, not settled``, and nothing else. The figures depend on the machine: every
daemon, the ground station and the bench share its cores, which :func:`machine_info`
describes.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import math
import os
import platform as platform_module
import random
import statistics
import subprocess
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING, Any

from actorswarm.core.config import CoreConfig
from actorswarm.daemon.launch import LocalSwarm
from actorswarm.daemon.loop import clock

if TYPE_CHECKING:
    from actorswarm.daemon.ground import GroundSession

__all__ = [
    "BenchResult",
    "FailoverRun",
    "LogTail",
    "ResourceRun",
    "Settings",
    "SizeResult",
    "SwitchRun",
    "bench",
    "bench_size",
    "cpu_fit",
    "describe_swarm",
    "from_json",
    "ground_session",
    "machine_info",
    "markdown",
    "measure_failover",
    "measure_resources",
    "read_cpu_seconds",
    "read_interface_packets",
    "read_memory_kib",
    "settled",
    "switch_script",
    "to_json",
    "wait_stable",
]

Progress = Callable[[str], None]

#: The events of the switch script: ``go`` takes every platform from A to B, ``back`` home.
FORWARD = ("go", "A", "B")
BACKWARD = ("back", "B", "A")


@dataclass(frozen=True, slots=True)
class Settings:
    """How much to measure. Windows and timeouts are seconds."""

    #: CPU window of each resource measurement.
    window: float = 20.0
    failovers: int = 10
    switches: int = 10
    #: Waiting for a booted swarm (every view full, one master); grows with the size, as
    #: every daemon is a Python process importing Zenoh on the same cores.
    boot_timeout: float = 180.0
    #: Waiting for a new master after a kill, and for a switch to reach every platform.
    run_timeout: float = 15.0
    #: Quiet time after the swarm agreed, before measuring: start-up work is not idling.
    settle: float = 2.0
    #: Measure the resources while the script runs too (the second window).
    script_window: bool = True
    seed: int = 1
    #: How broadcasts travel (``--broadcast``): ``mesh`` or ``multicast`` (on ``group``,
    #: through ``interface``).
    broadcast: str = "mesh"
    group: str = "224.0.0.225:7448"
    interface: str = "lo"
    #: Zenoh's session lease of every daemon, seconds (``--lease``; None: the default).
    lease: float | None = None
    #: A source checkout whose ``src`` the daemons run instead of this one's
    #: (``--daemons-from``): code before and after a change, measured by one harness.
    daemons_from: str | None = None


@dataclass(slots=True)
class ResourceRun:
    """One window over every daemon of a swarm. Lists are per daemon, by platform."""

    phase: str  # "idle" (no script) or "script" (actor A running, ground station connected)
    window_s: float
    platforms: list[int]
    peers: list[int]  # members in each daemon's view at the end of the window
    rss_mib: list[float]
    rss_anon_mib: list[float]
    cpu_pct: list[float]  # of one core
    loadavg_1min: float
    #: Packets ``lo`` received per second over the window (every packet on loopback is
    #: received once, a multicast datagram too, however many sockets take it).
    wire_packets_s: float = math.nan
    #: Packets the daemons sent per second (core sends; a broadcast counts once).
    sent_packets_s: float = math.nan
    #: The master the daemons agreed on at the end of the window (None: they did not).
    master: int | None = None
    #: Per daemon: how often a second its main thread went to sleep (voluntary context
    #: switches of the thread that runs the loop; empty in runs saved before it was
    #: measured). Each is a wake of the loop, the cost a daemon pays per timer or burst.
    sleeps_s: list[float] = field(default_factory=list)

    def cpu_of(self, role: str) -> list[float]:
        """CPU % of the ``"master"`` (one value, or none when there was no agreed
        master) or of the ``"members"`` (every other daemon; all of them without a
        master)."""
        return self._of(role, self.cpu_pct)

    def sleeps_of(self, role: str) -> list[float]:
        """:attr:`sleeps_s` of the master or the members, as :meth:`cpu_of`."""
        return self._of(role, self.sleeps_s) if self.sleeps_s else []

    def _of(self, role: str, values: list[float]) -> list[float]:
        pairs = list(zip(self.platforms, values, strict=True))
        if role == "master":
            return [c for p, c in pairs if p == self.master]
        return [c for p, c in pairs if p != self.master]


@dataclass(slots=True)
class FailoverRun:
    killed: int
    new_master: int | None
    to_claim_s: float  # kill -> the new master's own "master" line (nan: none)
    to_all_s: float  # kill -> the last survivor's line naming the new master (nan: not all)
    survivors: int
    followed: int  # survivors that logged the new master in time
    #: The master the whole swarm agreed on after the killed platform restarted (None: it
    #: did not agree): the restarted platform itself when it took the role back.
    master_after_restart: int | None = None
    error: str = ""


@dataclass(slots=True)
class SwitchRun:
    event: str
    src: str
    dst: str
    expected: int
    switched: int  # platforms that logged the transition in time
    first_s: float  # send -> first platform's transition (nan: none)
    last_s: float  # send -> last platform's transition (nan: not every platform)
    spread_s: float  # last - first platform (nan: not every platform)
    causes: dict[str, int] = field(default_factory=dict)
    error: str = ""
    #: CPU every daemon together spent on the switch beyond its idle rate, seconds (nan: not
    #: measured; see :func:`switch_cpu`).
    cpu_s: float = math.nan


@dataclass(slots=True)
class SizeResult:
    size: int
    boot_s: float = math.nan
    resources: list[ResourceRun] = field(default_factory=list)
    failover: list[FailoverRun] = field(default_factory=list)
    switch: list[SwitchRun] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)
    wall_s: float = 0.0


@dataclass(slots=True)
class BenchResult:
    command: str
    settings: dict[str, Any]
    machine: dict[str, Any]
    config: dict[str, float]
    sizes: list[SizeResult]
    started: str  # UTC, ISO 8601
    wall_s: float = 0.0


# --- /proc ------------------------------------------------------------------------------


def read_status_kib(pid: int | str, names: Sequence[str]) -> dict[str, int]:
    """The fields ``names`` (in KiB, e.g. ``VmRSS``, ``VmHWM``) that ``/proc/PID/status``
    has for process ``pid`` (or ``"self"``). OSError when the process is gone."""
    fields: dict[str, int] = {}
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        name, _, value = line.partition(":")
        if name in names:
            fields[name] = int(value.split()[0])
    return fields


def read_memory_kib(pid: int) -> tuple[int, int]:
    """(``VmRSS``, ``RssAnon``) of process ``pid`` in KiB, from ``/proc/PID/status``.
    OSError when the process is gone; ValueError when the fields are missing."""
    fields = read_status_kib(pid, ("VmRSS", "RssAnon"))
    if "VmRSS" not in fields:
        raise ValueError(f"/proc/{pid}/status has no VmRSS (a kernel thread or a zombie?)")
    return fields["VmRSS"], fields.get("RssAnon", fields["VmRSS"])


def read_interface_packets(interface: str = "lo", path: Path = Path("/proc/net/dev")) -> int:
    """Packets ``interface`` received so far (``/proc/net/dev`` of this network namespace);
    -1 when it has no such interface."""
    for line in path.read_text().splitlines()[2:]:
        name, _, counters = line.partition(":")
        if name.strip() == interface:
            return int(counters.split()[1])
    return -1


def _sent(status: dict[str, Any]) -> tuple[float, int] | None:
    """(when, packets sent) from a daemon's status, None before its first meters."""
    traffic = status.get("traffic")
    if not isinstance(traffic, dict) or "t" not in status:
        return None
    return float(status["t"]), int(traffic.get("sent_packets", 0))


def read_sleeps(pid: int) -> int:
    """How many times the main thread of process ``pid`` went to sleep so far: its
    voluntary context switches (``/proc/PID/task/PID/status``), which for a daemon are its
    loop's waits (and the few blocking calls it makes). OSError when the process is gone;
    ValueError when the kernel does not count them."""
    for line in Path(f"/proc/{pid}/task/{pid}/status").read_text().splitlines():
        name, _, value = line.partition(":")
        if name == "voluntary_ctxt_switches":
            return int(value)
    raise ValueError(f"/proc/{pid}/task/{pid}/status has no voluntary_ctxt_switches")


def read_cpu_seconds(pid: int, thread: int | None = None) -> float:
    """CPU time process ``pid`` used so far (user + system, all its threads; or only its
    thread ``thread``, e.g. ``pid`` for the main one), seconds. OSError when the process
    is gone."""
    where = f"/proc/{pid}" if thread is None else f"/proc/{pid}/task/{thread}"
    text = Path(f"{where}/stat").read_text()
    # The command name (field 2) is in parentheses and may hold spaces: split after it.
    rest = text[text.rindex(")") + 2 :].split()
    utime, stime = int(rest[11]), int(rest[12])  # fields 14 and 15 of proc(5)
    return (utime + stime) / os.sysconf("SC_CLK_TCK")


#: Seconds a switch's measurement of CPU goes on after the last platform switched: its
#: acknowledgements, the backups and status files the transition writes.
_SWITCH_TAIL = 0.2


def read_cpu_ns(pid: int) -> int:
    """CPU time process ``pid`` used so far, nanoseconds: the sum over its threads of the
    scheduler's run time (``/proc/PID/task/*/schedstat``), exact where
    :func:`read_cpu_seconds` counts in clock ticks (10 ms), too coarse to sum over 30
    processes for one switch. Falls back to the ticks where the kernel keeps no schedstat.
    OSError when the process is gone."""
    total = read = 0
    for task in os.listdir(f"/proc/{pid}/task"):
        try:
            total += int(Path(f"/proc/{pid}/task/{task}/schedstat").read_text().split()[0])
        except FileNotFoundError:  # a thread that just ended, or no schedstat at all
            continue
        read += 1
    return total if read else round(read_cpu_seconds(pid) * 1e9)


def switch_cpu(
    idle: tuple[int, float], before: tuple[int, float], after: tuple[int, float]
) -> float:
    """CPU seconds a switch cost the swarm: what every daemon used from ``before`` (just
    before the event was sent) to ``after`` (once every platform switched and the last
    acknowledgements settled), less what it would have used idle over that time, at the
    rate measured from ``idle`` to ``before``. Each point is (summed CPU ns, clock s)."""
    (c0, t0), (c1, t1), (c2, t2) = idle, before, after
    if not t0 < t1 <= t2:
        raise ValueError(f"switch_cpu: times out of order: {t0}, {t1}, {t2}")
    rate = (c1 - c0) / (t1 - t0)
    return (c2 - c1 - rate * (t2 - t1)) / 1e9


def machine_info() -> dict[str, Any]:
    """What the figures depend on: CPU model and count, memory, OS, Python and Zenoh."""
    model = "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem_gib = math.nan
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal:"):
                mem_gib = round(int(line.split()[1]) / 2**20, 1)
    except OSError:
        pass
    try:
        zenoh_version = metadata.version("eclipse-zenoh")
    except metadata.PackageNotFoundError:
        zenoh_version = "unknown"
    return {
        "actorswarm": _source_version(),
        "cpu_model": model,
        "cpus": os.cpu_count() or 0,
        "memory_gib": mem_gib,
        "os": f"{platform_module.system()} {platform_module.release()}",
        "python": platform_module.python_version(),
        "zenoh": zenoh_version,
    }


def _source_version(root: Path | None = None) -> str:
    """The package version, and the git commit of the source when it runs from a checkout
    (``+dirty`` when the working tree differs from it): what the daemons measured ran.
    ``root``: another checkout than this module's."""
    from actorswarm import __version__

    root = root or Path(__file__).resolve().parents[3]
    try:
        commit = subprocess.run(
            ["git", "-C", str(root), "describe", "--always", "--dirty=+dirty"],
            capture_output=True,
            text=True,
            timeout=10,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return __version__
    return f"{__version__} ({commit})" if commit else __version__


# --- the daemons' logs --------------------------------------------------------------------


class LogTail:
    """The JSON lines each daemon logged since :meth:`mark` (other lines are skipped)."""

    def __init__(self, swarm: LocalSwarm) -> None:
        self.swarm = swarm
        self._offset: dict[int, int] = {}
        self._partial: dict[int, bytes] = {}
        self._lines: dict[int, list[dict[str, Any]]] = {}

    def mark(self) -> None:
        """Forget what was logged so far: only later lines count."""
        for p in range(1, self.swarm.size + 1):
            path = self.swarm.log(p)
            self._offset[p] = path.stat().st_size if path.exists() else 0
            self._partial[p] = b""
            self._lines[p] = []

    def lines(self, platform: int) -> list[dict[str, Any]]:
        """Every complete JSON line platform ``platform`` logged since the mark."""
        try:
            with self.swarm.log(platform).open("rb") as f:
                f.seek(self._offset.get(platform, 0))
                data = f.read()
        except OSError:
            data = b""
        self._offset[platform] = self._offset.get(platform, 0) + len(data)
        chunk = self._partial.get(platform, b"") + data
        *complete, self._partial[platform] = chunk.split(b"\n")
        got = self._lines.setdefault(platform, [])
        for raw in complete:
            try:
                line = json.loads(raw)
            except ValueError:
                continue  # not one of the daemon's JSON lines (a library's warning)
            if isinstance(line, dict) and "t" in line and "event" in line:
                got.append(line)
        return got


# --- one swarm ----------------------------------------------------------------------------


def settled(swarm: LocalSwarm) -> bool:
    """Every running daemon's status was written by the process running now, has every
    other running one in its view, and they all follow the same master. (A daemon rewrites
    its status within a second of a change, and not when nothing changed: the status of a
    running daemon is current however old it is.)"""
    running = swarm.running()
    if len(running) != swarm.size:
        return False
    for p in running:
        status = swarm.status(p)
        if status.get("pid") != swarm.procs[p].pid:
            return False
        if len(status.get("members", ())) != swarm.size - 1:
            return False
    return swarm.agreed_master(running) is not None


def describe_swarm(swarm: LocalSwarm) -> str:
    """A swarm that does not settle, in a line: views, masters, epochs, master changes."""
    statuses = [swarm.status(p) for p in swarm.running()]
    views = [len(st.get("members", ())) for st in statuses]
    masters: dict[str, int] = {}
    for st in statuses:
        key = str(st.get("master"))
        masters[key] = masters.get(key, 0) + 1
    epochs = [int(st.get("epoch", 0)) for st in statuses]
    changes = sum(
        1
        for p in swarm.running()
        for line in swarm.log(p).read_text(errors="replace").splitlines()
        if '"event": "master"' in line
    )
    return (
        f"{len(statuses)} daemons running, views of {min(views, default=0)}–"
        f"{max(views, default=0)} peers (of {swarm.size - 1}), following "
        + ", ".join(f"{k} ({v})" for k, v in sorted(masters.items()))
        + f"; epochs up to {max(epochs, default=0)}, {changes} master changes logged"
    )


def _picture(swarm: LocalSwarm) -> tuple[int | None, tuple[int, ...]]:
    """The agreed master and every running daemon's epoch, to tell a steady swarm."""
    epochs = tuple(int(swarm.status(p).get("epoch", -1)) for p in swarm.running())
    return swarm.agreed_master(), epochs


def wait_stable(swarm: LocalSwarm, timeout: float, hold: float = 1.5) -> bool:
    """Wait until the swarm is :func:`settled` and stays so, with the same master and
    epochs, for ``hold`` seconds (longer than the second within which a daemon writes a
    change to its status, so a change under way shows). A swarm that merely passes through
    agreement — a restarted platform that is about to take the role over — does not
    count."""
    end = clock() + timeout
    while clock() < end:
        if not settled(swarm):
            time.sleep(0.2)
            continue
        seen = _picture(swarm)
        time.sleep(hold)
        if settled(swarm) and _picture(swarm) == seen:
            return True
    return False


def _wait(condition: Callable[[], bool], timeout: float, poll: float = 0.05) -> bool:
    end = clock() + timeout
    while not condition():
        if clock() >= end:
            return False
        time.sleep(poll)
    return True


async def measure_resources(swarm: LocalSwarm, phase: str, window: float) -> ResourceRun:
    """CPU over ``window`` seconds and memory at its end, of every running daemon. Waits
    with ``asyncio.sleep`` so a ground station in the same loop keeps serving meanwhile."""
    procs = {p: swarm.procs[p] for p in swarm.running()}
    start_wall = clock()
    start_cpu = {p: read_cpu_seconds(proc.pid) for p, proc in procs.items()}
    start_sleeps = {p: read_sleeps(proc.pid) for p, proc in procs.items()}
    start_sent = {p: _sent(swarm.status(p)) for p in procs}
    start_wire = read_interface_packets()
    await asyncio.sleep(window)
    elapsed = clock() - start_wall
    wire = read_interface_packets() - start_wire
    run = ResourceRun(
        phase=phase,
        window_s=elapsed,
        platforms=sorted(procs),
        peers=[],
        rss_mib=[],
        rss_anon_mib=[],
        cpu_pct=[],
        loadavg_1min=os.getloadavg()[0],
        wire_packets_s=wire / elapsed if start_wire >= 0 else math.nan,
    )
    # Each daemon writes its counters every 10 s or so, stamped: a rate over its own stamps.
    rates = []
    for p in run.platforms:
        before, after = start_sent[p], _sent(swarm.status(p))
        if before is not None and after is not None and after[0] > before[0]:
            rates.append((after[1] - before[1]) / (after[0] - before[0]))
    if rates and len(rates) == len(run.platforms):
        run.sent_packets_s = sum(rates)
    for p in run.platforms:
        pid = procs[p].pid
        used = read_cpu_seconds(pid) - start_cpu[p]
        rss, anon = read_memory_kib(pid)
        run.cpu_pct.append(100.0 * used / elapsed)
        run.sleeps_s.append((read_sleeps(pid) - start_sleeps[p]) / elapsed)
        run.rss_mib.append(rss / 1024)
        run.rss_anon_mib.append(anon / 1024)
        run.peers.append(len(swarm.status(p).get("members", ())))
    run.master = swarm.agreed_master()
    return run


def measure_failover(
    swarm: LocalSwarm, logs: LogTail, settings: Settings, rng: random.Random
) -> FailoverRun:
    """Kill the agreed master with SIGKILL, time the new master, restart the killed one and
    wait until the swarm agrees again. Never raises for a swarm that misbehaves: problems
    go into ``error``."""
    # Only a steady swarm has a master worth killing (a restart may still be settling).
    steady = wait_stable(swarm, settings.boot_timeout)
    master = swarm.agreed_master() if steady else None
    if master is None:
        return FailoverRun(
            killed=-1,
            new_master=None,
            to_claim_s=math.nan,
            to_all_s=math.nan,
            survivors=0,
            followed=0,
            error="no agreed master to kill",
        )
    incarnation = int(swarm.status(master).get("incarnation", -1))
    survivors = [p for p in swarm.running() if p != master]
    # A random phase within a heartbeat interval, so the kill does not lock onto one.
    time.sleep(rng.uniform(0.0, CoreConfig().heartbeat_interval))
    logs.mark()
    killed_at = clock()
    swarm.kill(master)

    def follows() -> dict[int, int | None]:
        """The master each survivor's latest ``master`` line names (absent: none yet)."""
        last: dict[int, int | None] = {}
        for p in survivors:
            for line in logs.lines(p):
                if line["event"] == "master":
                    last[p] = line.get("master")
        return last

    def agreed() -> bool:
        named = follows()
        values = set(named.values())
        return (
            len(named) == len(survivors)
            and len(values) == 1
            and None not in values
            and master not in values
        )

    done = _wait(agreed, settings.run_timeout)
    named = follows()
    counts: dict[int, int] = {}
    for value in named.values():
        if value is not None and value != master:
            counts[value] = counts.get(value, 0) + 1
    new = max(counts, key=lambda v: counts[v]) if counts else None
    firsts: dict[int, float] = {}
    for p in survivors:
        for line in logs.lines(p):
            if line["event"] == "master" and line.get("master") == new and new is not None:
                firsts.setdefault(p, float(line["t"]))
    claim = firsts.get(new, math.nan) if new is not None else math.nan
    run = FailoverRun(
        killed=master,
        new_master=new,
        to_claim_s=claim - killed_at,
        to_all_s=(max(firsts.values()) - killed_at)
        if done and len(firsts) == len(survivors)
        else math.nan,
        survivors=len(survivors),
        followed=len(firsts),
    )
    if not done:
        run.error = (
            f"after {settings.run_timeout:.0f} s not every survivor followed one new master: "
            f"{dict(sorted(named.items()))}"
        )
    # Back to a full swarm for the next repetition: the killed platform restarts from its
    # state directory (a new incarnation) and everyone must see everyone again.
    swarm.start(master)
    back = _wait(
        lambda: int(swarm.status(master).get("incarnation", -1)) > incarnation,
        settings.boot_timeout,
        poll=0.2,
    ) and wait_stable(swarm, settings.boot_timeout)
    run.master_after_restart = swarm.agreed_master() if back else None
    if not back:
        run.error += (" " if run.error else "") + (
            f"platform {master} restarted but the swarm did not agree again within "
            f"{settings.boot_timeout:.0f} s"
        )
    return run


def ground_session(swarm: LocalSwarm, lease: float | None = None) -> GroundSession:
    """A ground station for ``swarm`` in this process (enter it in a running event loop),
    connected to every daemon (or on its multicast group), with the swarm's keys when it is
    secure, and Zenoh's lease ``lease`` seconds (None: the default)."""
    from actorswarm.daemon.ground import GroundSession
    from actorswarm.security import PacketGuard, load_keys
    from actorswarm.transport.zenoh_transport import LEASE_MS, ZenohSettings

    lease_ms = LEASE_MS if lease is None else round(lease * 1000)
    guard = (
        PacketGuard.from_keys(load_keys(swarm.keys, need_private=True), role="ground")
        if swarm.secure
        else PacketGuard.insecure()
    )
    if swarm.group is not None:
        zenoh = ZenohSettings(
            multicast=False,
            broadcast="multicast",
            group=swarm.group,
            interface=swarm.interface,
            lease_ms=lease_ms,
        )
    else:
        zenoh = ZenohSettings(connect=tuple(swarm.endpoints), multicast=False, lease_ms=lease_ms)
    return GroundSession(swarm.swarm, zenoh, guard)


def switch_script(size: int) -> str:
    """The task script of the switch measurement for platforms ``1..size``."""
    idle = (
        "<OODAConfig><Bus><_P_Name>act_bus</_P_Name>"
        "<Plugin><_P_Name>core.idle</_P_Name></Plugin></Bus></OODAConfig>"
    )
    return f"""<TaskScript name="bench-switch" version="1">
  <_ActorsConfig>
    <Actor><_P_Name>A</_P_Name>{idle}</Actor>
    <Actor><_P_Name>B</_P_Name>{idle}</Actor>
  </_ActorsConfig>
  <_TaskConfig>
    <actor name="A">
      <transition name="{FORWARD[0]}" barrierKey="1" sysNum="all" timeout="30">
        <successor actor="B"/>
      </transition>
    </actor>
    <actor name="B">
      <transition name="{BACKWARD[0]}" barrierKey="2" sysNum="all" timeout="30">
        <successor actor="A"/>
      </transition>
    </actor>
  </_TaskConfig>
  <_PlatformActorConfig><platform id="1-{size}" actor="A"/></_PlatformActorConfig>
</TaskScript>
"""


async def run_switches(
    swarm: LocalSwarm,
    logs: LogTail,
    settings: Settings,
    result: SizeResult,
    progress: Progress,
) -> None:
    """Deploy and start the switch script from a ground station in this process, measure
    the resources while it runs, then fire ``go`` and ``back`` in turn. Appends to
    ``result``; a deployment or start that fails is recorded in ``result.errors``."""
    from actorswarm.ground.station import GroundStation

    size = swarm.size
    everyone = list(range(1, size + 1))
    data = switch_script(size).encode()
    (swarm.dir / "bench-switch.xml").write_bytes(data)
    async with ground_session(swarm, settings.lease) as gs:
        progress(f"N={size}: deploying the switch script")
        sha = gs.do(lambda st, now: st.deploy(data, everyone, now))
        if not await gs.wait_for(lambda: not gs.station.missing(sha), settings.boot_timeout):
            result.errors.append(f"deploy: not confirmed by {gs.station.missing(sha)}")
            return
        gs.do(lambda st, now: st.start(now))

        def in_a() -> bool:
            return set(everyone) <= set(gs.station.outcomes("Start")) and all(
                swarm.status(p).get("actors") == ["A"] for p in everyone
            )

        if not await gs.wait_for(in_a, settings.boot_timeout):
            result.errors.append(
                "start: not every platform running A: "
                + str({p: swarm.status(p).get("actors") for p in everyone})
            )
            return
        if settings.script_window:
            await asyncio.sleep(settings.settle)
            progress(f"N={size}: CPU and memory with the script running ({settings.window:.0f} s)")
            result.resources.append(await measure_resources(swarm, "script", settings.window))

        def swarm_cpu() -> int:
            total = 0
            for proc in swarm.procs.values():
                with contextlib.suppress(OSError):  # a daemon that died is not counted
                    total += read_cpu_ns(proc.pid)
            return total

        for i in range(settings.switches):
            event, src, dst = FORWARD if i % 2 == 0 else BACKWARD
            progress(f"N={size}: collective switch {i + 1}/{settings.switches} ({src} → {dst})")
            # The previous switch's acknowledgements settle, then the idle rate is taken.
            await asyncio.sleep(0.5)
            idle = (swarm_cpu(), clock())
            await asyncio.sleep(0.5)
            logs.mark()
            sent_at = clock()
            before = (swarm_cpu(), sent_at)

            def fire(st: GroundStation, now: float, event: str = event) -> None:
                st.event(event, now, platforms=everyone)

            gs.do(fire)

            def switched(event: str = event, dst: str = dst) -> dict[int, tuple[float, str]]:
                got: dict[int, tuple[float, str]] = {}
                for p in everyone:
                    for line in logs.lines(p):
                        if (
                            line["event"] == "transition"
                            and line.get("on") == event
                            and line.get("to") == dst
                        ):
                            got.setdefault(p, (float(line["at"]), str(line.get("cause"))))
                return got

            done = await gs.wait_for(lambda: len(switched()) == size, settings.run_timeout)
            got = switched()
            times = [t for t, _ in got.values()]
            causes: dict[str, int] = {}
            for _, cause in got.values():
                causes[cause] = causes.get(cause, 0) + 1
            await asyncio.sleep(_SWITCH_TAIL)  # the acknowledgements and backups after it
            run = SwitchRun(
                cpu_s=switch_cpu(idle, before, (swarm_cpu(), clock())) if done else math.nan,
                event=event,
                src=src,
                dst=dst,
                expected=size,
                switched=len(got),
                first_s=min(times) - sent_at if times else math.nan,
                last_s=max(times) - sent_at if done else math.nan,
                spread_s=max(times) - min(times) if done else math.nan,
                causes=causes,
            )
            if not done:
                run.error = (
                    f"after {settings.run_timeout:.0f} s only {len(got)} of {size} switched "
                    f"{src} → {dst}; missing {sorted(set(everyone) - set(got))}"
                )
                result.switch.append(run)
                return  # the swarm is split between A and B: later events would mislead
            result.switch.append(run)


def bench_size(
    directory: Path,
    size: int,
    settings: Settings,
    progress: Progress | None = None,
) -> SizeResult:
    """Every measurement on a fresh swarm of ``size`` daemons, files under ``directory``.
    Never raises for a swarm that misbehaves: what failed is in ``errors`` or the runs'
    ``error`` fields. The daemons are killed before it returns."""
    say = progress or (lambda _: None)
    result = SizeResult(size=size)
    began = time.perf_counter()
    rng = random.Random(f"bench-daemons:{settings.seed}:{size}")
    multicast = settings.broadcast == "multicast"
    with LocalSwarm(
        directory,
        size,
        swarm=f"bench{os.getpid()}n{size}",
        group=settings.group if multicast else None,
        interface=settings.interface if multicast else None,
        extra=() if settings.lease is None else ("--lease", str(settings.lease)),
        env=None if settings.daemons_from is None else daemons_env(settings.daemons_from),
    ) as swarm:
        say(f"N={size}: starting {size} daemons")
        booted_at = clock()
        swarm.start_all()
        if not wait_stable(swarm, settings.boot_timeout):
            # What the daemons cost while they try is still worth knowing (a machine too
            # small for the swarm is one reason it never settles); nothing else is.
            result.errors.append(
                f"boot: the swarm did not agree within {settings.boot_timeout:.0f} s: "
                f"{describe_swarm(swarm)} (`--dir` keeps the daemons' logs)"
            )
            say(f"N={size}: never agreed; CPU and memory anyway ({settings.window:.0f} s)")
            result.resources.append(
                asyncio.run(measure_resources(swarm, "idle, not settled", settings.window))
            )
            result.wall_s = time.perf_counter() - began
            return result
        result.boot_s = clock() - booted_at
        time.sleep(settings.settle)
        say(f"N={size}: CPU and memory at idle ({settings.window:.0f} s)")
        result.resources.append(asyncio.run(measure_resources(swarm, "idle", settings.window)))
        logs = LogTail(swarm)
        for i in range(settings.failovers):
            say(f"N={size}: master failover {i + 1}/{settings.failovers}")
            run = measure_failover(swarm, logs, settings, rng)
            result.failover.append(run)
            if run.error and not settled(swarm):
                result.errors.append(f"failover {i + 1}: the swarm did not recover; stopped")
                break
        if settled(swarm):
            asyncio.run(run_switches(swarm, logs, settings, result, say))
        else:
            result.errors.append("switch: skipped, the swarm was not whole")
    result.wall_s = time.perf_counter() - began
    return result


def daemons_env(checkout: str | Path) -> dict[str, str]:
    """The environment that makes a daemon run the source of ``checkout`` (its ``src`` first
    on ``PYTHONPATH``); ValueError when ``checkout`` holds no actorswarm source."""
    src = Path(checkout).resolve() / "src"
    if not (src / "actorswarm" / "__init__.py").is_file():
        raise ValueError(f"--daemons-from {checkout}: no actorswarm source in {src}")
    return {**os.environ, "PYTHONPATH": str(src)}


def bench(
    directory: Path,
    sizes: Sequence[int],
    settings: Settings,
    *,
    command: str = "",
    progress: Progress | None = None,
    done: Callable[[SizeResult], None] | None = None,
) -> BenchResult:
    """:func:`bench_size` for every size, each in its own subdirectory of ``directory``;
    ``done(result)`` after each size."""
    config = CoreConfig()
    began = time.perf_counter()
    result = BenchResult(
        command=command,
        settings=asdict(settings),
        machine=machine_info(),
        config={
            "heartbeat_interval": config.heartbeat_interval,
            "t_leave": config.t_leave,
        },
        sizes=[],
        started=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    )
    if settings.daemons_from is not None:
        result.machine["daemons"] = _source_version(Path(settings.daemons_from))
    for n in sizes:
        size_result = bench_size(directory / f"n{n}", n, settings, progress)
        result.sizes.append(size_result)
        if done is not None:
            done(size_result)
    result.wall_s = time.perf_counter() - began
    return result


# --- the report ---------------------------------------------------------------------------


def _finite(values: Sequence[float]) -> list[float]:
    return [v for v in values if not math.isnan(v)]


def p95(values: Sequence[float]) -> float:
    """The 95th percentile by nearest rank (with fewer than 20 values: the largest)."""
    clean = sorted(_finite(values))
    if not clean:
        return math.nan
    return clean[max(0, math.ceil(0.95 * len(clean)) - 1)]


def _ms(value: float) -> str:
    return "—" if math.isnan(value) else f"{value * 1000:.0f}"


def _ms_stats(values: Sequence[float]) -> str:
    """``median / p95 (min–max)`` in ms."""
    clean = _finite(values)
    if not clean:
        return "—"
    return (
        f"{_ms(statistics.median(clean))} / {_ms(p95(clean))} ({_ms(min(clean))}–{_ms(max(clean))})"
    )


def _cpu_per_switch(values: Sequence[float], size: int) -> str:
    """``median (min–max) (median per platform)`` in ms of CPU, or — when not measured."""
    clean = _finite(values)
    if not clean:
        return "—"
    mid = statistics.median(clean)
    return (
        f"{mid * 1e3:.0f} ({min(clean) * 1e3:.0f}–{max(clean) * 1e3:.0f}) ({mid / size * 1e3:.1f})"
    )


def _range(values: Sequence[float], digits: int) -> str:
    clean = _finite(values)
    if not clean:
        return "—"
    return (
        f"{statistics.median(clean):.{digits}f} ({min(clean):.{digits}f}–{max(clean):.{digits}f})"
    )


def _wakes(res: ResourceRun) -> str:
    """The members' median and the master's wakes per second ("—" when not measured)."""
    members, master = _finite(res.sleeps_of("members")), res.sleeps_of("master")
    if not members:
        return "—"
    median = f"{statistics.median(members):.0f}"
    return f"{median} / {master[0]:.0f}" if master else f"{median} / –"


def _verdict(values: Sequence[float], target: float, failed: int) -> str:
    """yes: every run within the target; "median only"; no."""
    clean = _finite(values)
    if not clean:
        return "**no** (nothing measured)"
    if max(clean) <= target and not failed:
        return "yes"
    if statistics.median(clean) <= target:
        return "**median only**" + (f"; {failed} failed run(s)" if failed else "")
    return "**no**"


def markdown(result: BenchResult) -> str:
    """The report: machine, settings, one table per measurement, then docs/design.md §8."""
    m, s, c = result.machine, result.settings, result.config
    t_leave = c["t_leave"]
    lines = [
        "# Real daemons on one machine (`actorswarm bench daemons`)",
        "",
        f"Command: `{result.command or 'actorswarm bench daemons'}`, started {result.started}, "
        f"{result.wall_s / 60:.1f} min in all.",
        "",
        f"Machine: {m['cpu_model']}, {m['cpus']} CPU(s), {m['memory_gib']} GiB, {m['os']}; "
        f"Python {m['python']}, eclipse-zenoh {m['zenoh']}; actorswarm {m['actorswarm']}"
        + (f"; **the daemons ran actorswarm {m['daemons']}**." if m.get("daemons") else "."),
        "",
        "Every daemon is a separate `actorswarm daemon` process on 127.0.0.1 (Zenoh peer mode, "
        + (
            "TCP, a full mesh of listed endpoints, no multicast, "
            if s.get("broadcast", "mesh") == "mesh"
            else f"everything on Zenoh's UDP multicast transport, group {s['group']} on "
            f"{s['interface']}, "
        )
        + "HMAC on every packet), "
        f"heartbeat {c['heartbeat_interval'] * 1000:.0f} ms, "
        f"T_leave {t_leave * 1000:.0f} ms. **All of them, the ground station and the bench "
        f"share the machine's {m['cpus']} CPU(s)**: at the larger sizes the machine is loaded "
        "(see the load average column), so these are figures of a crowded host, not of one "
        "robot's computer.",
        "",
        f"Settings: CPU window {s['window']:.0f} s, {s['failovers']} failovers and "
        f"{s['switches']} switches per size, timeout {s['run_timeout']:.0f} s per run; "
        "Zenoh session lease "
        + (f"{s['lease']:g} s." if s.get("lease") else "the daemons' default."),
        "",
        "## CPU and memory per daemon",
        "",
        "A swarm of N daemons: each has N − 1 peers (the *peers* column is what each view "
        "held at the end of the window). *idle*: no script, only heartbeats and membership; "
        "*script*: actor A running (one `core.idle` plugin at 10 Hz), ground station connected. "
        "CPU is `utime + stime` of every thread of the process over the window, in % of one "
        "core, of the members (every daemon but the master; median (min–max)) and of the "
        "master apart; RSS is `VmRSS` (private part `RssAnon`) at its end, median (min–max) "
        "over all the daemons. *wire/s*: packets `lo` received per second (the network namespace's "
        "loopback: run the bench in a namespace of its own to count the swarm alone); *sent/s*: "
        "packets the daemons sent per second (a broadcast counts once); their ratio is the "
        "packets on the wire per packet sent. *wakes/s*: how often a second the daemon's main "
        "thread went to sleep (its voluntary context switches: the loop's waits), members' "
        "median / the master's.",
        "",
        "| N | phase | peers | member CPU % of a core | master CPU % | wakes/s | RSS MiB "
        "| private MiB | all daemons, % of a core | load avg (1 min) | wire/s | sent/s "
        "| wire per sent |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in result.sizes:
        for res in r.resources:
            peers = sorted(set(res.peers))
            master = res.cpu_of("master")
            lines.append(
                f"| {r.size} | {res.phase} | {', '.join(map(str, peers))} "
                f"| {_range(res.cpu_of('members'), 2)} "
                f"| {f'{master[0]:.2f} (platform {res.master})' if master else '–'} "
                f"| {_wakes(res)} "
                f"| {_range(res.rss_mib, 1)} "
                f"| {_range(res.rss_anon_mib, 1)} | {sum(res.cpu_pct):.0f} "
                f"| {res.loadavg_1min:.1f} | {res.wire_packets_s:.0f} "
                f"| {res.sent_packets_s:.0f} "
                f"| {_ratio(res.wire_packets_s, res.sent_packets_s)} |"
            )
    capacity = 100.0 * max(1, int(m["cpus"]))
    crowded = [
        f"N={r.size} ({res.phase}: {sum(res.cpu_pct):.0f} %)"
        for r in result.sizes
        for res in r.resources
        if sum(res.cpu_pct) >= 0.8 * capacity
    ]
    if crowded:
        lines += [
            "",
            f"**CPU was scarce** at {', '.join(crowded)} of the {capacity:.0f} % the machine "
            "has: there the per-daemon figure is what each daemon got, and less than it would "
            "use on a computer of its own.",
        ]
    lines += [
        "",
        "## Master failover",
        "",
        "SIGKILL to the agreed master's daemon; times from the bench's clock just before the "
        "signal. *claim*: the new master's own `master` log line; *all follow*: the last "
        "survivor's line naming the new master. median / p95 (min–max), ms; p95 by nearest "
        "rank, which is the worst run when there are fewer than 20.",
        "",
        "*Took it back*: runs after which the killed platform, restarted, became master "
        "again (a second change of master the swarm went through; see below).",
        "",
        "| N | runs | failed | masters killed | claim, ms | all follow, ms | took it back |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in result.sizes:
        failed = sum(1 for f in r.failover if f.error or math.isnan(f.to_all_s))
        killed = ", ".join(str(f.killed) for f in r.failover)
        back = sum(1 for f in r.failover if f.master_after_restart == f.killed)
        lines.append(
            f"| {r.size} | {len(r.failover)} | {failed} | {killed} "
            f"| {_ms_stats([f.to_claim_s for f in r.failover])} "
            f"| {_ms_stats([f.to_all_s for f in r.failover])} | {back} of {len(r.failover)} |"
        )
    back_runs = [
        (r.size, f) for r in result.sizes for f in r.failover if f.master_after_restart == f.killed
    ]
    if back_runs:
        lines += [
            "",
            f"In {len(back_runs)} run(s) the restarted platform took the master role back "
            "although election is sticky (docs/design.md §3.2). Its log shows how: it names "
            "itself master within a second of starting, before its Zenoh links to the others "
            "are up; when they come up the two masters meet and the lower ID keeps the role, "
            "so the swarm changes master a second time, seconds after the restart.",
        ]
    lines += [
        "",
        "## Collective switch",
        "",
        "The ground station (in the bench process) sends the event to every platform; each "
        "platform's engine asks the master for the barrier, the master releases all with one "
        "message. *last*: send → the latest platform's transition (the switch time); *first*: "
        "send → the earliest; *spread*: first → last platform. median / p95 (min–max), ms. "
        "*Swarm CPU*: what every daemon together spent on the switch, from the send to "
        f"{_SWITCH_TAIL * 1000:.0f} ms after the last platform switched, less its idle rate "
        "measured in the half second before (per platform in brackets); divided by the "
        "machine's cores, about the least time the switch can take when every daemon shares "
        "them (less the part spent after the last platform switched).",
        "",
        "| N | runs | failed | last (switch time), ms | first, ms | spread, ms "
        "| swarm CPU, ms (per platform) | causes |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in result.sizes:
        failed = sum(1 for w in r.switch if w.error)
        causes: dict[str, int] = {}
        for w in r.switch:
            for k, v in w.causes.items():
                causes[k] = causes.get(k, 0) + v
        lines.append(
            f"| {r.size} | {len(r.switch)} | {failed} "
            f"| {_ms_stats([w.last_s for w in r.switch])} "
            f"| {_ms_stats([w.first_s for w in r.switch])} "
            f"| {_ms_stats([w.spread_s for w in r.switch])} "
            f"| {_cpu_per_switch([w.cpu_s for w in r.switch], r.size)} "
            f"| {', '.join(f'{k} {v}' for k, v in sorted(causes.items())) or '—'} |"
        )
    lines += ["", *_against_design(result), ""]
    problems = [f"- N={r.size}: {e}" for r in result.sizes for e in r.errors]
    problems += [
        f"- N={r.size}: failover of platform {f.killed}: {f.error}"
        for r in result.sizes
        for f in r.failover
        if f.error
    ]
    problems += [
        f"- N={r.size}: switch {w.src} → {w.dst}: {w.error}"
        for r in result.sizes
        for w in r.switch
        if w.error
    ]
    lines += ["## Problems during the run", ""]
    lines += problems or ["None: every run completed."]
    return "\n".join(lines) + "\n"


def _ratio(wire: float, sent: float) -> str:
    return f"{wire / sent:.1f}" if sent > 0 and not math.isnan(wire) else "–"


def _scarce(res: ResourceRun, cpus: int) -> bool:
    """Whether the daemons together used most of the machine in this window (then each
    got less CPU than it asked for)."""
    return sum(res.cpu_pct) >= 0.8 * 100.0 * max(1, cpus)


def cpu_fit(result: BenchResult) -> tuple[float, float, list[int]] | None:
    """CPU % per daemon at idle as ``a + b × peers``, least squares over the medians of the
    sizes that settled and where CPU was not scarce: (a, b, sizes used), or None with fewer
    than two such sizes."""
    cpus = int(result.machine.get("cpus") or 1)
    points = [
        (float(r.size - 1), statistics.median(res.cpu_pct), r.size)
        for r in result.sizes
        for res in r.resources
        if res.phase == "idle" and res.cpu_pct and not _scarce(res, cpus)
    ]
    if len({x for x, _, _ in points}) < 2:
        return None
    xs, ys = [x for x, _, _ in points], [y for _, y, _ in points]
    slope, intercept = statistics.linear_regression(xs, ys)
    return intercept, slope, [n for _, _, n in points]


def _against_design(result: BenchResult) -> list[str]:
    """The rows of docs/design.md §8 these measurements speak to, with a plain verdict."""
    t_leave = result.config["t_leave"]
    cpus = int(result.machine.get("cpus") or 1)
    failover_target = t_leave + 0.1
    switch_target = 0.005  # 3 x loopback's one-way latency (microseconds) + 5 ms
    biggest = max(result.sizes, key=lambda r: r.size, default=None)
    lines = [
        "## Against docs/design.md §8",
        "",
        "| measure | paper | target | measured | met? |",
        "|---|---|---|---|---|",
    ]
    if biggest is None:
        return lines
    # The largest swarm, and the largest that settled when that one did not: a swarm that
    # never agreed says what the daemons cost while trying, not what a working one costs.
    shown = [biggest]
    settled_sizes = [r for r in result.sizes if not math.isnan(r.boot_s)]
    if math.isnan(biggest.boot_s) and settled_sizes:
        shown.insert(0, max(settled_sizes, key=lambda r: r.size))
    rows = [(r.size, res) for r in shown for res in r.resources]
    for n, res in rows:
        scarce = " (CPU scarce: what it got)" if _scarce(res, cpus) else ""
        members = res.cpu_of("members")
        lines.append(
            f"| CPU per member, {res.phase}, N={n} ({n - 1} peers) | 0.25–1.1 % | ≤ 1 % of a "
            f"core at 30 peers | median {statistics.median(members):.2f} %, max "
            f"{max(members):.2f} %{scarce} | {_verdict(members, 1.0, 0)} |"
        )
        master = res.cpu_of("master")
        lines.append(
            f"| CPU of the master, {res.phase}, N={n} | 0.25–1.1 % | ≤ 3 % of a core at 30 "
            "peers | "
            + (
                f"{master[0]:.2f} %{scarce} | {_verdict(master, 3.0, 0)} |"
                if master
                else "no agreed master at the window's end | **no** |"
            )
        )
        megabytes = [v * 2**20 / 1e6 for v in res.rss_mib]
        lines.append(
            f"| RSS per daemon, {res.phase}, N={n} | 26–32 MB | ≤ 40 MB | median "
            f"{statistics.median(megabytes):.1f} MB, max {max(megabytes):.1f} MB "
            f"| {_verdict(megabytes, 40.0, 0)} |"
        )
    fit = cpu_fit(result)
    if fit is not None:
        a, b, used = fit
        at30 = a + b * 30
        lines.append(
            f"| CPU per daemon at idle, extrapolated to 30 peers from N="
            f"{', '.join(map(str, used))} | 0.25–1.1 % | ≤ 1 % of a core | {a:.2f} % + "
            f"{b:.2f} % per peer → {at30:.1f} % | {'yes' if at30 <= 1.0 else '**no**'} |"
        )
    for r in result.sizes:
        values = [f.to_all_s for f in r.failover]
        failed = sum(1 for f in r.failover if f.error or math.isnan(f.to_all_s))
        lines.append(
            f"| new master after master failure, N={r.size} (all follow) | 382–909 ms "
            f"| ≤ T_leave + 100 ms = {failover_target * 1000:.0f} ms, flat in N "
            f"| {_ms_stats(values)} | {_verdict(values, failover_target, failed)} |"
        )
    for r in result.sizes:
        values = [w.last_s for w in r.switch]
        failed = sum(1 for w in r.switch if w.error)
        lines.append(
            f"| collective switch, N={r.size} | 1332 ms (30 platforms) | ≤ 3 × one-way "
            f"latency + 5 ms ≈ {switch_target * 1000:.0f} ms on loopback | {_ms_stats(values)} "
            f"| {_verdict(values, switch_target, failed)} |"
        )
    settled = [r.size for r in result.sizes if not math.isnan(r.boot_s)]
    unsettled = [r.size for r in result.sizes if math.isnan(r.boot_s)]
    measured = f"largest swarm that settled: {max(settled) if settled else 'none'}"
    if unsettled:
        measured += f"; never settled: N={', '.join(map(str, unsettled))}"
    lines.append(
        f"| real processes on one host | 10 in field | 50 | {measured} | "
        + ("yes" if settled and max(settled) >= 50 else "**no** (not at 50)")
        + " |"
    )
    medians = [
        (r.size, statistics.median(v))
        for r in result.sizes
        if (v := _finite([f.to_all_s for f in r.failover]))
    ]
    if len(medians) >= 2:
        (n0, lo), (n1, hi) = medians[0], medians[-1]
        lines += [
            "",
            f"Failover in swarm size: median {_ms(lo)} ms at N={n0}, {_ms(hi)} ms at N={n1} "
            f"({(hi - lo) * 1000:+.0f} ms).",
        ]
    return lines


def from_json(data: dict[str, Any]) -> BenchResult:
    """A result back from :func:`to_json` (to render a saved run again); null times come
    back as NaN. KeyError or TypeError for data of another shape."""

    def nan(value: Any) -> Any:
        return math.nan if value is None else value

    sizes = [
        SizeResult(
            size=int(row["size"]),
            boot_s=nan(row["boot_s"]),
            resources=[
                ResourceRun(
                    **{
                        **res,
                        # Absent from runs saved before they were measured.
                        "wire_packets_s": nan(res.get("wire_packets_s")),
                        "sent_packets_s": nan(res.get("sent_packets_s")),
                    }
                )
                for res in row["resources"]
            ],
            failover=[
                FailoverRun(
                    **{**f, "to_claim_s": nan(f["to_claim_s"]), "to_all_s": nan(f["to_all_s"])}
                )
                for f in row["failover"]
            ],
            switch=[
                SwitchRun(
                    **{
                        **w,
                        "first_s": nan(w["first_s"]),
                        "last_s": nan(w["last_s"]),
                        "spread_s": nan(w["spread_s"]),
                        "cpu_s": nan(w.get("cpu_s")),  # absent from older runs
                    }
                )
                for w in row["switch"]
            ],
            errors=list(row["errors"]),
            wall_s=float(row["wall_s"]),
        )
        for row in data["sizes"]
    ]
    return BenchResult(
        command=str(data["command"]),
        settings=dict(data["settings"]),
        machine=dict(data["machine"]),
        config=dict(data["config"]),
        sizes=sizes,
        started=str(data["started"]),
        wall_s=float(data["wall_s"]),
    )


def to_json(result: BenchResult) -> dict[str, Any]:
    """Everything measured, run by run (NaN, for what was not measured, as null)."""

    def clean(value: Any) -> Any:
        if isinstance(value, float) and math.isnan(value):
            return None
        if isinstance(value, dict):
            return {k: clean(v) for k, v in value.items()}
        if isinstance(value, list):
            return [clean(v) for v in value]
        return value

    data: dict[str, Any] = clean(asdict(result))
    return data
