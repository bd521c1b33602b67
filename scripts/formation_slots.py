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
from dataclasses import dataclass
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

#: How often encounters are sampled (seconds of simulated time).
ENCOUNTER_SLICE = 0.2
#: Aircraft at or below this height (metres) are on the ground, as in the flights' analysis.
AIRBORNE_Z = 5.0


@dataclass
class Episode:
    """One approach of two aircraft under the threshold, and its closest sample."""

    pair: tuple[int, int]
    first: float
    last: float
    distance: float
    t: float
    heights: tuple[float, float]
    actors: str


class Encounters:
    """Episodes of two airborne aircraft closer than ``under`` metres: one per pair and
    approach (samples less than 2 s apart belong to one), with the closest sample's time,
    distance, heights and the actors the two ran."""

    def __init__(self, under: float) -> None:
        self.under = under
        self._open: dict[tuple[int, int], Episode] = {}
        self.done: list[Episode] = []

    def observe(self, t: float, sim: TaskSim) -> None:
        world = sim.world
        assert world is not None
        ids = [p for p in sim.hosts if world.vehicle(p).position()[2] > AIRBORNE_Z]
        points = np.array([world.vehicle(p).position() for p in ids]).reshape(-1, 3)
        for i, a in enumerate(ids):
            d = np.linalg.norm(points[i + 1 :] - points[i], axis=1)
            for j in np.flatnonzero(d < self.under):
                b = ids[i + 1 + int(j)]
                heights = (float(points[i][2]), float(points[i + 1 + j][2]))
                self._note(t, (a, b), float(d[j]), heights, sim)
        for pair, episode in list(self._open.items()):
            if t - episode.last > 2.0:
                self.done.append(self._open.pop(pair))

    def _note(
        self,
        t: float,
        pair: tuple[int, int],
        d: float,
        heights: tuple[float, float],
        sim: TaskSim,
    ) -> None:
        actors = "/".join(",".join(sim.hosts[p].engine.runtime.running()) or "-" for p in pair)
        episode = self._open.setdefault(pair, Episode(pair, t, t, d, t, heights, actors))
        episode.last = t
        if d <= episode.distance:
            episode.distance, episode.t, episode.heights, episode.actors = d, t, heights, actors

    def lines(self) -> list[str]:
        episodes = sorted([*self.done, *self._open.values()], key=lambda e: e.t)
        return [
            f"under {self.under:g} m: {e.pair[0]} and {e.pair[1]} at {e.t:.1f} s, "
            f"{e.distance:.1f} m apart, {e.heights[0]:.0f} and {e.heights[1]:.0f} m up, "
            f"running {e.actors} ({e.last - e.first + ENCOUNTER_SLICE:.1f} s)"
            for e in episodes
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
    encounters = Encounters(args.under)

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
