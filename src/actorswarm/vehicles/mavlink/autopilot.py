"""A simulated MAVLink autopilot: the project's quadrotor physics behind a real MAVLink 2
endpoint, answering as ArduCopter in GUIDED or PX4 in OFFBOARD do for the messages
:class:`~actorswarm.vehicles.mavlink.vehicle.MavlinkVehicle` sends.

``actorswarm autopilot`` runs one per vehicle, so the whole real stack (daemon, MAVLink,
autopilot) runs on a laptop and in the tests.

What it models
--------------
* Its link as the firmware's (:mod:`~.linkstreams`, :mod:`~.firmware`): ArduPilot sends
  unasked only ``HEARTBEAT`` (1 Hz: type, autopilot, armed flag, custom mode) and
  ``TIMESYNC``, one ``HOME_POSITION`` and one ``GPS_GLOBAL_ORIGIN`` once its EKF has an
  origin, and streams ``GLOBAL_POSITION_INT``, ``SYS_STATUS`` (battery, sensors, pre-arm),
  ``GPS_RAW_INT``, ``EKF_STATUS_REPORT`` and ``HOME_POSITION`` only once the link asks
  (``MAV_CMD_SET_MESSAGE_INTERVAL``, or ``REQUEST_DATA_STREAM``'s EXTENDED_STATUS, POSITION,
  EXTRA3); PX4 streams its onboard set at the measured rates from the start (the messages it
  does not model filled with zeros). A reboot (:meth:`SimAutopilot.reboot`) forgets every
  rate asked for. Its faults, on request: messages withheld even when asked for,
  ``SET_MESSAGE_INTERVAL`` ACKed and ignored, a MAVLink 1 only link.
* ``COMMAND_LONG`` answered with ``COMMAND_ACK``: ``DO_SET_MODE``, ``COMPONENT_ARM_DISARM``,
  ``NAV_TAKEOFF``, ``NAV_LAND``, ``DO_CHANGE_SPEED``, ``SET_MESSAGE_INTERVAL`` (DENIED for a
  message it cannot send: DENIED as ArduCopter answers, FAILED as PX4 does); anything else
  ``UNSUPPORTED``. A repeated command (same command, ``confirmation`` > 0) is answered
  again, as a lost ack must be repaired.
* ArduPilot: modes STABILIZE, GUIDED, LOITER, LAND (custom modes 0, 4, 5, 9). Arming needs
  GUIDED (or STABILIZE, LOITER) and some battery; ``NAV_TAKEOFF`` needs GUIDED and armed
  and takes its altitude (param 7) above home; ``SET_POSITION_TARGET_GLOBAL_INT`` flies
  in GUIDED once airborne; ``DO_CHANGE_SPEED`` sets the speed of the goals.
* PX4: main modes POSCTL, AUTO (sub-modes TAKEOFF, LOITER, LAND), OFFBOARD. ``NAV_TAKEOFF``
  takes its altitude above mean sea level, enters AUTO.TAKEOFF and then AUTO.LOITER.
  OFFBOARD is accepted only while setpoints stream, and left for AUTO.LOITER (hold) when
  none came for ``offboard_timeout`` seconds (PX4's ``COM_OF_LOSS_T``).
* The boot (:mod:`~actorswarm.vehicles.mavlink.boot`): arming refused with the real
  autopilot's words until ``ready_after``, positions zero (ArduPilot) or absent (PX4) until
  the estimator has one, ``GPS_RAW_INT``, ``EKF_STATUS_REPORT`` (ArduPilot), the pre-arm bit
  of ``SYS_STATUS``; STATUSTEXT (ArduPilot: only to a link that sent something; PX4: only
  after a GCS-type HEARTBEAT, chunked).
* ArduPlane 4.5.7 (``frame="plane"``, :mod:`~.simplane`): the project's fixed-wing physics
  fitted to the measured SITL (cruise 22 m/s in 10–30, clockwise circles 20–25 m wider than
  asked, at least 50 m; the take-off roll, lift-off and climb; a 3.5° glide at 16 m/s);
  HEARTBEAT type FIXED_WING from 0.9 s, INITIALISING (a mode asked then is accepted and
  lost) until ``ArduPilot Ready`` at 1.6 s, then MANUAL; its 1 Hz streams unasked from
  1.9 s, a ``SET_MESSAGE_INTERVAL`` before Ready ACKed and ignored; arming
  refused with its ``Arm:`` reasons until 22 s; TAKEOFF, GUIDED (``DO_REPOSITION``, the
  altitude of ``SET_POSITION_TARGET_GLOBAL_INT``), LOITER, RTL (``RTL_ALTITUDE``,
  ``RTL_AUTOLAND``), AUTO; ``DO_CHANGE_SPEED``; the mission protocol and a landing
  sequence (``DO_LAND_START``, ``NAV_LAND``) that touches down short, as measured, and
  disarms.
* Both: landing ends disarmed; an empty battery drops the vehicle (the physics' ``dead``)
  and disarms it. The failsafe parameters the pre-flight check reads answer
  ``PARAM_REQUEST_READ`` (1, or 0 with ``failsafes=False``) and take ``PARAM_SET``.

What it does not model
----------------------
Sensors, EKF and GPS (the position is exact), wind, attitude and yaw, RC input, enforcing
a geofence (one is taken, :class:`~actorswarm.vehicles.mavlink.fence.FenceReceiver`, with
its parameters, but never acted on), missions other than the fence (``MISSION_*``) and RTL
(but for ArduPlane's), the failsafes themselves (the parameters are read, never acted
on), pre-arm checks beyond the mode, the battery and the replayed boot
(:mod:`~actorswarm.vehicles.mavlink.boot`), parameters other than the failsafes' and the
fence's (ArduPlane: and its own), MAVLink signing, PX4 fixed-wings, VTOL vehicles,
ArduPlane's flare as its own phase, its AUTO take-off and the mission items beyond
waypoints and the landing, and any other message.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Final, Literal

from actorswarm.vehicles.mavlink.boot import (
    ARDUPLANE_READY_AFTER,
    DEFAULT_READY_AFTER,
    Boot,
    chunks,
)
from actorswarm.vehicles.mavlink.dialect import mav
from actorswarm.vehicles.mavlink.fence import FenceReceiver, fence_params
from actorswarm.vehicles.mavlink.firmware import (
    ARDUPLANE_DATA_STREAMS,
    ARDUPLANE_UNASKED,
    PX4_ONBOARD,
)
from actorswarm.vehicles.mavlink.flavours import (
    ARDUPILOT_MODES,
    GCS_ID,
    PX4_MAIN,
    PX4_SUB,
    px4_custom_mode,
)
from actorswarm.vehicles.mavlink.frame import MissionFrame
from actorswarm.vehicles.mavlink.link import open_connection, read_available
from actorswarm.vehicles.mavlink.linkstreams import LinkStreams
from actorswarm.vehicles.mavlink.simplane import (
    PLANE_MESSAGES,
    SimPlane,
    plane_params,
    plane_spec,
)
from actorswarm.vehicles.mavlink.vehicle import FAILSAFE_PARAMS, GCS_DEFAULT, OWN_SYSTEM
from actorswarm.world.config import QuadrotorParams, VehicleSpec
from actorswarm.world.vehicles import Fleet

__all__ = ["AutopilotOptions", "SimAutopilot", "ground_wander"]

#: The messages it fills with its state (the rest of PX4's onboard set goes out as zeros).
_MODELLED: Final = frozenset(
    (
        mav.MAVLINK_MSG_ID_HEARTBEAT,
        mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT,
        mav.MAVLINK_MSG_ID_SYS_STATUS,
        mav.MAVLINK_MSG_ID_HOME_POSITION,
        mav.MAVLINK_MSG_ID_GPS_RAW_INT,
        mav.MAVLINK_MSG_ID_TIMESYNC,
        mav.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN,
    )
)
#: The sensor bits SYS_STATUS reports: the GPS and the pre-arm check.
_SENSORS: Final = mav.MAV_SYS_STATUS_SENSOR_GPS | mav.MAV_SYS_STATUS_PREARM_CHECK
#: The physics step, seconds.
_DT: Final = 0.02
#: Seconds armed on the ground without a take-off before both autopilots disarm.
_IDLE_DISARM: Final = 10.0
#: PX4's MIS_TAKEOFF_ALT: the take-off altitude when NAV_TAKEOFF gives none.
_PX4_TAKEOFF_ALT: Final = 2.5
_ACCEPTED: Final[int] = mav.MAV_RESULT_ACCEPTED
_DENIED: Final[int] = mav.MAV_RESULT_DENIED
_FAILED: Final[int] = mav.MAV_RESULT_FAILED
_UNSUPPORTED: Final[int] = mav.MAV_RESULT_UNSUPPORTED


@dataclass(frozen=True, slots=True)
class AutopilotOptions:
    """``url``: where it listens (a pymavlink connection string, ``udpin:`` for a daemon's
    ``udpout:``); ``home``: where it stands, latitude, longitude, altitude AMSL;
    ``system``: its MAVLink system ID; ``kind``: which autopilot it plays; ``failsafes``:
    the value of its failsafe parameters (on, or all 0); ``battery``: the charge at start;
    ``endurance``: seconds of flight at cruise speed on a full battery;
    ``offboard_timeout``: PX4's setpoint timeout, seconds; ``ready_after``: seconds from
    the start of its clock until it accepts arming (None: as measured on the real one, 40 s
    for ArduPilot, 35 s for PX4; see :mod:`~actorswarm.vehicles.mavlink.boot`). The clock
    starts at once, or on a ``tcpin:`` endpoint when the first client connects, as SITL's
    does. ``frame``: a multicopter, or (ArduPilot only) ArduPlane's fixed-wing
    (:mod:`~actorswarm.vehicles.mavlink.simplane`; ready after 22 s by default);
    ``heading``: where a fixed-wing faces, down its runway (degrees clockwise from north,
    as SITL's ``--home`` takes it)."""

    url: str
    home: MissionFrame
    system: int = 1
    kind: Literal["ardupilot", "px4"] = "ardupilot"
    frame: Literal["copter", "plane"] = "copter"
    heading: float = 0.0
    failsafes: bool = True
    battery: float = 1.0
    endurance: float = 1200.0
    offboard_timeout: float = 1.0
    ready_after: float | None = None
    #: Message IDs it never sends, even when asked for.
    withheld: frozenset[int] = frozenset()
    #: ACK ``SET_MESSAGE_INTERVAL`` and ignore it.
    interval_ignored: bool = False
    #: Speak MAVLink 1 only (MAVLink 2 frames it receives are lost, as on such a link).
    mavlink1: bool = False

    def __post_init__(self) -> None:
        if self.ready_after is not None and not self.ready_after >= 0:
            raise ValueError(f"autopilot: --ready-after must be >= 0 s, not {self.ready_after}")
        if not 1 <= self.system <= 255:
            raise ValueError(f"autopilot: the system ID must be 1..255, not {self.system}")
        if not 0.0 < self.battery <= 1.0:
            raise ValueError(f"autopilot: the battery must be within (0, 1], not {self.battery}")
        if not (self.endurance > 0 and self.offboard_timeout > 0):
            raise ValueError("autopilot: endurance and offboard timeout must be > 0 s")
        if self.frame not in ("copter", "plane"):
            raise ValueError(f"autopilot: the frame is copter or plane, not {self.frame!r}")
        if self.frame == "plane" and self.kind != "ardupilot":
            raise ValueError(
                f"autopilot: a {self.kind} fixed-wing is not modelled yet (only ArduPlane: "
                "kind ardupilot)"
            )


def ground_wander(t: float) -> float:
    """The height an ArduPlane reports while it stands on the ground, metres, ``t`` seconds
    after boot: its barometer's altitude wanders there, between -0.22 and +0.40 m in 73
    take-offs and landings of ArduPlane 4.5.7 SITL (measured before arming and after
    landing). Reported, not flown: the aircraft stays on the ground. A plugin that takes
    0.2 m for "off the ground" is fooled by the firmware, and by this double too."""
    return (
        0.09 + 0.2 * math.sin(2.0 * math.pi * t / 29.0) + 0.11 * math.sin(2.0 * math.pi * t / 7.0)
    )


class SimAutopilot:
    """One simulated autopilot on ``options.url`` (opened here: MavlinkError when it
    cannot be). :meth:`service` does one look at ``now``; :meth:`run` loops until a stop."""

    def __init__(
        self, options: AutopilotOptions, *, clock: Callable[[], float] = time.monotonic
    ) -> None:
        self.options = options
        self._clock = clock
        self._conn = open_connection(
            options.url,
            who=f"autopilot {options.system}",
            source_system=options.system,
            source_component=mav.MAV_COMP_ID_AUTOPILOT1,
        )
        self._conn.mavlink1_only = options.mavlink1
        plane = options.frame == "plane"
        spec = (
            plane_spec(options.battery, options.endurance, options.heading)
            if plane
            else VehicleSpec(
                platform=1,
                kind="quadrotor",
                home=(0.0, 0.0),
                heading=math.pi / 2,
                battery=options.battery,
                params=QuadrotorParams(endurance=options.endurance),
            )
        )
        self._fleet = Fleet([spec])
        self._vehicle = self._fleet.vehicle(1)
        self._px4 = options.kind == "px4"
        self.armed = False
        self._armed_at: float | None = None
        self._flew = False  # armed and off the ground at the last physics step
        # ArduPilot: the custom mode number; PX4: (main mode, sub-mode).
        self._mode: int | tuple[int, int] = (
            (PX4_MAIN["AUTO"], PX4_SUB["LOITER"]) if self._px4 else ARDUPILOT_MODES["STABILIZE"]
        )
        self._ready = False  # ArduCopter's start-up over ("ArduPilot Ready")
        self._speed: float | None = None
        self._setpoint_at: float | None = None
        self._params = (
            plane_params(options.failsafes)
            if plane
            else dict.fromkeys(FAILSAFE_PARAMS[options.kind], 1.0 if options.failsafes else 0.0)
        )
        if options.kind == "ardupilot":
            # As a SITL set up for the daemon has it (or the firmware's default without).
            self._params[GCS_ID] = float(OWN_SYSTEM if options.failsafes else GCS_DEFAULT)
        # The geofence: its parameters take PARAM_SET, its polygon the mission protocol.
        self._params.update(fence_params(options.kind, 100.0))
        self.fence = FenceReceiver(options.system)
        producible = set(_MODELLED)
        if self._px4:
            producible |= set(PX4_ONBOARD)
        else:
            producible.add(mav.MAVLINK_MSG_ID_EKF_STATUS_REPORT)
        if plane:
            producible |= PLANE_MESSAGES
            tables: dict[str, Any] = {
                "unasked": ARDUPLANE_UNASKED,
                "data_streams": ARDUPLANE_DATA_STREAMS,
            }
        else:
            tables = {}
        self.streams = LinkStreams(
            options.kind,
            producible,
            withheld=options.withheld,
            interval_ignored=options.interval_ignored,
            **tables,
        )
        self._physics_at = self._started = clock()
        self._closed = False
        ready_after = options.ready_after
        if ready_after is None:
            ready_after = ARDUPLANE_READY_AFTER if plane else DEFAULT_READY_AFTER[options.kind]
        self.boot = Boot(options.kind, ready_after, options.frame)
        # SITL's clock (and so its boot) starts when the first client connects over TCP.
        self._booted: float | None = None if options.url.startswith("tcpin:") else self._started
        self._said = -1.0  # the boot texts said up to this boot time
        self._nagged: float | None = None
        self._text_id = 0
        # ArduPlane: the part that plays it (its modes, commands, mission and boot steps).
        self._plane = (
            SimPlane(
                self,
                link=self._conn,
                vehicle=self._vehicle,
                home=options.home,
                params=self._params,
            )
            if plane
            else None
        )

    # --- life ------------------------------------------------------------------------------------

    def run(self, stop: threading.Event) -> None:
        """Serve until ``stop`` is set."""
        while not stop.is_set():
            self.service(self._clock())
            stop.wait(_DT / 2)

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self._conn.close()

    def service(self, now: float) -> None:
        """Take in what arrived, advance the physics to ``now``, send what is due."""
        for message in read_available(self._conn):
            if message.get_type() not in ("BAD_DATA", "UNKNOWN"):
                self._on_message(message, now)
        if self._booted is None:
            if not self._conn.connected:
                self._physics_at = now
                return  # no client yet: SITL's clock has not started
            self._booted = self._physics_at = now
        self._boot_texts(now)
        while self._physics_at + _DT <= now:
            self._physics_at += _DT
            self._fleet.step(_DT)
            self._after_step(self._physics_at)
        self._streams(now)

    # --- state, as the tests and the command line see it -----------------------------------------

    @property
    def mode_name(self) -> str:
        if self._plane is not None:
            return self._plane.mode_name
        if isinstance(self._mode, tuple):
            main, sub = self._mode
            main_name = next(k for k, v in PX4_MAIN.items() if v == main)
            if main_name != "AUTO":
                return main_name
            return "AUTO." + next(k for k, v in PX4_SUB.items() if v == sub)
        return next(k for k, v in ARDUPILOT_MODES.items() if v == self._mode)

    def position(self) -> tuple[float, float, float]:
        """Local metres from home (x east, y north, z up)."""
        return self._vehicle.position()

    @property
    def physics_mode(self) -> str:
        return self._vehicle.mode

    def boot_time(self, now: float) -> float:
        """Seconds since its clock started (0 before)."""
        return 0.0 if self._booted is None else now - self._booted

    def reboot(self, now: float) -> None:
        """Restart: the boot from the beginning, disarmed where it stands (on the ground),
        and every stream rate a link asked for forgotten."""
        self.armed = False
        self._booted = now
        self._said = -1.0
        self._nagged = None
        self.streams.forget()
        self._ready = False
        if self._plane is not None:
            self._plane.restart()

    def say(self, text: str, severity: int = mav.MAV_SEVERITY_WARNING) -> None:
        """A STATUSTEXT, to a link that may receive one (ArduPilot: one that sent anything;
        PX4: one that sent a GCS-type HEARTBEAT); PX4 sends a text over 50 characters in
        chunks (one id, rising ``chunk_seq``)."""
        if not self.streams.texts_allowed:
            return
        self._text_id = self._text_id % 65535 + 1
        for piece, ident, seq in chunks(text, self._text_id):
            self._conn.mav.statustext_send(severity, piece.encode(), ident, seq)

    def _boot_texts(self, now: float) -> None:
        t = self.boot_time(now)
        for text in self.boot.texts(self._said, t):
            self.say(text, mav.MAV_SEVERITY_INFO)
        self._said = t
        state = self.boot.at(t)
        every = min(max(self.boot.ready_after / 4, 1.0), 10.0)
        due = self._nagged is None or now - self._nagged >= every
        if state.nag is not None and t >= 0.1 * self.boot.ready_after and due:
            self._nagged = now
            self.say(state.nag, mav.MAV_SEVERITY_CRITICAL)

    # --- inside ----------------------------------------------------------------------------------

    def _on_message(self, message: Any, now: float) -> None:
        kind = message.get_type()
        # Messages addressed to another system (0: to all) are not ours to answer.
        if getattr(message, "target_system", 0) not in (0, self.options.system):
            return
        self.streams.heard(kind, message.type if kind == "HEARTBEAT" else None)
        if self._plane is not None and self._plane.on_message(message, now):
            return
        if kind == "REQUEST_DATA_STREAM":
            self.streams.request_stream(
                message.req_stream_id, message.req_message_rate, bool(message.start_stop)
            )
        elif kind == "COMMAND_LONG":
            result = self._command(message, now)
            self._conn.mav.command_ack_send(
                message.command, result, 0, 0, message.get_srcSystem(), message.get_srcComponent()
            )
        elif kind == "SET_POSITION_TARGET_GLOBAL_INT":
            self._setpoint(message, now)
        elif kind == "PARAM_REQUEST_READ":
            self._param_value(message.param_id)
        elif kind in ("MISSION_COUNT", "MISSION_ITEM_INT"):
            for answer in self.fence.on_message(message):
                self._conn.mav.send(answer)
        elif kind == "PARAM_SET" and message.param_id in self._params:
            self._params[message.param_id] = float(message.param_value)
            self._param_value(message.param_id)

    def _param_value(self, name: str) -> None:
        if name in self._params:
            names = list(self._params)
            self._conn.mav.param_value_send(
                name.encode(),
                self._params[name],
                mav.MAV_PARAM_TYPE_REAL32,
                len(names),
                names.index(name),
            )

    def _command(self, m: Any, now: float) -> int:
        c = m.command
        if c == mav.MAV_CMD_SET_MESSAGE_INTERVAL:
            return self.streams.set_interval(int(m.param1), float(m.param2))
        if c == mav.MAV_CMD_DO_SET_MODE:
            return self._set_mode(m, now)
        if c == mav.MAV_CMD_COMPONENT_ARM_DISARM:
            return self._arm(m.param1 == 1, now)
        if c == mav.MAV_CMD_NAV_TAKEOFF:
            return self._takeoff(m.param7)
        if c == mav.MAV_CMD_NAV_LAND:
            if not self._airborne():
                return _DENIED
            self._land()
            return _ACCEPTED
        if c == mav.MAV_CMD_DO_CHANGE_SPEED:
            if not m.param2 > 0:
                return _DENIED
            self._speed = float(m.param2)
            if self._vehicle.mode == "flying":
                goal = self._vehicle.goal()
                self._vehicle.goto(*goal, speed=self._speed)
            return _ACCEPTED
        return _UNSUPPORTED

    def _airborne(self) -> bool:
        return self._vehicle.mode in ("takeoff", "flying", "landing")

    def _set_mode(self, m: Any, now: float) -> int:
        if not int(m.param1) & mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            return _UNSUPPORTED
        if self._px4:
            main, sub = int(m.param2), int(m.param3)
            if main == PX4_MAIN["OFFBOARD"]:
                fresh = self._setpoint_at is not None and (
                    now - self._setpoint_at <= self.options.offboard_timeout
                )
                if not fresh:
                    # PX4 enters OFFBOARD only while setpoints stream; 1.15.4 answers
                    # TEMPORARILY_REJECTED ("try again once they do").
                    return mav.MAV_RESULT_TEMPORARILY_REJECTED  # type: ignore[no-any-return]
                self._mode = (main, 0)
                return _ACCEPTED
            if main == PX4_MAIN["POSCTL"]:
                self._mode = (main, 0)
                self._hold()
                return _ACCEPTED
            if main == PX4_MAIN["AUTO"] and sub == PX4_SUB["LOITER"]:
                self._mode = (main, sub)
                self._hold()
                return _ACCEPTED
            if main == PX4_MAIN["AUTO"] and sub == PX4_SUB["LAND"]:
                if not self._airborne():
                    return _DENIED
                self._land()
                return _ACCEPTED
            if main == PX4_MAIN["AUTO"] and sub == PX4_SUB["TAKEOFF"]:
                return self._takeoff(math.nan)
            return _UNSUPPORTED
        mode = int(m.param2)
        if mode not in ARDUPILOT_MODES.values() or mode == ARDUPILOT_MODES["RTL"]:
            return _UNSUPPORTED
        if mode == ARDUPILOT_MODES["LAND"]:
            self._land()
            return _ACCEPTED
        positional = mode in (ARDUPILOT_MODES["LOITER"], ARDUPILOT_MODES["GUIDED"])
        if positional and self.armed and self.boot.at(self.boot_time(now)).position != "real":
            # ArduCopter checks a mode's needs only when armed (any mode while disarmed):
            # armed (in STABILIZE) before its EKF has a position, GUIDED is refused.
            return _FAILED
        self._mode = mode
        if positional:
            self._hold()
        return _ACCEPTED

    def _arm(self, arm: bool, now: float) -> int:
        if arm and not self.armed:
            state = self.boot.at(self.boot_time(now))
            if not state.armable:
                for text in state.refusal:
                    self.say(text, mav.MAV_SEVERITY_CRITICAL)
                return state.refused_with
        if not arm:
            if self._airborne():
                return _DENIED
            self.armed = False
            return _ACCEPTED
        if self._vehicle.mode == "dead" or self._vehicle.battery() < 0.05:
            return _DENIED
        if not self._px4 and self._mode == ARDUPILOT_MODES["LAND"]:
            return _DENIED
        self.armed = True
        self._armed_at = now
        return _ACCEPTED

    def _takeoff(self, altitude_param: float) -> int:
        if not self.armed or self._airborne():
            return _DENIED
        if self._px4:
            # PX4: param 7 is the altitude above mean sea level.
            altitude = (
                _PX4_TAKEOFF_ALT
                if math.isnan(altitude_param)
                else altitude_param - self.options.home.alt
            )
            mode_ok = True
        else:
            # ArduPilot: param 7 is the altitude above home, and GUIDED is needed.
            altitude = altitude_param
            mode_ok = self._mode == ARDUPILOT_MODES["GUIDED"]
        if not mode_ok or not (math.isfinite(altitude) and altitude > 0):
            return _DENIED
        self._vehicle.takeoff(float(altitude))
        if self._px4:
            self._mode = (PX4_MAIN["AUTO"], PX4_SUB["TAKEOFF"])
        return _ACCEPTED

    def _land(self) -> None:
        self._vehicle.land()
        self._mode = (PX4_MAIN["AUTO"], PX4_SUB["LAND"]) if self._px4 else ARDUPILOT_MODES["LAND"]

    def _hold(self) -> None:
        if self._airborne():
            self._vehicle.hold()

    def _setpoint(self, m: Any, now: float) -> None:
        self._setpoint_at = now
        frame = m.coordinate_frame
        if frame == mav.MAV_FRAME_GLOBAL_INT:
            alt = float(m.alt)
        elif frame in (mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT):
            alt = self.options.home.alt + float(m.alt)
        else:
            return
        guiding = (
            self._mode == (PX4_MAIN["OFFBOARD"], 0)
            if self._px4
            else self._mode == ARDUPILOT_MODES["GUIDED"]
        )
        if not (guiding and self.armed and self._vehicle.mode in ("takeoff", "flying")):
            return
        x, y, z = self.options.home.to_local(m.lat_int / 1e7, m.lon_int / 1e7, alt)
        if all(math.isfinite(v) for v in (x, y, z)):
            self._vehicle.goto(x, y, max(z, 0.5), speed=self._speed)

    def _after_step(self, now: float) -> None:
        if self._plane is not None:
            self._plane.after_step(now)
            return
        if not self._px4 and not self._ready and self.boot.at(self.boot_time(now)).link_ready:
            # "ArduPilot Ready": ArduCopter's start-up ends in STABILIZE, a mode asked
            # before then (accepted) forgotten, as measured.
            self._ready = True
            self._mode = ARDUPILOT_MODES["STABILIZE"]
        mode = self._vehicle.mode
        # Both autopilots disarm on touchdown, and on the ground after a few seconds armed
        # without a take-off (ArduCopter's DISARM_DELAY, PX4's COM_DISARM_PRFLT, 10 s by
        # default) — not at once: a take-off follows the arm. An empty battery disarms too.
        idle = self._armed_at is not None and now - self._armed_at >= _IDLE_DISARM
        if self.armed and (mode == "dead" or (mode == "landed" and (self._flew or idle))):
            self.armed = False
        self._flew = self.armed and mode != "landed"
        if self._px4:
            if self._mode == (PX4_MAIN["AUTO"], PX4_SUB["TAKEOFF"]) and mode == "flying":
                self._mode = (PX4_MAIN["AUTO"], PX4_SUB["LOITER"])
            elif (
                self._mode == (PX4_MAIN["OFFBOARD"], 0)
                and self._setpoint_at is not None
                and now - self._setpoint_at > self.options.offboard_timeout
            ):
                # PX4's offboard-loss failsafe: hold where it is.
                self._mode = (PX4_MAIN["AUTO"], PX4_SUB["LOITER"])
                self._hold()
                self.say("Offboard setpoints lost: holding")

    def _streams(self, now: float) -> None:
        plane = self._plane
        beating = self.boot.at(self.boot_time(now)).beating
        for message_id in self.streams.due(now):
            if message_id == mav.MAVLINK_MSG_ID_HEARTBEAT:
                held = not beating  # the ArduPilots' boot: not yet
            else:
                held = plane is not None and not plane.may_send(message_id, now)
            if held or not self._send_stream(message_id, now):
                self.streams.unsent(message_id)  # not yet, or nothing to say yet
        # ArduPilot: one of each, unasked: home once it has one, the origin once its EKF
        # has one (ArduCopter: both at once).
        state = self.boot.at(self.boot_time(now))
        for message_id, due in (
            (mav.MAVLINK_MSG_ID_HOME_POSITION, state.home),
            (mav.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN, state.origin),
        ):
            if due and self.streams.take_once(message_id):
                self._send_stream(message_id, now)

    def _custom_mode(self) -> int:
        if self._plane is not None:
            return self._plane.mode
        if isinstance(self._mode, tuple):
            return px4_custom_mode(*self._mode)
        return self._mode

    def _send_stream(self, message_id: int, now: float) -> bool:
        """Send the message ``message_id`` is due; False when there is nothing to send yet
        (no home, no position), so that it goes out as soon as there is."""
        mav_ = self._conn.mav
        boot_ms = int((now - self._started) * 1000) & 0xFFFFFFFF
        home = self.options.home
        if message_id == mav.MAVLINK_MSG_ID_HEARTBEAT:
            base = mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
            if self.armed:
                base |= mav.MAV_MODE_FLAG_SAFETY_ARMED
            autopilot = mav.MAV_AUTOPILOT_PX4 if self._px4 else mav.MAV_AUTOPILOT_ARDUPILOTMEGA
            state = mav.MAV_STATE_ACTIVE if self._airborne() else mav.MAV_STATE_STANDBY
            kind = mav.MAV_TYPE_QUADROTOR if self._plane is None else mav.MAV_TYPE_FIXED_WING
            mav_.heartbeat_send(kind, autopilot, base, self._custom_mode(), state)
        elif message_id == mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT:
            shown = self.boot.at(self.boot_time(now)).position
            if shown == "none":
                return False  # PX4: nothing before its estimator has a position
            if shown == "zeros":
                # ArduPilot: all zeros before the EKF has an origin.
                mav_.global_position_int_send(boot_ms, 0, 0, 0, 0, 0, 0, 0, 65535)
                return True
            x, y, z = self._vehicle.position()
            if self._plane is not None and not self._airborne():
                z += ground_wander(now - self._started)
            vx, vy, vz = self._vehicle.velocity()
            lat, lon, alt = home.to_geodetic(x, y, z)
            # Heading: degrees clockwise from north, centidegrees.
            heading = round((90.0 - math.degrees(self._vehicle.heading())) % 360.0 * 100) % 36000
            mav_.global_position_int_send(
                boot_ms,
                round(lat * 1e7),
                round(lon * 1e7),
                round(alt * 1000),
                round(z * 1000),
                round(vy * 100),
                round(vx * 100),
                round(-vz * 100),
                heading,
            )
        elif message_id == mav.MAVLINK_MSG_ID_SYS_STATUS:
            remaining = round(self._vehicle.battery() * 100)
            voltage = round(13_200 + 3_600 * self._vehicle.battery())  # a 4S pack, millivolts
            state = self.boot.at(self.boot_time(now))
            health = 0
            if state.gps_fix >= 3:
                health |= mav.MAV_SYS_STATUS_SENSOR_GPS
            if state.prearm_ok:
                health |= mav.MAV_SYS_STATUS_PREARM_CHECK
            mav_.sys_status_send(
                _SENSORS, _SENSORS, health, 500, voltage, -1, remaining, 0, 0, 0, 0, 0, 0
            )
        elif message_id == mav.MAVLINK_MSG_ID_GPS_RAW_INT:
            fix = self.boot.at(self.boot_time(now)).gps_fix
            lat, lon, alt = home.to_geodetic(*self._vehicle.position()) if fix >= 3 else (0, 0, 0)
            mav_.gps_raw_int_send(
                boot_ms * 1000,
                fix,
                round(lat * 1e7),
                round(lon * 1e7),
                round(alt * 1000),
                70 if fix >= 3 else 9999,
                120 if fix >= 3 else 9999,
                0,
                0,
                10 if fix >= 3 else 3,
            )
        elif message_id == mav.MAVLINK_MSG_ID_EKF_STATUS_REPORT:
            flags = self.boot.at(self.boot_time(now)).ekf_flags
            good = 0.1 if flags & mav.EKF_POS_HORIZ_ABS else 1.0
            mav_.ekf_status_report_send(flags, good, good, good, 0.1, 0.0)
        elif message_id == mav.MAVLINK_MSG_ID_TIMESYNC:
            mav_.timesync_send(0, int((now - self._started) * 1e9))
        elif message_id == mav.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN:
            mav_.gps_global_origin_send(
                round(home.lat * 1e7), round(home.lon * 1e7), round(home.alt * 1000)
            )
        elif message_id == mav.MAVLINK_MSG_ID_HOME_POSITION:
            if not self.boot.at(self.boot_time(now)).home:
                return False
            mav_.home_position_send(
                round(home.lat * 1e7),
                round(home.lon * 1e7),
                round(home.alt * 1000),
                0,
                0,
                0,
                [1, 0, 0, 0],
                0,
                0,
                0,
            )
        elif self._plane is None or not self._plane.send(message_id, boot_ms):
            mav_.send(zero_message(message_id))
        return True


def zero_message(message_id: int) -> Any:
    """A message of ``message_id`` with every field zero (PX4's onboard messages the
    autopilot does not model: their rate is what a vehicle meets, not their content)."""
    cls = mav.mavlink_map[message_id]
    lengths = dict(zip(cls.ordered_fieldnames, cls.array_lengths, strict=True))
    args: list[Any] = []
    for name, kind in zip(cls.fieldnames, cls.fieldtypes, strict=True):
        length = lengths[name]
        if kind == "char":
            args.append(b"")
        elif length:
            args.append([0] * length)
        else:
            args.append(0)
    return cls(*args)
