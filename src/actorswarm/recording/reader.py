"""Reading a recording back: an MCAP file of this project, or an older JSON Lines one.

:func:`read_recording` takes either and gives a :class:`~actorswarm.sim.record.Recording`
(what ``actorswarm plot`` draws and ``actorswarm web --replay`` plays). From an MCAP file it
takes the project's own channels (:mod:`actorswarm.recording.recorder`): ``/platforms`` for
the poses, ``/targets`` for the targets, ``/actorswarm/transitions``, ``/masters`` and
``/events`` for the rest, and the metadata record ``actorswarm`` for the run's metadata;
the Foxglove-only channels (``/scene``, ``/tf``, ``/fix``, ``/log``, ...) are not needed.

What it cannot read it says, naming the file: not a recording at all (wrong magic), an
MCAP file of something else (no ``actorswarm`` metadata), one of a newer format version,
a record that does not decode. A file cut short (its recorder killed, no summary) or a
channel missing is read as far as it goes, and :attr:`Recording.notes` says what is
missing, so a replay shows what it can.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
from mcap.records import Attachment, Channel, Message, Metadata
from mcap.stream_reader import StreamReader

from actorswarm.recording.recorder import FORMAT, VERSION
from actorswarm.sim.record import RecordError, Recording, read_record

__all__ = ["MAGIC", "is_mcap", "read_recording"]

#: The first bytes of every MCAP file.
MAGIC = b"\x89MCAP0\r\n"
# The channels the replay needs, and what is lost without each.
_NEEDED = {
    "/platforms": "no positions",
    "/actorswarm/transitions": "no actor transitions",
    "/actorswarm/masters": "no master changes",
}


# The channels this reader takes (the rest are Foxglove's alone).
_READ = frozenset({"/platforms", "/targets", "/areas", "/actorswarm/events", *_NEEDED})


def is_mcap(path: Path | str) -> bool:
    """Whether ``path`` starts as an MCAP file does (``OSError`` when unreadable)."""
    with Path(path).open("rb") as stream:
        return stream.read(len(MAGIC)) == MAGIC


def read_recording(path: Path | str) -> Recording:
    """The recording at ``path``, MCAP or JSON Lines (module docstring).

    :class:`~actorswarm.sim.record.RecordError` naming the file when it is not a recording
    this version can read; ``OSError`` when it cannot be read at all.
    """
    with Path(path).open("rb") as stream:
        start = stream.read(len(MAGIC))
    if start == MAGIC:
        return _read_mcap(Path(path))
    if start[:1] == MAGIC[:1]:
        raise RecordError(f"{path}: not a readable MCAP file (it ends within its magic bytes)")
    try:
        return read_record(path)  # the older JSON Lines format; it names the bad line
    except UnicodeDecodeError:
        raise RecordError(
            f"{path}: neither an MCAP recording nor a JSON Lines one (not text)"
        ) from None


class _Collect:
    """The replay's data, gathered message by message."""

    def __init__(self, where: str) -> None:
        self.where = where
        self.header: dict[str, str] | None = None
        self.channels: dict[int, str] = {}
        self.seen: set[str] = set()
        self.poses: list[tuple[float, int, float, float, float, float, str]] = []
        self.targets: dict[str, list[tuple[float, float, float, float]]] = {}
        self.transitions: list[dict[str, Any]] = []
        self.masters: list[dict[str, Any]] = []
        self.events: list[dict[str, Any]] = []
        self.script: str | None = None
        self.areas: dict[str, list[list[float]]] = {}

    @property
    def t0(self) -> int:
        assert self.header is not None
        return int(self.header.get("t0_ns", "0"))

    def metadata(self, record: Metadata) -> None:
        if record.name != FORMAT or self.header is not None:
            return
        version = record.metadata.get("version", "")
        if not version.isdigit():
            raise RecordError(f"{self.where}: its actorswarm metadata has no format version")
        if int(version) > VERSION:
            raise RecordError(
                f"{self.where}: written by a newer actorswarm (recording format {version}; "
                f"this one reads up to {VERSION}): upgrade actorswarm to read it"
            )
        self.header = dict(record.metadata)

    def message(self, record: Message) -> None:
        topic = self.channels.get(record.channel_id)
        if topic is None or self.header is None:
            return
        self.seen.add(topic)
        if topic not in _READ:
            return
        try:
            body = json.loads(record.data)
            self._take(topic, (record.log_time - self.t0) / 1e9, body)
        except (ValueError, KeyError, TypeError, AttributeError) as exc:
            raise RecordError(
                f"{self.where}: a {topic} message at log time {record.log_time} does not "
                f"decode ({exc})"
            ) from None

    def _take(self, topic: str, t: float, body: dict[str, Any]) -> None:
        if topic == "/platforms":
            for p in body["platforms"]:
                self.poses.append(
                    (
                        float(p.get("t", t)),
                        int(p["id"]),
                        float(p["x"]),
                        float(p["y"]),
                        float(p["z"]),
                        float(p.get("heading", 0.0)),
                        str(p.get("mode", "")),
                    )
                )
        elif topic == "/targets":
            for entity in body["entities"]:
                name = str(entity["id"]).removeprefix("target/")
                pos = entity["spheres"][0]["pose"]["position"]
                self.targets.setdefault(name, []).append(
                    (t, float(pos["x"]), float(pos["y"]), float(pos["z"]))
                )
        elif topic == "/areas":
            for entity in body["entities"]:
                name = str(entity["id"]).removeprefix("area/")
                points = [[float(q["x"]), float(q["y"])] for q in entity["lines"][0]["points"]]
                self.areas[name] = points[:-1] if len(points) > 1 else points  # open the ring
        elif topic == "/actorswarm/transitions":
            self.transitions.append(_checked(body, ("t", "platform", "from", "to")))
        elif topic == "/actorswarm/masters":
            self.masters.append(_checked(body, ("t", "masters", "epoch")))
        elif topic == "/actorswarm/events":
            self.events.append(_checked(body, ("t", "what", "platform", "text")))

    def recording(self, notes: list[str]) -> Recording:
        assert self.header is not None
        try:
            meta = json.loads(self.header.get("meta", "{}"))
        except ValueError:
            meta = {}
            notes.append("its run metadata does not decode")
        if not isinstance(meta, dict):
            meta = {}
        if self.script is not None:
            meta.setdefault("script_text", self.script)
        if self.areas:
            meta.setdefault("areas", self.areas)
        for topic, loss in _NEEDED.items():
            if topic not in self.seen:
                notes.append(f"no {topic} messages: {loss}")
        cols: list[tuple[Any, ...]] = list(zip(*self.poses, strict=True)) or [()] * 7
        return Recording(
            meta=meta,
            t=np.asarray(cols[0], dtype=np.float64),
            platform=np.asarray(cols[1], dtype=np.int64),
            x=np.asarray(cols[2], dtype=np.float64),
            y=np.asarray(cols[3], dtype=np.float64),
            z=np.asarray(cols[4], dtype=np.float64),
            heading=np.asarray(cols[5], dtype=np.float64),
            mode=[str(m) for m in cols[6]],
            transitions=self.transitions,
            targets={
                name: (
                    np.asarray([r[0] for r in rows], dtype=np.float64),
                    np.asarray([r[1:] for r in rows], dtype=np.float64).reshape(-1, 3),
                )
                for name, rows in self.targets.items()
            },
            masters=self.masters,
            events=self.events,
            notes=notes,
        )


def _checked(body: object, keys: tuple[str, ...]) -> dict[str, Any]:
    if not isinstance(body, dict) or any(k not in body for k in keys):
        raise KeyError(f"expected the fields {', '.join(keys)}")
    return body


def _read_mcap(path: Path) -> Recording:
    where = str(path)
    got = _Collect(where)
    notes: list[str] = []
    with path.open("rb") as stream:
        reader = StreamReader(stream, validate_crcs=True)
        try:
            for record in reader.records:
                if isinstance(record, Channel):
                    got.channels[record.id] = record.topic
                elif isinstance(record, Metadata):
                    got.metadata(record)
                elif isinstance(record, Message):
                    got.message(record)
                elif isinstance(record, Attachment) and record.media_type == "application/xml":
                    got.script = record.data.decode("utf-8", "replace")
        except RecordError:
            raise
        except Exception as exc:  # a cut or corrupt file fails in many ways
            # (mcap's own errors, struct, zstd, lz4): what was read so far stands.
            if got.header is None:
                raise RecordError(f"{where}: not a readable MCAP file ({exc})") from None
            notes.append(
                f"cut short at byte {stream.tell()} (its recorder stopped before finishing: "
                f"{type(exc).__name__}); read up to there"
            )
    if got.header is None:
        raise RecordError(
            f"{where}: an MCAP file, but not an actorswarm recording (no '{FORMAT}' metadata)"
        )
    return got.recording(notes)
