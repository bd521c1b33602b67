"""How a fixed-wing flies on ArduPlane: take-off, a point or a moving slot, speed, hold, landing.

One file for everything that differs from a multicopter; the link, the readiness model, the
command path and the failsafe check are the copter's (:mod:`~.vehicle`, :mod:`~.commands`).
The mapping follows what ArduPlane 4.5.7 accepts, as measured on its SITL (docs/vehicles.md,
"Fixed-wing"):

Take-off
    ``TKOFF_ALT`` set to the altitude asked (``PARAM_SET``, repeated until echoed), the
    ``TAKEOFF`` mode (13), arm: the aircraft rolls along its heading, leaves the ground at
    about 20 m/s, climbs to ``TKOFF_ALT`` and then circles a point ``TKOFF_DIST`` ahead,
    still in ``TAKEOFF``. A landing mission this vehicle left loaded is cleared first (with
    ``RTL_AUTOLAND`` 0, ArduPlane refuses to arm while one is). Nothing is planned in the
    autopilot's first 3 s heard: a mode asked while ArduPlane is still INITIALISING is
    accepted and then lost when its start-up ends in MANUAL (the vehicle's ``_STARTUP``).
A point, and a moving slot
    ``GUIDED`` (15), then ``MAV_CMD_DO_REPOSITION`` (``COMMAND_INT``, absolute altitude) to
    the goal: ArduPlane flies there and circles it clockwise. The goal is streamed by
    :class:`PlaneGuidance` — sent again at most :data:`REPOSITION_RATE` times a second while it
    moves, and every :data:`REPAIR` seconds while it does not (a lost datagram is repaired).
    ``SET_POSITION_TARGET_GLOBAL_INT``, the copter's way, is no use: ArduPlane 4.5.7 takes
    only its altitude. A fixed-wing holds a *moving* slot by chasing a point ahead of it
    (the formation plugins' carrot, ``lookahead`` seconds of flight ahead, farther than the
    aircraft's turning circle so it flies straight at it) while its airspeed closes the gap
    along the track.
Speed
    ``MAV_CMD_DO_CHANGE_SPEED`` (airspeed), sent when the speed asked changes by
    :data:`SPEED_STEP` or more (at most once a second), again after every mode change
    (ArduPlane forgets it then), and every :data:`SPEED_REPAIR` seconds. ArduPlane holds it
    within ``AIRSPEED_MIN``..``AIRSPEED_MAX`` (10..30 m/s in its SITL) and only in GUIDED and
    AUTO; a speed outside ``AIRSPEED_MIN``..``AIRSPEED_MAX`` (read from the autopilot,
    :data:`ENVELOPE`) is clamped to them here, as ArduPlane refuses it (``FAILED``) rather
    than flying the nearest. No speed: the cruise speed (``-2``, which ArduPlane reads as
    "back to cruise").
Hold
    ``LOITER`` (12): it circles where it is, at ``WP_LOITER_RAD``.
Landing
    ArduPlane has no landing command (``MAV_CMD_NAV_LAND``: unsupported) and ``RTL`` circles
    home for ever unless ``RTL_AUTOLAND`` is set. So a landing is a mission,
    :func:`landing_items`: ``[home, DO_LAND_START, the approach point, NAV_LAND at home]``,
    the approach :data:`APPROACH_DISTANCE` metres out at :data:`APPROACH_HEIGHT` metres on
    the line the aircraft took off along (so every aircraft of a field lands along its own
    take-off run), then ``MAV_CMD_DO_LAND_START``: ArduPlane switches to AUTO, flies to the
    approach point and glides down (3.5° at about 16 m/s), touching down 40–50 m before the
    land point and stopping 10–20 m before it, then disarms itself.

What "arrived" means for an aircraft that cannot stop: it circles the goal at its loiter
radius (ArduPlane: the radius asked, :data:`LOITER_RADIUS`, plus about 20 m; 50 m is the
tightest it sustains at cruise), so a plugin's ``tolerance`` for a fixed-wing must be at least
that circle's radius — the shipped fixed-wing missions use 60 m and more.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Final, Protocol

from actorswarm.vehicles.mavlink.commands import Check, CheckResult, Command, Do, Step
from actorswarm.vehicles.mavlink.dialect import mav
from actorswarm.vehicles.mavlink.flavours import (
    ARDUPLANE_MODES,
    FAILSAFE_PARAMS,
    Controls,
    Kind,
    Target,
    before_arming,
    ready_and_arm,
)
from actorswarm.vehicles.mavlink.frame import MissionFrame
from actorswarm.vehicles.mavlink.mission import MISSION_MESSAGES, MissionWrite, item

__all__ = [
    "APPROACH_DISTANCE",
    "APPROACH_HEIGHT",
    "ARDUPLANE_FAILSAFE_PARAMS",
    "ENVELOPE",
    "LOITER_RADIUS",
    "REPAIR",
    "REPOSITION_RATE",
    "SPEED_REPAIR",
    "SPEED_STEP",
    "ArduPlane",
    "FixedWing",
    "PlaneControls",
    "PlaneGuidance",
    "Px4FixedWing",
    "landing_items",
]

#: ArduPlane's failsafe parameters read before arming: ArduCopter's, its link-loss one
#: spelt ``FS_GCS_ENABL``.
ARDUPLANE_FAILSAFE_PARAMS: Final = {
    ("FS_GCS_ENABL" if name == "FS_GCS_ENABLE" else name): what
    for name, what in FAILSAFE_PARAMS["ardupilot"].items()
}
#: The airspeed limits read from ArduPlane (not checked before arming: they bound the speeds
#: asked for, :class:`PlaneGuidance`).
ENVELOPE: Final = ("AIRSPEED_MIN", "AIRSPEED_MAX")
#: The loiter radius asked with each goal, metres: the smallest that makes ArduPlane fly its
#: tightest sustained circle (about 50 m at cruise; it adds ~20 m to what is asked).
LOITER_RADIUS: Final = 30.0
#: Goals sent per second at most while the goal moves; and seconds between two sendings of a
#: goal that does not (repairs a lost one).
REPOSITION_RATE: Final = 2.0
REPAIR: Final = 2.0
#: A goal that moved less than this many metres is not sent again before :data:`REPAIR`.
_MOVED: Final = 1.0
#: A change of the speed asked, m/s, worth a new DO_CHANGE_SPEED; and seconds between two.
SPEED_STEP: Final = 0.3
_SPEED_GAP: Final = 1.0
#: Seconds between two sendings of an unchanged speed (repairs a lost one).
SPEED_REPAIR: Final = 5.0
#: The landing approach: metres out from the land point, and metres above home.
APPROACH_DISTANCE: Final = 700.0
APPROACH_HEIGHT: Final = 40.0
#: Seconds between two PARAM_SETs of a parameter not echoed yet.
_PARAM_RETRY: Final = 1.0
#: A take-off is over within this many metres below its altitude (ArduPlane closes the last
#: metres slowly: 39 of 40 m in 30 s).
_CLIMBED_WITHIN: Final = 3.0
#: Seconds a climb before a goto may take (40 m: about 30 s in ArduPlane's SITL).
_CLIMB_DEADLINE: Final = 120.0
_CUSTOM: Final = float(mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED)
#: ArduPlane reads a negative airspeed as "back to cruise".
_CRUISE: Final = -2.0


class PlaneControls(Controls, Protocol):
    """What the fixed-wing plans need of the vehicle beyond a copter's."""

    def home(self) -> tuple[float, float, float]:
        """Home, local metres."""
        ...


@dataclass(slots=True)
class FixedWing:
    """The vehicle's fixed-wing part: its goal stream (:class:`PlaneGuidance`), the mission
    it writes (a landing), the parameters it sets, and the line of its take-off run. The
    vehicle hands it what the autopilot says (:meth:`on_message`, :meth:`on_position`) and
    sends what it returns; ``params`` is the vehicle's table of the autopilot's parameters,
    ``send`` its way to the autopilot, ``clock`` its clock, ``who`` names it in errors."""

    origin: MissionFrame
    target: tuple[int, int]
    who: str
    send: Callable[[Any], None]
    clock: Callable[[], float]
    params: dict[str, float]
    guidance: PlaneGuidance = field(init=False)
    mission: MissionWrite | None = None
    #: Whether a landing mission this vehicle wrote may still be loaded.
    landing_loaded: bool = False
    _runway: tuple[float, float] | None = None
    _set_at: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.guidance = PlaneGuidance(self.origin, *self.target)

    # --- the plans' view ---------------------------------------------------------------------

    def param_is(self, name: str, value: float) -> CheckResult:
        """Set the autopilot's ``name`` to ``value``: ``PARAM_SET`` every second until a
        ``PARAM_VALUE`` echoes it (True then; None meanwhile)."""
        known = self.params.get(name)
        if known is not None and abs(known - value) < 1e-3:
            return True
        now = self.clock()
        if now - self._set_at.get(name, -math.inf) >= _PARAM_RETRY:
            self._set_at[name] = now
            self.send(
                mav.MAVLink_param_set_message(
                    *self.target, name.encode(), value, mav.MAV_PARAM_TYPE_REAL32
                )
            )
        return None

    def write_mission(self, items: list[Any], what: str) -> None:
        """Start writing ``items`` as the autopilot's mission (none: clear it)."""
        self.mission = MissionWrite(items, self.target, what=what, who=self.who)
        self.landing_loaded = bool(items)
        for message in self.mission.start(self.clock()):
            self.send(message)

    def mission_written(self) -> CheckResult:
        """The write's state: True, None (going on) or why it failed."""
        write = self.mission
        if write is None:
            return "no mission was written"
        if write.error is not None:
            return write.error
        return True if write.done else None

    def runway(self) -> tuple[float, float]:
        """The unit vector (east, north) of the aircraft's take-off run (east when it never
        took off under this vehicle)."""
        return self._runway or (1.0, 0.0)

    # --- what the autopilot says -------------------------------------------------------------

    def on_message(self, message: Any, now: float) -> None:
        """A mission answer, or an airspeed limit (:data:`ENVELOPE`) read."""
        if self.mission is not None and message.get_type() in MISSION_MESSAGES:
            for answer in self.mission.on_message(message, now):
                self.send(answer)
        elif message.get_type() == "PARAM_VALUE":
            low, high = ENVELOPE
            self.guidance.low = self.params.get(low, self.guidance.low)
            self.guidance.high = self.params.get(high, self.guidance.high)

    def on_position(self, armed: bool, height: float, velocity: tuple[float, float, float]) -> None:
        """Keep the line of the take-off run: the direction of the first fast ground track
        low after arming (the landing comes back along it); forgotten once disarmed."""
        if not armed:
            self._runway = None
            return
        vx, vy, _ = velocity
        speed = math.hypot(vx, vy)
        if self._runway is None and height < 15.0 and speed > 5.0:
            self._runway = (vx / speed, vy / speed)

    def service(self, target: Target | None, mode: str, now: float) -> None:
        """Move the mission write on and stream the goal being flown in ``mode``."""
        if self.mission is not None:
            for message in self.mission.tick(now):
                self.send(message)
        for message in self.guidance.messages(target, mode, now):
            self.send(message)


def _mode(name: str) -> Command:
    return Command(mav.MAV_CMD_DO_SET_MODE, (_CUSTOM, ARDUPLANE_MODES[name], 0, 0, 0, 0, 0))


def _climbed(v: Controls, altitude: float) -> Check:
    def test() -> bool | None:
        return True if v.height() >= altitude - _CLIMBED_WITHIN else None

    return Check(f"the climb to {altitude:g} m", test, deadline=_CLIMB_DEADLINE)


def landing_items(
    frame: MissionFrame,
    target: tuple[int, int],
    land: tuple[float, float, float],
    runway: tuple[float, float],
) -> list[Any]:
    """The landing mission (module docstring) for the autopilot ``target``:
    ``[home, DO_LAND_START, approach, NAV_LAND]``, landing at ``land`` (local metres in
    ``frame``; its z unused) along ``runway`` (a unit vector)."""
    ux, uy = runway
    x, y = land[0], land[1]
    approach = (x - ux * APPROACH_DISTANCE, y - uy * APPROACH_DISTANCE, 0.0)
    ground = (x, y, 0.0)
    return [
        item(0, mav.MAV_CMD_NAV_WAYPOINT, frame, ground, height=0.0, target=target),
        item(1, mav.MAV_CMD_DO_LAND_START, frame, ground, height=0.0, target=target),
        item(2, mav.MAV_CMD_NAV_WAYPOINT, frame, approach, height=APPROACH_HEIGHT, target=target),
        item(3, mav.MAV_CMD_NAV_LAND, frame, ground, height=0.0, target=target),
    ]


class ArduPlane:
    """ArduPlane: the module docstring's mapping, for the vehicle ``v`` and its fixed-wing
    part ``part``."""

    kind: Kind = "ardupilot"

    def __init__(self, v: PlaneControls, part: FixedWing) -> None:
        self._v = v
        self._part = part

    def takeoff(self, v: Controls, altitude: float) -> list[Step]:
        p, part = self._v, self._part
        if p.airborne:
            x, y, z = p.here()
            return self.goto(p, (x, y, z - p.height() + altitude), None)
        steps: list[Step] = [*before_arming(p)]
        if part.landing_loaded:
            steps += [
                Do("clear the landing", lambda: part.write_mission([], "the mission clear")),
                Check("the mission clear", part.mission_written, deadline=10.0),
            ]
        steps += [
            Check(f"TKOFF_ALT = {altitude:g}", lambda: part.param_is("TKOFF_ALT", altitude)),
            _mode("TAKEOFF"),
            *ready_and_arm(p),
        ]
        return steps

    def goto(
        self, v: Controls, goal: tuple[float, float, float], speed: float | None
    ) -> list[Step]:
        p = self._v
        steps: list[Step] = []
        if not p.airborne:
            altitude = max(goal[2] - (p.here()[2] - p.height()), 10.0)
            steps += [*self.takeoff(p, altitude), _climbed(p, altitude)]
        if p.mode != "GUIDED" or steps:
            steps.append(_mode("GUIDED"))
        target = Target(goal, goal, speed, REPOSITION_RATE)
        steps.append(Do("fly to the goal", lambda: p.set_target(target)))
        return steps

    def hold(self, v: Controls) -> list[Step]:
        p = self._v
        if not p.airborne:
            return []
        return [Do("stop streaming", lambda: p.set_target(None)), _mode("LOITER")]

    def land(self, v: Controls) -> list[Step]:
        p, part = self._v, self._part
        if not p.airborne:
            return [Do("stop streaming", lambda: p.set_target(None))]
        items = landing_items(part.origin, part.target, p.home(), part.runway())
        return [
            Do("stop streaming", lambda: p.set_target(None)),
            Do("load the landing", lambda: part.write_mission(items, "the landing mission")),
            Check("the landing mission", part.mission_written, deadline=15.0),
            Command(mav.MAV_CMD_DO_LAND_START, (0, 0, 0, 0, 0, 0, 0)),
        ]


@dataclass(slots=True)
class PlaneGuidance:
    """Streams a fixed-wing's goal and speed (module docstring): :meth:`messages` says what
    to send at ``now`` for the ``target`` being flown while the autopilot reports ``mode``."""

    origin: MissionFrame
    system: int
    component: int
    radius: float = LOITER_RADIUS
    #: The autopilot's airspeed limits, once read (:data:`ENVELOPE`).
    low: float = 0.0
    high: float = math.inf
    _goal: tuple[float, float, float] | None = None
    _goal_at: float = -math.inf
    _speed: float | None = None
    _speed_at: float = -math.inf
    _mode: str = ""

    def messages(self, target: Target | None, mode: str, now: float) -> list[Any]:
        if mode != self._mode:
            self._mode = mode
            self._speed = None  # ArduPlane resets the airspeed at every mode change
        if target is None:
            self._goal = None
            return []
        out: list[Any] = []
        goal = target.goal
        moved = self._goal is None or math.dist(goal, self._goal) >= _MOVED
        since = now - self._goal_at
        if (moved and since >= 1.0 / target.rate) or since >= REPAIR:
            out.append(self._reposition(goal))
            self._goal, self._goal_at = goal, now
        wanted = (
            _CRUISE if target.speed is None else min(max(float(target.speed), self.low), self.high)
        )
        since = now - self._speed_at
        changed = self._speed is None or abs(wanted - self._speed) >= SPEED_STEP
        if mode in ("GUIDED", "AUTO") and (
            (changed and since >= _SPEED_GAP) or since >= SPEED_REPAIR
        ):
            if not (self._speed is None and wanted == _CRUISE):
                out.append(self._change_speed(wanted))
            self._speed, self._speed_at = wanted, now
        return out

    def _reposition(self, goal: tuple[float, float, float]) -> Any:
        lat, lon, alt = self.origin.to_geodetic(*goal)
        return mav.MAVLink_command_int_message(
            self.system,
            self.component,
            mav.MAV_FRAME_GLOBAL_INT,
            mav.MAV_CMD_DO_REPOSITION,
            0,
            0,
            -1.0,  # ground speed: no change (the airspeed is DO_CHANGE_SPEED's)
            float(mav.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE),
            self.radius,
            math.nan,  # yaw: the autopilot's choice
            round(lat * 1e7),
            round(lon * 1e7),
            float(alt),
        )

    def _change_speed(self, speed: float) -> Any:
        return mav.MAVLink_command_long_message(
            self.system,
            self.component,
            mav.MAV_CMD_DO_CHANGE_SPEED,
            0,
            0.0,  # airspeed
            speed,
            -1.0,  # throttle: no change
            0,
            0,
            0,
            0,
        )


_PX4_FIXED_WING: Final = (
    "PX4 fixed-wing aircraft are not flown by this vehicle yet (its take-off, loiter and "
    "landing differ from a multicopter's); use ArduPlane, or a PX4 multicopter"
)


class Px4FixedWing:
    """A PX4 fixed-wing: every plan fails at once, saying so — flying it with the
    multicopter's commands would not be safe."""

    kind: Kind = "px4"

    def _refuse(self) -> list[Step]:
        return [Check("a PX4 fixed-wing", lambda: _PX4_FIXED_WING)]

    def takeoff(self, v: Controls, altitude: float) -> list[Step]:
        return self._refuse()

    def goto(
        self, v: Controls, goal: tuple[float, float, float], speed: float | None
    ) -> list[Step]:
        return self._refuse()

    def hold(self, v: Controls) -> list[Step]:
        return self._refuse()

    def land(self, v: Controls) -> list[Step]:
        return self._refuse()
