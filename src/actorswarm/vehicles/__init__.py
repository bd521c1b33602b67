"""Adapters from the plugins' :class:`~actorswarm.runtime.context.Vehicle` interface to real
autopilots. Each adapter lives in its own package and is imported only by a daemon that
flies one (:mod:`actorswarm.vehicles.mavlink`: PX4 and ArduPilot over MAVLink)."""
