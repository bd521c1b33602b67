"""The actor runtime (docs/design.md §5): Actors as plugin groups on the OODA buses.

:class:`ActorRuntime` runs one platform's actors under the task engine; :class:`ACB` is an
actor's control block; :class:`Plugin` is what algorithm developers subclass (see
``docs/writing-a-plugin.md``); :mod:`actorswarm.testing` holds the conformance kit.
"""

from actorswarm.runtime.acb import ACB, ActorStatus
from actorswarm.runtime.actor_runtime import (
    ActorRuntime,
    PluginFailure,
    SwitchTiming,
    UnsupportedPlugin,
)
from actorswarm.runtime.context import Camera, Detection, PluginContext, Vehicle
from actorswarm.runtime.operations import IllegalOperation, Operation
from actorswarm.runtime.plugin import LifecycleError, Param, ParamError, Plugin
from actorswarm.runtime.resources import ResourceArbiter, ResourceBusy
from actorswarm.runtime.storage import BackupStore, FileBackupStore, MemoryBackupStore

__all__ = [
    "ACB",
    "ActorRuntime",
    "ActorStatus",
    "BackupStore",
    "Camera",
    "Detection",
    "FileBackupStore",
    "IllegalOperation",
    "LifecycleError",
    "MemoryBackupStore",
    "Operation",
    "Param",
    "ParamError",
    "Plugin",
    "PluginContext",
    "PluginFailure",
    "ResourceArbiter",
    "ResourceBusy",
    "SwitchTiming",
    "UnsupportedPlugin",
    "Vehicle",
]
