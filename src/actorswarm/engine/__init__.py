"""The task engine (DESIGN.md §4): a task script's Actor state machine on the collective core.

:class:`TaskEngine` runs one platform's share; :class:`Plan` is the script compiled into
barrier groups; :class:`ActorHost` is the narrow interface to the actor runtime, with
:class:`StandInRuntime` running the vehicle-free plugins ``core.idle`` and
``core.emit_after``.
"""

from actorswarm.engine.engine import TaskEngine, TransitionRecord
from actorswarm.engine.plan import Group, Plan
from actorswarm.engine.runtime import (
    ActorContext,
    ActorHost,
    Emitted,
    StandInRuntime,
    UnsupportedPlugin,
    stand_in_plugins,
)

__all__ = [
    "ActorContext",
    "ActorHost",
    "Emitted",
    "Group",
    "Plan",
    "StandInRuntime",
    "TaskEngine",
    "TransitionRecord",
    "UnsupportedPlugin",
    "stand_in_plugins",
]
