"""Measuring a settled swarm of real daemons: its CPU and memory over a window, a master
failover after ``kill -9``, and collective switches fired from a ground station in this
process. Nothing here raises for a swarm that misbehaves: what went wrong is recorded in the
run's ``error`` (or the size's ``errors``)."""

from __future__ import annotations

import asyncio
import contextlib
import math
import os
import random
import time
from collections import Counter
from collections.abc import Callable
from typing import TYPE_CHECKING, Protocol

from actorswarm.bench.daemons.probe import (
    LogTail,
    read_cpu_ns,
    read_cpu_seconds,
    read_interface_packets,
    read_memory_kib,
    read_sleeps,
    sent_packets,
)
from actorswarm.bench.daemons.results import (
    SWITCH_TAIL,
    FailoverRun,
    ResourceRun,
    Settings,
    SizeResult,
    SwitchRun,
)
from actorswarm.bench.daemons.stats import same_processes, switch_cpu
from actorswarm.bench.daemons.swarm import deploy, ground_session, wait, wait_stable
from actorswarm.core.config import CoreConfig
from actorswarm.daemon.loop import clock

if TYPE_CHECKING:
    from actorswarm.daemon.launch import LocalSwarm


Progress = Callable[[str], None]

#: The events of the switch script: ``go`` takes every platform from A to B, ``back`` home.
FORWARD = ("go", "A", "B")
BACKWARD = ("back", "B", "A")


class Timeouts(Protocol):
    """The waits a failover needs (seconds): the bench's settings and the real tables'."""

    @property
    def boot_timeout(self) -> float: ...

    @property
    def run_timeout(self) -> float: ...


async def measure_resources(swarm: LocalSwarm, phase: str, window: float) -> ResourceRun:
    """CPU over ``window`` seconds and memory at its end, of every running daemon. Waits
    with ``asyncio.sleep`` so a ground station in the same loop keeps serving meanwhile."""
    procs = {p: swarm.procs[p] for p in swarm.running()}
    start_wall = clock()
    start_cpu = {p: read_cpu_seconds(proc.pid) for p, proc in procs.items()}
    start_sleeps = {p: read_sleeps(proc.pid) for p, proc in procs.items()}
    start_sent = {p: sent_packets(swarm.status(p)) for p in procs}
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
    run.sent_packets_s = await _sent_rate(swarm, start_sent)
    return run


#: How often a daemon rewrites its packet counters when only they moved (``status.json``).
COUNTERS_EVERY = 10.0


async def _sent_rate(
    swarm: LocalSwarm, start: dict[int, tuple[float, int] | None], poll: float = 0.5
) -> float:
    """Packets the daemons of ``start`` send a second, summed: each one's rate over the
    stamps of its own counters, the first read ``start`` and a newer one. A window
    shorter than :data:`COUNTERS_EVERY` may end before a daemon wrote newer counters: it
    is waited for, at most that long. NaN when one never wrote them."""
    rates: dict[int, float] = {}
    waited = 0.0
    while True:
        for p, before in start.items():
            after = sent_packets(swarm.status(p))
            if before is not None and after is not None and after[0] > before[0]:
                rates[p] = (after[1] - before[1]) / (after[0] - before[0])
        if len(rates) == len(start) or waited > COUNTERS_EVERY:
            break
        await asyncio.sleep(poll)
        waited += poll
    return sum(rates.values()) if rates and len(rates) == len(start) else math.nan


def measure_failover(
    swarm: LocalSwarm, logs: LogTail, settings: Timeouts, rng: random.Random
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

    done = wait(agreed, settings.run_timeout)
    named = follows()
    counts = Counter(v for v in named.values() if v is not None and v != master)
    new = max(counts, key=counts.__getitem__) if counts else None
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
    back = wait(
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
    async with ground_session(swarm, settings.lease) as gs:
        progress(f"N={size}: deploying the switch script")
        failed = await deploy(
            gs,
            swarm,
            switch_script(size),
            "bench-switch",
            lambda actors: actors == ["A"],
            settings.boot_timeout,
        )
        if failed:
            result.errors.append(failed)
            return
        if settings.script_window:
            await asyncio.sleep(settings.settle)
            progress(f"N={size}: CPU and memory with the script running ({settings.window:.0f} s)")
            result.resources.append(await measure_resources(swarm, "script", settings.window))

        def swarm_cpu() -> dict[int, int]:
            """CPU so far by daemon process (a daemon that died is not there)."""
            used: dict[int, int] = {}
            for proc in swarm.procs.values():
                with contextlib.suppress(OSError):
                    used[proc.pid] = read_cpu_ns(proc.pid)
            return used

        for i in range(settings.switches):
            event, src, dst = FORWARD if i % 2 == 0 else BACKWARD
            progress(f"N={size}: collective switch {i + 1}/{settings.switches} ({src} → {dst})")
            # The previous switch's acknowledgements settle, then the idle rate is taken.
            await asyncio.sleep(0.5)
            idle_cpu, idle_at = swarm_cpu(), clock()
            await asyncio.sleep(0.5)
            logs.mark()
            sent_at = clock()
            before_cpu = swarm_cpu()

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
            causes = dict(Counter(cause for _, cause in got.values()))
            await asyncio.sleep(SWITCH_TAIL)  # the acknowledgements and backups after it
            run = SwitchRun(
                cpu_s=_switch_cpu(idle_cpu, idle_at, before_cpu, sent_at, swarm_cpu(), clock())
                if done
                else math.nan,
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


def _switch_cpu(
    idle: dict[int, int],
    idle_at: float,
    before: dict[int, int],
    before_at: float,
    after: dict[int, int],
    after_at: float,
) -> float:
    """:func:`switch_cpu` over the daemons that ran through all three reads."""
    c0, c1, c2 = same_processes(idle, before, after)
    return switch_cpu((c0, idle_at), (c1, before_at), (c2, after_at))
