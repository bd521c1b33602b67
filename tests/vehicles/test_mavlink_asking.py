"""Ask for what you read; readiness is advice, the autopilot decides. MavlinkVehicle against
the simulated autopilot showing the faults a real link can have: a message never sent
though asked, ``SET_MESSAGE_INTERVAL`` ignored, a reboot that forgets what was asked, a link
that carries MAVLink 1 only. In real time over UDP loopback, with a short stream grace and
arm probe so that each takes seconds, not a minute."""

from __future__ import annotations

import time

from tests.vehicles.helpers import wait_for, wait_started
from tests.vehicles.test_mavlink_flight import fly

from actorswarm.vehicles.mavlink.dialect import mav
from actorswarm.vehicles.mavlink.streams import SILENT_INTERVALS, WANTED, StreamWatch

#: Quick asking: a message is asked again 0.4 s after it did not come; arming is asked
#: every second while the readiness signals say "not yet".
QUICK = {"stream_grace": 0.4, "arm_probe": 1.0}


def test_the_vehicle_asks_ardupilot_for_every_message_it_reads() -> None:
    with fly("ardupilot") as (vehicle, sim):
        wait_for("the autopilot ready", lambda: vehicle.status()["ready"] is True, 6.0)
        wanted = {w.message for w in WANTED["ardupilot"]}
        assert wanted <= set(sim.streams.intervals), "a message the vehicle reads is not asked"
        assert sim.streams.intervals[mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT] == 0.1
        assert vehicle.status()["unsent"] == []


def test_a_message_never_sent_is_named_and_does_not_hold_arming_back() -> None:
    withheld = frozenset({mav.MAVLINK_MSG_ID_EKF_STATUS_REPORT})
    with fly("ardupilot", settings=QUICK, withheld=withheld) as (vehicle, sim):
        wait_for("the autopilot heard", lambda: vehicle.status()["autopilot"] is not None, 3.0)
        wait_for(
            "EKF_STATUS_REPORT named",
            lambda: vehicle.status()["unsent"] == ["EKF_STATUS_REPORT"],
            6.0,
        )
        assert "the autopilot sends no EKF_STATUS_REPORT though asked" in str(
            vehicle.status()["reason"]
        )
        wait_started(vehicle)
        vehicle.takeoff(2.0)
        wait_for("the climb", lambda: vehicle.position()[2] > 1.8, 10.0)  # the autopilot said yes
        assert sim.armed
        log = vehicle.drain_log()
        assert (
            "vehicle-stream",
            {
                "vehicle": "platform 1",
                "message": "EKF_STATUS_REPORT",
                "what": "not sent though asked",
            },
        ) in log


def test_an_autopilot_that_ignores_the_interval_command_is_asked_the_legacy_way() -> None:
    with fly("ardupilot", settings=QUICK, interval_ignored=True) as (vehicle, sim):
        wait_for("the autopilot ready", lambda: vehicle.status()["ready"] is True, 8.0)
        assert vehicle.status()["unsent"] == []
        # REQUEST_DATA_STREAM: POSITION at 10 Hz, EXTENDED_STATUS and EXTRA3 at 1 Hz.
        assert sim.streams.intervals[mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT] == 0.1
        assert sim.streams.intervals[mav.MAVLINK_MSG_ID_EKF_STATUS_REPORT] == 1.0
        wait_started(vehicle)
        vehicle.takeoff(2.0)
        wait_for("the climb", lambda: vehicle.position()[2] > 1.8, 8.0)


def test_a_reboot_that_forgets_the_rates_is_asked_again() -> None:
    with fly("ardupilot", settings=QUICK) as (vehicle, sim):
        wait_for("the autopilot ready", lambda: vehicle.status()["ready"] is True, 6.0)
        sim.reboot(time.monotonic())  # the link stays up: only the streams stop
        assert mav.MAVLINK_MSG_ID_SYS_STATUS not in sim.streams.intervals
        # A message counts as stopped once silent for five of its intervals (SYS_STATUS:
        # 1 s, so 4-5 s after the reboot), and is asked again at the vehicle's next tick:
        # 5 s left no room for a loaded machine (a CI run missed it once).
        interval = next(
            w.interval for w in WANTED["ardupilot"] if w.message == mav.MAVLINK_MSG_ID_SYS_STATUS
        )
        silent = SILENT_INTERVALS * interval
        wait_for(
            "the streams asked again",
            lambda: mav.MAVLINK_MSG_ID_SYS_STATUS in sim.streams.intervals,
            silent + 3.0,
        )
        assert vehicle.status()["unsent"] == []


def test_a_mavlink1_link_is_answered_in_mavlink1_and_flies() -> None:
    with fly("ardupilot", settings=QUICK, mavlink1=True) as (vehicle, _sim):
        wait_for("the autopilot ready", lambda: vehicle.status()["ready"] is True, 8.0)
        wait_started(vehicle)
        vehicle.takeoff(2.0)
        wait_for("the climb", lambda: vehicle.position()[2] > 1.8, 8.0)
        log = vehicle.drain_log()
        assert any(
            event == "vehicle-link" and fields["what"] == "MAVLink 1" for event, fields in log
        )


def test_an_autopilot_that_never_answers_the_asks_still_gets_asked_to_arm_until_the_deadline() -> (
    None
):
    """Nothing it reads ever comes (everything withheld), and it never becomes ready: the
    take-off still asks to arm now and then, names what is missing, and fails at
    ``arm_timeout`` — not before, not never."""
    withheld = frozenset(w.message for w in WANTED["ardupilot"])
    with fly("ardupilot", arm_timeout=4.0, settings=QUICK, withheld=withheld, ready_after=60.0) as (
        vehicle,
        sim,
    ):
        wait_started(vehicle)
        vehicle.takeoff(2.0)
        began = time.monotonic()
        errors: list[str] = []

        def failed() -> bool:
            errors.extend(vehicle.drain_errors())
            return bool(errors)

        wait_for("the failure", failed, 8.0)
        assert 3.5 <= time.monotonic() - began <= 6.0
        assert len(errors) == 1 and "MAV_CMD_COMPONENT_ARM_DISARM: not done within 4 s" in errors[0]
        assert "the autopilot sends no GLOBAL_POSITION_INT" in errors[0]
        refused = [e for e, _ in vehicle.drain_log() if e == "vehicle-refused"]
        assert len(refused) >= 2, "asked to arm only once"
        assert not sim.armed


def test_the_watch_asks_again_with_back_off_and_the_legacy_way_on_ardupilot() -> None:
    watch = StreamWatch("ardupilot", (1, 1), grace=3.0)
    first = watch.tick(0.0)
    asked = {int(m.param1) for m in first if m.get_type() == "COMMAND_LONG"}
    assert asked == {w.message for w in WANTED["ardupilot"]}
    assert not [m for m in first if m.get_type() == "REQUEST_DATA_STREAM"]

    def at(t: float) -> list[object]:
        watch.heard(mav.MAVLINK_MSG_ID_SYS_STATUS, t - 0.5)  # SYS_STATUS comes at 1 Hz
        return watch.tick(t)

    assert at(1.0) == [] and at(2.0) == [] and at(2.9) == []
    again = at(3.0)  # everything but SYS_STATUS, once more, and the legacy streams
    names = sorted(m.get_type() for m in again)  # type: ignore[attr-defined]
    assert names == ["COMMAND_LONG"] * 4 + ["REQUEST_DATA_STREAM"] * 3
    assert all(at(t) == [] for t in (4.0, 5.0, 6.0, 7.0, 8.0, 8.9))
    assert len(at(9.0)) == 7  # then after 6 s
    assert watch.unsent() == [
        "GLOBAL_POSITION_INT",
        "GPS_RAW_INT",
        "EKF_STATUS_REPORT",
    ]  # HOME_POSITION: conditional, "not yet"
    assert "SYS_STATUS" not in watch.unsent()
    watch.heard(mav.MAVLINK_MSG_ID_GPS_RAW_INT, 9.5)
    assert "GPS_RAW_INT" not in watch.unsent()
    assert ("GPS_RAW_INT", "arrived") in watch.changes
