"""The web ground station: a live map of the swarm and the operator's controls, in a browser.

::

    from actorswarm.web import Server, SimSource

    with Server(SimSource(task_sim, speed=2.0)) as server:
        print(server.url)            # open it: map, swarm, task and controls

A :class:`SwarmSource` is what the page looks at — the simulator (:class:`SimSource`) or a
real swarm over Zenoh (:class:`RealSource`), or a recording played back
(:class:`ReplaySource`) — and all speak the same messages; the app
(:func:`create_app`) streams them over a WebSocket and takes the operator's commands back;
:func:`serve` runs it in the foreground for the command line. The page is plain files in
``static/`` (ES modules and a style sheet), so nothing is built or fetched to run it.
``docs/web.md`` describes the page, the messages and the access rules.
"""

from actorswarm.web.access import Access, policy
from actorswarm.web.app import create_app
from actorswarm.web.operator import Outcome, Timeouts
from actorswarm.web.real_source import RealSource
from actorswarm.web.replay_source import ReplaySource
from actorswarm.web.server import DEFAULT_HOST, DEFAULT_PORT, Server, serve
from actorswarm.web.sim_source import SimSource
from actorswarm.web.source import PlatformRow, SwarmSource

__all__ = [
    "DEFAULT_HOST",
    "DEFAULT_PORT",
    "Access",
    "Outcome",
    "PlatformRow",
    "RealSource",
    "ReplaySource",
    "Server",
    "SimSource",
    "SwarmSource",
    "Timeouts",
    "create_app",
    "policy",
    "serve",
]
