"""An autopilot's mission, written from the daemon: the MAVLink mission protocol, sans-IO.

A fixed-wing lands through a mission (:mod:`~.fixedwing`): ArduPlane takes no landing
command, only a landing sequence loaded as mission items and started by
``MAV_CMD_DO_LAND_START``. :class:`MissionWrite` writes a list of items (or clears the
mission, with none):

* items: ``MISSION_COUNT`` → the autopilot asks for each item (``MISSION_REQUEST_INT``, or
  the older ``MISSION_REQUEST``) → ``MISSION_ITEM_INT`` → ``MISSION_ACK``;
* none: ``MISSION_CLEAR_ALL`` → ``MISSION_ACK``.

It repeats what got no answer every ``retry`` seconds and fails, with one line naming the
vehicle and the reason, after ``deadline`` seconds without progress, or at once when the
autopilot refuses (ArduPlane refuses an upload before it is ready, "Only 0 items"; its
``MISSION_ACK`` result is named). The owner passes each mission message in and sends what
comes back; nothing here reads a clock or a socket.

:func:`item` builds one ``MISSION_ITEM_INT`` in the mission frame's terms (local metres,
altitude above home).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Final, Literal

from actorswarm.vehicles.mavlink.dialect import mav
from actorswarm.vehicles.mavlink.frame import MissionFrame

__all__ = ["MISSION_MESSAGES", "MissionWrite", "item"]

_MISSION: Final[int] = mav.MAV_MISSION_TYPE_MISSION
#: The messages of the protocol the autopilot sends back.
MISSION_MESSAGES: Final = frozenset({"MISSION_REQUEST", "MISSION_REQUEST_INT", "MISSION_ACK"})

Phase = Literal["writing", "done", "failed"]


def item(
    seq: int,
    command: int,
    frame: MissionFrame,
    point: tuple[float, float, float],
    *,
    height: float,
    target: tuple[int, int],
    params: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0),
) -> Any:
    """A ``MISSION_ITEM_INT`` number ``seq``: ``command`` at the local ``point``'s latitude
    and longitude, ``height`` metres above home (``MAV_FRAME_GLOBAL_RELATIVE_ALT_INT``)."""
    lat, lon, _ = frame.to_geodetic(*point)
    return mav.MAVLink_mission_item_int_message(
        target[0],
        target[1],
        seq,
        mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        command,
        0,
        1,
        *params,
        round(lat * 1e7),
        round(lon * 1e7),
        float(height),
        _MISSION,
    )


@dataclass(slots=True)
class MissionWrite:
    """Writes ``items`` as the mission of the autopilot ``target`` (system, component);
    with no items, clears it. ``mission_type``: the mission, or another list the protocol
    carries (the fence, :mod:`~.fence`); ``what`` names it in the error line, which ``who``
    starts (``vehicle platform 3``)."""

    items: Sequence[Any]
    target: tuple[int, int]
    what: str = "the mission"
    who: str = "vehicle"
    mission_type: int = _MISSION
    retry: float = 0.5
    deadline: float = 8.0
    phase: Phase = "writing"
    #: Why it failed (one line), None while it has not.
    error: str | None = None
    _last: list[Any] = field(default_factory=list)
    _sent_at: float = 0.0
    _progress_at: float = 0.0

    @property
    def done(self) -> bool:
        return self.phase == "done"

    def start(self, now: float) -> list[Any]:
        """The first message: the count, or the clear."""
        self._progress_at = now
        system, component = self.target
        kind = self.mission_type
        if self.items:
            first = mav.MAVLink_mission_count_message(system, component, len(self.items), kind)
        else:
            first = mav.MAVLink_mission_clear_all_message(system, component, kind)
        return self._send(now, [first])

    def on_message(self, message: Any, now: float) -> list[Any]:
        """What to send in answer to the autopilot's ``message``."""
        if self.phase != "writing" or message.get_type() not in MISSION_MESSAGES:
            return []
        if getattr(message, "mission_type", _MISSION) != self.mission_type:
            return []  # another list's (the fence's, the mission's)
        if message.get_type() == "MISSION_ACK":
            if message.type != mav.MAV_MISSION_ACCEPTED:
                entry = mav.enums["MAV_MISSION_RESULT"].get(message.type)
                return self._fail(f"refused {self.what}: {entry.name if entry else message.type}")
            if self.items and self._last and self._last[0].get_type() == "MISSION_COUNT":
                # An ACK to the count alone is the answer to an earlier write: ours is not
                # taken until the autopilot has asked for every item.
                return []
            self.phase = "done"
            return []
        seq = int(message.seq)
        if not 0 <= seq < len(self.items):
            return self._fail(f"asked for item {seq} of {len(self.items)} of {self.what}")
        self._progress_at = now
        return self._send(now, [self.items[seq]])

    def tick(self, now: float) -> list[Any]:
        """Repeat what got no answer; fail past the deadline."""
        if self.phase != "writing":
            return []
        if now - self._progress_at >= self.deadline:
            return self._fail(f"did not take {self.what} in {self.deadline:g} s (no answer)")
        if now - self._sent_at >= self.retry:
            return self._send(now, self._last)
        return []

    def _send(self, now: float, messages: list[Any]) -> list[Any]:
        self._last = messages
        self._sent_at = now
        return messages

    def _fail(self, why: str) -> list[Any]:
        self.phase = "failed"
        self.error = f"{self.who}: the autopilot {why}"
        return []
