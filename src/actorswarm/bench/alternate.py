"""The plugin that keeps two actors alternating for Table I: :class:`EmitOnEntry`.

``core.emit_after`` emits once per *start*: an actor switched away from sleeps with its
plugins' state, and a switch back re-activates it rather than starting it again, so a pair
``A → B → A`` driven by ``core.emit_after`` stops after its second switch (A's timer has
already fired). :class:`EmitOnEntry` counts down again on every activation, so
``A ⇄ B`` goes on forever with warm switches — the case Table I measures.

It is named in task scripts by its path, :data:`EMIT_ON_ENTRY`, so it needs no entry point.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Final

from actorswarm.runtime.builtin import EmitAfter

if TYPE_CHECKING:
    from actorswarm.runtime.context import PluginContext

__all__ = ["EMIT_ON_ENTRY", "EmitOnEntry"]

#: The plugin's name in a task script.
EMIT_ON_ENTRY: Final = "actorswarm.bench.alternate:EmitOnEntry"


class EmitOnEntry(EmitAfter):
    """Emits ``event`` ``after + spread_per_platform × platform ID`` seconds of running time
    after every entry into its actor: the start and every activation (a switch back to a
    sleeping actor, an operator's ``activate``). Params and snapshot as
    ``core.emit_after``; a pause still stops the countdown, an activation begins it anew."""

    def on_activate(self, ctx: PluginContext) -> None:
        delay = ctx.params["after"] + ctx.params["spread_per_platform"] * ctx.platform
        self._fired = False
        self._remaining = max(0.0, float(delay))
        super().on_activate(ctx)
