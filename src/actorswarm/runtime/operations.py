"""Actor operations (docs/design.md §5, paper Fig. 2) as one transition table.

Theory of operation
-------------------
An actor's life is the table :data:`TRANSITIONS`, keyed by (status, operation)::

    UNLOADED --start-->    RUNNING     load the plugin group, bind the hardware
    RUNNING  --pause-->    SLEEPING    suspend the plugins, keep their state
    SLEEPING --activate--> RUNNING     wake them where they were
    RUNNING, SLEEPING, ERROR --stop--> UNLOADED   unbind, unload
    RUNNING, SLEEPING --fail-->  ERROR   a plugin raised
    ERROR    --start-->    RUNNING     restart after a failure

A restart from ERROR is allowed because a failed plugin is often transient (a sensor that
timed out) and the task should be able to try again without the operator first stopping the
actor; the failed instance's state is not trusted, so it is a fresh *start*, not an
*activate*. A pair that is not in the table is illegal: :func:`apply` raises
:class:`IllegalOperation` and changes nothing. Every count and the running time are kept in
:func:`apply` and nowhere else, so the ACB's statistics always match its history.

``switch`` is not a state of one actor but a pair of operations on two:
:func:`plan_switch` says which (pause the current actor; re-activate the target if it is
sleeping — cheaper than reloading, and its plugins keep their state — or start it), and
:func:`switch` performs them all or none. The runtime does the side effects (plugin hooks,
hardware) around these calls; this module only keeps the record right.

:func:`mermaid` draws the state diagram from the table, so the docs cannot drift from it.
"""

from __future__ import annotations

import math
from enum import Enum
from typing import Final, assert_never

from actorswarm.runtime.acb import ACB, ActorStatus

__all__ = [
    "TRANSITIONS",
    "IllegalOperation",
    "Operation",
    "apply",
    "legal_operations",
    "mermaid",
    "plan_switch",
    "switch",
]


class Operation(Enum):
    """What can be done to one actor. ``FAIL`` is reported by the runtime when a plugin
    raises; the others are the paper's basic operations."""

    START = "start"
    STOP = "stop"
    PAUSE = "pause"
    ACTIVATE = "activate"
    FAIL = "fail"


_S = ActorStatus
_O = Operation

#: The whole state machine: (status, operation) -> the status it leads to. Anything missing
#: is illegal.
TRANSITIONS: Final[dict[tuple[ActorStatus, Operation], ActorStatus]] = {
    (_S.UNLOADED, _O.START): _S.RUNNING,
    (_S.RUNNING, _O.PAUSE): _S.SLEEPING,
    (_S.SLEEPING, _O.ACTIVATE): _S.RUNNING,
    (_S.RUNNING, _O.STOP): _S.UNLOADED,
    (_S.SLEEPING, _O.STOP): _S.UNLOADED,
    (_S.ERROR, _O.STOP): _S.UNLOADED,
    (_S.RUNNING, _O.FAIL): _S.ERROR,
    (_S.SLEEPING, _O.FAIL): _S.ERROR,
    (_S.ERROR, _O.START): _S.RUNNING,
}

#: Extra advice for the illegal operations people actually try.
_HINTS: Final[dict[tuple[ActorStatus, Operation], str]] = {
    (_S.SLEEPING, _O.START): "it is already loaded; activate it instead",
    (_S.RUNNING, _O.START): "it is already running",
    (_S.RUNNING, _O.ACTIVATE): "it is already running",
    (_S.UNLOADED, _O.ACTIVATE): "it was never loaded; start it instead",
    (_S.UNLOADED, _O.STOP): "it is not loaded, so there is nothing to stop",
    (_S.SLEEPING, _O.PAUSE): "it is already sleeping",
    (_S.ERROR, _O.ACTIVATE): "its plugins failed; start it again or stop it",
}


def legal_operations(status: ActorStatus) -> tuple[Operation, ...]:
    """The operations allowed from ``status``, in :class:`Operation` order."""
    return tuple(op for op in Operation if (status, op) in TRANSITIONS)


class IllegalOperation(ValueError):
    """An operation that the state table does not allow from the actor's status. Nothing
    was changed; ``legal`` lists what may be done instead."""

    def __init__(self, actor: str, status: ActorStatus, operation: Operation) -> None:
        self.actor = actor
        self.status = status
        self.operation = operation
        self.legal = legal_operations(status)
        hint = _HINTS.get((status, operation))
        legal = ", ".join(op.value for op in self.legal) or "none"
        super().__init__(
            f"cannot {operation.value} actor {actor!r}: it is {status.value}"
            + (f" ({hint})" if hint else "")
            + f"; from {status.value} the legal operations are: {legal}"
        )


def apply(
    acb: ACB, op: Operation, now: float, *, error: str | None = None, switch: bool = False
) -> ActorStatus:
    """Perform ``op`` on ``acb`` at time ``now`` and return its new status.

    Keeps every statistic: the operation's counter, ``started_at``, ``changed_at``, and
    ``time_running`` (a RUNNING period is closed when the actor leaves RUNNING). ``error`` is
    the message recorded in ``last_error`` for ``FAIL`` (ignored otherwise). ``switch`` marks
    the operation as half of a switch, which counts in ``switch_count``.

    Raises :class:`IllegalOperation` for a pair not in :data:`TRANSITIONS`, and ValueError
    for a ``now`` that is not finite or is before the actor's last change. In both cases
    ``acb`` is left exactly as it was.
    """
    new = TRANSITIONS.get((acb.status, op))
    if new is None:
        raise IllegalOperation(acb.name, acb.status, op)
    stats = acb.stats
    if not math.isfinite(now):
        raise ValueError(f"actor {acb.name!r}: {op.value} at now={now!r}; now must be finite")
    if stats.changed_at is not None and now < stats.changed_at:
        raise ValueError(
            f"actor {acb.name!r}: {op.value} at now={now} is before its last change at "
            f"{stats.changed_at}; pass the runtime's clock, which must never go back"
        )

    # Nothing below can fail: the record changes completely or (above) not at all.
    if acb.status is ActorStatus.RUNNING and new is not ActorStatus.RUNNING:
        # running_since is None only for an ACB built as RUNNING by hand: no period to close.
        if stats.running_since is not None:
            stats.time_running += now - stats.running_since
        stats.running_since = None
    elif new is ActorStatus.RUNNING and acb.status is not ActorStatus.RUNNING:
        stats.running_since = now

    match op:
        case Operation.START:
            stats.start_count += 1
            stats.started_at = now
        case Operation.STOP:
            stats.stop_count += 1
        case Operation.PAUSE:
            stats.pause_count += 1
        case Operation.ACTIVATE:
            stats.activate_count += 1
        case Operation.FAIL:
            stats.error_count += 1
            acb.last_error = error or "a plugin failed (no message)"
        case _:  # a new Operation must get its counter here (mypy checks exhaustiveness)
            assert_never(op)
    if switch:
        stats.switch_count += 1
    stats.changed_at = now
    acb.status = new
    return new


def plan_switch(current: ACB, target: ACB | None) -> list[tuple[str, Operation]]:
    """The operations that switch this platform from ``current`` to ``target``, in order.

    A switch is *pause the current actor* (only if it is running: a sleeping or failed
    actor is already out of the way) then *bring in the target*: activate it if it is
    sleeping (its plugins keep their state, and nothing is reloaded), start it if it is
    unloaded or failed, leave it alone if it already runs. ``target`` None: pause only.
    A switch from an actor to itself is empty: the runtime just hands it its new context.
    """
    if target is current or (target is not None and target.name == current.name):
        return []
    plan: list[tuple[str, Operation]] = []
    if current.status is ActorStatus.RUNNING:
        plan.append((current.name, Operation.PAUSE))
    if target is not None:
        if target.status is ActorStatus.SLEEPING:
            plan.append((target.name, Operation.ACTIVATE))
        elif target.status in (ActorStatus.UNLOADED, ActorStatus.ERROR):
            plan.append((target.name, Operation.START))
    return plan


def switch(current: ACB, target: ACB | None, now: float) -> list[tuple[str, Operation]]:
    """Perform :func:`plan_switch` at ``now`` on both ACBs and return the plan.

    All or nothing: ``now`` is checked against both actors before either changes, so a
    ValueError leaves both as they were. Each operation counts in its actor's
    ``switch_count``.
    """
    plan = plan_switch(current, target)
    target_name = target.name if target is not None else None
    by_name = {current.name: current}
    if target is not None:
        by_name[target.name] = target
    for name, _ in plan:
        changed_at = by_name[name].stats.changed_at
        if not math.isfinite(now) or (changed_at is not None and now < changed_at):
            raise ValueError(
                f"switch {current.name!r} -> {target_name!r} at "
                f"now={now!r}: actor {name!r} last changed at {changed_at}; pass the "
                "runtime's clock, which must be finite and never go back"
            )
    for name, op in plan:
        apply(by_name[name], op, now, switch=True)
    return plan


def mermaid() -> str:
    """The state diagram of :data:`TRANSITIONS` as a Mermaid ``stateDiagram-v2``."""
    lines = ["stateDiagram-v2", f"    [*] --> {ActorStatus.UNLOADED.value}"]
    lines += [
        f"    {src.value} --> {dst.value}: {op.value}" for (src, op), dst in TRANSITIONS.items()
    ]
    return "\n".join(lines) + "\n"
