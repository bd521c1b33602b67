"""The autopilot's own geofence, pushed from the daemon's fence box over MAVLink.

The daemon bounds every goal by its :class:`~actorswarm.vehicles.mavlink.vehicle.Fence`
(a box in the mission frame and a ceiling). That holds only while the companion computer
runs; the autopilot's own fence holds when it does not. :class:`FenceUpload` pushes the
same box there, with the two parts MAVLink has for it:

* the horizontal box as an inclusion polygon of four vertices
  (``MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION``, latitude and longitude from the mission
  frame), uploaded with the mission protocol on ``MAV_MISSION_TYPE_FENCE``:
  ``MISSION_COUNT`` → the autopilot asks for each item (``MISSION_REQUEST_INT``, or the
  older ``MISSION_REQUEST``) → ``MISSION_ITEM_INT`` → ``MISSION_ACK``;
* the ceiling as the autopilot's parameters (:func:`fence_params`): ArduPilot
  ``FENCE_ALT_MAX`` with ``FENCE_TYPE`` = altitude and polygon and ``FENCE_ENABLE`` = 1;
  PX4 ``GF_MAX_VER_DIST`` (PX4 enables its geofence from the uploaded polygon). Each
  ``PARAM_SET`` is repeated until the autopilot echoes the value (``PARAM_VALUE``).

The upload is sans-IO, like the rest of this layer's protocols: :meth:`FenceUpload.start`,
:meth:`~FenceUpload.on_message` and :meth:`~FenceUpload.tick` take the time and return the
messages to send. It repeats what got no answer every ``retry`` seconds and fails, with one
line naming the autopilot and the step, after ``deadline`` seconds without progress.

:class:`FenceReceiver` is the other side, for the project's simulated autopilot (and for
tests): it answers an upload as an autopilot does and keeps the polygon, so a test can see
the fence arrive.

Not done here: the fence's breach action (the autopilot's ``FENCE_ACTION`` /
``GF_ACTION``: the operator's choice, left as configured), a return point, circles and
exclusion zones, and downloading the fence back to compare.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Final, Literal, Protocol

from actorswarm.vehicles.mavlink.dialect import mav
from actorswarm.vehicles.mavlink.frame import MissionFrame
from actorswarm.vehicles.mavlink.mission import MissionWrite

__all__ = [
    "FENCE_MESSAGES",
    "FenceBox",
    "FencePusher",
    "FenceReceiver",
    "FenceUpload",
    "fence_items",
    "fence_params",
]

_FENCE: Final[int] = mav.MAV_MISSION_TYPE_FENCE
_VERTEX: Final[int] = mav.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION
#: ArduPilot's FENCE_TYPE bits: maximum altitude (1) and polygon (4).
_ARDUPILOT_ALT_AND_POLYGON: Final = 1 + 4
#: The messages of the fence upload, either way.
FENCE_MESSAGES: Final = frozenset(
    {
        "MISSION_COUNT",
        "MISSION_REQUEST",
        "MISSION_REQUEST_INT",
        "MISSION_ITEM_INT",
        "MISSION_ACK",
        "PARAM_VALUE",
    }
)


class FenceBox(Protocol):
    """A box in the mission frame (what :class:`~.vehicle.Fence` is)."""

    @property
    def x_min(self) -> float: ...
    @property
    def y_min(self) -> float: ...
    @property
    def x_max(self) -> float: ...
    @property
    def y_max(self) -> float: ...
    @property
    def z_max(self) -> float: ...


def fence_items(
    box: FenceBox, frame: MissionFrame, *, target_system: int, target_component: int
) -> list[Any]:
    """The four ``MISSION_ITEM_INT`` of ``box``'s inclusion polygon, counter-clockwise from
    its south-west corner, in WGS-84 from ``frame``."""
    corners = [
        (box.x_min, box.y_min),
        (box.x_max, box.y_min),
        (box.x_max, box.y_max),
        (box.x_min, box.y_max),
    ]
    items = []
    for seq, (x, y) in enumerate(corners):
        lat, lon, _ = frame.to_geodetic(x, y, 0.0)
        items.append(
            mav.MAVLink_mission_item_int_message(
                target_system,
                target_component,
                seq,
                mav.MAV_FRAME_GLOBAL,
                _VERTEX,
                0,
                1,
                float(len(corners)),  # param1: the polygon's vertex count
                0.0,
                0.0,
                0.0,
                round(lat * 1e7),
                round(lon * 1e7),
                0.0,
                _FENCE,
            )
        )
    return items


def fence_params(kind: Literal["ardupilot", "px4"], z_max: float) -> list[tuple[str, float]]:
    """The parameters that set the ceiling ``z_max`` (metres above home) on ``kind``."""
    if kind == "px4":
        return [("GF_MAX_VER_DIST", float(z_max))]
    return [
        ("FENCE_ALT_MAX", float(z_max)),
        ("FENCE_TYPE", float(_ARDUPILOT_ALT_AND_POLYGON)),
        ("FENCE_ENABLE", 1.0),
    ]


Phase = Literal["params", "polygon", "done", "failed"]


@dataclass(slots=True)
class FenceUpload:
    """Pushes ``params`` (name, value) and then the polygon ``items`` to the autopilot
    ``target_system``/``target_component`` (module docstring); the polygon goes by the
    mission protocol (:class:`~.mission.MissionWrite` on the fence). ``name`` starts the
    error line (``vehicle 3``)."""

    items: Sequence[Any]
    params: Sequence[tuple[str, float]]
    target_system: int
    target_component: int
    name: str = "vehicle"
    retry: float = 0.5
    deadline: float = 5.0
    phase: Phase = "params"
    #: Why the upload failed (one line), None while it has not.
    error: str | None = None
    _pending: list[tuple[str, float]] | None = None
    _polygon: MissionWrite | None = None
    _sent_at: float = 0.0
    _progress_at: float = 0.0

    @property
    def done(self) -> bool:
        """The autopilot accepted every parameter and the polygon."""
        return self.phase == "done"

    def start(self, now: float) -> list[Any]:
        """The first messages: the parameter sets (or, with none, the count)."""
        self._pending = list(self.params)
        self._progress_at = now
        if not self._pending:
            return self._write_polygon(now)
        self.phase = "params"
        self._sent_at = now
        return [self._param_set(n, v) for n, v in self._pending]

    def on_message(self, message: Any, now: float) -> list[Any]:
        """What to send in answer to ``message`` from the autopilot."""
        if self.phase == "polygon" and self._polygon is not None:
            return self._follow(self._polygon.on_message(message, now))
        if self.phase == "params" and message.get_type() == "PARAM_VALUE" and self._pending:
            name = message.param_id
            if isinstance(name, bytes):
                name = name.decode("ascii", "replace")
            name = str(name).rstrip("\x00")
            for wanted, value in list(self._pending):
                if name == wanted and abs(float(message.param_value) - value) < 1e-3:
                    self._pending.remove((wanted, value))
                    self._progress_at = now
            return self._write_polygon(now) if not self._pending else []
        return []

    def tick(self, now: float) -> list[Any]:
        """Repeat what got no answer; fail past the deadline."""
        if self.phase == "polygon" and self._polygon is not None:
            return self._follow(self._polygon.tick(now))
        if self.phase != "params" or self._pending is None:
            return []
        if now - self._progress_at >= self.deadline:
            return self._fail(
                f"did not set its fence parameters in {self.deadline:g} s (no answer)"
            )
        if now - self._sent_at >= self.retry:
            self._sent_at = now
            return [self._param_set(n, v) for n, v in self._pending]
        return []

    def _write_polygon(self, now: float) -> list[Any]:
        self.phase = "polygon"
        self._polygon = MissionWrite(
            self.items,
            (self.target_system, self.target_component),
            what="the fence",
            who=self.name,
            retry=self.retry,
            deadline=self.deadline,
            mission_type=_FENCE,
        )
        return self._polygon.start(now)

    def _follow(self, out: list[Any]) -> list[Any]:
        """The polygon write's messages, and its end as the upload's."""
        polygon = self._polygon
        assert polygon is not None
        if polygon.done:
            self.phase = "done"
        elif polygon.error is not None:
            self.phase = "failed"
            self.error = f"{polygon.error}; its own fence is not set"
        return out

    def _param_set(self, name: str, value: float) -> Any:
        return mav.MAVLink_param_set_message(
            self.target_system,
            self.target_component,
            name.encode(),
            value,
            mav.MAV_PARAM_TYPE_REAL32,
        )

    def _fail(self, why: str) -> list[Any]:
        self.phase = "failed"
        self.error = f"{self.name}: the autopilot {why}; its own fence is not set"
        return []


@dataclass(slots=True)
class FencePusher:
    """What a vehicle keeps to push its fence once its autopilot is known: :meth:`service`
    starts the upload on the first call with the autopilot's ``kind`` and address, and
    moves it on after; :meth:`on_message` takes the autopilot's answers. The messages to
    send come back from both; a failure comes once from :meth:`drain_error`."""

    box: FenceBox
    frame: MissionFrame
    name: str = "vehicle"
    retry: float = 0.5
    deadline: float = 5.0
    upload: FenceUpload | None = None
    _reported: bool = False

    def service(
        self, kind: Literal["ardupilot", "px4"], target: tuple[int, int], now: float
    ) -> list[Any]:
        if self.upload is None:
            system, component = target
            self.upload = FenceUpload(
                fence_items(self.box, self.frame, target_system=system, target_component=component),
                fence_params(kind, self.box.z_max),
                system,
                component,
                name=self.name,
                retry=self.retry,
                deadline=self.deadline,
            )
            return self.upload.start(now)
        return self.upload.tick(now)

    def on_message(self, message: Any, now: float) -> list[Any]:
        if self.upload is None or message.get_type() not in FENCE_MESSAGES:
            return []
        return self.upload.on_message(message, now)

    def drain_error(self) -> list[str]:
        if self._reported or self.upload is None or self.upload.error is None:
            return []
        self._reported = True
        return [self.upload.error]


@dataclass(slots=True)
class FenceReceiver:
    """The autopilot's side of a fence upload (module docstring): answers ``MISSION_COUNT``
    and ``MISSION_ITEM_INT`` on the fence, and keeps the items of the last complete upload
    in :attr:`items`."""

    system: int
    component: int = mav.MAV_COMP_ID_AUTOPILOT1
    items: tuple[Any, ...] = ()
    _incoming: list[Any] | None = None
    _expected: int = 0

    def on_message(self, message: Any) -> list[Any]:
        """The answers to ``message`` (none to anything else than a fence upload)."""
        kind = message.get_type()
        if getattr(message, "mission_type", None) != _FENCE:
            return []
        peer = (message.get_srcSystem(), message.get_srcComponent())
        if kind == "MISSION_COUNT":
            self._incoming, self._expected = [], int(message.count)
            if self._expected == 0:
                self.items, self._incoming = (), None
                return [self._ack(peer, mav.MAV_MISSION_ACCEPTED)]
            return [self._request(peer, 0)]
        if kind == "MISSION_ITEM_INT" and self._incoming is not None:
            if message.seq != len(self._incoming):
                return [self._request(peer, len(self._incoming))]  # ask again, in order
            if message.command != _VERTEX:
                self._incoming = None
                return [self._ack(peer, mav.MAV_MISSION_UNSUPPORTED)]
            self._incoming.append(message)
            if len(self._incoming) < self._expected:
                return [self._request(peer, len(self._incoming))]
            self.items, self._incoming = tuple(self._incoming), None
            return [self._ack(peer, mav.MAV_MISSION_ACCEPTED)]
        return []

    def polygon(self) -> list[tuple[float, float]]:
        """The inclusion polygon received, ``(lat, lon)`` degrees."""
        return [(item.x / 1e7, item.y / 1e7) for item in self.items]

    def _request(self, peer: tuple[int, int], seq: int) -> Any:
        return mav.MAVLink_mission_request_int_message(peer[0], peer[1], seq, _FENCE)

    def _ack(self, peer: tuple[int, int], result: int) -> Any:
        return mav.MAVLink_mission_ack_message(peer[0], peer[1], result, _FENCE)
