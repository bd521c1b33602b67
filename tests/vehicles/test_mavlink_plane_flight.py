"""End to end over UDP loopback: MavlinkVehicle flies the simulated ArduPlane (its measured
take-off, DO_REPOSITION circles, airspeed, landing sequence) — take-off, a goal, a moving
goal, hold, landing and a second take-off. Both run on the test's clock, stepped 20 ms at a
time, so three minutes of flight take seconds."""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Iterator
from typing import Any

from tests.vehicles.helpers import free_port

from actorswarm.vehicles.mavlink.autopilot import AutopilotOptions, SimAutopilot
from actorswarm.vehicles.mavlink.boot import ARDUPLANE_READY_AFTER
from actorswarm.vehicles.mavlink.frame import MissionFrame
from actorswarm.vehicles.mavlink.vehicle import MavlinkSettings, MavlinkVehicle

ORIGIN = MissionFrame(47.397742, 8.545594, 488.0)
#: The aircraft stands 30 m north of the mission origin, facing east down its runway.
HOME = (0.0, 30.0, 0.0)
_STEP = 0.02


class Flight:
    """A vehicle and its simulated ArduPlane on one clock."""

    def __init__(self, vehicle: MavlinkVehicle, sim: SimAutopilot, clock: list[float]) -> None:
        self.vehicle, self.sim, self.clock = vehicle, sim, clock

    def run(self, seconds: float, until: Callable[[], bool] | None = None) -> float:
        """Step both for ``seconds`` (or until ``until()``); the seconds it took."""
        start = self.clock[0]
        while self.clock[0] - start < seconds:
            self.clock[0] += _STEP
            self.sim.service(self.clock[0])
            self.vehicle.service(self.clock[0])
            if until is not None and until():
                break
        return self.clock[0] - start

    def horizontal(self, point: tuple[float, float, float]) -> float:
        x, y, _ = self.sim_position()
        return math.hypot(x - point[0], y - point[1])

    def sim_position(self) -> tuple[float, float, float]:
        """The aircraft's true position in the mission frame."""
        x, y, z = self.sim.position()
        return (x + HOME[0], y + HOME[1], z)


@contextlib.contextmanager
def plane(*, settings: dict[str, Any] | None = None, **autopilot: Any) -> Iterator[Flight]:
    clock = [1000.0]
    port = free_port()
    sim = SimAutopilot(
        AutopilotOptions(
            f"udpin:127.0.0.1:{port}",
            MissionFrame(*ORIGIN.to_geodetic(*HOME)),
            system=3,
            frame="plane",
            heading=90.0,
            **{"ready_after": 2.0, **autopilot},
        ),
        clock=lambda: clock[0],
    )
    vehicle = MavlinkVehicle(
        MavlinkSettings(
            f"udpout:127.0.0.1:{port}",
            ORIGIN,
            system=3,
            name="platform 3",
            fence=_WIDE,
            **(settings or {}),
        ),
        clock=lambda: clock[0],
    )
    try:
        yield Flight(vehicle, sim, clock)
    finally:
        vehicle.close()
        sim.close()


def _wide() -> Any:
    from actorswarm.vehicles.mavlink.vehicle import Fence

    return Fence(-2000.0, -2000.0, 2000.0, 2000.0, 200.0)


_WIDE = _wide()


def test_take_off_fly_a_goal_follow_a_moving_one_hold_land_and_take_off_again() -> None:
    with plane() as f:
        v = f.vehicle
        f.run(5.0, lambda: v.failsafes() is True and v.status()["ready"] is True)
        status = v.status()
        assert (status["autopilot"], status["airframe"]) == ("ardupilot", "plane")
        assert v.failsafes() is True  # FS_GCS_ENABL, BATT_FS_LOW_ACT and SYSID_MYGCS 245

        # Take-off: TKOFF_ALT set, TAKEOFF mode, armed; it rolls east and climbs.
        v.takeoff(40.0)
        took = f.run(60.0, lambda: v.height() >= 37.0)
        assert took < 45.0, f"40 m took {took:.0f} s"
        assert f.sim.armed and f.sim.mode_name == "TAKEOFF"
        assert f.sim._params["TKOFF_ALT"] == 40.0
        assert f.sim_position()[0] > 100.0  # down its runway, east

        # A goal: GUIDED, flown to and circled at the tightest radius (~50 m).
        goal = (600.0, 400.0, 60.0)
        v.goto(*goal, speed=20.0)
        f.run(80.0, lambda: f.horizontal(goal) < 70.0)
        f.run(30.0)
        assert f.sim.mode_name == "GUIDED"
        radii = []
        for _ in range(20):
            f.run(1.0)
            radii.append(f.horizontal(goal))
        assert min(radii) >= 40.0 and max(radii) <= 65.0, radii
        assert abs(f.sim_position()[2] - 60.0) < 3.0
        assert abs(f.sim._vehicle.speed() - 20.0) < 1.5  # the airspeed asked for

        # A moving goal, streamed as the formation plugins do: a carrot 180 m ahead of a
        # point moving north at 18 m/s (beyond three turning radii, so the aircraft flies
        # straight at it), the speed closing the along-track gap in 5 s.
        start = f.clock[0]
        errors = []
        for tick in range(600):  # 60 s at 10 Hz
            t = f.clock[0] - start
            slot = (600.0, 400.0 + 18.0 * t, 60.0)
            behind = slot[1] - f.sim_position()[1]
            v.goto(slot[0], slot[1] + 180.0, 60.0, speed=max(18.0 + behind / 5.0, 1.8))
            f.run(0.1)
            if tick >= 400:  # the last 20 s, settled
                errors.append(f.horizontal(slot))
        assert max(errors) < 10.0, f"{max(errors):.1f} m from the moving slot"

        # Hold: LOITER, circling where it is.
        v.hold()
        f.run(5.0)
        assert f.sim.mode_name == "LOITER"

        # Landing: the mission [home, DO_LAND_START, approach, NAV_LAND] and DO_LAND_START;
        # back along its take-off run, down, stopped short of home, disarmed.
        v.land()
        f.run(300.0, lambda: not f.sim.armed)
        assert not f.sim.armed, f"still armed, {f.sim.mode_name}, {f.sim_position()}"
        x, y, z = f.sim_position()
        assert z == 0.0 and abs(y - HOME[1]) < 3.0
        assert -40.0 < x - HOME[0] < -5.0, f"stopped {x - HOME[0]:.0f} m east of home"

        # Again: the landing mission left loaded would refuse arming (RTL_AUTOLAND 0);
        # the take-off clears it first.
        v.takeoff(30.0)
        f.run(60.0, lambda: v.height() >= 27.0)
        assert f.sim.armed and v.height() >= 27.0
        assert f.sim._plane is not None and f.sim._plane.mission == []


def test_the_height_on_the_ground_wanders_as_arduplane_s_does() -> None:
    """Standing on its runway, the simulated ArduPlane reports the wandering height the
    firmware does (-0.22..+0.40 m measured), though it does not move."""
    with plane() as f:
        v = f.vehicle
        f.run(5.0, lambda: v.status()["ready"] is True)
        heights = []
        for _ in range(300):  # 30 s
            f.run(0.1)
            heights.append(v.position()[2])
        assert -0.23 <= min(heights) < 0.0 and 0.3 < max(heights) <= 0.41, heights
        assert f.sim_position()[2] == 0.0


def test_a_take_off_asked_before_the_autopilot_boots_flies_once_it_is_heard() -> None:
    """An autopilot that boots after its daemon (its link silent when the aircraft's turn
    comes) is ready late, as one that has not aligned yet: the take-off waits for it,
    saying why, instead of failing for good (as it did: the aircraft stayed on the ground
    in the flight where ArduPlane started 60 s late)."""
    with plane(ready_after=ARDUPLANE_READY_AFTER) as f:  # its boot at the measured pace
        v = f.vehicle
        v.takeoff(40.0)
        for _ in range(500):  # 10 s with the autopilot not started: nothing answers
            f.clock[0] += _STEP
            v.service(f.clock[0])
        assert v.drain_faults() == []
        assert v.status()["plan"] == "takeoff"
        assert v.status()["waiting"] == 10.0
        waits = [fields for name, fields in v.drain_log() if name == "vehicle-waiting"]
        assert waits[0]["reason"] == (
            "takeoff: no HEARTBEAT from the autopilot on "
            f"{v.settings.url}: carried out once it is heard"
        ), waits
        f.sim.reboot(f.clock[0])  # the autopilot starts now
        # Planned at its first HEARTBEAT, while it is INITIALISING: the TAKEOFF mode asked
        # then is lost at "ArduPilot Ready" (as on the firmware), and asked again once
        # armed, which starts the take-off.
        took = f.run(90.0, lambda: v.height() >= 37.0)
        assert v.height() >= 37.0, f"{v.height():.1f} m after {took:.0f} s"
        assert f.sim.mode_name == "TAKEOFF" and f.sim._params["TKOFF_ALT"] == 40.0
        assert v.drain_faults() == []


def test_a_failsafe_watching_another_ground_station_refuses_the_take_off() -> None:
    with plane(settings={"own_system": 200}) as f:
        f.run(5.0, lambda: f.vehicle.failsafes() is not None)
        why = f.vehicle.failsafes()
        assert isinstance(why, str) and why.startswith("SYSID_MYGCS is 245, not this vehicle's")
        f.vehicle.takeoff(40.0)
        f.run(6.0)  # the start-up's 3 s, then the parameters read again
        errors = f.vehicle.drain_errors()
        assert any("SYSID_MYGCS" in e for e in errors), errors
        assert not f.sim.armed


def test_a_px4_fixed_wing_is_refused_with_its_reason() -> None:
    """PX4 fixed-wing is not flown yet: a plan fails at once, saying so (the simulated
    autopilot does not play PX4 planes, so a HEARTBEAT is faked)."""
    from actorswarm.vehicles.mavlink.dialect import mav
    from actorswarm.vehicles.mavlink.fixedwing import Px4FixedWing

    steps = Px4FixedWing().takeoff(None, 40.0)  # type: ignore[arg-type]
    (check,) = steps
    assert isinstance(check.test(), str) and "PX4 fixed-wing" in str(check.test())
    assert mav.MAV_TYPE_FIXED_WING == 1
