"""How well a formation script's shapes are flown in the simulator, measured as the real
ArduPlane flights were (docs/benchmarks/real-firmware.md): every second, the aircraft of each
formation actor are matched to that actor's slots by least squared horizontal distance; per
shape, the distances over the last ``--window`` seconds before the next operator event give
the median, the RMS and the largest.

Run: ``.venv/bin/python scripts/formation_slots.py examples/formation_arduplane.xml [--seed N]``.
The world, the duration and the events are the script's ``<?actorswarm sim ...?>`` line's.
Prints one line per shape, the closest approach of two airborne aircraft, and when each
aircraft landed (its ``landed_event``); with ``--under M``, every pass of two airborne
aircraft closer than M metres (sampled at 5 Hz), as the flights' were listed.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy.optimize import linear_sum_assignment

from actorswarm.core.config import CoreConfig
from actorswarm.dsl.checker import load
from actorswarm.plugins.formation import Formation
from actorswarm.runtime.actor_runtime import ActorRuntime
from actorswarm.sim.mission import run_slices
from actorswarm.sim.radio import LinkModel
from actorswarm.sim.tasksim import TaskSim
from actorswarm.sim.verify.scenario import scenario_of
from actorswarm.world.config import load_world
from actorswarm.world.separation import SeparationMonitor

#: How often encounters are sampled (seconds of simulated time).
ENCOUNTER_SLICE = 0.2


class Encounters:
    """Every pass of two airborne aircraft closer than ``under`` metres: the simulator's own
    separation monitor, with ``under`` as every aircraft's minimum, and the actors the two
    ran when each pass began."""

    def __init__(self, under: float, sim: TaskSim) -> None:
        assert sim.world is not None
        self.under = under
        self._monitor = SeparationMonitor(sim.world.platforms, [under] * len(sim.world.platforms))
        self._actors: dict[tuple[int, int, float], str] = {}

    def observe(self, t: float, sim: TaskSim) -> None:
        assert sim.world is not None
        positions = sim.world.fleet.positions
        for breach in self._monitor.observe(t, positions, np.ones(len(positions), dtype=bool)):
            pair = sorted((breach.closest.a, breach.closest.b))
            running = (",".join(sim.hosts[p].engine.runtime.running()) or "-" for p in pair)
            self._actors[(pair[0], pair[1], breach.start)] = "/".join(running)

    def lines(self) -> list[str]:
        return [
            f"under {self.under:g} m: {c.a} and {c.b} at {c.t:.1f} s, {c.distance:.1f} m "
            f"apart, {c.where[2]:.0f} m up, running "
            f"{self._actors[(min(c.a, c.b), max(c.a, c.b), b.start)]} "
            f"({b.end - b.start + ENCOUNTER_SLICE:.1f} s)"
            for b in self._monitor.result().breaches
            for c in (b.closest,)
        ]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("script", type=Path)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--window", type=float, default=30.0, help="seconds before each event")
    parser.add_argument(
        "--under",
        type=float,
        default=0.0,
        help="also list every encounter of two airborne aircraft closer than this (metres)",
    )
    args = parser.parse_args()
    scenario = scenario_of(args.script.read_text(), args.script)
    if scenario is None or scenario.world is None or not scenario.events:
        print(f"{args.script}: no <?actorswarm sim ...?> line with a world and events")
        return 2
    sim = TaskSim(
        load(args.script),
        seed=args.seed,
        link=LinkModel(),
        config=CoreConfig(),
        world_config=load_world(scenario.world),
    )
    sim.schedule(list(scenario.events), list(scenario.faults))
    samples: list[tuple[float, str, np.ndarray]] = []
    encounters = Encounters(args.under, sim)

    def probe(t: float, _new: object) -> None:
        world = sim.world
        assert world is not None
        if args.under > 0:
            encounters.observe(t, sim)
        if abs(t - round(t)) > 1e-6:
            return
        groups: dict[str, tuple[list[np.ndarray], list[np.ndarray]]] = {}
        for platform, host in sim.hosts.items():
            runtime = host.engine.runtime
            assert isinstance(runtime, ActorRuntime)
            for actor in runtime.running():
                for plugin in runtime.plugins(actor):
                    if isinstance(plugin, Formation):
                        here, slots = groups.setdefault(actor, ([], []))
                        here.append(np.array(world.vehicle(platform).position()[:2]))
                        slots.append(np.array(plugin.slot_point(sim.swarm.now)[:2]))
        for actor, (here, slots) in groups.items():
            cost = np.linalg.norm(np.array(here)[:, None] - np.array(slots)[None], axis=2)
            rows, cols = linear_sum_assignment(cost**2)
            samples.append((t, actor, cost[rows, cols]))

    slice_s = ENCOUNTER_SLICE if args.under > 0 else 1.0
    report = run_slices(sim, scenario.duration or 60.0, slice_s=slice_s, on_slice=probe)
    for event in scenario.events:
        end = event.t
        window = [(a, e) for t, a, e in samples if end - args.window <= t < end]
        if not window:
            continue
        errors = np.concatenate([e for _, e in window])
        actors = "/".join(sorted({a for a, _ in window}))
        print(
            f"{actors:6} the {args.window:g} s before {event.name} at {end:g} s: median "
            f"{np.median(errors):.1f} m, RMS {np.sqrt(np.mean(errors**2)):.1f} m, "
            f"max {errors.max():.0f} m"
        )
    separation = report["separation"]
    print(f"closest approach: {separation['min_distance_m']} m {separation['closest'] or ''}")
    for line in encounters.lines():
        print(line)
    landed = [
        (e["platform"], e["t"]) for e in report["ignored_events"] if e["event"] == "landed_event"
    ]
    if landed:
        print("landed: " + ", ".join(f"{p}@{t:.1f}s" for p, t in landed))
    return 0


if __name__ == "__main__":
    sys.exit(main())
