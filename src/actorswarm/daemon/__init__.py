"""The daemon host (docs/design.md §2): one process per platform, the same core, engine and
runtime objects as the simulator, driven by the wall clock and a real transport.

:class:`PlatformEndpoint` composes a platform's sans-IO pieces (core node, task engine,
actor runtime) behind the small interface every host drives (``receive_packet`` for the
packets its pipeline checked, ``tick``, ``next_deadline``, and ``ready()``, the one way
out); the ground station's
:class:`~actorswarm.ground.station.GroundStation` has the same interface. :func:`serve`
is the asyncio loop that drives one of them over a transport. :class:`StateDir` keeps
what a platform needs across a crash: its incarnation, the scripts deployed to it, its
backups.

Importing this package imports :mod:`asyncio` without :mod:`ssl` when nothing had imported
either (:mod:`.ssl_deferred`): a daemon never maps OpenSSL unless a plugin asks for TLS.
"""

from actorswarm.daemon.ssl_deferred import import_asyncio_without_ssl

import_asyncio_without_ssl()

from actorswarm.daemon.endpoint import Endpoint, PlatformEndpoint  # noqa: E402
from actorswarm.daemon.loop import serve  # noqa: E402
from actorswarm.daemon.state import StateDir  # noqa: E402

__all__ = ["Endpoint", "PlatformEndpoint", "StateDir", "serve"]
