"""Running a shipped mission (:mod:`actorswarm.missions`) in the simulator, in slices.

:func:`prepare` builds the :class:`~actorswarm.sim.tasksim.TaskSim` of a mission — its
script, resized to the number of platforms asked for, its world, the radio, the events and
crashes scheduled — and :func:`run_slices` advances it slice by slice, handing each slice's
new transitions to a callback, so a front end can show a progress bar and each collective
transition as it happens, or pace the run to the wall clock. Nothing here reads a clock:
the caller does, between slices.

Resizing (``platforms``): the script's platforms become ``1..N``, all starting the actor
the script starts them in; a numeric ``sysNum`` above 1 is scaled in proportion (the
formation mission's branch of 15 of 30 becomes 5 of 10), and a ``sysNum`` of 1 stays 1 (one
tracker is one tracker whatever the swarm's size).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

from actorswarm.core.config import CoreConfig
from actorswarm.dsl.checker import load
from actorswarm.dsl.model import PlatformLine, TaskScript
from actorswarm.missions import Mission
from actorswarm.sim.radio import LinkModel
from actorswarm.sim.record import sample_world
from actorswarm.sim.tasksim import Fault, GroundEvent, TaskSim
from actorswarm.sim.vehicle_faults import VehicleFault
from actorswarm.world.config import load_world

__all__ = ["RECORD_PERIOD", "prepare", "resize", "run_slices"]

#: Seconds between two recorded poses of every vehicle.
RECORD_PERIOD = 0.5


def resize(script: TaskScript, platforms: int, written_for: int) -> TaskScript:
    """``script`` for platforms ``1..platforms`` (see the module docstring)."""
    if platforms < 1:
        raise ValueError(f"a mission needs at least 1 platform, not {platforms}")
    if platforms == written_for:
        return script
    first = script.platforms[0].actor if script.platforms else script.actors[0].name
    line = PlatformLine(ids=frozenset(range(1, platforms + 1)), actor=first)

    def scaled(n: object) -> object:
        if isinstance(n, int) and n > 1:
            return max(1, round(n * platforms / written_for))
        return n

    transitions = {
        actor: tuple(dataclasses.replace(t, sys_num=scaled(t.sys_num)) for t in ts)  # type: ignore[arg-type]
        for actor, ts in script.transitions.items()
    }
    return dataclasses.replace(script, platforms=(line,), transitions=transitions)


def prepare(
    mission: Mission,
    *,
    platforms: int | None = None,
    seed: int = 0,
    loss: float = 0.0,
    kills: tuple[tuple[int, float], ...] = (),
    packets: list[tuple[float, int]] | None = None,
    min_separation: float | None = None,
    vehicle_faults: tuple[VehicleFault, ...] = (),
) -> TaskSim:
    """The mission's simulation, events and crashes scheduled, recording every
    :data:`RECORD_PERIOD` seconds. ``loss`` is an extra independent loss on every packet,
    on top of the world's distance-driven radio model. ``packets``: as
    :func:`~actorswarm.sim.record.sample_world` takes it; ``min_separation`` and
    ``vehicle_faults``: as :class:`~actorswarm.sim.tasksim.TaskSim` takes them."""
    script = load(mission.script_path)
    script = resize(script, platforms or mission.platforms, mission.platforms)
    sim = TaskSim(
        script,
        seed=seed,
        link=LinkModel(loss=loss),
        config=CoreConfig(),
        world_config=load_world(mission.world_path),
        min_separation=min_separation,
        vehicle_faults=vehicle_faults,
    )
    sample_world(sim, RECORD_PERIOD, packets)
    sim.schedule(
        [GroundEvent(name, t) for name, t in mission.events],
        [Fault("kill", t, frozenset({p})) for p, t in (*mission.kills, *kills)],
    )
    return sim


def run_slices(
    sim: TaskSim,
    duration: float,
    *,
    slice_s: float = 1.0,
    on_slice: Callable[[float, list[dict[str, Any]]], None] | None = None,
) -> dict[str, Any]:
    """Advance ``sim`` to ``duration`` in slices of ``slice_s`` virtual seconds, calling
    ``on_slice(t, new_transitions)`` after each; return the run's report."""
    if slice_s <= 0:
        raise ValueError(f"slice_s must be > 0 seconds, not {slice_s}")
    t = sim.swarm.now
    while t < duration:
        t = min(duration, t + slice_s)
        new = sim.advance(t)
        if on_slice is not None:
            on_slice(t, new)
    return sim.report()
