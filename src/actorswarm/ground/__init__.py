"""The ground station: the operator's side of the swarm (docs/design.md §4.2)."""

from actorswarm.ground.station import GroundStation, NotConfirmed

__all__ = ["GroundStation", "NotConfirmed"]
