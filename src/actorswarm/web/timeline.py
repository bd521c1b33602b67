"""The timeline of collective transitions: platforms' switches grouped as the operator
thinks of them.

A collective transition reaches its participants one release apart at most, so switches
with the same event, source, destination and cause within :data:`WINDOW` seconds of the
first are one *step* (the grouping of :func:`actorswarm.sim.tasksim.steps`, done
incrementally: a step can grow after it was first shown, so each has an ``id`` and the page
replaces it). Each step names its barrier group — the ``barrierKey`` of the transition it
came from, looked up in the running script — and its switch time, from the first
participant to the last. Starts are not steps; a long run keeps the last :data:`KEEP`.

A recording's operator commands come as records of cause ``command`` (no ``from`` or
``to``, the platform's answer as the ``event``): the platforms that answered alike make one
step, shown as a command rather than a switch.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from actorswarm.dsl.model import TaskScript

__all__ = ["KEEP", "WINDOW", "Step", "Timeline"]

#: Seconds within which switches of one kind belong to one step.
WINDOW = 1.0
#: Steps kept for pages that connect later.
KEEP = 500


@dataclass(slots=True)
class Step:
    """One collective transition (or a forced or lost one), as the page shows it."""

    id: int
    t: float
    t_last: float
    event: str
    src: str
    dst: str
    cause: str
    key: int | None
    platforms: list[int] = field(default_factory=list)

    def to_json(self) -> dict[str, Any]:
        return {
            "id": self.id,
            "t": round(self.t, 3),
            "t_last": round(self.t_last, 3),
            "event": self.event,
            "from": self.src,
            "to": self.dst,
            "cause": self.cause,
            "key": self.key,
            "platforms": sorted(self.platforms),
            "switch_ms": round((self.t_last - self.t) * 1000.0, 1),
        }


class Timeline:
    """Steps built from transition records (the simulator's report entries: ``t``,
    ``platform``, ``from``, ``to``, ``event``, ``cause``)."""

    def __init__(self, script: TaskScript | None = None) -> None:
        self.steps: list[Step] = []
        self._next = 1
        self._keys: dict[tuple[str, str], int | None] = {}
        self.use_script(script)

    def use_script(self, script: TaskScript | None) -> None:
        """Name groups after ``script``'s barrier keys from now on."""
        self._keys = (
            {}
            if script is None
            else {(t.actor, t.event): t.barrier_key for t in script.all_transitions()}
        )

    def add(self, records: Iterable[dict[str, Any]]) -> list[Step]:
        """Take new records (time order); return the steps they created or changed."""
        touched: dict[int, Step] = {}
        for rec in records:
            if rec["cause"] == "start":
                continue
            step = self._match(rec)
            if step is None:
                step = Step(
                    id=self._next,
                    t=rec["t"],
                    t_last=rec["t"],
                    event=rec["event"],
                    src=rec["from"],
                    dst=rec["to"],
                    cause=rec["cause"],
                    key=self._keys.get((rec["from"], rec["event"])),
                )
                self._next += 1
                self.steps.append(step)
            step.platforms.append(rec["platform"])
            step.t_last = max(step.t_last, rec["t"])
            touched[step.id] = step
        if len(self.steps) > KEEP:
            del self.steps[: len(self.steps) - KEEP]
        return list(touched.values())

    def _match(self, rec: dict[str, Any]) -> Step | None:
        kind = (rec["event"], rec["from"], rec["to"], rec["cause"])
        for step in reversed(self.steps):
            if rec["t"] - step.t > WINDOW:
                break  # steps are in time order: nothing older can match
            if (step.event, step.src, step.dst, step.cause) == kind:
                return step
        return None
