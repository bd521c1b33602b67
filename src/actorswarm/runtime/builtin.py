"""The two plugins that need no vehicle (docs/design.md §6), registered as entry points.

``core.idle`` (:class:`Idle`)
    Does nothing. An actor made of it only waits for events (from the ground station, or
    from the swarm). Takes no params; fits any bus.

``core.emit_after`` (:class:`EmitAfter`)
    Emits ``event`` once, ``after + spread_per_platform × platform ID`` seconds after the
    actor starts. Params: ``event`` (required), ``after`` (seconds ≥ 0, default 0),
    ``spread_per_platform`` (seconds, default 0) and ``scope`` (``local``, the default, or
    ``swarm``). Fits any bus.

They double as the smallest complete examples of the plugin contract: declarations,
params, hooks, a timer declared through ``next_deadline``, and a state that survives
``snapshot``/``restore``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, ClassVar

from actorswarm.runtime.plugin import Param, Plugin

if TYPE_CHECKING:
    from actorswarm.runtime.context import PluginContext

__all__ = ["EmitAfter", "Idle"]

#: What an event name may be (the task script's name syntax).
EVENT_NAME_PATTERN = r"[A-Za-z_][A-Za-z0-9_.\-]*"
#: :data:`EVENT_NAME_PATTERN` in words, for messages.
EVENT_NAME_FORM = "an event name (a letter or _, then letters, digits, _ . or -)"


class Idle(Plugin):
    """``core.idle``: does nothing, on any bus. An actor that only waits for events."""

    any_bus = True

    def step(self, ctx: PluginContext) -> None:
        """Nothing to do."""


class EmitAfter(Plugin):
    """``core.emit_after``: emits ``event`` once per start, after a delay of running time.

    The delay is ``after + spread_per_platform × ctx.platform`` seconds (a negative spread
    that makes it negative means: at once). The spread staggers the platforms of one actor,
    so their events reach the master one after another rather than all at once.

    **Only running time counts.** While the actor is paused the countdown stops, and
    ``activate`` resumes it where it was — like the rest of a sleeping plugin's state. A
    pause is a suspension (docs/design.md §5: "plugins suspended, state kept"), so waking up must
    not find the timer already expired and the event fired in a burst with every other
    plugin's; an operator who pauses a swarm for a minute gets the same mission, a minute
    later.

    The event goes out on the first step at or after the deadline, and never again in this
    start (a new start is a new instance, which waits again). The snapshot is
    ``{"remaining": seconds still to wait, "fired": bool}``: a restored instance waits out
    the remainder from its activation, whatever clock the restoring host runs on.
    """

    any_bus = True
    params: ClassVar[Mapping[str, Param]] = {
        "event": Param(
            kind="str",
            required=True,
            pattern=EVENT_NAME_PATTERN,
            form=EVENT_NAME_FORM,
            doc="the event to emit",
        ),
        "after": Param(
            kind="float",
            default=0.0,
            minimum=0.0,
            doc="seconds of running time after the actor starts",
        ),
        "spread_per_platform": Param(
            kind="float",
            default=0.0,
            doc="extra seconds per unit of platform ID",
        ),
        "scope": Param(
            kind="str",
            default="local",
            choices=("local", "swarm"),
            doc="local: only this platform becomes a candidate; swarm: every platform",
        ),
    }

    def __init__(self) -> None:
        self._remaining = 0.0  # seconds left while sleeping (kept current at each pause)
        self._deadline: float | None = None  # the absolute `now` to fire at, while running
        self._last_now = 0.0  # the host's time at the last call, for snapshots
        self._fired = False

    def on_start(self, ctx: PluginContext) -> None:
        delay = ctx.params["after"] + ctx.params["spread_per_platform"] * ctx.platform
        self._fired = False
        self._remaining = max(0.0, float(delay))
        self._deadline = ctx.now + self._remaining
        self._last_now = ctx.now

    def step(self, ctx: PluginContext) -> None:
        self._last_now = ctx.now
        if self._fired or self._deadline is None or ctx.now < self._deadline:
            return
        self._fired = True
        ctx.emit(ctx.params["event"], scope=ctx.params["scope"])

    def on_pause(self, ctx: PluginContext) -> None:
        self._remaining = self._left(ctx.now)
        self._deadline = None
        self._last_now = ctx.now

    def on_activate(self, ctx: PluginContext) -> None:
        self._deadline = ctx.now + self._remaining
        self._last_now = ctx.now

    def next_deadline(self) -> float | None:
        return None if self._fired else self._deadline

    def snapshot(self) -> dict[str, Any]:
        return {"remaining": self._left(self._last_now), "fired": self._fired}

    def restore(self, state: Mapping[str, Any]) -> None:
        remaining, fired = state.get("remaining"), state.get("fired")
        if (
            isinstance(remaining, bool)
            or not isinstance(remaining, int | float)
            or not math.isfinite(remaining)
            or remaining < 0
            or not isinstance(fired, bool)
        ):
            raise ValueError(
                "core.emit_after: a snapshot must read {'remaining': seconds ≥ 0, "
                f"'fired': true or false}}, not {dict(state)!r}"
            )
        self._remaining = float(remaining)
        self._fired = fired
        self._deadline = None

    def _left(self, now: float) -> float:
        if self._deadline is None:
            return self._remaining
        return max(0.0, self._deadline - now)
