"""The simulator's fixed-wing held against the firmware: a world that says nothing about its
fixed-wings flies ArduPlane 4.5.7 as it was measured in SITL with its stock airframe
(``plane.parm``; docs/vehicles.md, "Fixed-wing").

The measured figures are written here a second time, on purpose: a change of the model's
defaults that drifts from the firmware fails here, whatever the defaults say. The simulated
autopilot's ArduPlane (``actorswarm autopilot --frame plane``) flies the same model; its own
conformance over MAVLink is tests/vehicles/test_autopilot_plane.py.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from actorswarm.core.config import CoreConfig
from actorswarm.dsl.checker import load
from actorswarm.sim.mission import run_slices
from actorswarm.sim.radio import LinkModel
from actorswarm.sim.tasksim import TaskSim
from actorswarm.sim.verify.scenario import scenario_of
from actorswarm.vehicles.mavlink.simplane import flown_radius, plane_spec
from actorswarm.world.config import FixedWingParams, load_world, loads_world
from actorswarm.world.vehicles import Fleet, SimVehicle

DT = 0.05

# ArduPlane 4.5.7 SITL, measured (seconds from the arming that starts a TAKEOFF).
CRUISE = 22.0  # AIRSPEED_CRUISE, ~53 % throttle
AIRSPEED = (10.0, 30.0)  # DO_CHANGE_SPEED accepted within AIRSPEED_MIN..MAX
LIFT_OFF_S, LIFT_OFF_RUN, LIFT_OFF_SPEED = 3.8, 40.0, 19.5
AT_39_M_S = 29.8  # TKOFF_ALT 40
# 20 m is first reached 6-11 s after arming: the climb pauses for a few seconds while the
# aircraft turns onto its circle (9.3 and 6 s in a flight of ten, 10.8 s alone), which the
# model does not (it climbs on through the turn).
AT_20_M_S = (6.0, 11.0)
# A take-off to 162 m (TKOFF_ALT 162, a formation's top take-off layer): 80 m at 26.0 s,
# 120 m at 34.2 s; the sustained climb in between, m/s.
SUSTAINED_CLIMB = (120.0 - 80.0) / (34.2 - 26.0)
TKOFF_DIST = 200.0  # then circles the point this far down the runway
TIGHTEST_CIRCLE = (49.0, 55.0)  # DO_REPOSITION radius 25: circled clockwise at 49-55 m
SPEEDS = ((16.0, 15.9), (28.0, 28.4))  # DO_CHANGE_SPEED asked, airspeed held
GLIDE_SPEED = 16.0
TOUCHDOWN_SHORT = 46.0  # approach 700 m out at 40 m, 3.5° glide
STOPPED_SHORT = (9.0, 16.0)


def aircraft(heading: float = 0.0) -> tuple[Fleet, SimVehicle]:
    """One default fixed-wing at the origin, its runway along ``heading`` (degrees)."""
    config = loads_world(f'[fleet]\nkind = "fixed_wing"\nheading = {heading}\n')
    fleet = Fleet.from_config(config, (1,))
    return fleet, fleet.vehicle(1)


def fly(fleet: Fleet, seconds: float, until: Callable[[], bool] | None = None) -> np.ndarray:
    """Step for ``seconds`` (or until ``until``): rows of (t, x, y, z, speed, heading)."""
    rows = []
    for step in range(round(seconds / DT)):
        fleet.step(DT)
        x, y, z = fleet.positions[0]
        rows.append(((step + 1) * DT, x, y, z, fleet.airspeeds[0], fleet.headings[0]))
        if until is not None and until():
            break
    return np.array(rows)


def airborne_at(fleet: Fleet, vehicle: SimVehicle, altitude: float) -> np.ndarray:
    vehicle.takeoff(altitude)
    return fly(fleet, 90.0, until=lambda: vehicle.position()[2] >= altitude - 1.0)


def test_the_defaults_are_arduplane_s_airspeeds() -> None:
    wing = FixedWingParams()
    assert (wing.min_airspeed, wing.max_speed) == AIRSPEED
    assert wing.cruise_speed == CRUISE
    assert wing.loiter_clockwise


def test_take_off_rolls_lifts_off_and_climbs_as_arduplane_does() -> None:
    fleet, vehicle = aircraft()
    track = airborne_at(fleet, vehicle, 40.0)
    t, x, z, speed = track[:, 0], track[:, 1], track[:, 3], track[:, 4]
    rolled = np.flatnonzero(z > 0.0)[0]
    assert t[rolled] == pytest.approx(LIFT_OFF_S, abs=0.3)
    assert x[rolled] == pytest.approx(LIFT_OFF_RUN, abs=5.0)
    assert speed[rolled] == pytest.approx(LIFT_OFF_SPEED, abs=0.5)
    assert AT_20_M_S[0] <= t[np.flatnonzero(z >= 20.0)[0]] <= AT_20_M_S[1]
    # Up to 2 s early: the model climbs on through the turn where the firmware pauses.
    assert t[-1] == pytest.approx(AT_39_M_S, abs=2.5)
    # Straight down the runway, then circling the point TKOFF_DIST ahead while it climbs.
    outbound = np.flatnonzero(x >= TKOFF_DIST - 3 * 50.0)[0]  # blending onto its circle
    assert np.abs(track[:outbound, 2]).max() < 1e-6
    assert np.hypot(x[-1] - TKOFF_DIST, track[-1, 2]) == pytest.approx(50.0, abs=5.0)


def test_a_high_take_off_climbs_as_fast_as_arduplane_does() -> None:
    fleet, vehicle = aircraft()
    track = airborne_at(fleet, vehicle, 162.0)
    t, z = track[:, 0], track[:, 3]
    at_80, at_120 = (t[np.flatnonzero(z >= h)[0]] for h in (80.0, 120.0))
    assert 40.0 / (at_120 - at_80) == pytest.approx(SUSTAINED_CLIMB, abs=0.3)


def test_the_default_circle_is_the_tightest_arduplane_sustains() -> None:
    fleet, vehicle = aircraft()
    vehicle.goto(600.0, 300.0, 60.0)
    track = fly(fleet, 240.0)[-1200:]
    radius = np.hypot(*(track[:, 1:3] - (600.0, 300.0)).T)
    assert TIGHTEST_CIRCLE[0] <= radius.min() and radius.max() <= TIGHTEST_CIRCLE[1]


def test_a_goal_is_circled_clockwise_at_the_tightest_measured_circle() -> None:
    fleet, vehicle = aircraft()
    # Asked for a 25 m circle (as ArduPlane was): flown as tight as it turns at cruise.
    vehicle.set_loiter_radius(25.0)
    vehicle.goto(600.0, 300.0, 60.0)
    track = fly(fleet, 240.0)[-1200:]  # the last minute
    rel = track[:, 1:3] - (600.0, 300.0)
    radius = np.hypot(rel[:, 0], rel[:, 1])
    assert TIGHTEST_CIRCLE[0] <= radius.min() and radius.max() <= TIGHTEST_CIRCLE[1]
    assert track[:, 4] == pytest.approx(CRUISE)
    angle = np.unwrap(np.arctan2(rel[:, 1], rel[:, 0]))
    assert np.diff(angle).max() < 0.0  # clockwise
    assert track[:, 3] == pytest.approx(60.0, abs=0.1)


@pytest.mark.parametrize(("asked", "held"), SPEEDS)
def test_an_airspeed_asked_is_held_as_measured(asked: float, held: float) -> None:
    fleet, vehicle = aircraft()
    airborne_at(fleet, vehicle, 40.0)
    vehicle.goto(5000.0, 0.0, 40.0, speed=asked)
    track = fly(fleet, 30.0)
    assert track[-1, 4] == pytest.approx(held, abs=0.5)


@pytest.mark.parametrize(("asked", "held"), [(5.0, AIRSPEED[0]), (45.0, AIRSPEED[1])])
def test_an_airspeed_outside_the_limits_is_held_at_the_limit(asked: float, held: float) -> None:
    fleet, vehicle = aircraft()
    airborne_at(fleet, vehicle, 40.0)
    vehicle.goto(8000.0, 0.0, 40.0, speed=asked)
    assert fly(fleet, 30.0)[-1, 4] == pytest.approx(held)


def test_a_landing_glides_at_the_measured_slope_and_touches_down_short() -> None:
    fleet, vehicle = aircraft()
    airborne_at(fleet, vehicle, 40.0)
    vehicle.goto(-700.0, 0.0, 40.0)  # the approach point, 700 m west of home at 40 m
    fly(fleet, 120.0, until=lambda: abs(vehicle.position()[0] + 700.0) < 60.0)
    vehicle.land_at(0.0, 0.0, start=(-700.0, 0.0, 40.0))
    track = fly(fleet, 200.0, until=lambda: vehicle.mode == "landed")
    x, z, speed = track[:, 1], track[:, 3], track[:, 4]
    down = np.flatnonzero(z <= 0.05)[0]
    assert -x[down] == pytest.approx(TOUCHDOWN_SHORT, abs=6.0)
    gliding = (z > 5.0) & (z < 30.0)
    assert speed[gliding] == pytest.approx(GLIDE_SPEED, abs=0.5)
    assert vehicle.mode == "landed"
    # Measured 9-16 m short; the model brakes harder from touchdown and stops further out
    # (about 21 m: a known weak point, the flare is not modelled).
    assert STOPPED_SHORT[0] <= -x[-1] <= 25.0


def test_the_simulated_autopilot_flies_the_same_model() -> None:
    """One model: the simulated ArduPlane's physics is the world's default fixed-wing, but
    for the circle it holds in LOITER (WP_LOITER_RAD 80 flown at ~100 m), the battery, and
    the take-off's point, which its TAKEOFF mode sets from its own TKOFF_DIST."""
    spec = plane_spec(battery=1.0, endurance=1800.0)
    assert isinstance(spec.params, FixedWingParams)
    assert spec.params == dataclasses.replace(
        FixedWingParams(), loiter_radius=flown_radius(80.0), endurance=1800.0, takeoff_distance=0
    )
    assert spec.params.loiter_radius == pytest.approx(100.7, abs=0.5)
    assert math.isclose(FixedWingParams().turn_radius(CRUISE), 48.5, abs_tol=0.1)


@pytest.mark.parametrize(
    ("name", "count", "flown_s"),
    [("formation_arduplane", 10, 80.5), ("formation_arduplane_30", 30, 80.7)],
)
def test_the_arduplane_formation_reaches_its_first_shape_when_the_real_flight_did(
    name: str, count: int, flown_s: float
) -> None:
    """examples/formation_arduplane.xml (and its thirty-aircraft variant) in the simulator,
    from its own sim line: the aircraft take off in turn and in layers and switch to the
    arrow together 82.3 s after the start; ten ArduPlane SITL did 80.5 s after `gs start`
    (docs/benchmarks/real-firmware.md, flight 4), thirty 80.7 s (flight 7). They then
    leave their take-off layers for the arrow 10 m apart or more: before transit_hold (and
    with take-off layers 10 m apart), platform 7 descended from its layer through the
    arrow's altitude and passed 8.7 m from 5 at 112 s, as two aircraft of a flight did."""
    script = Path(__file__).resolve().parents[2] / "examples" / f"{name}.xml"
    scenario = scenario_of(script.read_text(), script)
    assert scenario is not None and scenario.world is not None
    assert scenario.world.name == f"{name}.toml"
    sim = TaskSim(
        load(script),
        seed=0,
        link=LinkModel(),
        config=CoreConfig(),
        world_config=load_world(scenario.world),
    )
    sim.schedule(list(scenario.events), [])
    report = run_slices(sim, 130.0, slice_s=5.0)
    to_arrow = [t for t in report["transitions"] if (t["from"], t["to"]) == ("Standby", "A")]
    assert len(to_arrow) == count
    assert [t["t"] for t in to_arrow] == pytest.approx([flown_s] * count, abs=5.0)
    assert report["violations"] == []
    assert report["separation"]["min_distance_m"] >= 10.0, report["separation"]["closest"]
