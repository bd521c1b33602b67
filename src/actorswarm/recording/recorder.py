"""A run as Foxglove channels: the facts of a swarm in, JSON messages out to sinks.

Theory of operation
-------------------
A :class:`Recorder` is told what happened, in time order, the same way for a simulated and a
real swarm: a platform's pose (:meth:`~Recorder.pose`), a target's (:meth:`~Recorder.target`),
an actor transition, a master change, a membership or operator event, a number worth
plotting. Poses are state: :meth:`~Recorder.snapshot` turns the latest ones into the scene's
messages at one time. Everything else is written at once. Each message goes, as UTF-8 JSON
with the schema named in :data:`TOPICS`, to every :class:`Sink` (an MCAP file, a live
Foxglove server); the recorder does no I/O of its own and reads no clock.

Channels (topic: schema):

* ``/scene`` (``foxglove.SceneUpdate``): every platform known so far as an entity in its own
  frame ``platform/N`` (frame-locked, so it moves with ``/tf``): an arrow coloured by its
  actor, a label ``N Actor``, metadata ``actor``, ``roles``, ``mode``;
* ``/trails``, ``/targets``, ``/areas`` (``foxglove.SceneUpdate``, frame ``world``): each
  platform's last :data:`TRAIL_POINTS` positions as a line, the moving targets, the areas
  (at the start, and again with each trail);
* ``/formation`` (``foxglove.SceneUpdate``, frame ``world``): where each platform is told to
  be (:meth:`~Recorder.goal`: a formation's slots, a goto's point), a translucent sphere in
  its actor's colour, with each trail when a goal changed — the formation's geometry;
  Each message holds the whole of its kind, so Foxglove, which shows the latest message of
  a topic after a seek, shows the whole scene;
* ``/tf`` (``foxglove.FrameTransforms``): ``world`` → ``platform/N`` per platform whose pose
  changed since the last snapshot;
* ``/fix`` (``foxglove.LocationFix``, frame ``platform/N``): the same poses as latitude,
  longitude, altitude, when the recorder has a geodetic origin;
* ``/platforms`` (``actorswarm.Platforms``): per snapshot, each updated platform's numbers
  (the time of its pose, position, heading, altitude, speed, battery, mode, actor,
  master) — the plots' and the web replay's source;
* ``/log`` (``foxglove.Log``): one line per transition, master change, join or leave,
  operator command answered, vehicle fault (and whatever :meth:`~Recorder.log` is given);
* ``/actorswarm/transitions``, ``/actorswarm/masters``, ``/actorswarm/events``: the same
  facts as the project's own records, field for field;
* ``/metrics`` (``actorswarm.Metrics``): swarm-wide numbers (platforms up, packets per
  second, a collective switch's latency from its first platform to its last).

Times: a message's log time is ``t0_ns`` plus the run's time ``t`` (seconds) in
nanoseconds, never going back: a fact dated before the latest message is written at the
latest message's time (its own ``t`` field keeps its date).
"""

from __future__ import annotations

import json
import math
import zlib
from collections import deque
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import msgspec

if TYPE_CHECKING:
    from actorswarm.vehicles.mavlink.frame import MissionFrame

__all__ = [
    "FORMAT",
    "TOPICS",
    "TRAIL_POINTS",
    "VERSION",
    "Recorder",
    "Sink",
]

#: The name of the MCAP metadata record that says a file is this project's recording.
FORMAT = "actorswarm"
#: The recording format's version (this project writes and reads it; a higher one is newer).
VERSION = 2

#: Each topic's schema name.
TOPICS: dict[str, str] = {
    "/scene": "foxglove.SceneUpdate",
    "/trails": "foxglove.SceneUpdate",
    "/targets": "foxglove.SceneUpdate",
    "/areas": "foxglove.SceneUpdate",
    "/formation": "foxglove.SceneUpdate",
    "/tf": "foxglove.FrameTransforms",
    "/fix": "foxglove.LocationFix",
    "/platforms": "actorswarm.Platforms",
    "/log": "foxglove.Log",
    "/actorswarm/transitions": "actorswarm.Transition",
    "/actorswarm/masters": "actorswarm.Masters",
    "/actorswarm/events": "actorswarm.Event",
    "/metrics": "actorswarm.Metrics",
}

#: Positions a platform's trail keeps (one per :attr:`Recorder.trail_every`).
TRAIL_POINTS = 20

# foxglove.Log levels
DEBUG, INFO, WARNING, ERROR = 1, 2, 3, 4
_LINE_STRIP = 0
_UPRIGHT = {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}
_IDENTITY = {"position": {"x": 0.0, "y": 0.0, "z": 0.0}, "orientation": _UPRIGHT}
_FOREVER = {"sec": 0, "nsec": 0}
_PRIMITIVES = ("arrows", "cubes", "spheres", "cylinders", "lines", "triangles", "texts", "models")
# Colour-blind-safe palette (Okabe-Ito, then Tol's muted): an actor's colour comes from its
# name, so the same actor has the same colour in every recording.
_PALETTE = (
    (0.90, 0.62, 0.00),
    (0.34, 0.71, 0.91),
    (0.00, 0.62, 0.45),
    (0.94, 0.89, 0.26),
    (0.00, 0.45, 0.70),
    (0.84, 0.37, 0.00),
    (0.80, 0.47, 0.65),
    (0.53, 0.80, 0.93),
    (0.27, 0.67, 0.60),
    (0.60, 0.60, 0.20),
)
_NO_ACTOR = (0.6, 0.6, 0.6)
# Event kinds written to the log as warnings (the rest are information).
_WARN = frozenset({"left", "gap", "fault", "crash", "lost"})


class Sink(Protocol):
    """Where a recorder's messages go (an MCAP file, a live server).

    ``message`` gets one encoded message of ``topic`` (whose schema :data:`TOPICS` names) at
    ``log_time`` ns; ``metadata`` and ``attachment`` self-describe the run (a live sink
    may ignore them); ``close`` ends the sink (idempotent).
    """

    def message(self, topic: str, log_time: int, data: bytes) -> None: ...

    def metadata(self, name: str, data: Mapping[str, str]) -> None: ...

    def attachment(self, name: str, media_type: str, data: bytes, log_time: int) -> None: ...

    def close(self) -> None: ...


def actor_colour(actor: str) -> tuple[float, float, float]:
    """The colour of ``actor`` (grey for none), the same in every recording."""
    if not actor:
        return _NO_ACTOR
    return _PALETTE[zlib.crc32(actor.encode()) % len(_PALETTE)]


# msgspec's encoder: several times faster than json.dumps on these nested dicts.
_ENCODE = msgspec.json.Encoder().encode


def _stamp(ns: int) -> dict[str, int]:
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def _rgba(rgb: tuple[float, float, float], a: float = 1.0) -> dict[str, float]:
    return {"r": rgb[0], "g": rgb[1], "b": rgb[2], "a": a}


def _vec(x: float, y: float, z: float) -> dict[str, float]:
    return {"x": x, "y": y, "z": z}


def _yaw(heading: float) -> dict[str, float]:
    """The quaternion of a rotation by ``heading`` radians about z (ENU: from east)."""
    half = heading / 2.0
    return {"x": 0.0, "y": 0.0, "z": round(math.sin(half), 6), "w": round(math.cos(half), 6)}


def _entity(ns: int, frame: str, ident: str, **prims: Any) -> dict[str, Any]:
    """A scene entity with the primitive lists Foxglove expects (empty unless given)."""
    entity: dict[str, Any] = {
        "timestamp": _stamp(ns),
        "frame_id": frame,
        "id": ident,
        "lifetime": _FOREVER,
        "frame_locked": prims.pop("frame_locked", False),
        "metadata": prims.pop("metadata", []),
    }
    for kind in _PRIMITIVES:
        entity[kind] = prims.pop(kind, [])
    return entity


@dataclass(slots=True)
class _Platform:
    """What the recorder knows of one platform."""

    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    heading: float = 0.0
    mode: str = ""
    battery: float | None = None
    speed: float = 0.0
    t: float | None = None  # of the latest pose; None: no pose yet
    actors: list[str] = field(default_factory=list)
    trail: deque[tuple[float, float, float]] = field(
        default_factory=lambda: deque(maxlen=TRAIL_POINTS)
    )

    @property
    def actor(self) -> str:
        return self.actors[0] if self.actors else ""


class Recorder:
    """Turns a run's facts into channel messages for ``sinks`` (module docstring).

    ``meta``: the run's free metadata (JSON-able; written as MCAP metadata ``actorswarm``
    with the format version and ``t0_ns``). ``script``: ``(file name, text)`` of the task
    script, attached. ``areas``: ``{name: polygon}`` (x, y in metres), written once.
    ``origin``: the mission frame's geodetic origin, for ``/fix``. ``trail_every``: seconds
    between two points of a trail (and two ``/trails`` messages). ``counts`` says how many
    facts of each kind were recorded (``pose``, ``transition``, ``master``, ``event``, ...).
    """

    def __init__(
        self,
        sinks: Sequence[Sink],
        *,
        meta: Mapping[str, Any],
        t0_ns: int = 0,
        script: tuple[str, str] | None = None,
        areas: Mapping[str, Sequence[tuple[float, float]]] | None = None,
        origin: MissionFrame | None = None,
        trail_every: float = 2.0,
    ) -> None:
        self.sinks = list(sinks)
        self.t0_ns = int(t0_ns)
        self.origin = origin
        self.trail_every = trail_every
        self.counts: dict[str, int] = {}
        self._last_ns = self.t0_ns
        self._platforms: dict[int, _Platform] = {}
        # Each platform's scene entity, rebuilt only when what it shows changes.
        self._entities: dict[int, tuple[tuple[Any, ...], dict[str, Any]]] = {}
        self._dirty: set[int] = set()
        self._targets: dict[str, tuple[float, float, float]] = {}
        self._targets_dirty = False
        self._masters: frozenset[int] = frozenset()
        self._next_trail = 0.0
        self._closed = False
        self._area_entities: list[dict[str, Any]] = []
        self._goals: dict[int, tuple[float, float, float]] = {}
        self._goals_dirty = False
        header = {
            "format": FORMAT,
            "version": str(VERSION),
            "t0_ns": str(self.t0_ns),
            "meta": json.dumps(dict(meta), allow_nan=False, separators=(",", ":")),
        }
        if origin is not None:
            header["origin"] = f"{origin.lat},{origin.lon},{origin.alt}"
        for sink in self.sinks:
            sink.metadata(FORMAT, header)
            if script is not None:
                sink.attachment(script[0], "application/xml", script[1].encode(), self.t0_ns)
        if areas:
            self._areas(areas)

    # --- the facts -----------------------------------------------------------------------

    def pose(
        self,
        t: float,
        platform: int,
        x: float,
        y: float,
        z: float,
        heading: float = 0.0,
        mode: str = "",
        battery: float | None = None,
    ) -> None:
        """``platform`` is at ``(x, y, z)`` (metres, ENU) heading ``heading`` (radians from
        east) at ``t``; written at the next :meth:`snapshot`. ``ValueError`` when a number is
        not finite (nothing is recorded then)."""
        if not all(map(math.isfinite, (t, x, y, z, heading))):
            raise ValueError(
                f"platform {platform}: a pose of finite numbers, not {(t, x, y, z, heading)}"
            )
        p = self._platforms.setdefault(int(platform), _Platform())
        # Rounded once here (millimetres, a tenth of a milliradian): every message that
        # carries them is shorter, and compresses better.
        x, y, z = round(x, 3), round(y, 3), round(z, 3)
        if p.t is not None and t > p.t:
            p.speed = round(math.dist((x, y, z), (p.x, p.y, p.z)) / (t - p.t), 3)
        p.x, p.y, p.z, p.heading, p.mode, p.t = x, y, z, round(heading, 4), mode, t
        if battery is not None:
            p.battery = round(battery, 4)
        self._dirty.add(int(platform))
        self._count("pose")

    def target(self, t: float, name: str, x: float, y: float, z: float) -> None:
        """The moving target ``name`` is at ``(x, y, z)`` at ``t`` (written at the next
        :meth:`snapshot`)."""
        self._targets[str(name)] = (x, y, z)
        self._targets_dirty = True

    def goal(self, t: float, platform: int, x: float, y: float, z: float) -> None:
        """``platform`` is told to be at ``(x, y, z)`` from ``t`` on (a formation slot);
        written with the next trail when it changed."""
        where = (round(x, 2), round(y, 2), round(z, 2))
        if self._goals.get(int(platform)) != where:
            self._goals[int(platform)] = where
            self._goals_dirty = True

    def snapshot(self, t: float) -> None:
        """Write the scene at ``t``: transforms, fixes and numbers of the platforms whose
        pose changed since the last snapshot, every platform's entity, the targets when
        they moved, the trails every :attr:`trail_every` seconds."""
        ns = self._ns(t)
        updated = sorted(self._dirty)
        self._dirty.clear()
        if updated:
            self._emit("/tf", ns, {"transforms": [self._transform(ns, p) for p in updated]})
            self._emit("/platforms", ns, {"platforms": [self._numbers(p) for p in updated]})
            if self.origin is not None:
                for p in updated:
                    self._emit("/fix", ns, self._fix(ns, p))
        if self._platforms:
            entities = [self._platform_entity(ns, p) for p in sorted(self._platforms)]
            self._emit("/scene", ns, {"deletions": [], "entities": entities})
        if self._targets_dirty:
            self._targets_dirty = False
            self._emit("/targets", ns, {"deletions": [], "entities": self._target_entities(ns)})
        if t >= self._next_trail and self._platforms:
            self._next_trail = t + self.trail_every
            self._slow_layers(ns)

    def _slow_layers(self, ns: int) -> None:
        """What changes slowly, every :attr:`trail_every`: the trails, the formation's
        slots when they moved, the areas again (a live client that connects late sees
        them too)."""
        for known in self._platforms.values():
            if known.t is not None:
                known.trail.append((known.x, known.y, known.z))
        self._emit("/trails", ns, {"deletions": [], "entities": self._trails(ns)})
        if self._goals_dirty:
            self._goals_dirty = False
            self._emit("/formation", ns, {"deletions": [], "entities": self._slots(ns)})
        if self._area_entities:
            self._emit("/areas", ns, {"deletions": [], "entities": self._area_entities})

    def transition(self, record: Mapping[str, Any]) -> None:
        """One actor transition (a run report's ``transitions`` entry: ``t``, ``platform``,
        ``from``, ``to``, ``event``, ``cause``; an empty ``from`` starts an actor, an empty
        ``to`` stops one)."""
        t, platform = float(record["t"]), int(record["platform"])
        src, dst = str(record.get("from", "")), str(record.get("to", ""))
        p = self._platforms.setdefault(platform, _Platform())
        if src in p.actors:
            p.actors.remove(src)
        if dst and dst not in p.actors:
            p.actors.append(dst)
        ns = self._ns(t)
        self._emit("/actorswarm/transitions", ns, dict(record))
        on = f" on {record['event']}" if record.get("event") else ""
        text = f"{src or '-'} → {dst or '-'} ({record.get('cause', '')}{on})"
        self._log(ns, INFO, f"platform/{platform}", text)
        self._count("transition")

    def master(self, t: float, masters: Iterable[int], epoch: int | None) -> None:
        """From ``t`` on, ``masters`` say they are master, the highest epoch being ``epoch``
        (None before any)."""
        who = sorted(int(p) for p in masters)
        self._masters = frozenset(who)
        ns = self._ns(t)
        self._emit("/actorswarm/masters", ns, {"t": float(t), "masters": who, "epoch": epoch})
        named = ", ".join(map(str, who)) or "none"
        self._log(ns, INFO if len(who) == 1 else WARNING, "swarm", f"master {named}, epoch {epoch}")
        self._count("master")

    def event(self, t: float, what: str, platform: int = 0, text: str = "") -> None:
        """Something that happened at ``t`` to ``platform`` (0: the swarm): ``joined``,
        ``left``, ``command`` (an operator's command answered), ``fault``, ``gap``, ..."""
        ns = self._ns(t)
        record = {"t": float(t), "what": str(what), "platform": int(platform), "text": str(text)}
        self._emit("/actorswarm/events", ns, record)
        level = WARNING if what in _WARN or "FAILED" in text else INFO
        name = f"platform/{platform}" if platform else "swarm"
        self._log(ns, level, name, f"{what}{': ' if text else ''}{text}")
        self._count("event")

    def metrics(self, t: float, **values: float | int) -> None:
        """Swarm-wide numbers at ``t`` (``platforms_up``, ``packets_per_s``,
        ``barrier_latency_ms``, ... : any finite number)."""
        clean = {k: v for k, v in values.items() if math.isfinite(v)}
        if clean:
            self._emit("/metrics", self._ns(t), clean)
            self._count("metrics")

    def log(self, t: float, level: int, name: str, text: str) -> None:
        """A free line for the log at ``t`` (``level`` as ``foxglove.Log``: 1 debug, 2 info,
        3 warning, 4 error, 5 fatal)."""
        self._log(self._ns(t), level, name, text)
        self._count("log")

    def close(self) -> None:
        """Close every sink (idempotent)."""
        if self._closed:
            return
        self._closed = True
        for sink in self.sinks:
            sink.close()

    # --- encoding ------------------------------------------------------------------------

    def _count(self, kind: str) -> None:
        self.counts[kind] = self.counts.get(kind, 0) + 1

    def _ns(self, t: float) -> int:
        ns = self.t0_ns + round(max(0.0, t) * 1e9)
        self._last_ns = max(self._last_ns, ns)
        return self._last_ns

    def _emit(self, topic: str, ns: int, message: Mapping[str, Any]) -> None:
        data = _ENCODE(message)
        for sink in self.sinks:
            sink.message(topic, ns, data)

    def _log(self, ns: int, level: int, name: str, text: str) -> None:
        message = {"timestamp": _stamp(ns), "level": level, "message": text, "name": name}
        self._emit("/log", ns, {**message, "file": "", "line": 0})

    def _transform(self, ns: int, platform: int) -> dict[str, Any]:
        p = self._platforms[platform]
        return {
            "timestamp": _stamp(ns),
            "parent_frame_id": "world",
            "child_frame_id": f"platform/{platform}",
            "translation": _vec(p.x, p.y, p.z),
            "rotation": _yaw(p.heading),
        }

    def _numbers(self, platform: int) -> dict[str, Any]:
        p = self._platforms[platform]
        return {
            "id": platform,
            "t": p.t or 0.0,
            "x": p.x,
            "y": p.y,
            "z": p.z,
            "heading": p.heading,
            "mode": p.mode,
            "actor": p.actor,
            "master": platform in self._masters,
            "altitude": p.z,
            "speed": p.speed,
            "battery": p.battery,
        }

    def _fix(self, ns: int, platform: int) -> dict[str, Any]:
        assert self.origin is not None
        p = self._platforms[platform]
        lat, lon, alt = self.origin.to_geodetic(p.x, p.y, p.z)
        return {
            "timestamp": _stamp(ns),
            "frame_id": f"platform/{platform}",
            "latitude": round(lat, 8),
            "longitude": round(lon, 8),
            "altitude": round(alt, 3),
            "position_covariance": [0.0] * 9,
            "position_covariance_type": 0,
        }

    def _platform_entity(self, ns: int, platform: int) -> dict[str, Any]:
        p = self._platforms[platform]
        key = (tuple(p.actors), p.mode, platform in self._masters)
        cached = self._entities.get(platform)
        if cached is not None and cached[0] == key:
            return {**cached[1], "timestamp": _stamp(ns)}
        entity = self._new_entity(ns, platform)
        self._entities[platform] = (key, entity)
        return entity

    def _new_entity(self, ns: int, platform: int) -> dict[str, Any]:
        p = self._platforms[platform]
        colour = _rgba(actor_colour(p.actor))
        roles = "master" if platform in self._masters else "member"
        arrow = {
            "pose": _IDENTITY,
            "shaft_length": 2.0,
            "shaft_diameter": 0.6,
            "head_length": 1.2,
            "head_diameter": 1.4,
            "color": colour,
        }
        label = {
            "pose": {
                "position": {"x": 0.0, "y": 0.0, "z": 2.5},
                "orientation": _UPRIGHT,
            },
            "billboard": True,
            "font_size": 14.0,
            "scale_invariant": True,
            "color": colour,
            "text": f"{platform} {'+'.join(p.actors) or '-'}{' ★' if roles == 'master' else ''}",
        }
        return _entity(
            ns,
            f"platform/{platform}",
            f"platform/{platform}",
            frame_locked=True,
            metadata=[
                {"key": "actor", "value": p.actor},
                {"key": "roles", "value": roles},
                {"key": "mode", "value": p.mode},
            ],
            arrows=[arrow],
            texts=[label],
        )

    def _trails(self, ns: int) -> list[dict[str, Any]]:
        out = []
        for platform, p in sorted(self._platforms.items()):
            if len(p.trail) < 2:
                continue
            line = {
                "type": _LINE_STRIP,
                "pose": _IDENTITY,
                "thickness": 2.0,
                "scale_invariant": True,
                "points": [_vec(*xyz) for xyz in p.trail],
                "color": _rgba(actor_colour(p.actor), 0.6),
                "colors": [],
                "indices": [],
            }
            out.append(_entity(ns, "world", f"trail/{platform}", lines=[line]))
        return out

    def _slots(self, ns: int) -> list[dict[str, Any]]:
        out = []
        for platform, (x, y, z) in sorted(self._goals.items()):
            known = self._platforms.get(platform)
            actor = known.actor if known is not None else ""
            sphere = {
                "pose": {"position": _vec(x, y, z), "orientation": _UPRIGHT},
                "size": _vec(1.5, 1.5, 1.5),
                "color": _rgba(actor_colour(actor), 0.35),
            }
            out.append(_entity(ns, "world", f"slot/{platform}", spheres=[sphere]))
        return out

    def _target_entities(self, ns: int) -> list[dict[str, Any]]:
        out = []
        for name, (x, y, z) in sorted(self._targets.items()):
            sphere = {
                "pose": {"position": _vec(x, y, z), "orientation": _UPRIGHT},
                "size": _vec(4.0, 4.0, 4.0),
                "color": _rgba((0.85, 0.1, 0.1)),
            }
            out.append(_entity(ns, "world", f"target/{name}", spheres=[sphere]))
        return out

    def _areas(self, areas: Mapping[str, Sequence[tuple[float, float]]]) -> None:
        entities = []
        for name, polygon in sorted(areas.items()):
            points = [_vec(float(x), float(y), 0.0) for x, y in polygon]
            line = {
                "type": _LINE_STRIP,
                "pose": _IDENTITY,
                "thickness": 2.0,
                "scale_invariant": True,
                "points": [*points, points[0]] if points else [],
                "color": _rgba((0.2, 0.5, 0.9), 0.8),
                "colors": [],
                "indices": [],
            }
            label = {
                "pose": {
                    "position": points[0] if points else _vec(0, 0, 0),
                    "orientation": _UPRIGHT,
                },
                "billboard": True,
                "font_size": 14.0,
                "scale_invariant": True,
                "color": _rgba((0.2, 0.5, 0.9)),
                "text": name,
            }
            entities.append(
                _entity(self.t0_ns, "world", f"area/{name}", lines=[line], texts=[label])
            )
        self._area_entities = entities
        self._emit("/areas", self.t0_ns, {"deletions": [], "entities": entities})
