"""The paper's Tables I–III with real daemon processes (``mode="real"``) on this machine.

Each swarm is a :class:`~actorswarm.daemon.launch.LocalSwarm` (``actorswarm daemon``
processes over Zenoh on loopback, packets authenticated); a ground station in this process
(:func:`~actorswarm.bench.daemons.ground_session`) deploys the scripts and fires the events.
Every time compared is CLOCK_MONOTONIC (:func:`~actorswarm.daemon.loop.clock`), which the
daemons stamp their log lines with; the traffic figures are the daemons' own counters of
what went through Zenoh (:class:`~actorswarm.daemon.loop.Traffic`), logged with the
``command``, ``transition`` and ``fired`` lines (:mod:`actorswarm.daemon.run`).

* **Table I** — one swarm of ``peers + 1`` daemons, started once and reused for every plugin
  count: each count deploys a new script version (:func:`~.scripts.table1_script`, actors named
  after the count so the new version replaces the old actors) in which every platform alternates
  ``A ⇄ B`` every second by local events (one platform per transition: a barrier of one,
  through the master). After ``settle`` seconds, ``repeat`` windows of ``window`` seconds on
  platform 2 (platform 1 in a swarm of one): ``cpu_pct`` is its ``utime + stime`` (every
  thread) over the window in % of one core; ``rss_mib`` its ``VmRSS`` at the window's end;
  ``switch_ms`` every ``switched`` line it logged in the window — its runtime's single Actor
  switch time, from the switch call to the end of the new actor's first OODA step. No ground
  station is connected during the windows.
* **Table II** — one swarm per size, each plugin count a new script version
  (:func:`~.scripts.table2_script`). ``switch``: the event goes to every platform, which switch
  ``A → B`` on one barrier of the whole swarm (``sysNum="all"``), the next repetition
  ``B → A``. ``branch``: ``split`` goes to two platforms drawn from a seeded generator, which
  branch ``A → C`` together (``sysNum="2"``); ``rejoin`` (not measured) brings them back.
  One sample per repetition:

  - ``transition_ms``: the bench's clock just before the event is sent → the latest
    ``transition`` line (its loop time) of the platforms that switch;
  - ``master_pps``: the master's packets sent + received from its ``command`` line (the
    counters when the wake that carried out the event began) to its ``fired`` line for the
    group (the counters after the release went out), divided by the time between them.
    In the branch case a master that is not one of the two is sent the event too, limited
    to the actor ``C`` it does not run: it skips it, but its ``command`` line marks when the
    ground station's event reached it;
  - ``member_pps``: the same for each switching non-master, from its ``command`` line to its
    ``transition`` line, averaged over them (``switch``: every non-master; ``branch``: the
    chosen ones that are not the master);
  - ``bytes_per_packet``: the bytes over the packets (sent and received) of all those
    windows together;
  - ``master_packets`` / ``member_packets``: the packets behind the two rates.

  Every daemon's window is its own (from when the event reached it to when it was done),
  so a non-master that takes no part — the branch case's bystanders — has none and is not
  counted.

* **Table III** — on the same swarm after Table II, ``repeat`` ×
  :func:`~actorswarm.bench.daemons.measure_failover`: SIGKILL to the agreed master;
  ``election_ms`` is the kill → the last survivor's ``master`` line naming the new master.

A repetition that fails is a NaN sample and a line in its row's ``errors``; nothing here
raises for a swarm that misbehaves. After a failed transition the platforms are forced back
home (``Force``) before the next repetition; if even that fails, the rest of the row is
recorded as not run. Each finished or failed repetition advances ``progress`` by one.
"""

from __future__ import annotations

import asyncio
import math
import os
import random
import statistics
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from actorswarm.bench.daemons import (
    LogTail,
    deploy,
    describe_swarm,
    ground_session,
    measure_failover,
    read_cpu_seconds,
    read_memory_kib,
    settled,
    wait_stable,
)
from actorswarm.bench.scripts import (
    BACK,
    GO,
    REJOIN,
    SPLIT,
    actor_names,
    table1_script,
    table2_script,
)
from actorswarm.bench.tables import (
    Plan,
    Progress,
    Rows,
    Table1Row,
    Table2Row,
    Table2Sample,
    Table3Row,
    TableSettings,
    quiet,
    record_sample,
    sample_lists,
    table1_units,
)
from actorswarm.daemon.launch import LocalSwarm
from actorswarm.daemon.loop import clock
from actorswarm.engine import commands as cmds

if TYPE_CHECKING:
    from actorswarm.daemon.ground import GroundSession
    from actorswarm.ground.station import GroundStation

__all__ = [
    "DaemonBackend",
    "real_table1",
    "real_table23",
    "table23_units",
]

NAN = math.nan

#: Quiet time before each transition, so the previous one's acknowledgements are done.
_GAP = 1.0
#: Table I: each actor runs this long (seconds of running time) before it hands over.
_PERIOD = 1.0
_STUCK = "the platforms could not be forced home; the rest of the row was not run"
#: How long a master's ``fired`` line may trail the last platform's transition line.
_FIRED_GRACE = 2.0


@dataclass(frozen=True, slots=True)
class DaemonBackend:
    """The tables with real daemons (a :class:`~actorswarm.bench.tables.Backend`): how
    much to measure, where the daemons keep their state, and how long to wait for them.
    Times are seconds; Table I's ``window`` is the measured daemon's CPU window."""

    settings: TableSettings = field(default_factory=TableSettings)
    #: :meth:`rows` keeps the daemons' state and logs under it.
    directory: Path = Path()
    #: Waiting for a swarm to agree (every view full, one master), for a deployment to be
    #: confirmed and started, and for a restarted daemon to be taken back.
    boot_timeout: float = 240.0
    #: Waiting for a transition to reach every platform, and for a new master.
    run_timeout: float = 15.0
    #: Quiet time after a script starts, before measuring.
    settle: float = 2.0

    @property
    def mode(self) -> str:
        return "real"

    def units(self, plan: Plan) -> int:
        """One per repetition: of Table I's plugin counts, of Table II's cases, plugin counts
        and sizes, of Table III's failovers at each size."""
        tables = frozenset(plan.tables)
        units = table1_units(plan.plugins, self.settings) if "1" in tables else 0
        return units + table23_units(plan.sizes, plan.plugins, self, tables)

    def rows(self, plan: Plan, progress: Progress) -> Iterator[Rows]:
        """Table I on one swarm, then Tables II and III on one swarm per size."""
        if "1" in plan.tables:
            yield real_table1(self.directory / "table1", plan.plugins, self, progress)
        tables23 = frozenset(t for t in plan.tables if t in ("2", "3"))
        if tables23:
            rows2, rows3 = real_table23(
                self.directory / "table23", plan.sizes, plan.plugins, self, tables23, progress
            )
            yield [*rows2, *rows3]


def table23_units(
    sizes: Sequence[int],
    plugins: Sequence[int],
    backend: DaemonBackend,
    tables: frozenset[str],
) -> int:
    """The progress units :func:`real_table23` reports: one per repetition of each case,
    plugin count and size (Table II), one per failover and size (Table III)."""
    repeat = backend.settings.repeat
    units = len(sizes) * len(plugins) * 2 * repeat if "2" in tables else 0
    return units + (len(sizes) * repeat if "3" in tables else 0)


# --- shared steps --------------------------------------------------------------------------


def _boot(swarm: LocalSwarm, backend: DaemonBackend) -> str:
    """Start every daemon and wait until they agree; "" or why not."""
    swarm.start_all()
    if wait_stable(swarm, backend.boot_timeout):
        return ""
    return (
        f"boot: the swarm of {swarm.size} did not agree within {backend.boot_timeout:.0f} s: "
        f"{describe_swarm(swarm)}"
    )


def _not_run(samples: list[list[float]], count: int, progress: Progress, message: str) -> None:
    """``count`` repetitions that could not run: NaN in every sample list, progress."""
    for _ in range(count):
        for values in samples:
            values.append(NAN)
        progress(message, advance=1)


# --- Table I -------------------------------------------------------------------------------


def real_table1(
    directory: Path,
    plugins: Sequence[int],
    backend: DaemonBackend,
    progress: Progress = quiet,
) -> list[Table1Row]:
    """Table I with ``peers + 1`` daemons under ``directory`` (see the module docstring):
    one row per plugin count, ``repeat`` windows each. The daemons are stopped before it
    returns."""
    rows = [Table1Row(mode="real", plugins=n, peers=backend.settings.peers) for n in plugins]
    if not rows:
        return rows
    size = backend.settings.peers + 1
    measured = 2 if size >= 2 else 1
    with LocalSwarm(directory / "table1", size, swarm=f"t1x{os.getpid()}") as swarm:
        progress(f"real table I: starting {size} daemons")
        failed = _boot(swarm, backend)
        if failed:
            for row in rows:
                row.errors.append(failed)
                _not_run([row.cpu_pct, row.rss_mib], backend.settings.repeat, progress, failed)
            return rows
        logs = LogTail(swarm)
        for row in rows:
            _table1_row(swarm, logs, row, measured, backend, progress)
    return rows


def _table1_row(
    swarm: LocalSwarm,
    logs: LogTail,
    row: Table1Row,
    measured: int,
    backend: DaemonBackend,
    progress: Progress,
) -> None:
    a, b, _ = actor_names(row.plugins)
    label = f"real table I: {row.plugins} plugin(s)"
    progress(f"{label}: deploying the alternating script")

    def alternating(actors: list[str]) -> bool:
        return actors in ([a], [b])

    async def start() -> str:
        async with ground_session(swarm) as gs:
            return await deploy(
                gs,
                swarm,
                table1_script(swarm.size, row.plugins, _PERIOD),
                f"table1-p{row.plugins}",
                alternating,
                backend.boot_timeout,
            )

    failed = asyncio.run(start())
    if failed:
        row.errors.append(failed)
        _not_run([row.cpu_pct, row.rss_mib], backend.settings.repeat, progress, f"{label}: not run")
        return
    time.sleep(backend.settle)  # the start's burst of work is not the steady state
    proc = swarm.procs[measured]
    for r in range(backend.settings.repeat):
        progress(
            f"{label}: window {r + 1}/{backend.settings.repeat} ({backend.settings.window:g} s)"
        )
        logs.mark()
        problem = ""
        try:
            cpu0, t0 = read_cpu_seconds(proc.pid), clock()
            time.sleep(backend.settings.window)
            cpu1, t1 = read_cpu_seconds(proc.pid), clock()
            rss_kib, _ = read_memory_kib(proc.pid)
            if proc.poll() is not None:
                raise OSError(f"the daemon exited with status {proc.returncode}")
            row.cpu_pct.append(100.0 * (cpu1 - cpu0) / (t1 - t0))
            row.rss_mib.append(rss_kib / 1024)
        except (OSError, ValueError) as exc:
            row.cpu_pct.append(NAN)
            row.rss_mib.append(NAN)
            problem = f"could not read platform {measured}'s process: {exc}"
        took = [
            float(line["took_ms"])
            for line in logs.lines(measured)
            if line["event"] == "switched" and isinstance(line.get("took_ms"), int | float)
        ]
        row.switch_ms += took
        if not took and not problem and backend.settings.window >= 1.5 * _PERIOD:
            # A window that long always holds a switch, unless the alternation stalled.
            problem = f"platform {measured} logged no switch (the alternation stalled?)"
        if problem:
            note = " (it was the master)" if swarm.agreed_master() == measured else ""
            row.errors.append(f"window {r + 1}: {problem}{note}")
        progress(f"{label}: window {r + 1} done", advance=1)


# --- Table II ------------------------------------------------------------------------------


_FAILED = Table2Sample(NAN, NAN, NAN, NAN, NAN, NAN)


def _first(lines: list[dict[str, Any]], **match: Any) -> dict[str, Any] | None:
    """The first line whose fields equal ``match``."""
    for line in lines:
        if all(line.get(k) == v for k, v in match.items()):
            return line
    return None


def _window(start: dict[str, Any], end: dict[str, Any]) -> tuple[float, int, int] | None:
    """(seconds, packets, bytes) between a ``command`` line (counters as its wake began, at
    its loop time ``at``) and a later line (counters after its wake, written at ``t``);
    None when the lines do not hold counters or the window is empty."""
    try:
        sp0, sb0, rp0, rb0 = (int(v) for v in start["traffic"])
        sp1, sb1, rp1, rb1 = (int(v) for v in end["traffic"])
        seconds = float(end["t"]) - float(start["at"])
    except (KeyError, TypeError, ValueError):
        return None
    if seconds <= 0:
        return None
    return seconds, (sp1 - sp0) + (rp1 - rp0), (sb1 - sb0) + (rb1 - rb0)


@dataclass(slots=True)
class _Table2:
    """Table II on one swarm of daemons, driven by one ground station: the switch and
    branch cases of each plugin count, repetition by repetition (see the module
    docstring)."""

    gs: GroundSession
    swarm: LocalSwarm
    logs: LogTail
    backend: DaemonBackend
    rng: random.Random
    progress: Progress

    @property
    def everyone(self) -> list[int]:
        return list(range(1, self.swarm.size + 1))

    async def rows(self, switch_row: Table2Row, branch_row: Table2Row) -> None:
        """Both cases of one plugin count, on a new version of the script."""
        size, count, backend = self.swarm.size, switch_row.plugins, self.backend
        a, b, c = actor_names(count)
        label = f"real table II: N={size}, {count} plugin(s)"
        self.progress(f"{label}: deploying")
        failed = await deploy(
            self.gs,
            self.swarm,
            table2_script(size, count),
            f"table2-p{count}",
            lambda actors: actors == [a],
            backend.boot_timeout,
        )
        if failed:
            for row in (switch_row, branch_row):
                row.errors.append(failed)
                _not_run(
                    sample_lists(row), backend.settings.repeat, self.progress, f"{label}: not run"
                )
            return
        await asyncio.sleep(backend.settle)
        await self.switch_case(switch_row, a, b)
        await self.branch_case(branch_row, a, c)

    async def transition(
        self, event: tuple[str, int], dst: str, targets: list[int], master: int
    ) -> tuple[Table2Sample, str]:
        """Send ``event`` to ``targets`` and measure their switch to ``dst``: the sample,
        and "" or what went wrong (then some fields are NaN)."""
        timeout = self.backend.run_timeout
        name, key = event
        await asyncio.sleep(_GAP)
        self.logs.mark()
        if master not in targets:
            # Sent first, limited to an actor the master does not run: it skips the event,
            # and its command line marks when the event reached it (see the module docstring).
            def mark_master(st: GroundStation, now: float) -> None:
                st.event(name, now, platforms=[master], actors=[dst])

            self.gs.do(mark_master)
        sent_at = clock()

        def fire(st: GroundStation, now: float) -> None:
            st.event(name, now, platforms=targets)

        self.gs.do(fire)

        def switched() -> dict[int, dict[str, Any]]:
            got = {}
            for p in targets:
                line = _first(self.logs.lines(p), event="transition", on=name, to=dst)
                if line is not None:
                    got[p] = line
            return got

        def fired() -> dict[str, Any] | None:
            return _first(self.logs.lines(master), event="fired", key=key)

        if not await self.gs.wait_for(lambda: len(switched()) == len(targets), timeout):
            missing = sorted(set(targets) - set(switched()))
            return _FAILED, (
                f"{name}: after {timeout:g} s platforms {missing} had not switched to {dst} "
                f"(of {targets})"
            )
        await self.gs.wait_for(lambda: fired() is not None, _FIRED_GRACE)
        ends = switched()
        transition_ms = (max(float(line["at"]) for line in ends.values()) - sent_at) * 1000
        problems: list[str] = []
        packets = octets = 0

        def window(platform: int, end: dict[str, Any] | None, what: str) -> tuple[float, float]:
            """(packets per second, packets) of ``platform`` from its command line to ``end``."""
            nonlocal packets, octets
            start = _first(self.logs.lines(platform), event="command", command="Inject", on=name)
            span = None if start is None or end is None else _window(start, end)
            if span is None:
                problems.append(
                    f"no traffic window for platform {platform} ({what}): "
                    f"command line {'found' if start else 'missing'}, "
                    f"end line {'found' if end else 'missing'}"
                    + ("" if start is None or end is None else ", ending before it began")
                )
                return NAN, NAN
            seconds, n, size = span
            packets += n
            octets += size
            return n / seconds, n

        end = fired()
        if end is not None and end.get("outcome") != "complete":
            problems.append(f"the master released {name} with outcome {end.get('outcome')}")
        master_pps, master_packets = window(master, end, "master")
        members = [window(p, ends[p], "member") for p in targets if p != master]

        def mean(values: list[float]) -> float:
            # Over every switching non-master, or not at all: a partial mean would mislead.
            return statistics.fmean(values) if values and not any(map(math.isnan, values)) else NAN

        sample = Table2Sample(
            transition_ms=transition_ms,
            master_pps=master_pps,
            member_pps=mean([rate for rate, _ in members]),
            bytes_per_packet=octets / packets if packets else NAN,
            master_packets=master_packets,
            member_packets=mean([n for _, n in members]),
        )
        return sample, "; ".join(problems)

    async def home(self, home: str) -> bool:
        """Force every platform back to actor ``home`` (after a transition that went wrong)
        and wait until their status files say so."""

        def force(st: GroundStation, now: float) -> None:
            st.send(cmds.Force(to=home), self.everyone, now)

        self.gs.do(force)
        return await self.gs.wait_for(
            lambda: all(self.swarm.status(p).get("actors") == [home] for p in self.everyone),
            self.backend.run_timeout,
        )

    async def master(self) -> int | None:
        await self.gs.wait_for(
            lambda: self.swarm.agreed_master() is not None, self.backend.run_timeout
        )
        return self.swarm.agreed_master()

    def not_run(self, row: Table2Row, count: int, label: str) -> None:
        _not_run(sample_lists(row), count, self.progress, f"{label}: not run")

    async def repetition(
        self, row: Table2Row, i: int, what: tuple[tuple[str, int], str, list[int]], label: str
    ) -> tuple[Table2Sample, int] | None:
        """Repetition ``i`` of ``row``: ``what`` = (event, the actor to switch to, the
        platforms it is sent to). Records the sample (and what went wrong) in ``row``;
        returns it with the master it was measured against, or None when there was no
        master to measure against (the rest of the row is then recorded as not run)."""
        event, dst, targets = what
        master = await self.master()
        if master is None:
            row.errors.append(f"repetition {i + 1}: no agreed master")
            self.not_run(row, self.backend.settings.repeat - i, label)
            return None
        sample, problem = await self.transition(event, dst, targets, master)
        record_sample(row, sample)
        self.progress(f"{label} {i + 1} done", advance=1)
        if problem:
            where = "" if len(targets) == self.swarm.size else f" (platforms {targets})"
            row.errors.append(f"repetition {i + 1}{where}: {problem}")
        return sample, master

    async def stuck(self, row: Table2Row, i: int, home: str, label: str) -> bool:
        """After repetition ``i`` went wrong: force everyone home; when even that fails,
        the rest of ``row`` is recorded as not run (True)."""
        if await self.home(home):
            return False
        row.errors.append(f"after repetition {i + 1}: {_STUCK}")
        self.not_run(row, self.backend.settings.repeat - i - 1, label)
        return True

    async def switch_case(self, row: Table2Row, a: str, b: str) -> None:
        label = f"real table II: N={self.swarm.size}, {row.plugins} plugin(s), switch"
        repeat = self.backend.settings.repeat
        at = a  # where every platform is
        for i in range(repeat):
            event, dst = (GO, b) if at == a else (BACK, a)
            self.progress(f"{label} {i + 1}/{repeat} ({at} → {dst})")
            measured = await self.repetition(row, i, (event, dst, self.everyone), label)
            if measured is None:
                return
            if not math.isnan(measured[0].transition_ms):
                at = dst
            elif await self.stuck(row, i, a, label):
                return
            else:
                at = a
        if at != a:  # home for the branch case, unmeasured
            master = await self.master() or 1
            back, _ = await self.transition(BACK, a, self.everyone, master)
            if math.isnan(back.transition_ms):  # not every platform came back: force them
                await self.home(a)

    async def branch_case(self, row: Table2Row, a: str, c: str) -> None:
        label = f"real table II: N={self.swarm.size}, {row.plugins} plugin(s), branch"
        repeat = self.backend.settings.repeat
        if self.swarm.size < 2:
            row.errors.append("a branch needs at least two platforms")
            self.not_run(row, repeat, label)
            return
        for i in range(repeat):
            chosen = sorted(self.rng.sample(self.everyone, 2))
            self.progress(f"{label} {i + 1}/{repeat} (platforms {chosen[0]} and {chosen[1]})")
            measured = await self.repetition(row, i, (SPLIT, c, chosen), label)
            if measured is None:
                return
            sample, master = measured
            back_ok = False
            if not math.isnan(sample.transition_ms):
                back, _ = await self.transition(REJOIN, a, chosen, master)
                back_ok = not math.isnan(back.transition_ms)
            if not back_ok and await self.stuck(row, i, a, label):
                return


# --- Tables II and III ---------------------------------------------------------------------


def real_table23(
    directory: Path,
    sizes: Sequence[int],
    plugins: Sequence[int],
    backend: DaemonBackend,
    tables: frozenset[str] = frozenset({"2", "3"}),
    progress: Progress = quiet,
) -> tuple[list[Table2Row], list[Table3Row]]:
    """Tables II and/or III (``tables`` holds ``"2"``, ``"3"``) with one swarm of daemons
    per size under ``directory`` (see the module docstring). Table II has a ``switch`` and a
    ``branch`` row per size and plugin count; Table III one row per size. The daemons are
    stopped before it returns."""
    table2: list[Table2Row] = []
    table3: list[Table3Row] = []
    for size in sizes:
        pairs = (
            [
                (
                    Table2Row(mode="real", case="switch", size=size, plugins=n),
                    Table2Row(mode="real", case="branch", size=size, plugins=n),
                )
                for n in plugins
            ]
            if "2" in tables
            else []
        )
        row3 = Table3Row(mode="real", size=size) if "3" in tables else None
        _one_size(directory / f"n{size}", size, pairs, row3, backend, progress)
        table2 += [row for pair in pairs for row in pair]
        if row3 is not None:
            table3.append(row3)
    return table2, table3


def _one_size(
    directory: Path,
    size: int,
    pairs: list[tuple[Table2Row, Table2Row]],
    row3: Table3Row | None,
    backend: DaemonBackend,
    progress: Progress,
) -> None:
    if not pairs and row3 is None:
        return
    rng = random.Random(f"tables-real:{backend.settings.seed}:{size}")
    with LocalSwarm(directory, size, swarm=f"t23x{os.getpid()}n{size}") as swarm:
        progress(f"real tables II/III: starting {size} daemons")
        failed = _boot(swarm, backend)
        if failed:
            for row in [r for pair in pairs for r in pair]:
                row.errors.append(failed)
                _not_run(sample_lists(row), backend.settings.repeat, progress, f"N={size}: not run")
            if row3 is not None:
                row3.errors.append(failed)
                _not_run(
                    [row3.election_ms], backend.settings.repeat, progress, f"N={size}: not run"
                )
            return
        logs = LogTail(swarm)

        async def table2() -> None:
            async with ground_session(swarm) as gs:
                table = _Table2(gs, swarm, logs, backend, rng, progress)
                for switch_row, branch_row in pairs:
                    await table.rows(switch_row, branch_row)

        if pairs:
            asyncio.run(table2())
        if row3 is not None:
            _table3(swarm, logs, row3, backend, rng, progress)


def _table3(
    swarm: LocalSwarm,
    logs: LogTail,
    row: Table3Row,
    backend: DaemonBackend,
    rng: random.Random,
    progress: Progress,
) -> None:
    label = f"real table III: N={swarm.size}"
    if swarm.size < 2:
        row.errors.append("a failover needs at least two platforms")
        _not_run([row.election_ms], backend.settings.repeat, progress, f"{label}: not run")
        return
    for i in range(backend.settings.repeat):
        progress(f"{label}: master failover {i + 1}/{backend.settings.repeat}")
        run = measure_failover(swarm, logs, backend, rng)
        row.election_ms.append(NAN if math.isnan(run.to_all_s) else run.to_all_s * 1000)
        if run.error:
            row.errors.append(f"failover {i + 1} (platform {run.killed} killed): {run.error}")
        progress(f"{label}: failover {i + 1} done", advance=1)
        if run.error and not settled(swarm):
            row.errors.append(f"after failover {i + 1}: the swarm did not recover; stopped")
            _not_run(
                [row.election_ms], backend.settings.repeat - i - 1, progress, f"{label}: not run"
            )
            return
