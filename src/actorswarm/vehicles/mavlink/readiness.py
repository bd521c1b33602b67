"""Whether the autopilot can fly yet, and why not, from what it says.

A real autopilot refuses to arm for half a minute or more after boot while its estimator
aligns, and no single message tells when it will accept: ArduPilot's ``SYS_STATUS`` pre-arm
bit reads healthy ~18 s before arming is accepted, its ``GLOBAL_POSITION_INT`` is all zeros
until the EKF has an origin; PX4 sends no position at all until its estimator has one.
:class:`Readiness` takes the signals together:

ArduPilot
    ``EKF_STATUS_REPORT`` with attitude, horizontal velocity, absolute horizontal and
    vertical position and not in constant-position mode; a ``HOME_POSITION``; a 3D GPS fix
    (``GPS_RAW_INT``); a real position; the pre-arm bit healthy.
PX4
    a ``HOME_POSITION``; a position (``GLOBAL_POSITION_INT``); the pre-arm bit healthy when
    ``SYS_STATUS`` reports it; a 3D fix when ``GPS_RAW_INT`` is sent.

Ready here means "worth asking": the autopilot may still refuse the arm, which the vehicle
asks again with back-off until its deadline. It is advice, never a lock: a signal whose
message the autopilot does not send although asked (:mod:`~.streams`) is left out, and
while the signals say "not yet" the vehicle still asks to arm now and then
(:mod:`~.commands`, a gated command): the autopilot's answer decides.

:class:`Texts` keeps the autopilot's ``STATUSTEXT`` (PX4's chunks reassembled by id and
``chunk_seq``, its trailing tab dropped); its latest warning while not armed is the reason
the operator sees (``PreArm: Need Position Estimate``).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Collection
from typing import Any, Final

from actorswarm.vehicles.mavlink.dialect import mav

__all__ = ["Readiness", "Texts"]

_EKF_NEEDED: Final = (
    mav.EKF_ATTITUDE | mav.EKF_VELOCITY_HORIZ | mav.EKF_POS_HORIZ_ABS | mav.EKF_POS_VERT_ABS
)
_PREARM: Final = mav.MAV_SYS_STATUS_PREARM_CHECK
#: A STATUSTEXT's text field, characters: a chunk this long has more to come.
_TEXT: Final = 50
#: Texts kept.
_KEPT: Final = 20


class Texts:
    """The autopilot's recent STATUSTEXT, whole."""

    def __init__(self) -> None:
        self.recent: deque[tuple[int, str]] = deque(maxlen=_KEPT)  # (severity, text)
        self._parts: dict[int, dict[int, str]] = {}

    def add(self, message: Any) -> str | None:
        """Take a STATUSTEXT; the whole text when it is complete (None: a chunk of one)."""
        raw = message.text
        text = raw.decode("utf-8", "replace") if isinstance(raw, bytes) else str(raw)
        text = text.rstrip("\x00")
        ident = getattr(message, "id", 0)
        if ident:
            parts = self._parts.setdefault(ident, {})
            parts[getattr(message, "chunk_seq", 0)] = text
            if len(text) >= _TEXT:
                if len(self._parts) > _KEPT:  # chunks whose end never came
                    self._parts.pop(next(iter(self._parts)))
                return None
            del self._parts[ident]
            text = "".join(parts[k] for k in sorted(parts))
        text = text.strip()
        if not text:
            return None
        self.recent.append((int(message.severity), text))
        return text

    def latest_warning(self) -> str | None:
        """The latest text of severity WARNING or worse (None: none)."""
        for severity, text in reversed(self.recent):
            if severity <= mav.MAV_SEVERITY_WARNING:
                return text
        return None

    def clear(self) -> None:
        self.recent.clear()


class Readiness:
    """The readiness signals of one autopilot, as they arrive."""

    def __init__(self) -> None:
        self.ekf_flags: int | None = None
        self.gps_fix: int | None = None
        self.prearm: bool | None = None  # None: SYS_STATUS does not report the bit
        self.home = False
        self.position = False

    def on_message(self, kind: str, message: Any) -> None:
        if kind == "EKF_STATUS_REPORT":
            self.ekf_flags = int(message.flags)
        elif kind == "GPS_RAW_INT":
            self.gps_fix = int(message.fix_type)
        elif kind == "SYS_STATUS":
            if message.onboard_control_sensors_present & _PREARM:
                self.prearm = bool(message.onboard_control_sensors_health & _PREARM)
        elif kind == "HOME_POSITION":
            self.home = True

    def missing(self, kind: str, unsent: Collection[str] = ()) -> list[str]:
        """What the autopilot of ``kind`` has not said yet (empty: ready to ask), leaving out
        the signals whose message is in ``unsent`` (asked for, never sent: no reason to
        hold arming back — the autopilot's answer decides)."""
        out: list[str] = []
        if kind == "ardupilot":
            flags = self.ekf_flags
            if flags is None:
                if "EKF_STATUS_REPORT" not in unsent:
                    out.append("an EKF status")
            elif flags & _EKF_NEEDED != _EKF_NEEDED or flags & mav.EKF_CONST_POS_MODE:
                out.append("an EKF position estimate")
        if not self.position and "GLOBAL_POSITION_INT" not in unsent:
            out.append("a position")
        if not self.home and "HOME_POSITION" not in unsent:
            out.append("a home position")
        if (self.gps_fix is None and kind == "ardupilot" and "GPS_RAW_INT" not in unsent) or (
            self.gps_fix is not None and self.gps_fix < 3
        ):
            out.append("a 3D GPS fix")
        if self.prearm is False or (
            self.prearm is None and kind == "ardupilot" and "SYS_STATUS" not in unsent
        ):
            out.append("the pre-arm checks passed")
        return out
