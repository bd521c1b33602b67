"""Whether the script's platforms hear each other at their homes: a warning from the world.

With a world, ``actorswarm task check --world WORLD`` (and ``actorswarm sim``) warns, at
the script's first line, when the platforms' homes are farther apart than the world's
``[radio] range`` allows:

* split into groups that cannot reach each other even hop by hop: each group forms a swarm
  of its own, and a barrier of all never releases;
* more than one hop apart while the radio does not relay (``[radio] relay``, the daemons'
  ``--relay``): platforms out of each other's range never hear each other, so the swarm
  cannot agree on one master.

A swarm that spans several hops with ``relay`` on is what relaying is for: no warning.
Homes are where the platforms start; in flight the span changes, which ``sim`` reports
(its ``radio`` line).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from actorswarm.dsl.diagnostics import Report
from actorswarm.dsl.model import TaskScript

if TYPE_CHECKING:
    from actorswarm.world.config import WorldConfig

__all__ = ["check_radio", "homes_span"]


def homes_span(script: TaskScript, world: WorldConfig) -> tuple[int, int]:
    """``(span, groups)`` of the script's platforms at their homes in ``world``
    (:func:`~actorswarm.world.radio_model.hop_span`)."""
    from actorswarm.world.radio_model import hop_span

    specs = world.vehicle_specs(sorted(script.platform_ids()))
    return hop_span([(*s.home, 0.0) for s in specs], world.radio)


def check_radio(script: TaskScript, world: WorldConfig, report: Report) -> None:
    """Warn on ``report`` about what the module docstring names."""
    if len(script.platform_ids()) < 2:
        return
    span, groups = homes_span(script, world)
    where = f"the world's [radio] range is {world.radio.range:g} m"
    if groups > 1:
        report.warning(
            script.pos,
            f"the platforms' homes are in {groups} groups out of each other's radio reach "
            f"({where}), even hop by hop: each would be a swarm of its own; bring them "
            "closer or give the radio more range",
        )
    elif span > 1 and not world.radio.relay:
        report.warning(
            script.pos,
            f"the platforms' homes span {span} radio hops ({where}) and the radio does not "
            "relay: platforms out of each other's range never hear each other; set [radio] "
            "relay = true (the daemons' --relay) or bring them closer",
        )
