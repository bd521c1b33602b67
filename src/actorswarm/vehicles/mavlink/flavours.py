"""What each autopilot wants for take-off, goto, hold and land: the steps of each plan.

ArduPilot (ArduCopter)
    Everything in ``GUIDED``: ``MAV_CMD_DO_SET_MODE`` GUIDED, arm, ``MAV_CMD_NAV_TAKEOFF``
    whose altitude (param 7) is metres above home; goals are
    ``SET_POSITION_TARGET_GLOBAL_INT`` (resent each second: a lost datagram is repaired),
    their speed ``MAV_CMD_DO_CHANGE_SPEED``; hold is a target at the current position; land
    is the ``LAND`` mode.
PX4
    Arm, then ``MAV_CMD_NAV_TAKEOFF`` whose altitude (param 7) is metres above mean sea
    level (PX4 switches itself to AUTO.TAKEOFF); goals are ``OFFBOARD`` setpoints, which PX4
    accepts only while they stream (above 2 Hz: it leaves ``OFFBOARD`` when they stop), so
    the stream starts before the mode is asked for; a speed is flown by moving the streamed
    setpoint along the line at that speed; hold is AUTO.LOITER, land AUTO.LAND.

Both: a goto on the ground takes off to the goal's altitude first, as the simulated
vehicle does; a take-off in the air climbs or descends where the vehicle is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Final, Literal, Protocol

from actorswarm.vehicles.mavlink.commands import Check, Command, Do, Step
from actorswarm.vehicles.mavlink.dialect import mav

__all__ = [
    "ARDUPILOT_MODES",
    "ARDUPLANE_MODES",
    "FAILSAFE_PARAMS",
    "GCS_ID",
    "PX4_MAIN",
    "PX4_SUB",
    "Airframe",
    "ArduPilot",
    "Controls",
    "Flavour",
    "Kind",
    "Px4",
    "Target",
    "before_arming",
    "flavour",
    "mode_name",
    "px4_custom_mode",
    "ready_and_arm",
]

Kind = Literal["ardupilot", "px4"]
#: ArduPilot's parameter naming the one ground station whose heartbeats its link-loss
#: failsafe counts: it must be the vehicle's own system ID (``MavlinkSettings.own_system``).
GCS_ID: Final = "SYSID_MYGCS"
#: The failsafe parameters read before arming, per autopilot: name -> what it guards. A
#: value of 0 means the failsafe is off; ArduPilot's :data:`GCS_ID` must be the vehicle's
#: own system, the one ground station its link-loss failsafe watches. (ArduPlane spells
#: the first one ``FS_GCS_ENABL``: :data:`~.fixedwing.ARDUPLANE_FAILSAFE_PARAMS`.)
FAILSAFE_PARAMS: Final[dict[Kind, dict[str, str]]] = {
    "ardupilot": {
        "FS_GCS_ENABLE": "link-loss failsafe",
        "BATT_FS_LOW_ACT": "low-battery failsafe",
        GCS_ID: "the ground station the link-loss failsafe watches",
    },
    "px4": {"NAV_DLL_ACT": "link-loss failsafe", "COM_LOW_BAT_ACT": "low-battery failsafe"},
}
#: The airframe, from the HEARTBEAT's type: a fixed-wing, or anything else (a multicopter).
Airframe = Literal["copter", "plane"]

#: ArduCopter's custom mode numbers.
ARDUPILOT_MODES: Final = {"STABILIZE": 0, "GUIDED": 4, "LOITER": 5, "RTL": 6, "LAND": 9}
#: ArduPlane's custom mode numbers (pymavlink's ``mode_mapping_apm``).
ARDUPLANE_MODES: Final = {
    "MANUAL": 0, "CIRCLE": 1, "STABILIZE": 2, "FBWA": 5, "AUTO": 10, "RTL": 11, "LOITER": 12,
    "TAKEOFF": 13, "GUIDED": 15, "INITIALISING": 16,
}  # fmt: skip
#: PX4's main modes, and the sub-modes of AUTO.
PX4_MAIN: Final = {"POSCTL": 3, "AUTO": 4, "OFFBOARD": 6}
PX4_SUB: Final = {"READY": 1, "TAKEOFF": 2, "LOITER": 3, "MISSION": 4, "RTL": 5, "LAND": 6}

#: ArduCopter's mode names by number (as pymavlink's ``mode_mapping_acm`` names them).
_ARDUCOPTER_NAMES: Final = {
    0: "STABILIZE", 1: "ACRO", 2: "ALT_HOLD", 3: "AUTO", 4: "GUIDED", 5: "LOITER", 6: "RTL",
    7: "CIRCLE", 8: "POSITION", 9: "LAND", 10: "OF_LOITER", 11: "DRIFT", 13: "SPORT",
    14: "FLIP", 15: "AUTOTUNE", 16: "POSHOLD", 17: "BRAKE", 18: "THROW", 19: "AVOID_ADSB",
    20: "GUIDED_NOGPS", 21: "SMART_RTL", 22: "FLOWHOLD", 23: "FOLLOW", 24: "ZIGZAG",
    25: "SYSTEMID", 26: "AUTOROTATE", 27: "AUTO_RTL", 28: "TURTLE", 29: "RATE_ACRO",
}  # fmt: skip
_ARDUPLANE_NAMES: Final = {number: name for name, number in ARDUPLANE_MODES.items()}
#: PX4's main modes and AUTO's sub-modes by number, named as pymavlink names them.
_PX4_MAIN_NAMES: Final = {
    1: "MANUAL", 2: "ALTCTL", 3: "POSCTL", 5: "ACRO", 6: "OFFBOARD", 7: "STABILIZED",
    8: "RATTITUDE",
}  # fmt: skip
_PX4_AUTO_NAMES: Final = {
    2: "TAKEOFF", 3: "LOITER", 4: "MISSION", 5: "RTL", 6: "LAND", 7: "RTGS", 8: "FOLLOWME",
}  # fmt: skip
_CUSTOM: Final = float(mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED)
_NAN: Final = math.nan
#: Seconds a climb before a goto may take.
CLIMB_DEADLINE: Final = 60.0
#: A take-off is over within this many metres of its altitude.
_AT_ALTITUDE: Final = 0.5


def px4_custom_mode(main: int, sub: int = 0) -> int:
    """PX4's ``custom_mode`` of a HEARTBEAT: the main mode in byte 2, the sub-mode in 3."""
    return (main << 16) | (sub << 24)


@dataclass(frozen=True, slots=True)
class Target:
    """A goal to stream: ``goal`` (local metres) reached from ``start`` at ``speed`` m/s
    (None: the setpoint is the goal at once); ``rate`` setpoints per second."""

    goal: tuple[float, float, float]
    start: tuple[float, float, float]
    speed: float | None
    rate: float


class Controls(Protocol):
    """What a flavour needs of the vehicle to build its plans."""

    @property
    def armed(self) -> bool: ...

    @property
    def airborne(self) -> bool: ...

    @property
    def mode(self) -> str: ...

    def here(self) -> tuple[float, float, float]:
        """The current local position."""
        ...

    def home_altitude(self) -> float:
        """Home's altitude above mean sea level, metres."""
        ...

    def set_target(self, target: Target | None) -> None:
        """Stream ``target`` from now (None: stop streaming)."""
        ...

    def failsafes(self) -> bool | str | None:
        """The pre-flight check: True, the reason it refuses, or None (not known yet)."""
        ...

    def read_failsafes_again(self) -> None:
        """Forget the failsafe parameters read, so that they are asked for again: each
        take-off checks the autopilot's values as they are then."""
        ...

    def height(self) -> float:
        """Metres above home."""
        ...

    def ready(self) -> bool | None:
        """Whether the autopilot's readiness signals together say it is worth asking to
        arm: True, or None (not yet)."""
        ...

    @property
    def arm_timeout(self) -> float:
        """Seconds a take-off may wait for the autopilot to be ready and to accept arming."""
        ...

    @property
    def arm_probe(self) -> float:
        """Seconds between two asks to arm while the readiness signals say "not yet"."""
        ...


class Flavour(Protocol):
    kind: Kind

    def takeoff(self, v: Controls, altitude: float) -> list[Step]: ...

    def goto(
        self, v: Controls, goal: tuple[float, float, float], speed: float | None
    ) -> list[Step]: ...

    def hold(self, v: Controls) -> list[Step]: ...

    def land(self, v: Controls) -> list[Step]: ...


def _check_failsafes(v: Controls) -> Check:
    return Check("the failsafe parameters", v.failsafes)


def _climbed(v: Controls, altitude: float) -> Check:
    def test() -> bool | None:
        return True if v.height() >= altitude - _AT_ALTITUDE else None

    return Check(f"the climb to {altitude:g} m", test, deadline=CLIMB_DEADLINE)


def _above_here(v: Controls, altitude: float) -> tuple[float, float, float]:
    """Where a take-off of an airborne vehicle goes: ``altitude`` above the ground here."""
    x, y, z = v.here()
    return (x, y, z - v.height() + altitude)


def before_arming(v: Controls) -> list[Step]:
    """Both autopilots: stop any setpoint stream, then the failsafe pre-flight check on the
    parameters read afresh (an operator may have set one since the last take-off)."""
    return [
        Do("stop streaming", lambda: v.set_target(None)),
        Do("read the failsafe parameters again", v.read_failsafes_again),
        _check_failsafes(v),
    ]


def ready_and_arm(v: Controls) -> list[Step]:
    """Arm, asking again after each refusal, within ``arm_timeout`` of the plan's start;
    while the autopilot's readiness signals say "not yet", only every ``arm_probe``
    seconds (the signals are advice: the autopilot's answer decides)."""
    return [
        Command(
            mav.MAV_CMD_COMPONENT_ARM_DISARM,
            (1, 0, 0, 0, 0, 0, 0),
            persist=True,
            deadline=v.arm_timeout,
            from_plan=True,
            gate=v.ready,
            probe=v.arm_probe,
        ),
    ]


class ArduPilot:
    """ArduCopter in GUIDED."""

    kind: Kind = "ardupilot"

    def _guided(self) -> Command:
        return Command(mav.MAV_CMD_DO_SET_MODE, (_CUSTOM, ARDUPILOT_MODES["GUIDED"], 0, 0, 0, 0, 0))

    def takeoff(self, v: Controls, altitude: float) -> list[Step]:
        if v.airborne:
            return self.goto(v, _above_here(v, altitude), None)
        return [
            *before_arming(v),
            self._guided(),
            *ready_and_arm(v),
            # ArduPilot: param 7 is the altitude above home.
            Command(mav.MAV_CMD_NAV_TAKEOFF, (0, 0, 0, 0, 0, 0, altitude)),
        ]

    def goto(
        self, v: Controls, goal: tuple[float, float, float], speed: float | None
    ) -> list[Step]:
        steps: list[Step] = []
        if not v.airborne:
            altitude = max(goal[2] - (v.here()[2] - v.height()), 1.0)
            steps += [*self.takeoff(v, altitude), _climbed(v, altitude)]
        elif v.mode != "GUIDED":
            steps.append(self._guided())
        if speed is not None:
            steps.append(Command(mav.MAV_CMD_DO_CHANGE_SPEED, (1, speed, -1, 0, 0, 0, 0)))
        target = Target(goal, goal, None, 1.0)
        steps.append(Do("stream the goal", lambda: v.set_target(target)))
        return steps

    def hold(self, v: Controls) -> list[Step]:
        if not v.airborne:
            return []
        here = v.here()
        return [self._guided(), Do("hold here", lambda: v.set_target(Target(here, here, None, 1)))]

    def land(self, v: Controls) -> list[Step]:
        return [
            Do("stop streaming", lambda: v.set_target(None)),
            Command(mav.MAV_CMD_DO_SET_MODE, (_CUSTOM, ARDUPILOT_MODES["LAND"], 0, 0, 0, 0, 0)),
        ]


class Px4:
    """PX4 multicopter (and any other autopilot using PX4's modes): AUTO.TAKEOFF, OFFBOARD
    goals, AUTO.LOITER, AUTO.LAND."""

    kind: Kind = "px4"
    #: Setpoints per second: PX4 leaves OFFBOARD below 2 Hz.
    rate: Final = 5.0

    def takeoff(self, v: Controls, altitude: float) -> list[Step]:
        if v.airborne:
            return self.goto(v, _above_here(v, altitude), None)
        return [
            *before_arming(v),
            *ready_and_arm(v),
            # PX4: param 7 is the altitude above mean sea level (home's plus the climb).
            Command(
                mav.MAV_CMD_NAV_TAKEOFF,
                (-1, 0, 0, _NAN, _NAN, _NAN, v.home_altitude() + altitude),
            ),
        ]

    def goto(
        self, v: Controls, goal: tuple[float, float, float], speed: float | None
    ) -> list[Step]:
        steps: list[Step] = []
        if not v.airborne:
            altitude = max(goal[2] - (v.here()[2] - v.height()), 1.0)
            steps += [*self.takeoff(v, altitude), _climbed(v, altitude)]
        rate = self.rate

        def stream() -> None:
            v.set_target(Target(goal, v.here(), speed, rate))

        steps.append(Do("stream setpoints", stream))
        if v.mode != "OFFBOARD":
            steps.append(
                Command(mav.MAV_CMD_DO_SET_MODE, (_CUSTOM, PX4_MAIN["OFFBOARD"], 0, 0, 0, 0, 0))
            )
        return steps

    def hold(self, v: Controls) -> list[Step]:
        if not v.airborne:
            return []
        return [
            Do("stop streaming", lambda: v.set_target(None)),
            Command(
                mav.MAV_CMD_DO_SET_MODE,
                (_CUSTOM, PX4_MAIN["AUTO"], PX4_SUB["LOITER"], 0, 0, 0, 0),
            ),
        ]

    def land(self, v: Controls) -> list[Step]:
        # AUTO.LAND through the mode, as ground stations do: PX4 and MAVSDK's action server
        # both take it (the latter does not answer MAV_CMD_NAV_LAND).
        return [
            Do("stop streaming", lambda: v.set_target(None)),
            Command(
                mav.MAV_CMD_DO_SET_MODE, (_CUSTOM, PX4_MAIN["AUTO"], PX4_SUB["LAND"], 0, 0, 0, 0)
            ),
        ]


def mode_name(kind: Kind, base_mode: int, custom_mode: int, airframe: Airframe = "copter") -> str:
    """The name of the mode a HEARTBEAT reports, read as ``kind`` encodes it (the names
    pymavlink gives: ``GUIDED``; PX4's ``OFFBOARD``, and ``LOITER`` for AUTO.LOITER;
    ArduPlane's own numbers for an ArduPilot ``plane``)."""
    del base_mode  # PX4 1.12+ and ArduPilot: the custom mode alone says which
    if kind == "px4":
        main, sub = (custom_mode >> 16) & 0xFF, (custom_mode >> 24) & 0xFF
        if main == PX4_MAIN["AUTO"]:
            return _PX4_AUTO_NAMES.get(sub, "UNKNOWN")
        return _PX4_MAIN_NAMES.get(main, "UNKNOWN")
    if airframe == "plane":
        return _ARDUPLANE_NAMES.get(custom_mode, f"Mode({custom_mode})")
    return _ARDUCOPTER_NAMES.get(custom_mode, f"Mode({custom_mode})")


def flavour(kind: Kind) -> Flavour:
    """The multicopter flavour of ``kind`` (a fixed-wing's: :mod:`~.fixedwing`)."""
    return ArduPilot() if kind == "ardupilot" else Px4()
