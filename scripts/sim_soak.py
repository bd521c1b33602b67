#!/usr/bin/env python3
"""What a long run keeps in memory: the protocol core, the engine and the runtime of a
swarm whose every platform switches actors every second (Table I's script), run in the
simulator for a long while (docs/deploying.md, §9 "Memory").

    .venv/bin/python scripts/sim_soak.py [--platforms 4] [--warm 60] [--seconds 600]

After ``--warm`` simulated seconds, ``tracemalloc`` takes a snapshot; the swarm runs
``--seconds`` more, and a second snapshot says what grew, by allocation site. Every
simulated second the script drains what a daemon's host drains (the engine's transitions,
firings, commands and ignored events, the runtime's plugin failures and switch timings)
and what only the simulator keeps (its event log, its invariant checker is off): what is
left growing is the platforms' own. Prints the total growth and the largest sites; a core
that forgets nothing it should shows a few hundred KiB of warm-up (the bounded records of
recent releases and firings) however long it runs.
"""

from __future__ import annotations

import argparse
import gc
import tracemalloc
from typing import Any

from actorswarm.bench.scripts import table1_script
from actorswarm.dsl.checker import check
from actorswarm.runtime.actor_runtime import ActorRuntime
from actorswarm.sim.radio import LinkModel
from actorswarm.sim.tasksim import TaskSim


class _NoChecks:
    """The invariant checker switched off: it keeps every event of the run by design."""

    def on_event(self, *args: Any) -> None:
        pass

    def sample(self, *args: Any) -> None:
        pass

    def finish(self, *args: Any) -> list[str]:
        return []


def _drain(sim: TaskSim) -> None:
    """What a daemon's loop lets go of on every wake, and what only the simulator keeps."""
    for host in sim.hosts.values():
        engine = host.engine
        for records in (engine.fired, engine.commands, engine.transitions, engine.ignored):
            records.clear()
        runtime = engine.runtime
        assert isinstance(runtime, ActorRuntime)
        runtime.drain_switches()
        runtime.failures.clear()
    sim.swarm.log.clear()
    sim.records.clear()
    sim.ignored.clear()
    sim.fired.clear()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--platforms", type=int, default=4)
    parser.add_argument("--warm", type=float, default=60.0, help="simulated seconds first")
    parser.add_argument("--seconds", type=float, default=600.0, help="simulated seconds then")
    parser.add_argument("--top", type=int, default=8, help="allocation sites shown")
    args = parser.parse_args()
    result = check(table1_script(args.platforms, 1), path="table1")
    assert result.script is not None, result.errors
    sim = TaskSim(result.script, seed=1, link=LinkModel(latency=0.002, jitter=0.001))
    sim.swarm.checker = _NoChecks()  # type: ignore[assignment]
    sim.advance(args.warm)
    _drain(sim)
    gc.collect()
    tracemalloc.start(6)
    before = tracemalloc.take_snapshot()
    end = sim.swarm.now + args.seconds
    while sim.swarm.now < end:
        sim.advance(min(end, sim.swarm.now + 1.0))
        _drain(sim)
    gc.collect()
    stats = tracemalloc.take_snapshot().compare_to(before, "traceback")
    switches = args.platforms * args.seconds
    grown = sum(s.size_diff for s in stats)
    print(
        f"{args.platforms} platforms, {args.seconds:g} s after {args.warm:g} s "
        f"(about {switches:.0f} switches): {grown / 1024:.1f} KiB grown "
        f"({grown / switches:.1f} bytes per switch)"
    )
    for stat in stats[: args.top]:
        print(f"{stat.size_diff / 1024:+8.1f} KiB {stat.count_diff:+6d} blocks")
        for line in stat.traceback.format()[-2:]:
            print("    " + line.strip())


if __name__ == "__main__":
    main()
