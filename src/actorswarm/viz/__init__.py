"""Pictures of a recorded run (PNG files; see :mod:`actorswarm.sim.record`)."""

from actorswarm.viz.pictures import timeline_png, trajectory_png

__all__ = ["timeline_png", "trajectory_png"]
