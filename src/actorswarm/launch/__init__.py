"""``actorswarm launch``: a swarm of daemons on this machine from one file.

:mod:`.config` reads and checks the launch file; :mod:`.runner` starts the daemons (as
:class:`~actorswarm.daemon.launch.LocalSwarm` processes), shows them (:mod:`.monitor`:
``status.json`` and ``/proc``), restarts one on request and stops them all on Ctrl-C.
"""

from actorswarm.launch.config import LaunchError, LaunchFile, PlatformPlan, load_launch

__all__ = ["LaunchError", "LaunchFile", "PlatformPlan", "load_launch"]
