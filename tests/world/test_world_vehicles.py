"""Vehicle physics: every limit holds step by step, and each mode does what it promises."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pytest
from numpy.typing import NDArray

from actorswarm.runtime.context import Vehicle
from actorswarm.testing import make_context
from actorswarm.world import (
    MODES,
    FixedWingParams,
    Fleet,
    Kind,
    QuadrotorParams,
    SimVehicle,
    WorldConfig,
    loads_world,
)

DT = 0.05
QUAD = QuadrotorParams()
WING = FixedWingParams()
EPS = 1e-9


@dataclass
class Flight:
    """Per-step history of one vehicle: positions, velocities, headings, speeds, modes."""

    pos: NDArray[np.float64]
    vel: NDArray[np.float64]
    heading: NDArray[np.float64]
    speed: NDArray[np.float64]
    modes: list[str]
    battery: NDArray[np.float64]


def fleet_of(kind: Kind, platforms: tuple[int, ...] = (1,), text: str = "") -> Fleet:
    config = loads_world(f'[fleet]\nkind = "{kind}"\n{text}')
    return Fleet.from_config(config, platforms)


def fly(
    fleet: Fleet,
    seconds: float,
    platform: int = 1,
    *,
    until: Callable[[SimVehicle], bool] | None = None,
) -> Flight:
    """Step ``fleet`` for up to ``seconds`` (or until ``until``), recording ``platform``."""
    vehicle = fleet.vehicle(platform)
    row = fleet.index(platform)
    rows: list[tuple[NDArray[np.float64], ...]] = []
    modes = []

    def snap() -> None:
        rows.append(
            (
                fleet.positions[row].copy(),
                fleet.velocities[row].copy(),
                np.array([fleet.headings[row]]),
                np.array([fleet.airspeeds[row]]),
                np.array([fleet.batteries[row]]),
            )
        )
        modes.append(vehicle.mode)

    snap()
    for _ in range(round(seconds / DT)):
        fleet.step(DT)
        snap()
        if until is not None and until(vehicle):
            break
    return Flight(
        pos=np.array([r[0] for r in rows]),
        vel=np.array([r[1] for r in rows]),
        heading=np.array([r[2][0] for r in rows]),
        speed=np.array([r[3][0] for r in rows]),
        battery=np.array([r[4][0] for r in rows]),
        modes=modes,
    )


def turn_rates(heading: NDArray[np.float64]) -> NDArray[np.float64]:
    change = np.diff(heading, axis=0)
    return np.abs((change + np.pi) % (2 * np.pi) - np.pi) / DT


def assert_quad_limits(flight: Flight, params: QuadrotorParams = QUAD) -> None:
    speed = np.linalg.norm(flight.vel, axis=1)
    assert speed.max() <= params.max_speed + EPS
    assert np.abs(flight.vel[:, 2]).max() <= params.max_climb + EPS
    accel = np.linalg.norm(np.diff(flight.vel, axis=0), axis=1) / DT
    assert accel.max() <= params.max_accel + 1e-6
    assert flight.pos[:, 2].min() >= 0.0


def assert_wing_limits(flight: Flight, params: FixedWingParams = WING) -> None:
    speed = np.linalg.norm(flight.vel, axis=1)
    assert speed.max() <= params.max_speed + EPS
    assert np.allclose(speed, flight.speed)
    flying = np.array([m == "flying" for m in flight.modes])
    assert flying.any()
    assert speed[flying].min() >= params.min_airspeed - EPS
    assert np.abs(flight.vel[:, 2]).max() <= params.max_climb + EPS
    assert turn_rates(flight.heading).max() <= params.turn_rate_rad + 1e-6
    # max_accel bounds changes of airspeed and of vertical speed (turning is the turn
    # rate's business).
    assert (np.abs(np.diff(flight.speed)) / DT).max() <= params.max_accel + 1e-6
    assert (np.abs(np.diff(flight.vel[:, 2])) / DT).max() <= params.max_accel + 1e-6
    assert flight.pos[:, 2].min() >= 0.0


# --- the interface -------------------------------------------------------------------------------


def test_a_sim_vehicle_is_a_vehicle() -> None:
    fleet = fleet_of("quadrotor", (3, 4))
    vehicle = fleet.vehicle(3)
    assert isinstance(vehicle, Vehicle)
    assert fleet.vehicle(3) is vehicle and vehicle.platform == 3 and vehicle.kind == "quadrotor"
    assert vehicle.mode == "ground" and vehicle.battery() == 1.0
    assert vehicle.position() == (0.0, 0.0, 0.0) and fleet.vehicle(4).position() == (10.0, 0, 0)
    ctx = make_context(platform=3, vehicle=vehicle)
    assert ctx.require_vehicle() is vehicle
    with pytest.raises(KeyError, match="platforms 3-4"):
        fleet.vehicle(5)


def test_commands_check_their_arguments() -> None:
    vehicle = fleet_of("quadrotor").vehicle(1)
    with pytest.raises(ValueError, match="finite"):
        vehicle.goto(math.nan, 0, 10)
    with pytest.raises(ValueError, match="speed"):
        vehicle.goto(0, 0, 10, speed=0)
    with pytest.raises(ValueError, match="altitude"):
        vehicle.takeoff(-1)
    assert vehicle.mode == "ground"


def test_state_arrays_are_read_only() -> None:
    fleet = fleet_of("quadrotor")
    with pytest.raises(ValueError):
        fleet.positions[0, 0] = 1.0


# --- quadrotor -----------------------------------------------------------------------------------


def test_quadrotor_takes_off_vertically_and_hovers() -> None:
    fleet = fleet_of("quadrotor")
    vehicle = fleet.vehicle(1)
    vehicle.takeoff(20)
    assert vehicle.mode == "takeoff"
    flight = fly(fleet, 30)
    assert_quad_limits(flight)
    assert np.allclose(flight.pos[:, :2], 0.0)
    first_flying = flight.modes.index("flying")
    assert set(flight.modes[1:first_flying]) == {"takeoff"}
    # 20 m at 3 m/s takes at least 6.7 s.
    assert first_flying * DT >= 20 / QUAD.max_climb
    assert flight.pos[-1] == pytest.approx((0, 0, 20), abs=0.06)
    assert np.linalg.norm(flight.vel[-1]) < 1e-3


def test_quadrotor_reaches_a_goal_within_its_limits_and_hovers() -> None:
    fleet = fleet_of("quadrotor")
    vehicle = fleet.vehicle(1)
    vehicle.goto(300, -200, 40, speed=50)  # on the ground: take off first; 50 is clamped
    flight = fly(fleet, 80)
    assert_quad_limits(flight)
    assert flight.modes[1] == "takeoff" and flight.modes[-1] == "flying"
    # The climb to 40 m is vertical, then it heads straight for the goal.
    climbing = np.array([m == "takeoff" for m in flight.modes])
    assert np.allclose(flight.pos[climbing, :2], 0.0)
    speed = np.linalg.norm(flight.vel, axis=1)
    assert speed.max() == pytest.approx(QUAD.max_speed)
    assert flight.pos[-1] == pytest.approx((300, -200, 40), abs=1e-3)
    # Hovering: still there, still, for the rest of the flight.
    hover = fly(fleet, 20)
    assert np.abs(hover.pos - (300, -200, 40)).max() < 1e-3
    assert np.abs(hover.vel).max() < 1e-3
    assert vehicle.velocity() == pytest.approx((0, 0, 0), abs=1e-3)


def test_quadrotor_cruises_at_cruise_speed_by_default() -> None:
    fleet = fleet_of("quadrotor")
    vehicle = fleet.vehicle(1)
    vehicle.takeoff(10)
    fly(fleet, 10)
    vehicle.goto(500, 0, 10)
    flight = fly(fleet, 20)
    assert np.linalg.norm(flight.vel, axis=1).max() == pytest.approx(QUAD.cruise_speed)


def test_quadrotor_holds_where_it_can_stop() -> None:
    fleet = fleet_of("quadrotor")
    vehicle = fleet.vehicle(1)
    vehicle.takeoff(10)
    fly(fleet, 10)
    vehicle.goto(1000, 0, 10, speed=12)
    fly(fleet, 10)
    x_at_hold = vehicle.position()[0]
    vehicle.hold()
    flight = fly(fleet, 15)
    assert_quad_limits(flight)
    braking = 12.0**2 / (2 * QUAD.max_accel)
    assert x_at_hold + braking <= flight.pos[:, 0].max() <= x_at_hold + braking * 1.3
    assert np.linalg.norm(flight.vel[-1]) < 1e-3
    assert np.diff(flight.pos[:, 0]).min() >= -1e-9  # never turns back


def test_quadrotor_lands_where_it_is() -> None:
    fleet = fleet_of("quadrotor")
    vehicle = fleet.vehicle(1)
    vehicle.goto(50, 50, 15)
    fly(fleet, 30)
    vehicle.land()
    assert vehicle.mode == "landing"
    flight = fly(fleet, 20, until=lambda v: v.mode == "landed")
    assert_quad_limits(flight)
    assert vehicle.mode == "landed"
    assert vehicle.position() == pytest.approx((50, 50, 0), abs=1e-3)
    assert vehicle.velocity() == (0.0, 0.0, 0.0)
    assert len(flight.modes) * DT >= 15 / QUAD.max_climb
    # It can take off again.
    vehicle.takeoff(5)
    fly(fleet, 10)
    assert vehicle.mode == "flying" and vehicle.position()[2] == pytest.approx(5, abs=0.06)


def test_a_goto_during_takeoff_waits_for_the_altitude() -> None:
    fleet = fleet_of("quadrotor")
    vehicle = fleet.vehicle(1)
    vehicle.takeoff(30)
    fly(fleet, 2)
    vehicle.goto(100, 0, 30)
    flight = fly(fleet, 40)
    climbing = np.array([m == "takeoff" for m in flight.modes])
    assert climbing.any() and np.allclose(flight.pos[climbing, :2], 0.0)
    assert vehicle.position() == pytest.approx((100, 0, 30), abs=1e-3)


# --- fixed-wing ----------------------------------------------------------------------------------


def test_fixed_wing_takes_off_along_its_runway() -> None:
    # No take-off distance: straight up the runway's line to its altitude (the default's
    # climb-out to a point 200 m ahead is tests/world/test_fixedwing_conformance.py's).
    fleet = fleet_of("fixed_wing", text="heading = 30\n[fixed_wing]\ntakeoff_distance = 0")
    vehicle = fleet.vehicle(1)
    vehicle.takeoff(50)
    flight = fly(fleet, 60, until=lambda v: v.mode == "flying")
    assert_wing_limits(flight)
    runway = math.radians(30)
    assert np.allclose(flight.heading, runway)
    # Along the runway: x / y follow the heading all the way.
    assert np.allclose(flight.pos[:, 1], flight.pos[:, 0] * math.tan(runway), atol=1e-6)
    on_ground = flight.pos[:, 2] == 0.0
    # Rolls until it has its rotate speed (ArduPlane's 19.5 m/s), then climbs.
    assert flight.speed[on_ground].max() < WING.rotate_speed + WING.max_accel * DT
    assert flight.speed[on_ground].max() >= WING.rotate_speed - WING.max_accel * DT
    airborne = ~on_ground
    assert flight.speed[airborne].min() >= WING.min_airspeed - EPS
    assert vehicle.mode == "flying" and vehicle.position()[2] == pytest.approx(50, abs=0.06)
    # Then it circles where it got to, never stopping.
    top = np.array(vehicle.position())
    flight = fly(fleet, 120)
    assert_wing_limits(flight)
    assert flight.speed.min() >= WING.min_airspeed
    distance = np.hypot(*(flight.pos[-400:, :2] - top[:2]).T)
    assert distance == pytest.approx(WING.loiter_radius, rel=0.05)


def test_fixed_wing_flies_to_a_goal_within_its_limits_and_loiters() -> None:
    fleet = fleet_of("fixed_wing")
    vehicle = fleet.vehicle(1)
    vehicle.goto(1500, -800, 120, speed=40)  # takes off first; 40 is clamped to max_speed
    flight = fly(fleet, 300)
    assert_wing_limits(flight)
    assert flight.speed.max() == pytest.approx(WING.max_speed)
    assert np.abs(flight.vel[:, 2]).max() == pytest.approx(WING.max_climb)
    assert turn_rates(flight.heading).max() == pytest.approx(WING.turn_rate_rad)
    # Loitering: on the circle, at altitude, clockwise (ArduPlane's way), never stopping.
    # At 30 m/s the 50 m loiter radius is tighter than it can turn: it circles as tight as
    # it can, max_speed / max_turn_rate (66 m), steadily.
    last = flight.pos[-600:]
    rel = last[:, :2] - (1500, -800)
    widest = WING.turn_radius(WING.max_speed)
    assert widest > WING.loiter_radius
    assert np.hypot(rel[:, 0], rel[:, 1]) == pytest.approx(widest, rel=0.02)
    assert last[:, 2] == pytest.approx(120, abs=0.1)
    angle = np.unwrap(np.arctan2(rel[:, 1], rel[:, 0]))
    assert np.diff(angle).max() < 0
    assert angle[0] - angle[-1] > 2 * math.pi  # 30 s at 30 m/s on a 66 m circle
    assert vehicle.goal() == (1500.0, -800.0, 120.0)


def test_fixed_wing_slows_to_its_commanded_speed_but_never_stalls() -> None:
    fleet = fleet_of("fixed_wing")
    vehicle = fleet.vehicle(1)
    vehicle.takeoff(40)
    fly(fleet, 60)
    vehicle.goto(5000, 5000, 40, speed=1.0)
    flight = fly(fleet, 30)
    assert_wing_limits(flight)
    assert flight.speed[-1] == pytest.approx(WING.min_airspeed)


def test_fixed_wing_hold_circles_the_current_position() -> None:
    fleet = fleet_of("fixed_wing")
    vehicle = fleet.vehicle(1)
    vehicle.takeoff(60)
    fly(fleet, 40)
    vehicle.goto(3000, 0, 60)
    fly(fleet, 30)
    here = np.array(vehicle.position())
    vehicle.hold()
    flight = fly(fleet, 200)
    assert_wing_limits(flight)
    distance = np.hypot(*(flight.pos[-800:, :2] - here[:2]).T)
    assert distance == pytest.approx(WING.loiter_radius, rel=0.02)


def test_fixed_wing_lands_straight_ahead_and_stops() -> None:
    fleet = fleet_of("fixed_wing")
    vehicle = fleet.vehicle(1)
    vehicle.takeoff(30)
    fly(fleet, 60)
    vehicle.land()
    heading = vehicle.heading()
    flight = fly(fleet, 120, until=lambda v: v.mode == "landed")
    assert flight.modes[-1] == "landed"
    assert np.allclose(flight.heading, heading)
    airborne = flight.pos[:, 2] > 0
    assert flight.speed[airborne].min() >= WING.min_airspeed - EPS
    assert np.abs(flight.vel[:, 2]).max() <= WING.max_climb + EPS
    assert (np.abs(np.diff(flight.speed)) / DT).max() <= WING.max_accel + 1e-6
    assert (np.abs(np.diff(flight.vel[:, 2])) / DT).max() <= WING.max_accel + 1e-6
    assert np.diff(flight.pos[:, 2]).max() <= EPS  # only ever descends
    assert vehicle.velocity() == (0.0, 0.0, 0.0) and vehicle.position()[2] == 0.0
    # Descending 30 m at 4 m/s from 18 m/s covers well over 100 m ahead.
    travelled = np.hypot(*(flight.pos[-1, :2] - flight.pos[0, :2]))
    assert travelled > 100


# --- battery -------------------------------------------------------------------------------------


def test_battery_drains_in_the_air_only_and_more_when_moving() -> None:
    fleet = fleet_of("quadrotor", (1, 2, 3))
    fleet.vehicle(1).takeoff(10)
    fleet.vehicle(2).takeoff(10)
    fly(fleet, 10)
    start = fleet.batteries.copy()
    fleet.vehicle(2).goto(10_000, 0, 10, speed=12)
    fly(fleet, 60)
    used = start - fleet.batteries
    assert used[2] == 0.0  # never took off
    assert 0 < used[0] < used[1]
    # Hovering draws rest_power / cruise power of the endurance rate.
    cruise_power = QUAD.rest_power + (1 - QUAD.rest_power) * QUAD.cruise_speed / QUAD.max_speed
    assert used[0] == pytest.approx(60 * QUAD.rest_power / cruise_power / QUAD.endurance)


def test_endurance_is_the_flight_time_at_cruise_speed() -> None:
    fleet = fleet_of("fixed_wing", text="[fixed_wing]\nendurance = 120")
    vehicle = fleet.vehicle(1)
    vehicle.takeoff(40)
    flight = fly(fleet, 200, until=lambda v: v.mode == "dead")
    assert vehicle.mode == "dead"
    # Taking off accelerates from rest and flies under cruise speed for a while: a
    # little longer than the endurance.
    assert 120 <= len(flight.modes) * DT <= 130


def test_an_empty_battery_kills_the_vehicle_which_falls_and_ignores_commands() -> None:
    config = loads_world("[quadrotor]\nendurance = 20\n[fleet]\nbattery = 0.5")
    fleet = Fleet.from_config(config, [1])
    vehicle = fleet.vehicle(1)
    assert vehicle.battery() == 0.5
    vehicle.takeoff(25)
    flight = fly(fleet, 60, until=lambda v: v.mode == "dead")
    assert vehicle.mode == "dead" and vehicle.battery() == 0.0
    assert np.diff(flight.battery).max() <= 0
    height = vehicle.position()[2]
    assert height > 10
    flight = fly(fleet, 5)
    assert vehicle.position()[2] == 0.0 and vehicle.velocity() == (0.0, 0.0, 0.0)
    # Free fall: it reached the ground faster than any climb limit would allow.
    landed_at = int(np.argmax(flight.pos[:, 2] == 0.0)) * DT
    assert landed_at == pytest.approx(math.sqrt(2 * height / 9.81), abs=0.1)
    for command in (lambda: vehicle.takeoff(10), lambda: vehicle.goto(1, 1, 1), vehicle.hold):
        command()
        fly(fleet, 1)
        assert vehicle.mode == "dead" and vehicle.position()[2] == 0.0


# --- many vehicles -------------------------------------------------------------------------------


def test_300_vehicles_step_fast_and_within_their_limits(capsys: pytest.CaptureFixture[str]) -> None:
    config = loads_world('[[fleet.groups]]\nplatforms = "151-300"\nkind = "fixed_wing"\n')
    fleet = Fleet.from_config(config, range(1, 301))
    for i, pid in enumerate(fleet.platforms):
        angle = 2 * math.pi * i / 300
        fleet.vehicle(pid).goto(800 * math.cos(angle), 800 * math.sin(angle), 30 + i % 50)
    wing = fleet.fixed_wing
    previous_vel = fleet.velocities.copy()
    previous_heading = fleet.headings.copy()
    previous_speed = fleet.airspeeds.copy()
    started = time.perf_counter()
    worst = np.zeros(4)
    for _ in range(1000):
        fleet.step(DT)
        vel, speed = fleet.velocities, fleet.airspeeds
        accel = np.linalg.norm(vel - previous_vel, axis=1) / DT
        turn = turn_rates(np.stack((previous_heading, fleet.headings)))[0]
        worst = np.maximum(
            worst,
            [
                accel[~wing].max(),
                turn[wing].max(),
                (np.abs(speed - previous_speed) / DT)[wing].max(),
                np.abs(vel[:, 2]).max(),
            ],
        )
        assert speed[~wing].max() <= QUAD.max_speed + EPS
        assert speed[wing].max() <= WING.max_speed + EPS
        flying = fleet.modes == MODES.index("flying")
        assert speed[wing & flying].min(initial=math.inf) >= WING.min_airspeed - EPS
        previous_vel, previous_heading = vel.copy(), fleet.headings.copy()
        previous_speed = speed.copy()
    elapsed = time.perf_counter() - started
    with capsys.disabled():
        print(f"\n300 vehicles, 1000 steps (with checks): {elapsed:.2f} s")
    assert worst[0] <= QUAD.max_accel + 1e-6
    assert worst[1] <= WING.turn_rate_rad + 1e-6
    assert worst[2] <= WING.max_accel + 1e-6
    assert worst[3] <= max(QUAD.max_climb, WING.max_climb) + EPS
    assert np.isfinite(fleet.positions).all()
    assert set(fleet.modes.tolist()) == {MODES.index("flying")}


def test_physics_is_deterministic() -> None:
    def run() -> NDArray[np.float64]:
        fleet = Fleet.from_config(WorldConfig.defaults(range(1, 11), kind="fixed_wing"))
        for pid in fleet.platforms:
            fleet.vehicle(pid).goto(100.0 * pid, -50.0 * pid, 20.0 + pid)
        for _ in range(600):
            fleet.step(DT)
        return np.hstack((fleet.positions, fleet.velocities, fleet.batteries[:, None]))

    assert np.array_equal(run(), run())


# --- commands in every mode ----------------------------------------------------------------------


def test_hold_during_takeoff_stays_at_the_takeoff_altitude() -> None:
    fleet = fleet_of("quadrotor")
    vehicle = fleet.vehicle(1)
    vehicle.takeoff(12)
    vehicle.goto(100, 100, 30)
    fly(fleet, 1)
    vehicle.hold()
    fly(fleet, 15)
    assert vehicle.mode == "flying"
    assert vehicle.position() == pytest.approx((0, 0, 12), abs=0.06)


def test_commands_on_the_ground() -> None:
    fleet = fleet_of("quadrotor")
    vehicle = fleet.vehicle(1)
    for command in (vehicle.hold, vehicle.land, lambda: vehicle.goto(50, 0, 0)):
        command()
        fly(fleet, 1)
        assert vehicle.mode == "ground" and vehicle.position() == (0.0, 0.0, 0.0)
    assert vehicle.battery() == 1.0


def test_goto_or_hold_abort_a_landing_and_takeoff_in_the_air_changes_altitude() -> None:
    fleet = fleet_of("quadrotor")
    vehicle = fleet.vehicle(1)
    vehicle.takeoff(20)
    fly(fleet, 10)
    vehicle.land()
    fly(fleet, 2)
    vehicle.goto(0, 30, 25)
    assert vehicle.mode == "flying"
    fly(fleet, 20)
    assert vehicle.position() == pytest.approx((0, 30, 25), abs=1e-3)
    vehicle.land()
    fly(fleet, 2)
    vehicle.hold()
    assert vehicle.mode == "flying"
    vehicle.takeoff(40)
    fly(fleet, 20)
    assert vehicle.mode == "flying"
    assert vehicle.position()[2] == pytest.approx(40, abs=1e-3)


def test_a_fixed_wing_rolling_out_takes_off_again_when_sent_somewhere() -> None:
    fleet = fleet_of("fixed_wing")
    vehicle = fleet.vehicle(1)
    vehicle.takeoff(20)
    fly(fleet, 40)
    vehicle.land()
    fly(fleet, 120, until=lambda v: v.position()[2] == 0.0 and v.speed() < 6)
    assert vehicle.mode == "landing"
    vehicle.goto(0, 0, 30)
    assert vehicle.mode == "takeoff"
    flight = fly(fleet, 200)
    assert_wing_limits(flight)
    rel = flight.pos[-400:, :2]
    assert np.hypot(rel[:, 0], rel[:, 1]) == pytest.approx(WING.loiter_radius, rel=0.05)
