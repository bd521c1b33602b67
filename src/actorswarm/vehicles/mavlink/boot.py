"""How a real autopilot boots, as the simulated one replays it: what it says and when it
will fly, by the seconds since its clock started.

Measured on ArduCopter 4.5.7 SITL and PX4 v1.15.4 SITL (SIH quadrotor), both from source
(docs/vehicles.md, "In the field"). Times scale with ``ready_after``, the second from which
arming is accepted (ArduPilot about 40 s, PX4 about 35 s by default):

ArduPilot
    The first ``HEARTBEAT`` at 2.4 % of ``ready_after``, in STABILIZE, where a mode asked is
    accepted and then lost at ``ArduPilot Ready`` (5.5 %), which starts it in STABILIZE
    again; the EKF's attitude at 9 % of ``ready_after``; a GPS, then
    its 3D fix at 19 % and 30 %; the EKF origin (and home) at 44 %: ``GLOBAL_POSITION_INT``
    is all zeros before it; the pre-arm bit of ``SYS_STATUS`` healthy from 58 % although
    arming is still refused; ``EKF3 IMU0 is using GPS`` (absolute horizontal position,
    constant-position mode off) at 98 %; arming accepted from 100 %. A refused arm is
    answered ``MAV_RESULT_FAILED`` with ``Arm:`` texts; ``PreArm:`` texts repeat while not
    ready.
ArduPlane (``frame="plane"``, measured on ArduPlane 4.5.7 SITL with ``plane.parm``)
    About 22 s to arming; as measured, in seconds of that (from the link's connection, which
    SITL waits for): the first ``HEARTBEAT`` at 0.9 s, in mode INITIALISING, which takes a
    ``DO_SET_MODE`` (ACCEPTED, and shown) that is lost at ``ArduPilot Ready``, 1.6 s, when
    the mode becomes MANUAL whatever was asked (before Ready, a ``SET_MESSAGE_INTERVAL`` is
    ACKed and never applied, a mission refused); its 1 Hz
    streams from 1.9 s, ``EKF_STATUS_REPORT`` from 3 s; home, a 3D fix and a real
    ``GLOBAL_POSITION_INT`` at 10 s; ``EKF3 IMU0 is using GPS`` at 20.3 s; the EKF origin
    (``GPS_GLOBAL_ORIGIN``) at 21.7 s. A refused arm is answered ``MAV_RESULT_FAILED`` with
    ``Arm: Accels inconsistent``, ``Arm: Compass not healthy``, ``Arm: AHRS: waiting for
    home`` (until home), ``Arm: Airspeed 1 not healthy`` and, until Ready, ``Arm:
    INITIALISING mode not armable``; from 12 s ``Arm: Gyros inconsistent`` alone (measured
    12–18 s; held until ready, the last reason seen). No ``PreArm:`` nagging is modelled.
PX4
    ``HOME_POSITION`` from 5 %; every arm ``MAV_RESULT_TEMPORARILY_REJECTED`` with
    ``Arming denied: Resolve system health failures first`` (51 characters: two chunks) and
    ``Preflight Fail: ...`` texts; no ``GLOBAL_POSITION_INT`` at all, and the pre-arm bit
    unhealthy, until 100 %.

Pure: :meth:`Boot.at` answers for any time given; nothing here reads a clock.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final, Literal

from actorswarm.vehicles.mavlink.dialect import mav

__all__ = ["ARDUPLANE_READY_AFTER", "DEFAULT_READY_AFTER", "Boot", "BootState", "chunks"]

#: Seconds from the start of its clock until each autopilot accepts arming, as measured.
DEFAULT_READY_AFTER: Final[dict[str, float]] = {"ardupilot": 40.0, "px4": 35.0}
#: ... ArduPlane 4.5.7 (first accepted at 21.3 s, on another boot 23.4 s).
ARDUPLANE_READY_AFTER: Final = 22.0
#: STATUSTEXT's text field, characters.
_TEXT: Final = 50

#: ArduPilot's boot: (fraction of ready_after, what it says then).
#: ArduCopter 4.5.7 SITL's start (measured from the link's connection, as ArduPlane's): its
#: first HEARTBEAT at 0.96 s, in STABILIZE, taking a mode (ACCEPTED, shown) that it forgets
#: at "ArduPilot Ready", 2.19 s, when it is in STABILIZE again; fractions of 40 s.
_COPTER_FIRST_HEARTBEAT: Final = 0.024
_COPTER_READY: Final = 0.055
_ARDUPILOT_TEXTS: Final = (
    (_COPTER_READY, "ArduPilot Ready"),
    (0.05, "EKF3 IMU0 initialised"),
    (0.09, "EKF3 IMU0 tilt alignment complete"),
    (0.19, "GPS 1: detected as u-blox at 230400 baud"),
    (0.44, "EKF3 IMU0 origin set"),
    (0.98, "EKF3 IMU0 is using GPS"),
)
_PX4_TEXTS: Final = ((0.0, "PX4 SITL boot"),)
#: ArduPlane's boot, in seconds of its measured 22 s (scaled with ready_after).
_PLANE_FIRST_HEARTBEAT: Final = 0.9
_PLANE_READY: Final = 1.6
_PLANE_STREAMS: Final = 1.9
_PLANE_EKF: Final = 3.0
_PLANE_HOME: Final = 10.0
_PLANE_GYROS: Final = 12.0
_PLANE_USING_GPS: Final = 20.3
_PLANE_ORIGIN: Final = 21.7
_PLANE_TEXTS: Final = (
    (_PLANE_READY / ARDUPLANE_READY_AFTER, "ArduPilot Ready"),
    (_PLANE_EKF / ARDUPLANE_READY_AFTER, "EKF3 IMU0 initialised"),
    (_PLANE_USING_GPS / ARDUPLANE_READY_AFTER, "EKF3 IMU0 is using GPS"),
)
_PX4_DENIED: Final = "Arming denied: Resolve system health failures first\t"


def chunks(text: str, ident: int) -> list[tuple[str, int, int]]:
    """PX4's split of a text over 50 characters: ``(piece, id, chunk_seq)`` each (id 0 and
    one piece when it fits). A trailing tab marks a text also sent as an event, as PX4
    does."""
    if len(text) <= _TEXT:
        return [(text, 0, 0)]
    return [(text[i : i + _TEXT], ident, n) for n, i in enumerate(range(0, len(text), _TEXT))]


@dataclass(frozen=True, slots=True)
class BootState:
    """What the autopilot can do and reports ``t`` seconds after its clock started."""

    armable: bool
    #: Refusal texts for an arm asked now (empty when ``armable``).
    refusal: tuple[str, ...]
    #: The MAV_RESULT of a refused arm.
    refused_with: int
    #: ``SYS_STATUS``: the pre-arm check reported healthy.
    prearm_ok: bool
    #: ``GLOBAL_POSITION_INT``: "zeros" (ArduPilot before its origin), "none" (PX4 before
    #: its estimator has a position) or "real".
    position: Literal["zeros", "none", "real"]
    home: bool
    gps_fix: int
    #: ``EKF_STATUS_REPORT`` flags (ArduPilot; 0 for PX4, which does not send it).
    ekf_flags: int
    #: The texts repeated while not ready (ArduPilot's ``PreArm:``, PX4's ``Preflight Fail``).
    nag: str | None
    #: ``GPS_GLOBAL_ORIGIN`` may go (ArduPilot: once, when its EKF has an origin).
    origin: bool = False
    #: The start-up steps (PX4 has them all from the start): HEARTBEAT sent (ArduPlane in
    #: mode INITIALISING); "ArduPilot Ready": its mode set to MANUAL (ArduCopter:
    #: STABILIZE) whatever was asked, and, on ArduPlane, SET_MESSAGE_INTERVAL applied and a
    #: mission taken; ArduPlane's streams going; its EKF_STATUS_REPORT going.
    beating: bool = True
    link_ready: bool = True
    streaming: bool = True
    ekf_streaming: bool = True


class Boot:
    """The boot of a ``kind`` autopilot that accepts arming from ``ready_after`` s."""

    def __init__(
        self,
        kind: Literal["ardupilot", "px4"],
        ready_after: float,
        frame: Literal["copter", "plane"] = "copter",
    ) -> None:
        if not ready_after >= 0:
            raise ValueError(f"ready_after must be >= 0 s, not {ready_after!r}")
        if frame == "plane" and kind != "ardupilot":
            raise ValueError(f"the boot of a {kind} plane is not modelled yet")
        self.kind = kind
        self.ready_after = ready_after
        self.frame = frame

    def texts(self, t0: float, t1: float) -> list[str]:
        """The boot messages said in ``(t0, t1]`` (the first one at ``t0 == t1 == 0``)."""
        table = (
            _PLANE_TEXTS
            if self.frame == "plane"
            else _ARDUPILOT_TEXTS
            if self.kind == "ardupilot"
            else _PX4_TEXTS
        )
        r = self.ready_after
        return [text for f, text in table if (t0 < f * r <= t1) or (f * r == t1 == t0 == 0)]

    def at(self, t: float) -> BootState:
        if self.frame == "plane":
            return self._plane(t)
        r = self.ready_after
        armable = t >= r
        if self.kind == "px4":
            return BootState(
                armable=armable,
                refusal=() if armable else (_PX4_DENIED,),
                refused_with=mav.MAV_RESULT_TEMPORARILY_REJECTED,
                prearm_ok=armable,
                position="real" if armable else "none",
                home=t >= 0.05 * r,
                gps_fix=3 if t >= 0.3 * r else 1,
                ekf_flags=0,
                nag=None if armable else "Preflight Fail: horizontal velocity unstable\t",
            )
        origin = t >= 0.44 * r
        using_gps = t >= 0.98 * r
        flags = 0
        if t >= 0.09 * r:
            flags |= mav.EKF_ATTITUDE
        if origin:
            flags |= (
                mav.EKF_VELOCITY_HORIZ
                | mav.EKF_VELOCITY_VERT
                | mav.EKF_POS_VERT_ABS
                | mav.EKF_POS_VERT_AGL
            )
        if using_gps:
            flags |= mav.EKF_POS_HORIZ_REL | mav.EKF_POS_HORIZ_ABS | mav.EKF_PRED_POS_HORIZ_ABS
        elif flags:
            flags |= mav.EKF_CONST_POS_MODE
        if armable:
            refusal: tuple[str, ...] = ()
        elif t < 0.09 * r:
            refusal = ("Arm: Accels inconsistent", "Arm: AHRS: waiting for home")
        elif not origin:
            refusal = ("Arm: AHRS: waiting for home",)
        else:
            refusal = ("Arm: Need Position Estimate",)
        return BootState(
            armable=armable,
            refusal=refusal,
            refused_with=mav.MAV_RESULT_FAILED,
            prearm_ok=t >= 0.58 * r,
            position="real" if origin else "zeros",
            home=origin,
            gps_fix=3 if t >= 0.3 * r else (1 if t >= 0.19 * r else 0),
            ekf_flags=flags,
            nag=None
            if armable
            else ("PreArm: Need Position Estimate" if origin else "PreArm: AHRS: waiting for home"),
            origin=origin,
            beating=t >= _COPTER_FIRST_HEARTBEAT * r,
            link_ready=t >= _COPTER_READY * r,
        )

    def _plane(self, t: float) -> BootState:
        """ArduPlane's boot (module docstring), its measured seconds scaled to ready_after."""
        scale = self.ready_after / ARDUPLANE_READY_AFTER

        def since(seconds: float) -> bool:
            return t >= seconds * scale

        armable = t >= self.ready_after
        home = since(_PLANE_HOME)
        using_gps = since(_PLANE_USING_GPS)
        flags = 0
        if since(_PLANE_EKF):
            flags = mav.EKF_ATTITUDE | mav.EKF_VELOCITY_HORIZ | mav.EKF_VELOCITY_VERT
            flags |= mav.EKF_POS_VERT_ABS | mav.EKF_POS_VERT_AGL
            if using_gps:
                flags |= mav.EKF_POS_HORIZ_REL | mav.EKF_POS_HORIZ_ABS | mav.EKF_PRED_POS_HORIZ_ABS
            else:
                flags |= mav.EKF_CONST_POS_MODE
        refusal: tuple[str, ...]
        if armable:
            refusal = ()
        elif since(_PLANE_GYROS):
            refusal = ("Arm: Gyros inconsistent",)
        else:
            refusal = ("Arm: Accels inconsistent", "Arm: Compass not healthy")
            if not home:
                refusal += ("Arm: AHRS: waiting for home",)
            refusal += ("Arm: Airspeed 1 not healthy",)
            if not since(_PLANE_READY):
                refusal += ("Arm: INITIALISING mode not armable",)
        return BootState(
            armable=armable,
            refusal=refusal,
            refused_with=mav.MAV_RESULT_FAILED,
            prearm_ok=armable,
            position="real" if home else "zeros",
            home=home,
            gps_fix=3 if home else 0,
            ekf_flags=flags,
            nag=None,
            origin=since(_PLANE_ORIGIN),
            beating=since(_PLANE_FIRST_HEARTBEAT),
            link_ready=since(_PLANE_READY),
            streaming=since(_PLANE_STREAMS),
            ekf_streaming=since(_PLANE_EKF),
        )
