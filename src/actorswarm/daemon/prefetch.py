"""Load what a deployed script will need before it needs it, off the event loop.

A daemon's loop must never stop for long: its heartbeats stop with it, and a master silent
for ``T_leave`` (0.5 s) is replaced. Two things a script needs were loaded lazily, inside
the loop, at the worst moments: a plugin's module when its actor first starts (the
formations import NumPy: 0.2–0.5 s), and SciPy when a master releases a group whose actor
hands out slots (:mod:`actorswarm.engine.assign`, through :mod:`scipy.optimize`: 0.6 s
idle, up to 2 s on a busy 2-core host). Flying ten ArduCopter SITL from one launch file,
the master went silent right after it released the formation; the members elected the
next platform, which released again, imported SciPy and went silent in turn, and so on —
each transient master handed out its own slots, and two copters sent to one slot passed
0.25 m apart.

So when a deployed script has passed its check, :func:`prefetch` loads, in a worker
thread, every plugin class the script names and, when one of them gives its members places
(:meth:`~actorswarm.runtime.plugin.Plugin.group_points`), the assignment's solver (NumPy
and SciPy's one C extension for it, not the whole of :mod:`scipy.optimize`:
:func:`~actorswarm.engine.assign.warm_up`) — before the deploy is acknowledged, so before
the script can start. A thread, not the loop: the
interpreter switches threads every few milliseconds while a module imports, so the loop
keeps beating. What fails to load is left for the runtime to report when the actor starts.
"""

from __future__ import annotations

from actorswarm.dsl.model import TaskScript
from actorswarm.engine.assign import warm_up
from actorswarm.runtime.plugin import Plugin
from actorswarm.runtime.registry import RegistryError, resolve

__all__ = ["prefetch"]


def prefetch(script: TaskScript) -> list[str]:
    """Load every plugin class ``script`` names and, if one hands out slots, the slot
    assignment's solver; the names of what was loaded, in order (``slot assignment`` for
    the solver). Blocking, for seconds on a busy host: call it from a worker thread."""
    loaded: list[str] = []
    slots = False
    for actor in script.actors:
        for _bus, spec in actor.plugins():
            try:
                cls = resolve(spec.name)
            except RegistryError:
                continue  # the runtime says so when the actor starts
            if spec.name not in loaded:
                loaded.append(spec.name)
            slots = slots or _gives_places(cls)
    if slots:
        warm_up()
        loaded.append("slot assignment")
    return loaded


def _gives_places(cls: type[Plugin]) -> bool:
    """Whether the plugin class overrides :meth:`Plugin.group_points`."""
    return getattr(cls.group_points, "__func__", None) is not getattr(
        Plugin.group_points, "__func__", None
    )
