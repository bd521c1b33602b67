""":class:`MavlinkVehicle`: the plugins' :class:`~actorswarm.runtime.context.Vehicle` on a PX4
or ArduPilot autopilot.

Theory of operation
-------------------
One vehicle, one autopilot, one connection. A background thread (:meth:`MavlinkVehicle.start`)
calls :meth:`MavlinkVehicle.service` every few milliseconds: it reads whatever arrived,
keeps the messages of this vehicle's autopilot (:class:`~.link.MessageFilter`), updates the
latest state, moves the command plan on (:class:`~.commands.CommandSender`), streams the
current goal, sends our own ``HEARTBEAT`` each second and watches the autopilot's.

A multicopter's plans are :mod:`~.flavours`'. An autopilot whose ``HEARTBEAT`` says
fixed-wing is flown by :mod:`~.fixedwing` (ArduPlane: its plans, and its part that streams
the goal, writes the landing mission and sets parameters); a PX4 fixed-wing is refused.

The plugins' calls never block: a read returns the latest state under a lock; a command
builds its plan (:mod:`~.flavours`) and returns, the thread carries it out. What fails
— a refused or unanswered command, a pre-flight check that refuses to arm — is kept for
:meth:`drain_errors`, each message naming the vehicle and the command.

Safety:

* The autopilot's ``HEARTBEAT`` silent for ``link_timeout`` seconds (default 3) raises the
  local event ``vehicle_link_lost`` (also when it is never heard from the start); the next
  heartbeat raises ``vehicle_link_restored``: :meth:`drain_events`, which the daemon turns
  into events its task script can handle. A command asked before the autopilot is first
  heard (it boots after its daemon), or in its first three seconds (its start-up, when the
  ArduPilots forget a mode asked), waits for it, as a take-off waits for an autopilot that
  is not ready yet: the latest one asked is carried out then, or fails for good (a fault)
  when none was heard within ``arm_timeout``.
* Before arming, the autopilot's link-loss and low-battery failsafe parameters are read
  (``PARAM_REQUEST_READ``); a take-off is refused while one is off, unless ``force``.
* The operator's ``land`` or ``hold`` (:meth:`MavlinkVehicle.override`, the daemon's
  :data:`OPERATOR_EVENTS`) takes the vehicle from the plugins: their commands are ignored
  (the first one reported) until the operator gives it back.
* Every goal is bounded by the :class:`Fence`: one outside is moved onto its edge, and the
  move is reported as an error.

Ask for what you read: every message the vehicle reads is asked for on the link
(:mod:`~.streams`) once the autopilot is heard and again whenever the link comes back, and
watched until it comes; one the autopilot does not send although asked is named in the
waiting reason and no longer holds arming back. Readiness is advice: while its signals say
"not yet", a take-off still asks to arm every ten seconds, and the autopilot's answer decides
(``arm_timeout`` is the only deadline). A link on which the autopilot speaks MAVLink 1 only
is answered in MAVLink 1.
"""

from __future__ import annotations

import math
import struct
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Final, Literal

from actorswarm.runtime.context import VEHICLE_FAULT_EVENT
from actorswarm.vehicles.mavlink.commands import Check, Command, CommandSender, Step
from actorswarm.vehicles.mavlink.dialect import mav, result_name
from actorswarm.vehicles.mavlink.fence import FencePusher
from actorswarm.vehicles.mavlink.fixedwing import (
    ARDUPLANE_FAILSAFE_PARAMS,
    ENVELOPE,
    ArduPlane,
    FixedWing,
    Px4FixedWing,
)
from actorswarm.vehicles.mavlink.flavours import (
    FAILSAFE_PARAMS,
    GCS_ID,
    Airframe,
    Flavour,
    Kind,
    Target,
    flavour,
    mode_name,
    px4_custom_mode,
)
from actorswarm.vehicles.mavlink.frame import MissionFrame
from actorswarm.vehicles.mavlink.link import (
    Link,
    MessageFilter,
    drain_library_lines,
    is_mavlink1,
)
from actorswarm.vehicles.mavlink.readiness import Readiness, Texts
from actorswarm.vehicles.mavlink.streams import StreamWatch

__all__ = [
    "FAILSAFE_PARAMS",
    "FAULT",
    "GCS_DEFAULT",
    "LINK_LOST",
    "LINK_RESTORED",
    "OPERATOR_EVENTS",
    "OWN_SYSTEM",
    "Fence",
    "MavlinkSettings",
    "MavlinkVehicle",
]

LINK_LOST: Final = "vehicle_link_lost"
LINK_RESTORED: Final = "vehicle_link_restored"
#: The local event of a command that failed for good (its deadline passed, the autopilot
#: refused it, the autopilot was never heard); its data is ``{"reason": ...}``.
FAULT: Final = VEHICLE_FAULT_EVENT
#: The operator's events (``gs event NAME``) that take the vehicle from the plugins
#: (``land``, ``hold``) and give it back (None).
OPERATOR_EVENTS: Final[dict[str, Literal["land", "hold"] | None]] = {
    "vehicle_land": "land",
    "vehicle_hold": "hold",
    "vehicle_resume": None,
}

#: Our own MAVLink system ID by default (``MavlinkSettings.own_system``).
OWN_SYSTEM: Final = 245
#: ``SYSID_MYGCS``'s firmware default.
GCS_DEFAULT: Final = 255

_INT_TYPES: Final = frozenset(
    (
        mav.MAV_PARAM_TYPE_UINT8,
        mav.MAV_PARAM_TYPE_INT8,
        mav.MAV_PARAM_TYPE_UINT16,
        mav.MAV_PARAM_TYPE_INT16,
        mav.MAV_PARAM_TYPE_UINT32,
        mav.MAV_PARAM_TYPE_INT32,
    )
)
#: Our own heartbeat, and re-requests of unknown parameters, every this many seconds.
_BEAT: Final = 1.0
#: Our HEARTBEAT's type (a GCS-type one on PX4 links, see :meth:`MavlinkVehicle.service`).
_OUR_TYPE: Final = mav.MAV_TYPE_ONBOARD_CONTROLLER
#: Seconds a mode we asked for counts as the vehicle's mode until a HEARTBEAT reports it.
_MODE_SETTLE: Final = 3.0
#: Seconds :meth:`MavlinkVehicle.close` waits for its thread.
_CLOSE_WAIT: Final = 0.5
#: Seconds between two looks of the background thread.
_PERIOD: Final = 0.02
#: Metres above home from which the vehicle counts as airborne.
_AIRBORNE: Final = 0.5
#: Seconds from an autopilot's first HEARTBEAT before a command is planned. Both ArduPilots
#: send it before their start-up is over (ArduPlane 4.5.7 SITL 0.71 s, ArduCopter 1.23 s
#: before "ArduPilot Ready"), take a mode then, and start in MANUAL or STABILIZE regardless:
#: a take-off planned at once lost its mode and the aircraft stayed on the ground.
_STARTUP: Final = 3.0
# SET_POSITION_TARGET_GLOBAL_INT: use the position only (ignore velocity, acceleration, yaw).
_POSITION_ONLY: Final = 0b0000_1101_1111_1000

LinkState = Literal["never heard", "up", "lost"]


@dataclass(frozen=True, slots=True)
class Fence:
    """The box every goal must stay in: local metres ``x_min..x_max`` east,
    ``y_min..y_max`` north, up to ``z_max``."""

    x_min: float = -500.0
    y_min: float = -500.0
    x_max: float = 500.0
    y_max: float = 500.0
    z_max: float = 120.0

    def __post_init__(self) -> None:
        if not (self.x_min < self.x_max and self.y_min < self.y_max and self.z_max > 0):
            raise ValueError(f"fence: an empty box {self}")

    def bound(self, x: float, y: float, z: float) -> tuple[float, float, float]:
        """The point of the box nearest to ``(x, y, z)`` (itself when inside)."""
        return (
            min(max(x, self.x_min), self.x_max),
            min(max(y, self.y_min), self.y_max),
            min(z, self.z_max),
        )


@dataclass(frozen=True, slots=True)
class MavlinkSettings:
    """How to reach and fly one autopilot.

    ``url``: a pymavlink connection string; ``origin``: the mission's origin;
    ``system``: the autopilot's system ID (None: the first autopilot heard);
    ``component``: its component ID; ``own_system``/``own_component``: ours;
    ``kind``: ``"auto"`` (from its HEARTBEAT), ``"ardupilot"`` or ``"px4"``;
    ``link_timeout``: seconds of heartbeat silence that count as a lost link;
    ``retry``/``deadline``: seconds between two sendings of a command, and before one
    fails; ``arm_timeout``: seconds a take-off waits for the autopilot to be ready and to
    accept arming (refusals asked again with back-off) before it fails; ``arm_probe``:
    seconds between two asks to arm while the readiness signals say "not yet" (they are
    advice: the autopilot's answer decides); ``stream_grace``: seconds a message asked for
    may take to arrive before it is asked again (:mod:`~.streams`); ``force``: take off even
    when the failsafe check refuses; ``name``: how messages name the vehicle.
    """

    url: str
    origin: MissionFrame
    system: int | None = None
    component: int = 1
    own_system: int = OWN_SYSTEM
    own_component: int = 191
    kind: Literal["auto", "ardupilot", "px4"] = "auto"
    link_timeout: float = 3.0
    retry: float = 0.5
    deadline: float = 5.0
    arm_timeout: float = 120.0
    arm_probe: float = 10.0
    stream_grace: float = 3.0
    force: bool = False
    fence: Fence = field(default_factory=Fence)
    name: str = "mavlink"
    #: Also push ``fence`` to the autopilot's own geofence once it is heard
    #: (:mod:`~actorswarm.vehicles.mavlink.fence`).
    push_fence: bool = False

    def __post_init__(self) -> None:
        for name in ("link_timeout", "retry", "deadline", "arm_timeout", "arm_probe"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and value > 0):
                raise ValueError(f"mavlink settings: {name} must be > 0 s, not {value!r}")
        if not self.stream_grace > 0:
            raise ValueError(
                f"mavlink settings: stream_grace must be > 0 s, not {self.stream_grace!r}"
            )


@dataclass(slots=True)
class _State:
    """The latest known state of the autopilot."""

    heard: float | None = None  # the last HEARTBEAT
    link: LinkState = "never heard"
    kind: Kind | None = None
    airframe: Airframe = "copter"
    mode: str = ""
    armed: bool = False
    position: tuple[float, float, float] | None = None
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    height: float = 0.0  # above home
    battery: float | None = None
    home: tuple[float, float, float] | None = None
    home_amsl: float | None = None
    params: dict[str, float] = field(default_factory=dict)


class MavlinkVehicle:
    """A :class:`~actorswarm.runtime.context.Vehicle` flying the autopilot of ``settings``.

    The connection opens here (MavlinkError naming the vehicle and the string when it
    cannot); nothing is read until :meth:`start` (a thread) or calls to :meth:`service`.
    """

    def __init__(
        self, settings: MavlinkSettings, *, clock: Callable[[], float] = time.monotonic
    ) -> None:
        self.settings = settings
        self.name = settings.name
        self._clock = clock
        self._link = Link(
            settings.url,
            who=f"vehicle {self.name}",
            source_system=settings.own_system,
            source_component=settings.own_component,
        )
        self._filter = MessageFilter(settings.system, settings.component)
        self._lock = threading.RLock()
        self._state = _State()
        self._started = clock()
        self._plan: CommandSender | None = None
        self._streams: StreamWatch | None = None
        self._flavour: Flavour | None = None
        self._target: Target | None = None
        self._target_since = 0.0
        self._target_sent: float | None = None
        self._beat: float | None = None
        self._params_asked: float | None = None
        self._events: list[str] = []
        self._errors: list[str] = []
        self._faults: list[str] = []
        self._log: list[tuple[str, dict[str, Any]]] = []
        self._mode_asked: tuple[str, float] | None = None  # a mode asked for, and when
        self._readiness = Readiness()
        self._texts = Texts()
        self._refused: str | None = None  # the last command refused, and how
        self._refusals: list[tuple[str, str]] = []  # refused in this batch, to log after it
        self._said: tuple[bool | None, str | None] = (None, None)  # readiness last logged
        self._override: Literal["land", "hold"] | None = None
        self._ignored = False
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._fence = (
            FencePusher(settings.fence, settings.origin, f"vehicle {self.name}")
            if settings.push_fence
            else None
        )
        # A fixed-wing's part (:mod:`~.fixedwing`), once its HEARTBEAT says it is one.
        self._fixed_wing: FixedWing | None = None
        # The command asked before the autopilot was heard, or in its start-up: label,
        # plan, and since when a command has waited.
        self._pending: tuple[str, Callable[[Flavour], list[Step]], float] | None = None
        self._first_heard: float | None = None  # its first HEARTBEAT

    # --- life ------------------------------------------------------------------------------------

    def start(self) -> None:
        """Serve the link in a background thread until :meth:`close`."""
        if self._thread is None:
            self._thread = threading.Thread(
                target=self._run, name=f"mavlink {self.name}", daemon=True
            )
            self._thread.start()

    def close(self) -> None:
        """Stop the thread and close the connection, whatever state the link is in (gone,
        reconnecting, never opened); never raises, and returns within about half a second
        (the thread is a daemon thread: one still inside a connection attempt is left to
        end on its own)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=_CLOSE_WAIT)
        self._link.close()

    def _run(self) -> None:
        while not self._stop.is_set():
            self.service(self._clock())
            self._stop.wait(_PERIOD)

    def service(self, now: float) -> None:
        """Read, update, command, stream, watch: one look at the link at ``now``. A broken
        link is reopened first, outside the lock (an attempt may take half a second)."""
        self._link.maintain(now)
        with self._lock:
            for message in self._link.read():
                if self._filter.accept(message):
                    self._on_message(message, now)
                    self._note_version(message)
            self._log_refusals()
            self._link_changes()
            if self._beat is None or now - self._beat >= _BEAT:
                self._beat = now
                # PX4 sends its STATUSTEXT (the reasons it refuses) only on a link that
                # heard a ground station's heartbeat.
                ours = mav.MAV_TYPE_GCS if self._state.kind == "px4" else _OUR_TYPE
                self._send(
                    mav.MAVLink_heartbeat_message(
                        ours,
                        mav.MAV_AUTOPILOT_INVALID,
                        0,
                        0,
                        mav.MAV_STATE_ACTIVE,
                        3,
                    )
                )
            self._watch_link(now)
            if self._state.kind is not None:
                self._ask_params(now)
                if self._fence is not None:
                    target = (self._filter.system or 0, self.settings.component)
                    for message in self._fence.service(self._state.kind, target, now):
                        self._send(message)
                    self._errors += self._fence.drain_error()
            if self._streams is not None:
                for request in self._streams.tick(now):
                    self._send(request)
                self._stream_changes()
            self._start_pending(now)
            if self._plan is not None:
                self._plan.tick(now)
                failed = self._plan.drain_errors()
                self._errors += failed
                self._faults += failed
            self._give_up_waiting(now)
            self._stream(now)
            self._watch_readiness(now)

    # --- what the daemon reads -------------------------------------------------------------------

    def drain_events(self) -> list[str]:
        """The local events raised since the last call (:data:`LINK_LOST`,
        :data:`LINK_RESTORED`), oldest first."""
        with self._lock:
            out, self._events = self._events, []
            return out

    def drain_log(self) -> list[tuple[str, dict[str, Any]]]:
        """Structured log records since the last call, oldest first: ``(event, fields)``
        — ``vehicle-link`` (the connection broke or reopened, and why),
        ``vehicle-library`` (a line pymavlink printed, kept off the output),
        ``vehicle-ready`` / ``vehicle-waiting`` (readiness changed, and the autopilot's
        reason), ``vehicle-refused`` (a command refused, with the autopilot's words)."""
        with self._lock:
            out, self._log = self._log, []
        out += [("vehicle-library", {"text": line}) for line in drain_library_lines()]
        return out

    def drain_faults(self) -> list[str]:
        """The vehicle commands that failed for good since the last call, oldest first (each
        also in :meth:`drain_errors`): the daemon raises :data:`FAULT` for each, with the
        reason as its data, so that a task script can branch (to a Grounded actor, home)."""
        with self._lock:
            out, self._faults = self._faults, []
            return out

    def drain_errors(self) -> list[str]:
        """What failed since the last call, oldest first; each names the vehicle."""
        with self._lock:
            out, self._errors = self._errors, []
            return out

    def status(self) -> dict[str, Any]:
        """The link, the autopilot's kind, mode and arming, the battery (None: not
        reported), the plan in progress (or waiting for the autopilot to be heard), whether
        it was heard less than 3 s ago (``starting``: a command waits for that), whether
        the autopilot is ready to fly (None: not heard yet), the seconds a take-off (or a
        command asked before it was heard) has been waiting for it (None: none waits), the
        reason it is not ready or a take-off still waits (its own words when it said any), the
        last command it refused, the messages it does not send although asked (``unsent``),
        the failsafe parameters read, and the messages dropped by reason."""
        with self._lock:
            s = self._state
            ready, waiting = self._is_ready(), self._waiting(self._clock())
            return {
                "link": s.link,
                "autopilot": s.kind,
                "airframe": s.airframe if s.kind is not None else None,
                "system": self._filter.system,
                "mode": s.mode,
                "armed": s.armed,
                "battery": s.battery,
                "override": self._override,
                "plan": self._plan_label(),
                "starting": self._first_heard is not None and self._starting(self._clock()),
                "ready": ready,
                "waiting": waiting,
                "reason": self._why() if not ready or waiting is not None else self._sends_no(),
                "refused": self._refused,
                "unsent": self._unsent(),
                "failsafes": dict(s.params),
                "dropped": dict(self._filter.dropped),
            }

    def _plan_label(self) -> str | None:
        """The command in progress, or waiting for the autopilot's first HEARTBEAT."""
        if self._pending is not None:
            return self._pending[0]
        return None if self._plan is None else self._plan.busy

    def override(self, action: Literal["land", "hold"] | None) -> None:
        """The operator's command: ``land`` or ``hold`` now, and ignore the plugins' commands
        until ``override(None)`` gives the vehicle back to them."""
        with self._lock:
            self._override = None
            if action is not None:
                label = f"{action} (operator)"
                if action == "land":
                    self._command(label, lambda f: f.land(self))
                else:
                    self._command(label, lambda f: f.hold(self))
            self._override = action
            self._ignored = False

    def _overridden(self, label: str) -> bool:
        """True (and the first time reported) when the operator holds the vehicle."""
        if self._override is None:
            return False
        if not self._ignored:
            self._ignored = True
            self._errors.append(
                f"vehicle {self.name}: {label} ignored: the operator's {self._override} holds "
                "the vehicle until vehicle_resume"
            )
        return True

    # --- the Vehicle interface -------------------------------------------------------------------

    def position(self) -> tuple[float, float, float]:
        """The latest position; the mission origin ``(0, 0, 0)`` until the autopilot sent
        its first (:attr:`located` says which): the engine reads positions at any time, and
        a read never raises."""
        with self._lock:
            return self._state.position or (0.0, 0.0, 0.0)

    @property
    def located(self) -> bool:
        """Whether the autopilot has sent a position yet."""
        return self._state.position is not None

    def velocity(self) -> tuple[float, float, float]:
        with self._lock:
            return self._state.velocity

    def battery(self) -> float:
        with self._lock:
            # Unknown (an autopilot that does not report it) reads as full, not as empty:
            # an empty reading would send every plugin home at once.
            return 1.0 if self._state.battery is None else self._state.battery

    def home(self) -> tuple[float, float, float]:
        """Where the autopilot's home is, local metres (its first position when it sent no
        HOME_POSITION; the origin before that)."""
        with self._lock:
            return self._state.home or self._state.position or (0.0, 0.0, 0.0)

    def goto(self, x: float, y: float, z: float, *, speed: float | None = None) -> None:
        point = (x, y, z)
        if not all(_is_number(v) for v in point):
            raise ValueError(f"goto: a point is three finite numbers (x, y, z), not {point!r}")
        if speed is not None and not (_is_number(speed) and speed > 0):
            raise ValueError(f"goto: speed must be a positive number (m/s) or None, not {speed!r}")
        goal = self.settings.fence.bound(float(x), float(y), float(z))
        with self._lock:
            if self._overridden("goto"):
                return
            if goal != point:
                self._errors.append(
                    f"vehicle {self.name}: goto ({x:g}, {y:g}, {z:g}) is outside the fence: "
                    f"flying to ({goal[0]:g}, {goal[1]:g}, {goal[2]:g}) instead"
                )
            self._command("goto", lambda f: f.goto(self, goal, speed))

    def hold(self) -> None:
        with self._lock:
            if not self._overridden("hold"):
                self._command("hold", lambda f: f.hold(self))

    def land(self) -> None:
        with self._lock:
            if not self._overridden("land"):
                self._command("land", lambda f: f.land(self))

    def takeoff(self, altitude: float) -> None:
        if not (_is_number(altitude) and altitude > 0):
            raise ValueError(
                f"takeoff: altitude must be a positive number (metres), not {altitude!r}"
            )
        altitude = min(float(altitude), self.settings.fence.z_max)
        with self._lock:
            if not self._overridden("takeoff"):
                self._command("takeoff", lambda f: f.takeoff(self, altitude))

    # --- the flavours' view (Controls) -----------------------------------------------------------

    @property
    def armed(self) -> bool:
        return self._state.armed

    @property
    def airborne(self) -> bool:
        """Armed, and above the ground or climbing after an accepted take-off (a goto in
        the first second of the climb must not ask for a second take-off)."""
        if not self._state.armed:
            return False
        climbing = self._plan is not None and self._plan.completed[-1:] == ["takeoff"]
        return climbing or self._state.height > _AIRBORNE

    @property
    def mode(self) -> str:
        """The mode the plans build on: the one we last asked for while the autopilot has
        not reported it yet (for :data:`_MODE_SETTLE` seconds), else the reported one.

        This is how the latest command wins: a hold asks for AUTO.LOITER, and a goto in the
        same instant must ask for OFFBOARD again although the last HEARTBEAT still says
        OFFBOARD — or the hold, carried out after it, would cancel the new goal."""
        asked = self._mode_asked
        if asked is not None and self._clock() - asked[1] <= _MODE_SETTLE:
            return asked[0]
        return self._state.mode

    def here(self) -> tuple[float, float, float]:
        return self._state.position or (0.0, 0.0, 0.0)

    def height(self) -> float:
        return self._state.height

    def home_altitude(self) -> float:
        s = self._state
        return s.home_amsl if s.home_amsl is not None else self.settings.origin.alt

    def set_target(self, target: Target | None) -> None:
        self._target = target
        self._target_since = self._clock()
        self._target_sent = None
        if target is not None:
            self._stream(self._target_since)  # the first setpoint goes out now

    def ready(self) -> bool | None:
        """True when the autopilot's readiness signals together say it can fly."""
        return True if self._is_ready() else None

    @property
    def arm_timeout(self) -> float:
        return self.settings.arm_timeout

    @property
    def arm_probe(self) -> float:
        return self.settings.arm_probe

    def read_failsafes_again(self) -> None:
        params = self._state.params
        for name in self._failsafe_params():
            params.pop(name, None)
        self._params_asked = None  # asked at the next look

    def failsafes(self) -> bool | str | None:
        kind = self._state.kind
        if kind is None:
            return None
        params = self._state.params
        for name, what in self._failsafe_params().items():
            value = params.get(name)
            if value is None:
                return None
            if value == 0 and name != GCS_ID and not self.settings.force:
                return (
                    f"{name} is 0 ({what} off): refusing to arm; set it on the autopilot, "
                    "or force the take-off"
                )
        watched, ours = params.get(GCS_ID), self.settings.own_system
        if watched is not None and round(watched) != ours and not self.settings.force:
            # ArduPilot's link-loss failsafe counts only the heartbeats of SYSID_MYGCS. One
            # that watches another system: ArduPlane's fires on the ground (RTL, "RTL mode
            # not armable"); ArduCopter's never starts (it waits for that system's first
            # heartbeat), so FS_GCS_ENABLE 1 would guard nothing.
            return (
                f"{GCS_ID} is {watched:g}, not this vehicle's system {ours}: the link-loss "
                f"failsafe watches another ground station; set {GCS_ID} {ours} on the "
                "autopilot, or force the take-off"
            )
        return True

    # --- inside ----------------------------------------------------------------------------------

    def _flavour_of(self, kind: Kind, airframe: Airframe, target: tuple[int, int]) -> Flavour:
        if airframe == "copter":
            return flavour(kind)
        if kind == "px4":
            return Px4FixedWing()
        self._fixed_wing = FixedWing(
            self.settings.origin,
            target,
            f"vehicle {self.name}",
            self._send,
            self._clock,
            self._state.params,
        )
        return ArduPlane(self, self._fixed_wing)

    def _failsafe_params(self) -> dict[str, str]:
        s = self._state
        if s.kind is None:
            return {}
        if s.kind == "ardupilot" and s.airframe == "plane":
            return ARDUPLANE_FAILSAFE_PARAMS
        return FAILSAFE_PARAMS[s.kind]

    def _command(self, label: str, plan: Callable[[Flavour], list[Step]]) -> None:
        now = self._clock()
        if self._starting(now):
            # An autopilot that boots after its daemon is ready late, as one that has not
            # aligned yet is: the command waits for it (the latest one asked replaces an
            # earlier one, as a new plan replaces the one in progress) and is planned once
            # its first HEARTBEAT has said which flavour speaks for it and its start-up is
            # over (_STARTUP). One never heard raises ``vehicle_link_lost`` for the script.
            if self._pending is None or self._pending[0] != label:
                why = (
                    f"{self._why()}: carried out once it is heard"
                    if self._first_heard is None
                    else f"the autopilot is starting: carried out {_STARTUP:g} s after its "
                    "first HEARTBEAT"
                )
                self._log.append(
                    (
                        "vehicle-waiting",
                        {"vehicle": self.name, "reason": f"{label}: {why}", "waiting": None},
                    )
                )
            # Waiting since the first command that waited: a plugin that asks again every
            # step (a moving goal) must not put off the fault at arm_timeout for ever.
            since = now if self._pending is None else self._pending[2]
            self._pending = (label, plan, since)
            return
        self._start(label, plan, now)

    def _starting(self, now: float) -> bool:
        """Whether a command must wait: the autopilot not heard yet, or heard for less than
        :data:`_STARTUP` seconds."""
        heard = self._first_heard  # set with the plan and the flavour
        return heard is None or now - heard < _STARTUP

    def _start_pending(self, now: float) -> None:
        """Plan the command that waited for the autopilot, once its start-up is over."""
        if self._pending is not None and not self._starting(now):
            label, plan, _ = self._pending
            self._pending = None
            self._start(label, plan, now)

    def _give_up_waiting(self, now: float) -> None:
        """A command still waiting for the autopilot's first HEARTBEAT ``arm_timeout``
        after it was asked fails for good, as a take-off that waited as long for an
        autopilot that was heard but never ready does."""
        if (
            self._pending is None
            or self._first_heard is not None  # heard: it waits for the start-up's end
            or now - self._pending[2] < self.settings.arm_timeout
        ):
            return
        label = self._pending[0]
        self._pending = None
        why = (
            f"vehicle {self.name}: {label}: the autopilot was not heard within "
            f"{self.settings.arm_timeout:g} s (no HEARTBEAT on {self.settings.url})"
        )
        self._errors.append(why)
        self._faults.append(why)

    def _start(self, label: str, plan: Callable[[Flavour], list[Step]], now: float) -> None:
        assert self._flavour is not None and self._plan is not None
        steps = plan(self._flavour)
        self._plan.start(label, steps, now)
        failed = self._plan.drain_errors()
        self._errors += failed
        self._faults += failed

    def _send(self, message: Any) -> None:
        if (
            self._state.kind is not None
            and message.get_type() == "COMMAND_LONG"
            and message.command == mav.MAV_CMD_DO_SET_MODE
        ):
            if self._state.kind == "px4":
                custom = px4_custom_mode(int(message.param2), int(message.param3))
            else:
                custom = int(message.param2)
            asked = mode_name(self._state.kind, int(message.param1), custom, self._state.airframe)
            self._mode_asked = (asked, self._clock())
        # A link that is down drops what is sent; the heartbeat watch reports it.
        self._link.send(message)

    def _on_message(self, message: Any, now: float) -> None:
        kind = message.get_type()
        s = self._state
        if self._streams is not None:
            self._streams.heard(message.get_msgId(), now)
        if self._fence is not None:
            for answer in self._fence.on_message(message, now):
                self._send(answer)
        if kind == "HEARTBEAT":
            self._on_heartbeat(message, now)
        elif kind == "GLOBAL_POSITION_INT":
            if message.lat == 0 and message.lon == 0:
                return  # ArduPilot before its EKF has an origin: all zeros, not a place
            self._readiness.position = True
            lat, lon, alt = message.lat / 1e7, message.lon / 1e7, message.alt / 1000.0
            s.position = self.settings.origin.to_local(lat, lon, alt)
            # NED centimetres per second -> ENU metres per second.
            s.velocity = (message.vy / 100.0, message.vx / 100.0, -message.vz / 100.0)
            s.height = message.relative_alt / 1000.0
            if s.home_amsl is None:
                s.home_amsl = alt - s.height
            if self._fixed_wing is not None:
                self._fixed_wing.on_position(s.armed, s.height, s.velocity)
        elif kind in ("EKF_STATUS_REPORT", "GPS_RAW_INT"):
            self._readiness.on_message(kind, message)
        elif kind == "STATUSTEXT":
            text = self._texts.add(message)
            if text is not None:
                self._log.append(
                    (
                        "vehicle-text",
                        {"vehicle": self.name, "severity": message.severity, "text": text},
                    )
                )
        elif kind == "SYS_STATUS":
            self._readiness.on_message(kind, message)
            if message.battery_remaining >= 0:
                s.battery = min(message.battery_remaining, 100) / 100.0
        elif kind == "HOME_POSITION":
            self._readiness.on_message(kind, message)
            lat, lon, alt = message.latitude / 1e7, message.longitude / 1e7, message.altitude / 1e3
            s.home = self.settings.origin.to_local(lat, lon, alt)
            s.home_amsl = alt
        elif kind == "PARAM_VALUE":
            name = message.param_id
            if isinstance(name, bytes):
                name = name.decode("ascii", "replace")
            s.params[name.rstrip("\x00")] = self._param_value(message)
        elif kind == "COMMAND_ACK":
            if (
                message.command == mav.MAV_CMD_COMPONENT_ARM_DISARM
                and message.result == mav.MAV_RESULT_ACCEPTED
            ):
                # We only ever ask to arm: it is armed now, not at the next HEARTBEAT.
                s.armed = True
            if self._plan is not None:
                self._plan.on_ack(message, now)
        if self._fixed_wing is not None:
            self._fixed_wing.on_message(message, now)  # after the parameters above are kept

    def _on_heartbeat(self, message: Any, now: float) -> None:
        s = self._state
        s.heard = now
        if s.link == "lost":
            self._events.append(LINK_RESTORED)
            if self._streams is not None:
                self._streams.restart()  # it may have rebooted and forgotten what we asked
        s.link = "up"
        s.armed = bool(message.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED)
        if s.kind is None:
            chosen = self.settings.kind
            if chosen == "auto":
                # ArduPilot says so; PX4 and other autopilots use PX4's modes.
                ardupilot = message.autopilot == mav.MAV_AUTOPILOT_ARDUPILOTMEGA
                chosen = "ardupilot" if ardupilot else "px4"
            s.kind = chosen
            s.airframe = "plane" if message.type == mav.MAV_TYPE_FIXED_WING else "copter"
            self._beat = None  # our next heartbeat now, of the kind's type (PX4: a GCS's)
            target = (message.get_srcSystem(), message.get_srcComponent())
            self._flavour = self._flavour_of(chosen, s.airframe, target)
            self._plan = CommandSender(
                self.name,
                self._send,
                target,
                retry=self.settings.retry,
                deadline=self.settings.deadline,
                explain=self._why,
                on_refused=self._on_refused,
            )
            self._streams = StreamWatch(chosen, target, grace=self.settings.stream_grace)
            self._first_heard = now
        s.mode = mode_name(s.kind, message.base_mode, message.custom_mode, s.airframe)
        if self._mode_asked is not None and self._mode_asked[0] == s.mode:
            self._mode_asked = None  # carried out

    def _param_value(self, message: Any) -> float:
        """A PARAM_VALUE's value. PX4 (and MAVSDK) carry an integer parameter's bytes in the
        float field; ArduPilot converts it to a float."""
        value = float(message.param_value)
        if self._state.kind == "px4" and message.param_type in _INT_TYPES:
            return float(struct.unpack("<i", struct.pack("<f", value))[0])
        return value

    def _is_ready(self) -> bool | None:
        kind = self._state.kind
        if kind is None:
            return None
        return self._state.armed or not self._readiness.missing(kind, self._unsent())

    def _unsent(self) -> list[str]:
        """The messages the autopilot does not send although asked."""
        return [] if self._streams is None else self._streams.unsent()

    def _why(self) -> str | None:
        """Why the autopilot is not ready or refused: its own latest warning, else what it
        has not said yet (None: nothing to say)."""
        kind = self._state.kind
        if kind is None:
            return f"no HEARTBEAT from the autopilot on {self.settings.url}"
        why = self._texts.latest_warning()
        if why is None:
            missing = self._readiness.missing(kind, self._unsent())
            why = "waiting for " + ", ".join(missing) if missing else None
        sends_no = self._sends_no()
        if sends_no is not None:
            why = sends_no if why is None else f"{why} ({sends_no})"
        return why

    def _sends_no(self) -> str | None:
        """``the autopilot sends no EKF_STATUS_REPORT though asked`` (None: it sends all)."""
        unsent = self._unsent()
        return f"the autopilot sends no {', '.join(unsent)} though asked" if unsent else None

    def _waiting(self, now: float) -> float | None:
        """Seconds the plan in progress has been waiting for the autopilot to be ready or
        to accept arming, or for its first HEARTBEAT (None: it is not waiting for that)."""
        if self._pending is not None:
            return round(now - self._pending[2], 1)
        plan = self._plan
        step = None if plan is None else plan.step
        began = None if plan is None else plan.began
        waits = (isinstance(step, Check) and step.from_plan) or (
            isinstance(step, Command) and step.persist
        )
        return round(now - began, 1) if waits and began is not None else None

    def _on_refused(self, name: str, result: int) -> None:
        self._refused = f"{name}: {result_name(result)}"
        # Logged once the whole batch is read: the autopilot's texts saying why follow its
        # COMMAND_ACK (ArduCopter's ``Arm: …``), and the record should carry them.
        self._refusals.append((name, result_name(result)))

    def _log_refusals(self) -> None:
        for name, result in self._refusals:
            self._log.append(
                (
                    "vehicle-refused",
                    {
                        "vehicle": self.name,
                        "command": name,
                        "result": result,
                        "reason": self._why(),
                    },
                )
            )
        self._refusals.clear()

    def _watch_readiness(self, now: float) -> None:
        """Log when the autopilot becomes ready, or its reason for not being so changes."""
        if self._state.kind is None:
            return
        ready = bool(self._is_ready())
        if ready and self._state.armed:
            self._texts.clear()  # old refusals are no reason any more
        said = (ready, None if ready else self._why())
        if said == self._said:
            return
        self._said = said
        if ready:
            self._refused = None
            self._log.append(("vehicle-ready", {"vehicle": self.name}))
        else:
            waiting = self._waiting(now)
            self._log.append(
                ("vehicle-waiting", {"vehicle": self.name, "reason": said[1], "waiting": waiting})
            )

    def _stream_changes(self) -> None:
        streams = self._streams
        if streams is None or not streams.changes:
            return
        for name, what in streams.changes:
            text = "not sent though asked" if what == "unsent" else "arrived"
            self._log.append(
                ("vehicle-stream", {"vehicle": self.name, "message": name, "what": text})
            )
        streams.changes.clear()

    def _note_version(self, message: Any) -> None:
        """Speak MAVLink 1 to an autopilot heard speaking it (a link that carries MAVLink 1
        only would drop our MAVLink 2 frames), and 2 again once it does."""
        one = is_mavlink1(message)
        if one != self._link.mavlink1:
            self._link.mavlink1 = one
            self._log.append(
                (
                    "vehicle-link",
                    {
                        "vehicle": self.name,
                        "what": "MAVLink 1" if one else "MAVLink 2",
                        "why": "the autopilot speaks it: answering in it",
                    },
                )
            )

    def _link_changes(self) -> None:
        link = self._link
        for what, why in link.changes:
            self._log.append(("vehicle-link", {"vehicle": self.name, "what": what, "why": why}))
        link.changes.clear()

    def _watch_link(self, now: float) -> None:
        s = self._state
        since = s.heard if s.heard is not None else self._started
        if s.link != "lost" and now - since > self.settings.link_timeout:
            self._events.append(LINK_LOST)
            who = "system " + str(self._filter.system) if self._filter.system else "an autopilot"
            others = sorted(self._filter.others - {self._filter.system})
            heard = (
                f" (heard system {', '.join(map(str, others))} instead: a wrong --mavlink-sysid?)"
                if others
                else ""
            )
            self._errors.append(
                f"vehicle {self.name}: no HEARTBEAT from {who} on {self.settings.url} "
                f"for {self.settings.link_timeout:g} s: link lost{heard}"
            )
            s.link = "lost"
            # An autopilot that comes back may have rebooted: its readiness starts over.
            self._readiness = Readiness()

    def _ask_params(self, now: float) -> None:
        kind = self._state.kind
        if kind is None or (self._params_asked is not None and now - self._params_asked < _BEAT):
            return
        wanted = [*self._failsafe_params(), *(ENVELOPE if self._fixed_wing is not None else ())]
        missing = [name for name in wanted if name not in self._state.params]
        if not missing:
            return
        self._params_asked = now
        system, component = self._filter.system or 0, self.settings.component
        for name in missing:
            self._send(mav.MAVLink_param_request_read_message(system, component, name.encode(), -1))

    def _stream(self, now: float) -> None:
        target = self._target
        if self._fixed_wing is not None:
            self._fixed_wing.service(target, self._state.mode, now)
            return
        if target is None or (
            self._target_sent is not None and now - self._target_sent < 1.0 / target.rate
        ):
            return
        self._target_sent = now
        goal = target.goal
        if target.speed is not None:
            # Move the setpoint along the line at the speed asked for.
            delta = [g - s for g, s in zip(goal, target.start, strict=True)]
            dist = math.sqrt(sum(d * d for d in delta))
            run = target.speed * (now - self._target_since)
            if dist > run:
                f = run / dist
                sx, sy, sz = target.start
                goal = (sx + delta[0] * f, sy + delta[1] * f, sz + delta[2] * f)
        lat, lon, alt = self.settings.origin.to_geodetic(*goal)
        system, component = self._filter.system or 0, self.settings.component
        self._send(
            mav.MAVLink_set_position_target_global_int_message(
                int((now - self._started) * 1000) & 0xFFFFFFFF,
                system,
                component,
                mav.MAV_FRAME_GLOBAL_INT,
                _POSITION_ONLY,
                round(lat * 1e7),
                round(lon * 1e7),
                alt,
                0,
                0,
                0,
                0,
                0,
                0,
                0,
                0,
            )
        )


def _is_number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
