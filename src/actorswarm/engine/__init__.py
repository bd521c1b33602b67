"""The task engine (docs/design.md §4): a task script's Actor state machine on the collective core.

:class:`TaskEngine` runs one platform's share; :class:`Plan` is the script compiled into
barrier groups; :class:`ActorHost` is the narrow interface to the actor runtime
(:mod:`actorswarm.runtime`).
"""

from actorswarm.engine.engine import TaskEngine
from actorswarm.engine.plan import Group, Plan
from actorswarm.engine.records import CommandRecord, FiredRecord, TransitionRecord
from actorswarm.engine.runtime import ActorContext, ActorHost, Emitted

__all__ = [
    "ActorContext",
    "ActorHost",
    "CommandRecord",
    "Emitted",
    "FiredRecord",
    "Group",
    "Plan",
    "TaskEngine",
    "TransitionRecord",
]
