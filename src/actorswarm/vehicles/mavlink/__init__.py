"""A :class:`~actorswarm.runtime.context.Vehicle` on a PX4 or ArduPilot autopilot over
MAVLink 2 (pymavlink), and a simulated MAVLink autopilot to fly it against.

The pieces, one job each:

* :mod:`~actorswarm.vehicles.mavlink.frame`: the mission's local frame (x east, y north,
  z up from one origin for the whole swarm) to and from latitude, longitude, altitude.
* :mod:`~actorswarm.vehicles.mavlink.link`: the connection (UDP, TCP, serial, written as
  pymavlink writes them; reopened when it breaks), the filter that keeps only the messages
  of this vehicle's autopilot.
* :mod:`~actorswarm.vehicles.mavlink.commands`: commands retried until ``COMMAND_ACK``, with a
  deadline, in ordered steps (mode, then arm, then take-off).
* :mod:`~actorswarm.vehicles.mavlink.flavours`: what ArduPilot and PX4 each want for take-off,
  goto, hold and land.
* :mod:`~actorswarm.vehicles.mavlink.vehicle`: :class:`MavlinkVehicle`, the whole adapter.
* :mod:`~actorswarm.vehicles.mavlink.autopilot`: the simulated autopilot
  (``actorswarm autopilot``).
* :mod:`~actorswarm.vehicles.mavlink.readiness`: whether the autopilot can fly yet, and why
  not.
* :mod:`~actorswarm.vehicles.mavlink.boot`: the real autopilots' boot, as the simulated one
  replays it.

pymavlink (its generated dialect only) is imported only here: a daemon without
``--vehicle mavlink`` never loads it.
"""

from actorswarm.vehicles.mavlink.errors import MavlinkError

__all__ = ["MavlinkError"]
