"""The collective core: sans-IO swarm organization (docs/design.md §3).

Start with :class:`Node`, one platform's core; :class:`CoreConfig` holds every protocol
timing; :mod:`actorswarm.core.wire` defines the packets; :mod:`actorswarm.core.events` what
the core reports upward.
"""

from actorswarm.core.config import ConfigError, CoreConfig
from actorswarm.core.events import (
    AppReceived,
    BarrierFired,
    BarrierReleased,
    BarrierStaleNotice,
    BecameMaster,
    CoreEvent,
    DeliveryFailed,
    HandshakeComplete,
    MasterChanged,
    MemberJoined,
    MemberLeft,
    RoleDenied,
    RoleGranted,
    RoleRevoked,
    SteppedDown,
)
from actorswarm.core.membership.detectors import (
    FixedTimeout,
    LeaveDetector,
    PhiAccrual,
    make_detector,
)
from actorswarm.core.node import Node, Outgoing
from actorswarm.core.ready import Ready
from actorswarm.core.wire import GROUND_STATION, NEED_ALL, WireError, decode, encode

__all__ = [
    "GROUND_STATION",
    "NEED_ALL",
    "AppReceived",
    "BarrierFired",
    "BarrierReleased",
    "BarrierStaleNotice",
    "BecameMaster",
    "ConfigError",
    "CoreConfig",
    "CoreEvent",
    "DeliveryFailed",
    "FixedTimeout",
    "HandshakeComplete",
    "LeaveDetector",
    "MasterChanged",
    "MemberJoined",
    "MemberLeft",
    "Node",
    "Outgoing",
    "PhiAccrual",
    "Ready",
    "RoleDenied",
    "RoleGranted",
    "RoleRevoked",
    "SteppedDown",
    "WireError",
    "decode",
    "encode",
    "make_detector",
]
