"""A run's recording in the older JSON Lines format, and the analysis of any recording.

Recordings are MCAP files now (:mod:`actorswarm.recording`, which reads both formats into
the :class:`Recording` defined here). This module still reads and writes the JSON Lines
format of earlier versions, so their files stay readable (``actorswarm record convert``
turns one into MCAP), and holds what both share: :class:`Recording`, the actor timeline,
the collective transitions, the sampling of a simulated world.

File format
-----------
One JSON object per line, UTF-8, each with a ``type``:

* line 1, ``{"type": "meta", "format": "actorswarm-record", "version": 1, ...}``: the
  caller's free metadata (script, seed, duration, ...) next to the format marker;
* ``{"type": "pose", "t", "platform", "x", "y", "z", "heading", "mode"}``: one vehicle at
  one time (metres in the world's ENU frame, heading in radians, the vehicle's mode);
* ``{"type": "target", "t", "name", "x", "y", "z"}``: one moving target (the jeep) at one
  time; the meta line may carry the world's ``areas`` as ``{name: [[x, y], ...]}``;
* ``{"type": "transition", "t", "platform", "from", "to", "event", "cause", ...}``: one
  entry of a run report's ``transitions`` (an empty ``from`` starts an actor, an empty
  ``to`` stops one);
* ``{"type": "master", "t", "masters", "epoch"}``: from ``t`` on, the platforms in the list
  ``masters`` say they are master (none: empty; two while a partition lasts), the highest
  epoch heard being ``epoch`` (an integer, or null before any);
* ``{"type": "event", "t", "what", "platform", "text"}``: something that happened to the
  swarm as a whole or to one platform (``platform`` 0 for the swarm), e.g. ``what``
  ``joined`` or ``left`` for membership, ``command`` for an operator's command seen.

A recording of a real swarm (``gs record`` of earlier versions) was written line by line
as it happened, so its lines of every type come interleaved in time order; a simulation's
was written at the end. Readers take either.

:func:`write_record` writes the meta line, then the poses, then the transitions;
:class:`RecordWriter` writes one line at a time, flushing each;
:func:`read_record` reads one back as a :class:`Recording` and refuses a malformed file
with a :class:`RecordError` that names the line. :func:`actor_timeline` turns transitions
into who ran what when, and :func:`collective_transitions` finds the moments many
platforms switched together (the steps of a task). :func:`sample_world` makes a world-backed
:class:`~actorswarm.sim.tasksim.TaskSim` snapshot its vehicles at a fixed period, so that
``sim.world.track().rows()`` has poses to write.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from actorswarm.sim.tasksim import TaskSim

__all__ = [
    "FORMAT",
    "VERSION",
    "Collective",
    "RecordError",
    "RecordWriter",
    "Recording",
    "Span",
    "actor_timeline",
    "collective_transitions",
    "read_record",
    "sample_world",
    "write_record",
]

#: The ``format`` marker of the meta line.
FORMAT = "actorswarm-record"
#: The version of the file format this module writes and reads.
VERSION = 1

PoseRow = tuple[float, int, float, float, float, float, str]
#: ``(platform, actor, t_start, t_end)``; ``t_end`` None: still running at the end.
Span = tuple[int, str, float, float | None]

_RESERVED_META = ("type", "format", "version")
_POSE_NUMBERS = ("t", "x", "y", "z", "heading")
_TRANSITION_TEXT = ("from", "to", "event", "cause")


class RecordError(ValueError):
    """A recording file that cannot be read; the message names the line."""


@dataclass(frozen=True, slots=True, eq=False)
class Recording:
    """A recording read back: metadata, poses as parallel arrays, transitions.

    The pose arrays all have one entry per pose line, in file order: ``t``, ``x``, ``y``,
    ``z``, ``heading`` (float64), ``platform`` (int64) and ``mode`` (a list of str).
    ``meta`` is the caller's metadata (without the format keys); ``transitions`` the
    transition lines as dicts (without ``type``).
    """

    meta: dict[str, Any]
    t: NDArray[np.float64]
    platform: NDArray[np.int64]
    x: NDArray[np.float64]
    y: NDArray[np.float64]
    z: NDArray[np.float64]
    heading: NDArray[np.float64]
    mode: list[str]
    transitions: list[dict[str, Any]] = field(default_factory=list)
    #: Each target's ``(times (m,), positions (m, 3))``, by name, in time order.
    targets: dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]] = field(
        default_factory=dict
    )
    #: The master lines (without ``type``), in file order.
    masters: list[dict[str, Any]] = field(default_factory=list)
    #: The event lines (without ``type``), in file order.
    events: list[dict[str, Any]] = field(default_factory=list)
    #: What the reader could not read of the file (an MCAP recording cut short, a channel
    #: missing), one line each; empty for a whole recording.
    notes: list[str] = field(default_factory=list)

    def areas(self) -> dict[str, list[tuple[float, float]]]:
        """The areas the meta line names (``{name: polygon}``; malformed entries are
        skipped, since meta is free-form)."""
        raw = self.meta.get("areas")
        out: dict[str, list[tuple[float, float]]] = {}
        if not isinstance(raw, dict):
            return out
        for name, polygon in raw.items():
            if isinstance(polygon, list) and all(
                isinstance(p, list) and len(p) == 2 and all(_is_number(v) for v in p)
                for p in polygon
            ):
                out[str(name)] = [(float(p[0]), float(p[1])) for p in polygon]
        return out

    def __len__(self) -> int:
        """The number of poses."""
        return len(self.t)

    def rows(self) -> list[PoseRow]:
        """The poses as ``(t, platform, x, y, z, heading, mode)`` rows, in file order."""
        return list(
            zip(
                self.t.tolist(),
                self.platform.tolist(),
                self.x.tolist(),
                self.y.tolist(),
                self.z.tolist(),
                self.heading.tolist(),
                self.mode,
                strict=True,
            )
        )

    def platforms(self) -> list[int]:
        """Every platform with a pose or a transition, ascending."""
        ids = set(self.platform.tolist())
        ids.update(int(tr["platform"]) for tr in self.transitions)
        return sorted(ids)

    def path(self, platform: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(times (m,), positions (m, 3))`` of ``platform``, in time order (empty when it
        has no pose)."""
        where = np.flatnonzero(self.platform == platform)
        order = where[np.argsort(self.t[where], kind="stable")]
        xyz = np.stack([self.x[order], self.y[order], self.z[order]], axis=1)
        return self.t[order], xyz.reshape(-1, 3)

    def end_time(self) -> float:
        """The last time the recording knows of: the latest pose or transition, or the
        ``duration`` in the metadata if that is later, or a simulation's ``sim_time_s``
        (the time simulated, which outlasts its last transition) (0 when there is nothing)."""
        ends = [0.0]
        if len(self.t):
            ends.append(float(self.t.max()))
        ends.extend(float(tr["t"]) for tr in self.transitions)
        ends.extend(float(m["t"]) for m in self.masters)
        ends.extend(float(e["t"]) for e in self.events)
        for key in ("duration", "sim_time_s"):
            duration = self.meta.get(key)
            if isinstance(duration, int | float) and not isinstance(duration, bool):
                ends.append(float(duration))
        return max(ends)


# --- writing -------------------------------------------------------------------------------


def _pose(
    t: float, platform: int, x: float, y: float, z: float, heading: float, mode: str
) -> dict[str, Any]:
    """A ``pose`` line's fields, typed as the format has them."""
    return {
        "type": "pose",
        "t": float(t),
        "platform": int(platform),
        "x": float(x),
        "y": float(y),
        "z": float(z),
        "heading": float(heading),
        "mode": str(mode),
    }


def _line(obj: Mapping[str, Any]) -> str:
    try:
        return json.dumps(obj, allow_nan=False, ensure_ascii=False, separators=(",", ":"))
    except ValueError as exc:  # NaN or infinity
        raise ValueError(f"cannot record {dict(obj)!r}: {exc}") from None


def write_record(
    path: Path | str,
    *,
    rows: Iterable[tuple[float, int, float, float, float, float, str]],
    transitions: list[dict[str, Any]],
    meta: dict[str, Any],
    targets: Iterable[tuple[float, str, float, float, float]] = (),
) -> None:
    """Write a recording to ``path`` (module docstring): the meta line, one line per pose
    row ``(t, platform, x, y, z, heading, mode)`` (as :meth:`~actorswarm.world.world.Track.
    rows` gives them), one per target row ``(t, name, x, y, z)`` (:meth:`~actorswarm.world.
    world.Track.target_rows`), then one line per transition (as a run report's
    ``transitions``).

    ``ValueError`` when ``meta`` uses a reserved key (``type``, ``format``, ``version``),
    a transition has a ``type`` key, or a value is not finite or not JSON. The file is
    written to a temporary name first and renamed, so a failure leaves no half file.
    """
    clash = [key for key in _RESERVED_META if key in meta]
    if clash:
        raise ValueError(f"meta may not use the reserved key(s) {clash}")
    target = Path(path)
    partial = target.with_name(target.name + ".partial")
    try:
        with partial.open("w", encoding="utf-8", newline="\n") as out:
            out.write(_line({"type": "meta", "format": FORMAT, "version": VERSION, **meta}))
            out.write("\n")
            for row in rows:
                out.write(_line(_pose(*row)))
                out.write("\n")
            for t, name, x, y, z in targets:
                sighting = {
                    "type": "target",
                    "t": float(t),
                    "name": str(name),
                    "x": float(x),
                    "y": float(y),
                    "z": float(z),
                }
                out.write(_line(sighting))
                out.write("\n")
            for tr in transitions:
                if "type" in tr:
                    raise ValueError(f"a transition may not have a 'type' key: {tr!r}")
                out.write(_line({"type": "transition", **tr}))
                out.write("\n")
        partial.replace(target)
    except BaseException:
        partial.unlink(missing_ok=True)
        raise


class RecordWriter:
    """A recording written as it happens, one line at a time (module docstring).

    ``with RecordWriter(path, meta) as out: out.pose(...)``: the meta line is written on
    opening; every line is written whole and flushed at once, so a recording cut short (the
    recorder killed) is readable up to its last full line, and one stopped cleanly (leaving
    the ``with`` block, or :meth:`close`) is complete. ``lines`` counts what was written by
    type. ``ValueError`` as for :func:`write_record`; ``OSError`` when the file cannot be
    written.
    """

    def __init__(self, path: Path | str, meta: Mapping[str, Any]) -> None:
        clash = [key for key in _RESERVED_META if key in meta]
        if clash:
            raise ValueError(f"meta may not use the reserved key(s) {clash}")
        header = _line({"type": "meta", "format": FORMAT, "version": VERSION, **meta})
        self.path = Path(path)
        self.lines: dict[str, int] = {}
        self._out = self.path.open("w", encoding="utf-8", newline="\n")
        self._write(header, "meta")

    def __enter__(self) -> RecordWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def closed(self) -> bool:
        return self._out.closed

    def close(self) -> None:
        """Finish the file (idempotent)."""
        self._out.close()

    def _write(self, text: str, kind: str) -> None:
        self._out.write(text + "\n")
        self._out.flush()
        self.lines[kind] = self.lines.get(kind, 0) + 1

    def pose(
        self,
        t: float,
        platform: int,
        x: float,
        y: float,
        z: float,
        heading: float = 0.0,
        mode: str = "",
    ) -> None:
        """One vehicle's pose at ``t``."""
        self._write(_line(_pose(t, platform, x, y, z, heading, mode)), "pose")

    def transition(self, record: Mapping[str, Any]) -> None:
        """One transition record (``t``, ``platform``, ``from``, ``to``, ``event``,
        ``cause``, ...)."""
        if "type" in record:
            raise ValueError(f"a transition may not have a 'type' key: {dict(record)!r}")
        self._write(_line({"type": "transition", **record}), "transition")

    def master(self, t: float, masters: Iterable[int], epoch: int | None) -> None:
        """From ``t`` on, ``masters`` say they are master, in (at most) ``epoch``."""
        line = {
            "type": "master",
            "t": float(t),
            "masters": sorted(int(p) for p in masters),
            "epoch": None if epoch is None else int(epoch),
        }
        self._write(_line(line), "master")

    def event(self, t: float, what: str, platform: int = 0, text: str = "") -> None:
        """Something that happened at ``t`` (``platform`` 0: to the swarm as a whole)."""
        line = {
            "type": "event",
            "t": float(t),
            "what": str(what),
            "platform": int(platform),
            "text": str(text),
        }
        self._write(_line(line), "event")


# --- reading -------------------------------------------------------------------------------


def _is_number(value: object) -> bool:
    return (
        isinstance(value, int | float)
        and not isinstance(value, bool)
        and math.isfinite(float(value))
    )


def _is_int(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _fail(where: str, lineno: int, problem: str) -> RecordError:
    return RecordError(f"{where}, line {lineno}: {problem}")


def read_record(path: Path | str) -> Recording:
    """Read the recording at ``path``.

    Blank lines are skipped. :class:`RecordError` (naming the file and the line) when a
    line is not a JSON object, the first is not the meta line of this format and version,
    a line has an unknown ``type``, or a pose or transition lacks a field or has one of the
    wrong kind; ``OSError`` when the file cannot be read.
    """
    where = str(path)
    meta: dict[str, Any] | None = None
    cols: dict[str, list[float]] = {key: [] for key in _POSE_NUMBERS}
    platforms: list[int] = []
    modes: list[str] = []
    transitions: list[dict[str, Any]] = []
    masters: list[dict[str, Any]] = []
    events: list[dict[str, Any]] = []
    target_rows: dict[str, list[tuple[float, float, float, float]]] = {}
    with Path(path).open(encoding="utf-8") as stream:
        for lineno, text in enumerate(stream, start=1):
            if not text.strip():
                continue
            try:
                obj = json.loads(text)
            except json.JSONDecodeError as exc:
                raise _fail(where, lineno, f"not JSON ({exc.msg})") from None
            if not isinstance(obj, dict):
                raise _fail(where, lineno, f"expected a JSON object, got {type(obj).__name__}")
            kind = obj.get("type")
            if meta is None:
                if kind != "meta":
                    raise _fail(
                        where, lineno, f"the first line must be the meta line, not {kind!r}"
                    )
                if obj.get("format") != FORMAT:
                    raise _fail(where, lineno, f"format {obj.get('format')!r}, expected {FORMAT!r}")
                if obj.get("version") != VERSION:
                    raise _fail(
                        where, lineno, f"version {obj.get('version')!r}; this reads {VERSION}"
                    )
                meta = {k: v for k, v in obj.items() if k not in _RESERVED_META}
            elif kind == "pose":
                for key in _POSE_NUMBERS:
                    if not _is_number(obj.get(key)):
                        raise _fail(where, lineno, f"pose {key!r} must be a finite number")
                if not _is_int(obj.get("platform")):
                    raise _fail(where, lineno, "pose 'platform' must be an integer")
                if not isinstance(obj.get("mode"), str):
                    raise _fail(where, lineno, "pose 'mode' must be a string")
                for key in _POSE_NUMBERS:
                    cols[key].append(float(obj[key]))
                platforms.append(obj["platform"])
                modes.append(obj["mode"])
            elif kind == "transition":
                if not _is_number(obj.get("t")):
                    raise _fail(where, lineno, "transition 't' must be a finite number")
                if not _is_int(obj.get("platform")):
                    raise _fail(where, lineno, "transition 'platform' must be an integer")
                for key in _TRANSITION_TEXT:
                    if not isinstance(obj.get(key), str):
                        raise _fail(where, lineno, f"transition {key!r} must be a string")
                transitions.append({k: v for k, v in obj.items() if k != "type"})
            elif kind == "target":
                for key in ("t", "x", "y", "z"):
                    if not _is_number(obj.get(key)):
                        raise _fail(where, lineno, f"target {key!r} must be a finite number")
                if not isinstance(obj.get("name"), str):
                    raise _fail(where, lineno, "target 'name' must be a string")
                target_rows.setdefault(obj["name"], []).append(
                    (float(obj["t"]), float(obj["x"]), float(obj["y"]), float(obj["z"]))
                )
            elif kind == "master":
                masters.append(_master_line(obj, where, lineno))
            elif kind == "event":
                events.append(_event_line(obj, where, lineno))
            elif kind == "meta":
                raise _fail(where, lineno, "a second meta line")
            else:
                raise _fail(
                    where,
                    lineno,
                    f"unknown type {kind!r} (meta, pose, target, transition, master or event "
                    "expected)",
                )
    if meta is None:
        raise RecordError(f"{where}, line 1: empty recording (no meta line)")
    return Recording(
        meta=meta,
        t=np.asarray(cols["t"], dtype=np.float64),
        platform=np.asarray(platforms, dtype=np.int64),
        x=np.asarray(cols["x"], dtype=np.float64),
        y=np.asarray(cols["y"], dtype=np.float64),
        z=np.asarray(cols["z"], dtype=np.float64),
        heading=np.asarray(cols["heading"], dtype=np.float64),
        mode=modes,
        transitions=transitions,
        targets={name: _path_of(rows) for name, rows in target_rows.items()},
        masters=masters,
        events=events,
    )


def _master_line(obj: dict[str, Any], where: str, lineno: int) -> dict[str, Any]:
    if not _is_number(obj.get("t")):
        raise _fail(where, lineno, "master 't' must be a finite number")
    masters = obj.get("masters")
    if not isinstance(masters, list) or not all(_is_int(p) for p in masters):
        raise _fail(where, lineno, "master 'masters' must be a list of platform IDs")
    epoch = obj.get("epoch")
    if epoch is not None and not _is_int(epoch):
        raise _fail(where, lineno, "master 'epoch' must be an integer or null")
    return {k: v for k, v in obj.items() if k != "type"}


def _event_line(obj: dict[str, Any], where: str, lineno: int) -> dict[str, Any]:
    if not _is_number(obj.get("t")):
        raise _fail(where, lineno, "event 't' must be a finite number")
    if not _is_int(obj.get("platform")):
        raise _fail(where, lineno, "event 'platform' must be an integer")
    for key in ("what", "text"):
        if not isinstance(obj.get(key), str):
            raise _fail(where, lineno, f"event {key!r} must be a string")
    return {k: v for k, v in obj.items() if k != "type"}


def _path_of(
    rows: list[tuple[float, float, float, float]],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    data = np.asarray(sorted(rows), dtype=np.float64).reshape(-1, 4)
    return data[:, 0], data[:, 1:]


# --- analysis ------------------------------------------------------------------------------


def actor_timeline(transitions: Iterable[Mapping[str, Any]]) -> list[Span]:
    """Who ran which actor when: ``(platform, actor, t_start, t_end)`` spans.

    A transition closes the span of its ``from`` actor (when not empty) and opens one of
    its ``to`` actor (when not empty) on its platform; a platform may run several actors at
    once. A span still open at the end has ``t_end`` None. An actor stopped without having
    been started in ``transitions`` (a recording begun mid-run) counts from the first
    transition's time; starting an actor that already runs changes nothing. Transitions
    are taken in time order (ties in the given order); spans come sorted by platform,
    start and actor.
    """
    ordered = sorted(transitions, key=lambda tr: float(tr["t"]))
    if not ordered:
        return []
    first = float(ordered[0]["t"])
    open_at: dict[tuple[int, str], float] = {}
    spans: list[Span] = []
    for tr in ordered:
        t, platform = float(tr["t"]), int(tr["platform"])
        src, dst = str(tr.get("from", "")), str(tr.get("to", ""))
        if src:
            start = open_at.pop((platform, src), first)
            spans.append((platform, src, start, t))
        if dst:
            open_at.setdefault((platform, dst), t)
    spans.extend((p, actor, start, None) for (p, actor), start in open_at.items())
    spans.sort(key=lambda s: (s[0], s[2], s[1]))
    return spans


@dataclass(frozen=True, slots=True)
class Collective:
    """Many platforms making the same move together: ``src`` → ``dst`` on ``event`` (for
    ``cause``), from ``t`` to ``t_last``, by ``platforms``."""

    t: float
    t_last: float
    event: str
    src: str
    dst: str
    cause: str
    platforms: tuple[int, ...]

    @property
    def label(self) -> str:
        """A short caption: the event, else the move."""
        return self.event or f"{self.src or '-'} → {self.dst or '-'}"


def collective_transitions(
    transitions: Iterable[Mapping[str, Any]],
    *,
    fleet: int | None = None,
    window: float = 1.0,
    share: float = 0.5,
) -> list[Collective]:
    """The moments many platforms switched actors together, in time order.

    Transitions with the same ``event``, ``from``, ``to`` and ``cause`` within ``window``
    seconds of the first of them form one group (a release reaches some platforms a
    retransmission later than others); starts (empty ``from``) are left out. A group is
    collective when it holds at least ``share`` of the ``fleet`` platforms (default: every
    platform the transitions name) and at least two of them, unless the fleet has one.
    """
    rows = sorted(transitions, key=lambda tr: float(tr["t"]))
    n = fleet if fleet is not None else len({int(tr["platform"]) for tr in rows})
    groups: list[tuple[float, float, tuple[str, str, str, str], list[int]]] = []
    for tr in rows:
        if not tr.get("from"):
            continue
        t = float(tr["t"])
        key = (
            str(tr.get("event", "")),
            str(tr.get("from", "")),
            str(tr.get("to", "")),
            str(tr.get("cause", "")),
        )
        for i, (first, _, gkey, who) in enumerate(groups):
            if gkey == key and t - first <= window:
                who.append(int(tr["platform"]))
                groups[i] = (first, t, gkey, who)
                break
        else:
            groups.append((t, t, key, [int(tr["platform"])]))
    need = max(min(2, n), math.ceil(share * n))
    return [
        Collective(first, last, key[0], key[1], key[2], key[3], tuple(sorted(set(who))))
        for first, last, key, who in groups
        if len(set(who)) >= need
    ]


# --- sampling a simulation -------------------------------------------------------------------


def sample_world(
    sim: TaskSim, every: float, packets: list[tuple[float, int]] | None = None
) -> None:
    """Make ``sim``'s world snapshot its vehicles at times 0, ``every``, ``2 * every``, ...
    of virtual time while the simulation runs (call before :meth:`TaskSim.run`); the
    snapshots are then in ``sim.world.track()``. ``packets``, when given, gets
    ``(t, packets the swarm sent so far)`` at each snapshot (a recording's packets/s).

    ``ValueError`` when ``sim`` has no world or ``every`` is not a time > 0.
    """
    world = sim.world
    if world is None:
        raise ValueError("the simulation has no world (give TaskSim a world_config)")
    if not (math.isfinite(every) and every > 0):
        raise ValueError(f"every must be a number of seconds > 0, not {every!r}")
    start = sim.swarm.now
    count = 0

    def snapshot() -> None:
        nonlocal count
        world.step_to(sim.swarm.now)  # catch up first: the physics timer may come later
        world.record()
        if packets is not None:
            traffic = sim.swarm.radio.traffic
            packets.append((sim.swarm.now, sum(traffic.totals(p)[0] for p in traffic.platforms)))
        count += 1
        sim.swarm.at(start + count * every, snapshot)

    sim.swarm.at(start, snapshot)
