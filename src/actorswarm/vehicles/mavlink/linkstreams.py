"""What the simulated autopilot sends on its link, and when, as each firmware does
(:mod:`~.firmware`).

:class:`LinkStreams` keeps the link's streams: ArduPilot starts with only what ArduCopter
sends unasked (``HEARTBEAT``, ``TIMESYNC``; ``HOME_POSITION`` and ``GPS_GLOBAL_ORIGIN`` once,
when the EKF has its origin) and adds what the link asks for, by
``MAV_CMD_SET_MESSAGE_INTERVAL`` or the legacy ``REQUEST_DATA_STREAM``; PX4 starts with its
onboard set at the measured rates. It also knows whether the link may receive
``STATUSTEXT``: ArduPilot's once the link sent anything, PX4's once it sent a GCS-type
``HEARTBEAT``.

The faults an autopilot can show a vehicle, for the tests and for ``actorswarm autopilot``:
``withheld`` messages are never sent, even when asked for (a firmware built without them);
``interval_ignored`` ACKs ``SET_MESSAGE_INTERVAL`` and does nothing (as ArduPlane does before
its first ``HEARTBEAT``); :meth:`LinkStreams.forget` is a reboot (every rate asked for is
gone).

Pure: the owner gives ``now`` and sends the messages :meth:`LinkStreams.due` names.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence
from typing import Final, Literal

from actorswarm.vehicles.mavlink.dialect import mav
from actorswarm.vehicles.mavlink.firmware import (
    ARDUCOPTER_UNASKED,
    ARDUPILOT_DATA_STREAMS,
    PX4_ONBOARD,
    PX4_POSITION_RATE,
)

__all__ = ["LinkStreams"]

_ACCEPTED: Final[int] = mav.MAV_RESULT_ACCEPTED
_DENIED: Final[int] = mav.MAV_RESULT_DENIED
_FAILED: Final[int] = mav.MAV_RESULT_FAILED


def _initial(
    kind: Literal["ardupilot", "px4"], unasked: Mapping[int, float | None]
) -> dict[int, float]:
    """Intervals (seconds) of what ``kind`` sends unasked, sent once or not at all left out."""
    if kind == "px4":
        out = {m: 1.0 / rate for m, rate in PX4_ONBOARD.items()}
        out[mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT] = 1.0 / PX4_POSITION_RATE
        return out
    return {m: 1.0 / rate for m, rate in unasked.items() if rate is not None}


class LinkStreams:
    """The streams of one link of a ``kind`` autopilot that can produce the messages
    ``producible`` (the rest of what a firmware could be asked for is refused).
    ``unasked`` and ``data_streams`` are an ArduPilot firmware's tables (ArduCopter's by
    default; ArduPlane's are in :mod:`~.firmware`)."""

    def __init__(
        self,
        kind: Literal["ardupilot", "px4"],
        producible: Collection[int],
        *,
        withheld: Collection[int] = (),
        interval_ignored: bool = False,
        unasked: Mapping[int, float | None] = ARDUCOPTER_UNASKED,
        data_streams: Mapping[int, Sequence[int]] = ARDUPILOT_DATA_STREAMS,
    ) -> None:
        self.kind = kind
        self._unasked = unasked
        self._data_streams = data_streams
        self.producible = frozenset(producible) - frozenset(withheld)
        self.withheld = frozenset(withheld)
        self.interval_ignored = interval_ignored
        self.intervals: dict[int, float] = {}
        self.once: set[int] = set()
        self._next: dict[int, float] = {}  # when each stream is next due
        self.active = False  # the link sent us something
        self.gcs = False  # ... a GCS-type HEARTBEAT
        self.forget()

    def forget(self) -> None:
        """A reboot: back to what the firmware sends unasked, every rate asked for gone."""
        self.intervals = {
            m: i for m, i in _initial(self.kind, self._unasked).items() if m not in self.withheld
        }
        self.once = (
            set()
            if self.kind == "px4"
            else {m for m, rate in self._unasked.items() if rate is None} - self.withheld
        )
        self._next.clear()
        self.active = self.gcs = False

    def heard(self, message_type: str, mav_type: int | None = None) -> None:
        """The link sent a message (``mav_type``: a HEARTBEAT's type)."""
        self.active = True
        if message_type == "HEARTBEAT" and mav_type == mav.MAV_TYPE_GCS:
            self.gcs = True

    @property
    def texts_allowed(self) -> bool:
        """Whether a STATUSTEXT reaches this link."""
        return self.gcs if self.kind == "px4" else self.active

    def set_interval(self, message_id: int, interval_us: float) -> int:
        """``MAV_CMD_SET_MESSAGE_INTERVAL``: its MAV_RESULT. 0 µs: the firmware's default;
        −1: stop it."""
        if message_id not in self.producible:
            # As measured: ArduCopter 4.5.7 answers DENIED ("No ap_message for mavlink
            # id"), PX4 1.15.4 FAILED.
            return _DENIED if self.kind == "ardupilot" else _FAILED
        if self.interval_ignored:
            return _ACCEPTED
        if interval_us == 0:
            default = _initial(self.kind, self._unasked).get(message_id)
            if default is None:
                self.intervals.pop(message_id, None)
            else:
                self.intervals[message_id] = default
        elif interval_us < 0:
            self.intervals.pop(message_id, None)
        else:
            self.intervals[message_id] = interval_us / 1e6
        return _ACCEPTED

    def request_stream(self, stream: int, rate: int, start: bool) -> None:
        """ArduPilot's legacy ``REQUEST_DATA_STREAM`` (no answer): the messages of
        ``stream`` (or of all, ``MAV_DATA_STREAM_ALL``) at ``rate`` per second, or stopped.
        PX4 ignores it."""
        if self.kind != "ardupilot":
            return
        table = self._data_streams
        streams = (
            list(table)
            if stream == mav.MAV_DATA_STREAM_ALL
            else [stream]
            if stream in table
            else []
        )
        for s in streams:
            for message_id in table[s]:
                if message_id not in self.producible:
                    continue
                if start and rate > 0:
                    self.intervals[message_id] = 1.0 / rate
                else:
                    self.intervals.pop(message_id, None)

    def due(self, now: float) -> list[int]:
        """The streamed messages due at ``now``, in schedule: a message keeps its rate
        whatever the caller's period (one due twice since the last call comes twice, a
        backlog of more is dropped). :meth:`unsent` takes back one that had nothing to say."""
        out: list[int] = []
        for message_id, interval in self.intervals.items():
            if not (math.isfinite(interval) and interval > 0):
                continue
            due = self._next.get(message_id, now)
            due = max(due, now - interval)  # a backlog (a paused process) is not made up
            while due <= now:
                out.append(message_id)
                due += interval
            self._next[message_id] = due
        return out

    def unsent(self, message_id: int) -> None:
        """``message_id`` was due but had nothing to say (no home yet): due again at once."""
        self._next.pop(message_id, None)

    def take_once(self, message_id: int) -> bool:
        """Whether the one-off ``message_id`` is still to be sent (True once)."""
        if message_id in self.once:
            self.once.discard(message_id)
            return True
        return False
