"""Orchestration of ``bench daemons``: a fresh swarm per size, booted, measured idle, its
master killed and restarted, a script deployed and switched, the daemons killed after."""

from __future__ import annotations

import asyncio
import os
import random
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict
from pathlib import Path

from actorswarm.bench.daemons.measure import (
    Progress,
    measure_failover,
    measure_resources,
    run_switches,
)
from actorswarm.bench.daemons.probe import LogTail, machine_info, source_version
from actorswarm.bench.daemons.results import BenchResult, Settings, SizeResult
from actorswarm.bench.daemons.swarm import daemons_env, describe_swarm, settled, wait_stable
from actorswarm.core.config import CoreConfig
from actorswarm.daemon.launch import LocalSwarm
from actorswarm.daemon.loop import clock


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
        result.machine["daemons"] = source_version(Path(settings.daemons_from))
    for n in sizes:
        size_result = bench_size(directory / f"n{n}", n, settings, progress)
        result.sizes.append(size_result)
        if done is not None:
            done(size_result)
    result.wall_s = time.perf_counter() - began
    return result
