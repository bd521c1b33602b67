"""The simulated autopilot's ArduPlane: what :class:`~.autopilot.SimAutopilot` does
differently when it plays ArduPlane 4.5.7 (``AutopilotOptions(kind="ardupilot",
frame="plane")``), composed into it rather than stacked on it.

Everything here is fitted to ArduPlane 4.5.7 SITL (``plane.parm``) as measured
(docs/vehicles.md; the figures are pinned by ``tests/vehicles/test_autopilot_plane.py``).
Where nothing was measured it takes ArduPlane's documented default, and says so.

Flight (the project's fixed-wing physics, :class:`~actorswarm.world.vehicles.Fleet`, with
:func:`plane_spec`'s numbers)
    Airspeed 22 m/s cruise (``AIRSPEED_CRUISE``), 10–30 (``AIRSPEED_MIN``/``MAX``). Circles
    clockwise. A circle asked for at radius R is flown at ``16.9 + 1.047 R`` m, at least
    50 m (the tightest sustained, 56° of bank at 22 m/s): measured 100.5–100.9 m for R = 80
    (``WP_LOITER_RAD``), ~174 for 150, 49–55 for 25. The take-off roll accelerates at
    5.13 m/s² and lifts off at 19.5 m/s (+3.8 s, ~37 m of run; measured 40 m), climbs at up
    to 4.8 m/s (measured 4.9 from 80 to 120 m of a take-off to 162 m), slowing as it nears
    its altitude (0.158/s of the height left: TKOFF_ALT − 1 at +28 s, measured +30 s). It
    climbs on through the turn onto its circle, where the firmware pauses a few seconds:
    20 m at +8.9 s, measured 6–11 s.

Modes (``MAV_CMD_DO_SET_MODE``, ArduPlane's numbers; any other mode FAILED as ArduPilot
answers a mode it cannot enter)
    INITIALISING from its first HEARTBEAT until ``ArduPilot Ready``, then MANUAL: a mode asked
    while INITIALISING is accepted and then forgotten, as the firmware does. MANUAL, STABILIZE,
    FBWA and CIRCLE circle where they are (no RC input is modelled: a stand-in for "wings level,
    keep going"). LOITER and GUIDED circle where they are at ``WP_LOITER_RAD``. TAKEOFF, armed
    on the ground, rolls along the runway and climbs to ``TKOFF_ALT`` while it circles the point
    ``TKOFF_DIST`` ahead, staying in TAKEOFF (arming in TAKEOFF starts it). RTL climbs (or
    descends) to ``RTL_ALTITUDE`` and circles home for ever with ``RTL_AUTOLAND`` 0; with 1,
    once at home it flies the mission's landing sequence. AUTO flies the mission from its
    current item. Every mode change resets the airspeed to cruise.

Commands (``COMMAND_LONG`` and ``COMMAND_INT``, each answered with ``COMMAND_ACK``)
    ``DO_REPOSITION`` (in GUIDED, or with the change-mode flag: to GUIDED; else FAILED):
    fly to the point and circle it (param3 the radius, 0: ``WP_LOITER_RAD``).
    ``DO_CHANGE_SPEED`` (GUIDED and AUTO only, else FAILED): airspeed param2 within 10–30,
    −2 back to cruise, else FAILED. ``GUIDED_CHANGE_SPEED`` (GUIDED only; DENIED outside
    10–30). ``DO_LAND_START``: to the mission's landing sequence in AUTO, FAILED without
    one. ``NAV_RETURN_TO_LAUNCH``, ``MISSION_START``, ``NAV_LOITER_UNLIM``: RTL, AUTO,
    LOITER. ``NAV_LAND``: UNSUPPORTED. ``NAV_TAKEOFF``: FAILED (a plane that is no
    quadplane). ``SET_POSITION_TARGET_GLOBAL_INT``: only its altitude is applied, in
    GUIDED (4.5.7 ignores latitude and longitude).

The mission (``mission_type`` 0; the fence still goes to the fence receiver)
    ``MISSION_COUNT`` → ``MISSION_REQUEST_INT`` per item → ``MISSION_ACK``;
    ``MISSION_CLEAR_ALL``. Before "ArduPilot Ready" (1.6 s) an upload is refused
    (``MAV_MISSION_NO_SPACE``, "Only 0 items are supported"). Item 0 is home. AUTO flies
    ``NAV_WAYPOINT`` items (reached within 90 m, ``WP_RADIUS``) and lands on ``NAV_LAND``:
    along the line from the previous waypoint falling at 3.5° at 16 m/s (measured), or more
    steeply when that would land past the point, touching down where the line meets the
    ground (46 m short for the measured 700 m, 40 m approach; measured 46 m), braking to a
    stop, and disarming 28.2 s after touchdown (measured: +67.8 s, +96 s). A loaded
    ``DO_LAND_START`` with ``RTL_AUTOLAND`` 0 refuses arming.

Not modelled: the flare as its own phase (measured 2.3 s before touchdown), AUTO's
``NAV_TAKEOFF`` and every other mission item but waypoints and the landing, the end of a
mission (it circles its last point), wind, stalls, quadplanes, rally points, the failsafes
(their parameters are read and set only), ``PreArm:`` texts, ``DO_GO_AROUND``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, Final, Protocol

from actorswarm.vehicles.mavlink.boot import Boot
from actorswarm.vehicles.mavlink.dialect import mav
from actorswarm.vehicles.mavlink.flavours import ARDUPLANE_MODES
from actorswarm.vehicles.mavlink.frame import MissionFrame
from actorswarm.vehicles.mavlink.linkstreams import LinkStreams
from actorswarm.world.config import FixedWingParams, VehicleSpec
from actorswarm.world.vehicles import SimVehicle

__all__ = ["PLANE_MESSAGES", "PlaneHost", "SimPlane", "flown_radius", "plane_params", "plane_spec"]

_ACCEPTED: Final[int] = mav.MAV_RESULT_ACCEPTED
_FAILED: Final[int] = mav.MAV_RESULT_FAILED
_DENIED: Final[int] = mav.MAV_RESULT_DENIED
_UNSUPPORTED: Final[int] = mav.MAV_RESULT_UNSUPPORTED
_MISSION: Final[int] = mav.MAV_MISSION_TYPE_MISSION
_LAND_START: Final[int] = mav.MAV_CMD_DO_LAND_START
_M: Final = ARDUPLANE_MODES

#: The messages only the plane sends (on top of the copter's).
PLANE_MESSAGES: Final = frozenset(
    (
        mav.MAVLINK_MSG_ID_ATTITUDE,
        mav.MAVLINK_MSG_ID_VFR_HUD,
        mav.MAVLINK_MSG_ID_EKF_STATUS_REPORT,
    )
)
#: ArduPlane 4.5.7's parameters it answers (``plane.parm`` and the firmware defaults):
#: TKOFF_ALT 50 m, TKOFF_DIST 200 m, TKOFF_LVL_ALT 5 m, RTL_ALTITUDE 100 m, RTL_AUTOLAND 0
#: are ArduPlane's defaults; WP_LOITER_RAD and the airspeeds are plane.parm's.
_DEFAULTS: Final = {
    "TKOFF_ALT": 50.0,
    "TKOFF_DIST": 200.0,
    "WP_LOITER_RAD": 80.0,
    "WP_RADIUS": 90.0,
    "RTL_AUTOLAND": 0.0,
    "RTL_ALTITUDE": 100.0,
    "AIRSPEED_CRUISE": 22.0,
    "AIRSPEED_MIN": 10.0,
    "AIRSPEED_MAX": 30.0,
}
#: The radius flown for a radius asked (fitted to the three measured circles).
_RADIUS_OFFSET: Final = 16.9
_RADIUS_GROWTH: Final = 1.047
_TIGHTEST: Final = 50.0
#: Seconds from touchdown to the automatic disarm (measured 96 − 67.8; LAND_DISARMDELAY
#: is 20 s from when it no longer thinks itself flying).
_DISARM_AFTER_TOUCHDOWN: Final = 28.2
#: Throttle, %, at cruise (measured ~53).
_CRUISE_THROTTLE: Final = 53.0


def flown_radius(asked: float) -> float:
    """The radius, metres, ArduPlane circles at when asked for ``asked`` (measured)."""
    return max(_RADIUS_OFFSET + _RADIUS_GROWTH * abs(asked), _TIGHTEST)


def plane_params(failsafes: bool) -> dict[str, float]:
    """The parameters it answers: with ``failsafes``, as a SITL set up for the daemon has
    them (``FS_GCS_ENABL`` 1, ``BATT_FS_LOW_ACT`` 1); without, the firmware's defaults (0).
    ``SYSID_MYGCS`` is every simulated ArduPilot's (:class:`~.autopilot.SimAutopilot`)."""
    out = {
        "FS_GCS_ENABL": 1.0 if failsafes else 0.0,
        "BATT_FS_LOW_ACT": 1.0 if failsafes else 0.0,
    }
    out.update(_DEFAULTS)
    return out


def plane_spec(battery: float, endurance: float, heading: float = 0.0) -> VehicleSpec:
    """The physics of the simulated ArduPlane (module docstring), at home facing
    ``heading`` (degrees clockwise from north)."""
    # The world's fixed-wing is ArduPlane's (its defaults are these figures, measured); only
    # the hold circle is ArduPlane's WP_LOITER_RAD as flown, since the world's default is
    # the circle of a goal asked with the vehicle's radius, and TAKEOFF's point is its own.
    params = replace(
        FixedWingParams(),
        min_airspeed=_DEFAULTS["AIRSPEED_MIN"],
        max_speed=_DEFAULTS["AIRSPEED_MAX"],
        cruise_speed=_DEFAULTS["AIRSPEED_CRUISE"],
        loiter_radius=flown_radius(_DEFAULTS["WP_LOITER_RAD"]),
        endurance=endurance,
        takeoff_distance=0.0,  # TAKEOFF mode sends it to TKOFF_DIST itself (a parameter)
    )
    return VehicleSpec(
        platform=1,
        kind="fixed_wing",
        home=(0.0, 0.0),
        heading=math.radians(90.0 - heading),
        battery=battery,
        params=params,
    )


class PlaneHost(Protocol):
    """What :class:`SimPlane` uses of the autopilot it is part of."""

    armed: bool
    boot: Boot
    streams: LinkStreams

    def say(self, text: str, severity: int = ...) -> None: ...
    def boot_time(self, now: float) -> float: ...


@dataclass(frozen=True, slots=True)
class _Command:
    """A COMMAND_LONG or COMMAND_INT, one shape: params 1–4, position (degrees and metres,
    NaN when none) and the altitude's frame."""

    command: int
    p1: float
    p2: float
    p3: float
    p4: float
    lat: float
    lon: float
    alt: float
    frame: int

    @classmethod
    def of(cls, m: Any) -> _Command:
        if m.get_type() == "COMMAND_INT":
            return cls(
                int(m.command), m.param1, m.param2, m.param3, m.param4,
                m.x / 1e7, m.y / 1e7, float(m.z), int(m.frame),
            )  # fmt: skip
        # ArduPilot reads a COMMAND_LONG's location as latitude, longitude, altitude AMSL.
        return cls(
            int(m.command), m.param1, m.param2, m.param3, m.param4,
            m.param5, m.param6, m.param7, mav.MAV_FRAME_GLOBAL,
        )  # fmt: skip


class SimPlane:
    """The ArduPlane part of one simulated autopilot (module docstring): its mode, mission
    and commands, flying ``vehicle``; answers go out on ``link``; ``params`` is the
    autopilot's parameter table (PARAM_SET lands there)."""

    def __init__(
        self,
        host: PlaneHost,
        *,
        link: Any,
        vehicle: SimVehicle,
        home: MissionFrame,
        params: dict[str, float],
    ) -> None:
        self._host = host
        self._link = link
        self._vehicle = vehicle
        self._home = home
        self._params = params
        self.mode = _M["INITIALISING"]
        self._ready = False  # its start-up over ("ArduPilot Ready")
        self.mission: list[Any] = []
        self._incoming: list[Any] | None = None
        self._expected = 0
        self._current = 1  # the mission item AUTO flies next
        self._leg: int | None = None  # the item whose flight has begun
        self._previous: tuple[float, float, float] | None = None  # the last waypoint reached
        self._touchdown: float | None = None
        self._speed: float | None = None  # the airspeed asked for (None: cruise)
        self._heading = vehicle.heading()
        self._turn_rate = 0.0

    def restart(self) -> None:
        """A reboot: INITIALISING again until "ArduPilot Ready"."""
        self.mode = _M["INITIALISING"]
        self._ready = False

    # --- reading ---------------------------------------------------------------------------------

    @property
    def mode_name(self) -> str:
        return next(k for k, v in _M.items() if v == self.mode)

    def airborne(self) -> bool:
        return self._vehicle.mode in ("takeoff", "flying", "landing")

    # --- messages --------------------------------------------------------------------------------

    def on_message(self, m: Any, now: float) -> bool:
        """Handle ``m`` if it is the plane's to handle (True), else leave it (False)."""
        kind = m.get_type()
        if kind in ("COMMAND_LONG", "COMMAND_INT"):
            result = self._command(_Command.of(m), now)
            self._link.mav.command_ack_send(
                m.command, result, 0, 0, m.get_srcSystem(), m.get_srcComponent()
            )
            return True
        if kind == "SET_POSITION_TARGET_GLOBAL_INT":
            self._altitude_target(m)
            return True
        if kind in ("MISSION_COUNT", "MISSION_ITEM_INT", "MISSION_CLEAR_ALL"):
            if getattr(m, "mission_type", _MISSION) != _MISSION:
                return False
            self._mission_message(m, now)
            return True
        return False

    def after_step(self, now: float) -> None:
        """After each physics step: the boot's mode, AUTO's and RTL's progress, touchdown
        and the automatic disarm, an empty battery."""
        v = self._vehicle
        heading = v.heading()
        self._turn_rate = (
            math.remainder(heading - self._heading, math.tau) / 0.02 if self.airborne() else 0.0
        )
        self._heading = heading
        if not self._ready and self._host.boot.at(self._host.boot_time(now)).link_ready:
            # "ArduPilot Ready": the start-up ends in MANUAL, a mode asked while it was
            # INITIALISING (accepted then) forgotten, as measured.
            self._ready = True
            self.mode = _M["MANUAL"]
        if v.mode == "dead":
            self._host.armed = False
            return
        if self.mode == _M["AUTO"] and self._host.armed:
            self._fly_mission()
        elif self.mode == _M["RTL"] and self._param("RTL_AUTOLAND") >= 1 and v.mode == "flying":
            x, y, _ = v.position()
            if math.hypot(x, y) <= flown_radius(self._param("WP_LOITER_RAD")) + 5.0:
                start = self._landing_start()
                if start is not None:
                    self._current, self._leg = start, None
                    self._set_mode(_M["AUTO"])
        if v.mode in ("landing", "landed") and v.position()[2] <= 0.0 and self._touchdown is None:
            self._touchdown = now
        if (
            self._touchdown is not None
            and self._host.armed
            and now - self._touchdown >= _DISARM_AFTER_TOUCHDOWN
        ):
            self._host.armed = False
            self.say("Disarmed")

    def may_send(self, message_id: int, now: float) -> bool:
        """Whether ``message_id`` (not HEARTBEAT: the host holds that back until the boot's
        first one) may go yet in ArduPlane's boot (module docstring of :mod:`~.boot`): its
        streams a little after its first HEARTBEAT."""
        state = self._host.boot.at(self._host.boot_time(now))
        if message_id == mav.MAVLINK_MSG_ID_EKF_STATUS_REPORT:
            return state.ekf_streaming
        return state.streaming

    def send(self, message_id: int, boot_ms: int) -> bool:
        """Send the plane's own messages (ATTITUDE, VFR_HUD); False for any other."""
        v = self._vehicle
        vx, vy, vz = v.velocity()
        ground = math.hypot(vx, vy)
        # ArduPilot's yaw: clockwise from north; roll right wing down for a right turn.
        yaw = math.remainder(math.pi / 2 - v.heading(), math.tau)
        if message_id == mav.MAVLINK_MSG_ID_ATTITUDE:
            roll = math.atan(v.speed() * -self._turn_rate / 9.81)
            pitch = math.atan2(vz, ground) if ground > 0.5 else 0.0
            self._link.mav.attitude_send(boot_ms, roll, pitch, yaw, 0.0, 0.0, -self._turn_rate)
            return True
        if message_id == mav.MAVLINK_MSG_ID_VFR_HUD:
            _, _, alt = self._home.to_geodetic(*v.position())
            throttle = (
                round(_CRUISE_THROTTLE * v.speed() / _DEFAULTS["AIRSPEED_CRUISE"])
                if self.airborne() and self._host.armed
                else 0
            )
            self._link.mav.vfr_hud_send(
                v.speed(), ground, round(math.degrees(yaw)) % 360, throttle, alt, vz
            )
            return True
        return False

    def say(self, text: str) -> None:
        self._host.say(text, mav.MAV_SEVERITY_INFO)

    # --- arming ----------------------------------------------------------------------------------

    def arm(self, arm: bool, now: float) -> int:
        """``COMPONENT_ARM_DISARM``: its MAV_RESULT."""
        host = self._host
        if not arm:
            if self.airborne() and self._vehicle.position()[2] > 0.0:
                return _FAILED  # ArduPlane will not disarm a flying aircraft unforced
            host.armed = False
            return _ACCEPTED
        if host.armed:
            return _ACCEPTED
        state = host.boot.at(host.boot_time(now))
        refusal = list(state.refusal)
        if self._landing_start() is not None and self._param("RTL_AUTOLAND") == 0:
            refusal.append("Arm: DO_LAND_START set and RTL_AUTOLAND disabled")
        if self._vehicle.mode == "dead" or self._vehicle.battery() < 0.05:
            refusal.append("Arm: Battery 1 low")
        if refusal:
            for text in refusal:
                host.say(text, mav.MAV_SEVERITY_CRITICAL)
            return _FAILED
        host.armed = True
        self._touchdown = None
        if self.mode == _M["TAKEOFF"]:
            self._takeoff()
        return _ACCEPTED

    # --- commands --------------------------------------------------------------------------------

    def _command(self, c: _Command, now: float) -> int:
        host = self._host
        if c.command == mav.MAV_CMD_SET_MESSAGE_INTERVAL:
            if not host.boot.at(host.boot_time(now)).link_ready:
                return _ACCEPTED  # as measured: ACKed before the first HEARTBEAT, never applied
            return host.streams.set_interval(int(c.p1), float(c.p2))
        if c.command == mav.MAV_CMD_DO_SET_MODE:
            if not int(c.p1) & mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
                return _UNSUPPORTED
            mode = int(c.p2)
            if mode not in _M.values() or mode == _M["INITIALISING"]:
                return _FAILED
            self._set_mode(mode)
            return _ACCEPTED
        if c.command == mav.MAV_CMD_COMPONENT_ARM_DISARM:
            return self.arm(c.p1 == 1, now)
        if c.command == mav.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            self._set_mode(_M["RTL"])
            return _ACCEPTED
        if c.command == mav.MAV_CMD_MISSION_START:
            self._set_mode(_M["AUTO"])
            return _ACCEPTED
        if c.command == mav.MAV_CMD_NAV_LOITER_UNLIM:
            self._set_mode(_M["LOITER"])
            return _ACCEPTED
        if c.command == mav.MAV_CMD_DO_LAND_START:
            start = self._landing_start()
            if start is None:
                return _FAILED
            self._set_mode(_M["AUTO"])
            self._current, self._leg = start, None
            return _ACCEPTED
        if c.command == mav.MAV_CMD_DO_REPOSITION:
            return self._reposition(c)
        if c.command == mav.MAV_CMD_DO_CHANGE_SPEED:
            if self.mode not in (_M["GUIDED"], _M["AUTO"]):
                return _FAILED
            return self._change_speed(int(c.p1), float(c.p2))
        if c.command == mav.MAV_CMD_GUIDED_CHANGE_SPEED:
            if self.mode != _M["GUIDED"]:
                return _FAILED
            low, high = self._param("AIRSPEED_MIN"), self._param("AIRSPEED_MAX")
            if int(c.p1) != 0 or not low <= c.p2 <= high:
                return _DENIED
            return self._change_speed(0, float(c.p2))
        if c.command == mav.MAV_CMD_NAV_TAKEOFF:
            return _FAILED  # only a quadplane takes it as a command
        return _UNSUPPORTED  # NAV_LAND among them, as measured

    def _set_mode(self, mode: int) -> None:
        """Enter ``mode``: what it flies, the airspeed back to cruise. The mode it is in
        already changes nothing (ArduPlane returns at once)."""
        if mode == self.mode:
            return
        self.mode = mode
        self._speed = None
        v = self._vehicle
        v.set_loiter_radius(flown_radius(self._param("WP_LOITER_RAD")))
        if mode == _M["TAKEOFF"]:
            if self._host.armed:
                self._takeoff()
        elif mode == _M["RTL"]:
            if self.airborne() and v.mode != "landing":
                v.goto(0.0, 0.0, self._param("RTL_ALTITUDE"))
        elif mode == _M["AUTO"]:
            self._leg = None
        elif self.airborne() and v.mode != "landing":
            v.hold()  # and the cruise airspeed

    def _takeoff(self) -> None:
        """TAKEOFF mode: from the runway, or climbing on to TKOFF_ALT from the air, towards
        the point TKOFF_DIST ahead, circling it there."""
        v = self._vehicle
        x, y, z = v.position()
        heading = v.heading()
        alt, dist = self._param("TKOFF_ALT"), self._param("TKOFF_DIST")
        if v.mode in ("ground", "landed"):
            v.goto(x + dist * math.cos(heading), y + dist * math.sin(heading), alt)
        elif v.mode == "flying":
            if z >= alt:
                v.hold()  # "Above TKOFF alt - loitering"
            else:
                v.goto(x + dist * math.cos(heading), y + dist * math.sin(heading), alt)

    def _reposition(self, c: _Command) -> int:
        change = int(c.p2) & mav.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE
        if not (math.isfinite(c.lat) and math.isfinite(c.lon) and abs(c.lat) <= 90):
            return _DENIED
        if not (change or self.mode == _M["GUIDED"]):
            return _FAILED
        if self.mode != _M["GUIDED"]:
            self._set_mode(_M["GUIDED"])
        point = self._local(c.lat, c.lon, c.alt, c.frame)
        if point is None:
            return _DENIED
        radius = c.p3 if math.isfinite(c.p3) and c.p3 > 0 else self._param("WP_LOITER_RAD")
        if self.airborne() and self._vehicle.mode != "landing":
            self._vehicle.set_loiter_radius(flown_radius(radius))
            self._vehicle.goto(*point, speed=self._speed)
        return _ACCEPTED

    def _change_speed(self, kind: int, speed: float) -> int:
        """ArduPlane's airspeed change: −2 back to cruise, else within its limits."""
        if kind != 0:
            return _FAILED  # ground speed: not modelled
        if speed == -2.0:
            speed = self._param("AIRSPEED_CRUISE")
        elif not self._param("AIRSPEED_MIN") <= speed <= self._param("AIRSPEED_MAX"):
            return _FAILED
        self._speed = speed
        v = self._vehicle
        if v.mode == "flying":
            v.goto(*v.goal(), speed=speed)
        return _ACCEPTED

    def _altitude_target(self, m: Any) -> None:
        """SET_POSITION_TARGET_GLOBAL_INT in GUIDED: the altitude only (4.5.7)."""
        if self.mode != _M["GUIDED"] or self._vehicle.mode != "flying":
            return
        point = self._local(m.lat_int / 1e7, m.lon_int / 1e7, float(m.alt), m.coordinate_frame)
        if point is not None:
            x, y, _ = self._vehicle.goal()
            self._vehicle.goto(x, y, point[2], speed=self._speed)

    def _local(
        self, lat: float, lon: float, alt: float, frame: int
    ) -> tuple[float, float, float] | None:
        """Local metres from home for a MAVLink position, None for a frame not taken."""
        if frame in (mav.MAV_FRAME_GLOBAL, mav.MAV_FRAME_GLOBAL_INT):
            z = alt - self._home.alt
        elif frame in (mav.MAV_FRAME_GLOBAL_RELATIVE_ALT, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT):
            z = alt
        else:
            return None
        # Altitudes are above home, as ArduPilot keeps them (not the tangent plane's z,
        # which falls away with the Earth's curvature far from home).
        x, y, _ = self._home.to_local(lat, lon, self._home.alt)
        if not all(math.isfinite(v) for v in (x, y, z)):
            return None
        return (x, y, max(z, 0.0))

    def _param(self, name: str) -> float:
        return self._params[name]

    # --- the mission -----------------------------------------------------------------------------

    def _mission_message(self, m: Any, now: float) -> None:
        peer = (m.get_srcSystem(), m.get_srcComponent())
        kind = m.get_type()
        if kind == "MISSION_CLEAR_ALL":
            self.mission, self._incoming = [], None
            self._current, self._leg = 1, None
            self._ack(peer, mav.MAV_MISSION_ACCEPTED)
        elif kind == "MISSION_COUNT":
            if not self._host.boot.at(self._host.boot_time(now)).link_ready:
                # Before "ArduPilot Ready" the mission holds no items yet.
                self._ack(peer, mav.MAV_MISSION_NO_SPACE)
                self._host.say("Only 0 items are supported", mav.MAV_SEVERITY_WARNING)
                return
            self._incoming, self._expected = [], int(m.count)
            if self._expected == 0:
                self.mission, self._incoming = [], None
                self._ack(peer, mav.MAV_MISSION_ACCEPTED)
            else:
                self._request(peer, 0)
        elif self._incoming is not None:
            if m.seq != len(self._incoming):
                self._request(peer, len(self._incoming))  # ask again, in order
                return
            self._incoming.append(m)
            if len(self._incoming) < self._expected:
                self._request(peer, len(self._incoming))
                return
            self.mission, self._incoming = self._incoming, None
            self._current, self._leg = 1, None
            self._ack(peer, mav.MAV_MISSION_ACCEPTED)

    def _request(self, peer: tuple[int, int], seq: int) -> None:
        self._link.mav.mission_request_int_send(peer[0], peer[1], seq, _MISSION)

    def _ack(self, peer: tuple[int, int], result: int) -> None:
        self._link.mav.mission_ack_send(peer[0], peer[1], result, _MISSION)

    def _landing_start(self) -> int | None:
        """The index of the mission's first DO_LAND_START (None: it has none)."""
        for seq, item in enumerate(self.mission):
            if seq > 0 and item.command == _LAND_START:
                return seq
        return None

    def _item_point(self, item: Any) -> tuple[float, float, float] | None:
        return self._local(item.x / 1e7, item.y / 1e7, float(item.z), int(item.frame))

    def _fly_mission(self) -> None:
        """AUTO: start or finish the current item, moving on past what it does not fly."""
        v = self._vehicle
        if v.mode not in ("flying", "landing", "takeoff"):
            return
        while self._current < len(self.mission):
            item = self.mission[self._current]
            point = self._item_point(item)
            if item.command == mav.MAV_CMD_NAV_WAYPOINT and point is not None:
                if self._leg != self._current:
                    self._leg = self._current
                    v.set_loiter_radius(_TIGHTEST)
                    v.goto(*point, speed=self._speed)
                x, y, _ = v.position()
                if math.hypot(x - point[0], y - point[1]) > self._param("WP_RADIUS"):
                    return
                self._previous = point
            elif item.command == mav.MAV_CMD_NAV_LAND and point is not None:
                if self._leg != self._current:
                    self._leg = self._current
                    start = self._previous if self._previous is not None else v.position()
                    v.land_at(point[0], point[1], start=start)
                return
            self._current += 1
        if self._leg != self._current:  # the mission is over: circle where it is
            self._leg = self._current
            v.set_loiter_radius(flown_radius(self._param("WP_LOITER_RAD")))
            v.hold()
