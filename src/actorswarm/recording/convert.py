"""An older recording (:class:`~actorswarm.sim.record.Recording`, from JSON Lines) fed to a
:class:`~actorswarm.recording.recorder.Recorder`: what ``actorswarm record convert`` does.

Facts go in time order; at one time, transitions, master changes and events come before
the poses and targets, and a snapshot closes each time that had poses — as a live
recorder would have written them.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial

from actorswarm.recording.recorder import Recorder
from actorswarm.sim.record import Recording

__all__ = ["replay_into"]

_FACT, _POSE = 0, 1


def replay_into(recorder: Recorder, data: Recording) -> None:
    """Write everything ``data`` holds to ``recorder`` (not closed)."""
    facts: list[tuple[float, int, int, Callable[[], None]]] = []

    def add(t: float, kind: int, write: Callable[[], None]) -> None:
        facts.append((float(t), kind, len(facts), write))

    for tr in data.transitions:
        add(tr["t"], _FACT, partial(recorder.transition, tr))
    for m in data.masters:
        add(m["t"], _FACT, partial(recorder.master, m["t"], m["masters"], m["epoch"]))
    for e in data.events:
        add(e["t"], _FACT, partial(recorder.event, e["t"], e["what"], e["platform"], e["text"]))
    for row in data.rows():
        add(row[0], _POSE, partial(recorder.pose, *row))
    for name, (times, xyz) in data.targets.items():
        for t, (x, y, z) in zip(times.tolist(), xyz.tolist(), strict=True):
            add(t, _POSE, partial(recorder.target, t, name, x, y, z))
    facts.sort(key=lambda f: f[:3])
    pending: float | None = None  # the time of poses not yet snapshot
    for t, kind, _, write in facts:
        if pending is not None and t != pending:
            recorder.snapshot(pending)
            pending = None
        write()
        if kind == _POSE:
            pending = t
    if pending is not None:
        recorder.snapshot(pending)
