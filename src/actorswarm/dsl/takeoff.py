"""Whether a script answers an autopilot that never lets its platform take off: a warning.

A real autopilot may refuse to arm for good (a failed pre-arm check, no position estimate).
The take-off then gives up (the daemon's ``mavlink_arm_timeout``, 120 s by default; the
simulator's ``--refuse-takeoff`` likewise) and raises the local event
``vehicle_fault_event``. An actor that takes off and has no transition on that event keeps
the platform for good: a group waiting for all its platforms waits for its timeout, and
the task never ends. With a world (vehicles to fly), ``actorswarm task check --world
WORLD`` (and ``actorswarm sim``) warn, at the take-off plugin's line, about every actor
with a ``flight.takeoff`` and no ``vehicle_fault_event`` transition.

The usual answer is an actor of its own for the grounded platform, reached with
``sysNum="1"`` (that platform alone)::

    <transition name="vehicle_fault_event" barrierKey="8" sysNum="1">
      <successor actor="Grounded"/>
    </transition>

with ``Grounded`` running ``core.idle``: it stays on the ground, out of the mission, and a
run whose other platforms end where the mission ends is complete.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Final

from actorswarm.dsl.diagnostics import Report
from actorswarm.dsl.model import TaskScript
from actorswarm.runtime.context import VEHICLE_FAULT_EVENT

if TYPE_CHECKING:
    from actorswarm.world.config import WorldConfig

__all__ = ["check_takeoff_fault"]

#: The plugins that take a platform off the ground, where an autopilot that never arms
#: shows.
_TAKES_OFF: Final = frozenset({"flight.takeoff"})


def check_takeoff_fault(script: TaskScript, world: WorldConfig, report: Report) -> None:
    """Warn on ``report`` about each actor that takes off and does not answer
    :data:`~actorswarm.runtime.context.VEHICLE_FAULT_EVENT` (the module docstring).
    ``world`` is only asked whether the script's platforms fly vehicles in it."""
    platforms = script.platform_ids()
    if not platforms or not world.vehicle_specs(platforms):
        return
    for actor in script.actors:
        answered = any(
            t.event == VEHICLE_FAULT_EVENT for t in script.transitions.get(actor.name, ())
        )
        if answered:
            continue
        for specs in actor.buses.values():
            for spec in specs:
                if spec.name in _TAKES_OFF:
                    report.warning(
                        spec.pos,
                        f"{spec.name}: a platform whose autopilot never lets it take off "
                        f"stays in {actor.name} for good (its take-off gives up and raises "
                        f"{VEHICLE_FAULT_EVENT}, which {actor.name} does not answer), and "
                        "the task never ends; add "
                        f'<transition name="{VEHICLE_FAULT_EVENT}" sysNum="1"> to an actor of '
                        "its own, such as a Grounded one running core.idle",
                    )
