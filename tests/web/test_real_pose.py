"""A real swarm on the map: positions come with the platforms' status replies."""

from __future__ import annotations

import math

from actorswarm.engine import commands as cmds
from actorswarm.testing import FakeVehicle
from actorswarm.web.real_source import _pose


def _reply(position: list[float] | None) -> cmds.StatusReply:
    return cmds.StatusReply(actors={}, master=False, epoch=1, incarnation=0, position=position)


def test_the_pose_is_the_reported_position_heading_where_it_moved() -> None:
    assert _pose(None, None) == (None, None, None)
    assert _pose(_reply(None), None) == (None, None, None), "no vehicle: laid out by actor"
    assert _pose(_reply([3.0, 4.0, 10.0]), None) == (3.0, 4.0, None)
    x, y, heading = _pose(_reply([3.0, 4.0, 10.0]), [3.0, 2.0, 10.0])
    assert (x, y) == (3.0, 4.0) and heading is not None
    assert math.isclose(heading, math.pi / 2), "moved north"
    assert _pose(_reply([3.0, 4.0, 10.0]), [3.0, 3.9, 10.0])[2] is None, "hovering"


def test_a_platform_with_a_vehicle_reports_where_it_is() -> None:
    """The engine's status reply carries the vehicle's position (what gs web draws)."""
    from actorswarm.daemon.endpoint import PlatformEndpoint

    plain = PlatformEndpoint(1, swarm="t", incarnation=0, now=0.0)
    assert plain.engine._status().position is None
    vehicle = FakeVehicle(position=(5.0, -2.0, 12.0))
    flying = PlatformEndpoint(2, swarm="t", incarnation=0, now=0.0, vehicle=vehicle)
    assert flying.engine._status().position == [5.0, -2.0, 12.0]
