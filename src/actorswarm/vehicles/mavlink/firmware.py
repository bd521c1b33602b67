"""What each real autopilot sends on a link, measured, for the simulated one to replay.

A stand-in is worth only what it matches of the real thing: these tables are the firmware's
behaviour as measured on a fresh boot of ArduCopter 4.5.7 SITL (its first serial port,
``tcp:…:5760``) and PX4 v1.15.4 SITL (SIH, the onboard link ``udpin:…:14540``), with a
client that asked for nothing (docs/vehicles.md, "What each autopilot sends"). The
conformance test (``tests/vehicles/test_autopilot_conformance.py``) pins the simulated
autopilot to the same figures, written there a second time, so that neither can drift back
to agreeing with the daemon instead of with the firmware.

ArduPilot (ArduCopter)
    Unasked, only ``HEARTBEAT`` (1 Hz) and ``TIMESYNC`` (a few in 25 s), and once the EKF has
    an origin one ``HOME_POSITION`` and one ``GPS_GLOBAL_ORIGIN``. ``STATUSTEXT`` goes only to
    a link that has sent something (ArduPilot's "active" channel). Everything else comes once
    the link asks: ``MAV_CMD_SET_MESSAGE_INTERVAL`` per message (ACKed ``ACCEPTED``, sent at
    the rate asked from then on) or the legacy ``REQUEST_DATA_STREAM`` per group of messages
    (:data:`ARDUPILOT_DATA_STREAMS`, no ACK). Streams are per link, and forgotten at a reboot.
ArduPlane
    Its ``SR0_*`` defaults are 1 Hz, so unlike ArduCopter it streams unasked
    (:data:`ARDUPLANE_UNASKED`, from 1.9 s after its clock starts; ``EKF_STATUS_REPORT``
    from 3 s; one ``HOME_POSITION`` at 10 s, one ``GPS_GLOBAL_ORIGIN`` at 21.7 s: the
    simulated autopilot's boot, :mod:`~.boot`, holds those times). ``REQUEST_DATA_STREAM``
    rewrites the rates of :data:`ARDUPLANE_DATA_STREAMS`' groups (no ACK); a
    ``SET_MESSAGE_INTERVAL`` that comes before its first ``HEARTBEAT`` is ACKed and never
    applied.
PX4 (onboard mode)
    Its default onboard set streams unasked at the rates of :data:`PX4_ONBOARD` (messages
    per second over the first 20 s), ``GLOBAL_POSITION_INT`` only once the estimator has a
    position; ``SET_MESSAGE_INTERVAL`` changes a rate. ``STATUSTEXT`` only to a link that sent
    a GCS-type ``HEARTBEAT``.

Pure data: nothing here sends or reads anything.
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Final

from actorswarm.vehicles.mavlink.dialect import mav

__all__ = [
    "ARDUCOPTER_UNASKED",
    "ARDUPILOT_DATA_STREAMS",
    "ARDUPLANE_DATA_STREAMS",
    "ARDUPLANE_UNASKED",
    "PX4_ONBOARD",
    "PX4_ONBOARD_NOT_IN_DIALECT",
    "PX4_POSITION_RATE",
]

#: ArduCopter's first serial port, asking for nothing: message -> messages per second
#: (None: sent once, when the EKF has its origin).
ARDUCOPTER_UNASKED: Final = MappingProxyType(
    {
        mav.MAVLINK_MSG_ID_HEARTBEAT: 1.0,
        mav.MAVLINK_MSG_ID_TIMESYNC: 0.1,  # 2 in the first 25 s
        mav.MAVLINK_MSG_ID_HOME_POSITION: None,
        mav.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN: None,
    }
)

#: ArduCopter's legacy streams (``REQUEST_DATA_STREAM``'s ``req_stream_id``) -> the messages
#: of each that the vehicle reads (ArduCopter's ``GCS_Mavlink.cpp``: EXTENDED_STATUS carries
#: SYS_STATUS and GPS_RAW_INT among others, POSITION GLOBAL_POSITION_INT and
#: LOCAL_POSITION_NED, EXTRA3 EKF_STATUS_REPORT among others). ``HOME_POSITION`` is in none.
ARDUPILOT_DATA_STREAMS: Final = MappingProxyType(
    {
        mav.MAV_DATA_STREAM_EXTENDED_STATUS: (
            mav.MAVLINK_MSG_ID_SYS_STATUS,
            mav.MAVLINK_MSG_ID_GPS_RAW_INT,
        ),
        mav.MAV_DATA_STREAM_POSITION: (mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT,),
        mav.MAV_DATA_STREAM_EXTRA3: (mav.MAVLINK_MSG_ID_EKF_STATUS_REPORT,),
    }
)

#: ArduPlane 4.5.7's first serial port (``plane.parm``), asking for nothing: message ->
#: messages per second (None: sent once). Measured: these at 1 Hz, and more of the
#: ``SR0_*`` groups that the simulated autopilot does not send.
ARDUPLANE_UNASKED: Final = MappingProxyType(
    {
        mav.MAVLINK_MSG_ID_HEARTBEAT: 1.0,
        mav.MAVLINK_MSG_ID_ATTITUDE: 1.0,
        mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 1.0,
        mav.MAVLINK_MSG_ID_VFR_HUD: 1.0,
        mav.MAVLINK_MSG_ID_SYS_STATUS: 1.0,
        mav.MAVLINK_MSG_ID_GPS_RAW_INT: 1.0,
        mav.MAVLINK_MSG_ID_EKF_STATUS_REPORT: 1.0,
        mav.MAVLINK_MSG_ID_HOME_POSITION: None,
        mav.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN: None,
    }
)

#: ArduPlane's legacy streams -> the messages of each that the simulated one sends (the
#: copter's, and ATTITUDE in EXTRA1, VFR_HUD in EXTRA2, as ``GCS_Mavlink.cpp`` groups them).
ARDUPLANE_DATA_STREAMS: Final = MappingProxyType(
    {
        **ARDUPILOT_DATA_STREAMS,
        mav.MAV_DATA_STREAM_EXTRA1: (mav.MAVLINK_MSG_ID_ATTITUDE,),
        mav.MAV_DATA_STREAM_EXTRA2: (mav.MAVLINK_MSG_ID_VFR_HUD,),
    }
)

#: PX4's onboard link, asking for nothing: message -> messages per second, as measured.
PX4_ONBOARD: Final = MappingProxyType(
    {
        mav.MAVLINK_MSG_ID_HIGHRES_IMU: 49.7,
        mav.MAVLINK_MSG_ID_ODOMETRY: 29.8,
        mav.MAVLINK_MSG_ID_LOCAL_POSITION_NED: 29.8,
        mav.MAVLINK_MSG_ID_TIMESYNC: 9.9,
        mav.MAVLINK_MSG_ID_ALTITUDE: 9.9,
        mav.MAVLINK_MSG_ID_ATTITUDE_TARGET: 9.9,
        mav.MAVLINK_MSG_ID_DISTANCE_SENSOR: 9.9,
        mav.MAVLINK_MSG_ID_POSITION_TARGET_LOCAL_NED: 9.9,
        mav.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW: 9.9,
        mav.MAVLINK_MSG_ID_VFR_HUD: 9.9,
        mav.MAVLINK_MSG_ID_GPS_RAW_INT: 8.0,
        mav.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: 5.0,
        mav.MAVLINK_MSG_ID_SYS_STATUS: 5.0,
        mav.MAVLINK_MSG_ID_ESTIMATOR_STATUS: 1.0,
        mav.MAVLINK_MSG_ID_SCALED_PRESSURE: 1.0,
        mav.MAVLINK_MSG_ID_SYSTEM_TIME: 1.0,
        mav.MAVLINK_MSG_ID_PING: 1.0,
        mav.MAVLINK_MSG_ID_OPEN_DRONE_ID_LOCATION: 1.0,
        mav.MAVLINK_MSG_ID_OPEN_DRONE_ID_SYSTEM: 1.0,
        mav.MAVLINK_MSG_ID_HEARTBEAT: 0.9,
        mav.MAVLINK_MSG_ID_MISSION_CURRENT: 0.9,
        mav.MAVLINK_MSG_ID_BATTERY_STATUS: 0.5,
        mav.MAVLINK_MSG_ID_HOME_POSITION: 0.5,
        mav.MAVLINK_MSG_ID_VIBRATION: 0.5,
    }
)

#: The onboard link's ``GLOBAL_POSITION_INT`` once the estimator has a position, per second
#: (PX4 1.15's onboard stream configuration; none at all before).
PX4_POSITION_RATE: Final = 50.0

#: Messages PX4's onboard link also sends that pymavlink's ArduPilot dialect cannot encode
#: (``CURRENT_MODE`` 0.5/s, ``LINK_NODE_STATUS``, ``TIME_ESTIMATE_TO_TARGET``,
#: ``CURRENT_EVENT_SEQUENCE``): the simulated autopilot leaves them out; a real PX4's reach
#: the vehicle as unknown messages, which it counts and drops.
PX4_ONBOARD_NOT_IN_DIALECT: Final = (436, 8, 380, 411)
