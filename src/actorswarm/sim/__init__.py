"""The simulated swarm: a discrete-event scheduler in virtual time and a simulated radio.

Everything here is deterministic: time is virtual (no wall clock is ever read) and every
random choice comes from a ``random.Random`` the caller seeds, so one seed gives one run.
Start with :class:`SimSwarm`; :class:`LinkModel` describes the radio's faults and
:class:`Airtime` its shared channel.
"""

from actorswarm.sim.invariants import InvariantChecker
from actorswarm.sim.radio import (
    Airtime,
    ChannelStats,
    GilbertElliott,
    LinkModel,
    SimRadio,
    Traffic,
    Transmission,
)
from actorswarm.sim.scheduler import Scheduler, Timer
from actorswarm.sim.swarm import LogEntry, SimSwarm

__all__ = [
    "Airtime",
    "ChannelStats",
    "GilbertElliott",
    "InvariantChecker",
    "LinkModel",
    "LogEntry",
    "Scheduler",
    "SimRadio",
    "SimSwarm",
    "Timer",
    "Traffic",
    "Transmission",
]
