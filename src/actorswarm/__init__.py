"""actorswarm: an Actor-based programming framework for robot swarms.

The layers, bottom up (docs/design.md §2): :mod:`actorswarm.core` — the sans-IO collective core
(membership, failure detection, master election, reliable delivery, barriers, gather/scatter,
arbitration); :mod:`actorswarm.sim` — the deterministic simulated radio and scheduler that host
it in virtual time; :mod:`actorswarm.cli` — the ``actorswarm`` command line.
"""

__version__ = "0.1.0"

__all__ = ["__version__"]
