"""Ask for what you read: the messages the vehicle reads, asked for on its link and watched
until they come.

Theory of operation
-------------------
Each firmware decides for itself what it sends unasked, and per link: ArduCopter's first
serial port sends only ``HEARTBEAT`` and ``TIMESYNC`` (and one ``HOME_POSITION`` once it has
a home) until a ground station asks; ArduPlane streams its standard messages at 1 Hz but
ignores a ``SET_MESSAGE_INTERVAL`` that came before its first ``HEARTBEAT``; PX4 streams its
onboard set unasked. So the vehicle assumes nothing: :class:`StreamWatch` asks for every
message of :data:`WANTED` (``MAV_CMD_SET_MESSAGE_INTERVAL``) when the autopilot is first
heard and again whenever the link comes back, and checks that each one comes:

* one that has not arrived :data:`GRACE` seconds (the vehicle's ``stream_grace``) after it
  was asked is asked again, then after twice as long, up to every :data:`LONGEST` seconds
  (both scale with the grace); ArduPilot is then also asked
  through the legacy ``REQUEST_DATA_STREAM`` for the stream that carries the message
  (:data:`~actorswarm.vehicles.mavlink.firmware.ARDUPILOT_DATA_STREAMS`), for firmware that
  ignores the interval command;
* one that stopped arriving (an autopilot that rebooted forgets what it was asked) is
  asked again the same way;
* one asked :data:`GIVE_UP_AFTER` times with nothing since is *unsent*
  (:meth:`StreamWatch.unsent`): the waiting reason names it (``the autopilot sends no
  EKF_STATUS_REPORT though asked``) and the readiness signals it carries no longer hold
  arming back — readiness is advice, the autopilot's answer to ARM decides. It is still
  asked, every :data:`LONGEST` seconds at most, and counts again the moment it arrives.

A message the autopilot sends only once it has one (a home; PX4's position before its
estimator has one) is *conditional*: asked and watched the same way, but its absence is
"not yet", never "unsent".

The answer to the command (``COMMAND_ACK``) is not what counts: ArduPlane ACKs an interval it
then ignores. Arrival is. No clock and no socket: the owner gives ``now`` and sends what
:meth:`StreamWatch.tick` returns.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Final

from actorswarm.vehicles.mavlink.dialect import mav, message_name
from actorswarm.vehicles.mavlink.firmware import ARDUPILOT_DATA_STREAMS
from actorswarm.vehicles.mavlink.flavours import Kind

__all__ = [
    "GIVE_UP_AFTER",
    "GRACE",
    "LONGEST",
    "SILENT_INTERVALS",
    "WANTED",
    "StreamWatch",
    "Wanted",
]

#: Seconds a message asked for may take to arrive before it is asked again.
GRACE: Final = 3.0
#: The longest wait between two asks, seconds.
LONGEST: Final = 30.0
#: Asks with nothing arriving after which a message counts as unsent.
GIVE_UP_AFTER: Final = 3
#: A message that stopped: silent for this many of its intervals (and at least GRACE).
SILENT_INTERVALS: Final = 5.0


@dataclass(frozen=True, slots=True)
class Wanted:
    """A message the vehicle reads: its ID and the interval asked for, seconds.
    ``conditional``: sent only once the autopilot has one (its absence is "not yet")."""

    message: int
    interval: float
    conditional: bool = False

    @property
    def name(self) -> str:
        return message_name(self.message)


#: What the vehicle reads, per firmware, and how often: positions at 10 Hz, the rest each
#: second. ArduPilot's readiness needs EKF_STATUS_REPORT and GPS_RAW_INT, which ArduCopter
#: sends only when asked; PX4 has no EKF_STATUS_REPORT (its estimator's state reaches
#: readiness through the position it sends or withholds).
WANTED: Final[dict[Kind, tuple[Wanted, ...]]] = {
    "ardupilot": (
        Wanted(mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, 0.1),
        Wanted(mav.MAVLINK_MSG_ID_SYS_STATUS, 1.0),
        Wanted(mav.MAVLINK_MSG_ID_GPS_RAW_INT, 1.0),
        Wanted(mav.MAVLINK_MSG_ID_EKF_STATUS_REPORT, 1.0),
        Wanted(mav.MAVLINK_MSG_ID_HOME_POSITION, 1.0, conditional=True),
    ),
    "px4": (
        Wanted(mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, 0.1, conditional=True),
        Wanted(mav.MAVLINK_MSG_ID_SYS_STATUS, 1.0),
        Wanted(mav.MAVLINK_MSG_ID_GPS_RAW_INT, 1.0),
        Wanted(mav.MAVLINK_MSG_ID_HOME_POSITION, 1.0, conditional=True),
    ),
}


@dataclass(slots=True)
class _Watch:
    wanted: Wanted
    asked: float | None = None  # the last ask
    asks: int = 0  # asks since the message last arrived
    heard: float | None = None  # its last arrival


class StreamWatch:
    """The messages of ``kind``'s :data:`WANTED`, asked of the autopilot ``target`` =
    (system ID, component ID) and watched."""

    def __init__(self, kind: Kind, target: tuple[int, int], *, grace: float = GRACE) -> None:
        if not grace > 0:
            raise ValueError(f"stream grace must be > 0 s, not {grace!r}")
        self.kind = kind
        self.target = target
        self.grace = grace
        self._watches = {w.message: _Watch(w) for w in WANTED[kind]}
        #: What changed, in order, for the log: ``(message name, "unsent" | "arrived")``.
        self.changes: list[tuple[str, str]] = []

    def restart(self) -> None:
        """Ask for everything again at the next :meth:`tick` (the link came back: the
        autopilot may have rebooted and forgotten)."""
        for watch in self._watches.values():
            watch.asked, watch.asks = None, 0

    def heard(self, message_id: int, now: float) -> None:
        """A message of ``message_id`` arrived at ``now``."""
        watch = self._watches.get(message_id)
        if watch is None:
            return
        if self._unsent(watch):
            self.changes.append((watch.wanted.name, "arrived"))
        watch.heard, watch.asks = now, 0

    def unsent(self) -> list[str]:
        """The names of the messages asked :data:`GIVE_UP_AFTER` times that never came (or
        stopped and did not come back), in :data:`WANTED`'s order."""
        return [w.wanted.name for w in self._watches.values() if self._unsent(w)]

    def tick(self, now: float) -> list[Any]:
        """The requests due at ``now``: a ``SET_MESSAGE_INTERVAL`` for each message to ask
        for (first, overdue or stopped), and on ArduPilot, for those asked before, one
        ``REQUEST_DATA_STREAM`` per legacy stream that carries them."""
        due = [w for w in self._watches.values() if self._due(w, now)]
        out: list[Any] = []
        again: set[int] = set()
        system, component = self.target
        for watch in due:
            if watch.asks and self.kind == "ardupilot":
                again.add(watch.wanted.message)
            watch.asked = now
            watch.asks += 1
            if watch.asks == GIVE_UP_AFTER and not watch.wanted.conditional:
                self.changes.append((watch.wanted.name, "unsent"))
            out.append(
                mav.MAVLink_command_long_message(
                    system,
                    component,
                    mav.MAV_CMD_SET_MESSAGE_INTERVAL,
                    0,
                    watch.wanted.message,
                    watch.wanted.interval * 1e6,
                    0,
                    0,
                    0,
                    0,
                    0,
                )
            )
        for stream, members in ARDUPILOT_DATA_STREAMS.items():
            if again & set(members):
                out.append(
                    mav.MAVLink_request_data_stream_message(
                        system, component, stream, self._stream_rate(members), 1
                    )
                )
        return out

    def _stream_rate(self, members: tuple[int, ...]) -> int:
        """Messages per second for a legacy stream: the fastest of what we want in it (the
        stream's rate replaces the intervals of all its messages)."""
        intervals = [self._watches[m].wanted.interval for m in members if m in self._watches]
        return max(1, math.ceil(1.0 / min(intervals))) if intervals else 1

    def _due(self, watch: _Watch, now: float) -> bool:
        if watch.asked is None:
            return True
        if watch.heard is not None and watch.heard >= watch.asked:
            # It came after the last ask: due again only if it stopped.
            silent = max(self.grace, SILENT_INTERVALS * watch.wanted.interval)
            return now - watch.heard > silent
        longest = LONGEST * self.grace / GRACE
        wait = min(self.grace * (1 << min(max(watch.asks - 1, 0), 8)), longest)
        return now - watch.asked >= wait

    @staticmethod
    def _unsent(watch: _Watch) -> bool:
        return not watch.wanted.conditional and watch.asks >= GIVE_UP_AFTER
