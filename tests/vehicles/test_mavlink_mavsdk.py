"""MavlinkVehicle against an autopilot side we did not write: MAVSDK's server plugins
(``ActionServer``: arming, modes, take-off, with its own COMMAND_ACKs; ``ParamServer``: the
failsafe parameters), over UDP loopback. The cross-check of the command protocol, the mode
encoding and the parameter encoding against our own simulated autopilot."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import pytest
from mavsdk import ComponentType, Configuration, Mavsdk
from mavsdk.plugins.action_server import ActionServer, AllowableFlightModes, FlightMode
from mavsdk.plugins.param_server import ParamServer
from mavsdk.plugins.telemetry_server import Heading, Position, TelemetryServer, VelocityNed
from tests.vehicles.helpers import free_port, wait_for, wait_started

from actorswarm.vehicles.mavlink.frame import MissionFrame
from actorswarm.vehicles.mavlink.vehicle import MavlinkSettings, MavlinkVehicle

ORIGIN = MissionFrame(47.397742, 8.545594, 488.0)


@dataclass
class Server:
    """MAVSDK as the autopilot (system 1, component 1): what its plugins were asked."""

    action: Any
    params: Any
    arms: list[bool] = field(default_factory=list)
    takeoffs: list[bool] = field(default_factory=list)
    modes: list[FlightMode] = field(default_factory=list)
    #: The height the telemetry reports (metres above home): MAVSDK's server does not fly.
    height: float = 0.0


@pytest.fixture
def link() -> Iterator[tuple[Server, Callable[..., MavlinkVehicle]]]:
    port = free_port()
    mavsdk = Mavsdk(Configuration.create_with_component_type(ComponentType.AUTOPILOT))
    mavsdk.add_any_connection(f"udpin://127.0.0.1:{port}")
    component = mavsdk.server_component()
    server = Server(ActionServer(component), ParamServer(component))
    server.params.provide_param_int("NAV_DLL_ACT", 2)
    server.params.provide_param_int("COM_LOW_BAT_ACT", 3)
    server.action.set_armable(True, True)
    server.action.set_disarmable(True, True)
    server.action.set_allow_takeoff(True)
    server.action.set_allowable_flight_modes(AllowableFlightModes(*[True] * 7))
    server.action.subscribe_arm_disarm(lambda _r, arm, *_: server.arms.append(arm.arm))
    server.action.subscribe_takeoff(lambda _r, ok, *_: server.takeoffs.append(ok))
    server.action.subscribe_flight_mode_change(lambda _r, mode, *_: server.modes.append(mode))
    # A position and a home, as a ready PX4 sends them: the vehicle arms only after both.
    telemetry = TelemetryServer(component)
    home = Position(ORIGIN.lat, ORIGIN.lon, ORIGIN.alt, 0.0)
    stop = threading.Event()

    def publish() -> None:
        while not stop.is_set():
            h = server.height
            here = Position(ORIGIN.lat, ORIGIN.lon, ORIGIN.alt + h, h)
            telemetry.publish_position(here, VelocityNed(0.0, 0.0, 0.0), Heading(0.0))
            telemetry.publish_home(home)
            stop.wait(0.1)

    publisher = threading.Thread(target=publish, daemon=True)
    publisher.start()
    vehicles: list[MavlinkVehicle] = []

    def make(**kw: Any) -> MavlinkVehicle:
        settings = MavlinkSettings(
            f"udpout:127.0.0.1:{port}", ORIGIN, system=1, name="platform 4", **kw
        )
        vehicle = MavlinkVehicle(settings)
        vehicles.append(vehicle)
        vehicle.start()
        wait_for("the link", lambda: vehicle.status()["link"] == "up")
        return vehicle

    yield server, make
    for vehicle in vehicles:
        vehicle.close()
    stop.set()
    publisher.join(timeout=2)
    mavsdk.destroy()


def errors(vehicle: MavlinkVehicle) -> list[str]:
    # MAVSDK's server answers no SET_MESSAGE_INTERVAL (it streams nothing itself): that
    # plan fails on its own deadline and is left out here.
    return [e for e in vehicle.drain_errors() if "stream rates" not in e]


def test_px4_modes_and_integer_parameters(
    link: tuple[Server, Callable[..., MavlinkVehicle]],
) -> None:
    _, make = link
    vehicle = make()
    assert vehicle.status()["autopilot"] == "px4"  # MAVSDK uses PX4's mode encoding
    wait_for("the failsafe parameters", lambda: vehicle.failsafes() is not None)
    # PX4 and MAVSDK carry integers bytewise in PARAM_VALUE: read as 2 and 3, not ~1e-45.
    assert vehicle.status()["failsafes"] == {"NAV_DLL_ACT": 2.0, "COM_LOW_BAT_ACT": 3.0}
    assert vehicle.failsafes() is True


def test_takeoff_offboard_hold_land(link: tuple[Server, Callable[..., MavlinkVehicle]]) -> None:
    server, make = link
    vehicle = make()
    wait_for("the failsafe parameters", lambda: vehicle.failsafes() is True)
    wait_started(vehicle)
    vehicle.takeoff(5.0)
    wait_for("arm and take-off", lambda: server.takeoffs == [True])
    assert server.arms == [True]
    wait_for("the take-off plan done", lambda: vehicle.status()["plan"] is None)
    assert errors(vehicle) == []
    server.height = 5.0  # as if it climbed
    wait_for("the height seen", lambda: vehicle.height() > 4.0)

    vehicle.goto(10.0, 5.0, 5.0)  # setpoints stream, then OFFBOARD is asked for
    wait_for("OFFBOARD", lambda: FlightMode.OFFBOARD in server.modes)
    wait_for("the mode seen", lambda: vehicle.status()["mode"] == "OFFBOARD")
    assert errors(vehicle) == []

    # An actor switch: the outgoing actor holds, the incoming one's goal follows at once.
    # The hold's mode change must not be the last: OFFBOARD is asked for again.
    modes = len(server.modes)
    vehicle.hold()
    vehicle.goto(0.0, 10.0, 5.0)
    wait_for(
        "hold, then OFFBOARD again", lambda: server.modes[modes:][-1:] == [FlightMode.OFFBOARD]
    )
    assert FlightMode.HOLD in server.modes[modes:]
    assert errors(vehicle) == []

    vehicle.land()
    wait_for("LAND", lambda: server.modes[-1] == FlightMode.LAND)
    wait_for("the land plan done", lambda: vehicle.status()["plan"] is None)
    assert errors(vehicle) == []


def test_an_autopilot_that_will_not_arm(
    link: tuple[Server, Callable[..., MavlinkVehicle]],
) -> None:
    server, make = link
    server.action.set_armable(False, False)
    vehicle = make(deadline=2.0, arm_timeout=3.0)
    wait_for("the failsafe parameters", lambda: vehicle.failsafes() is True)
    wait_started(vehicle)
    vehicle.takeoff(5.0)
    seen: list[str] = []

    def refused() -> bool:
        seen.extend(errors(vehicle))
        return bool(seen)

    wait_for("the refusal", refused)
    # MAVSDK answers TEMPORARILY_REJECTED: asked again after 1 s, then 2 s, given up at the
    # take-off's arm_timeout.
    assert seen == [
        "vehicle platform 4: takeoff: MAV_CMD_COMPONENT_ARM_DISARM: not done within 3 s "
        f"({len(server.arms)} tries), last refused: MAV_RESULT_TEMPORARILY_REJECTED"
    ]
    assert 2 <= len(server.arms) <= 4
    assert vehicle.status()["refused"] == (
        "MAV_CMD_COMPONENT_ARM_DISARM: MAV_RESULT_TEMPORARILY_REJECTED"
    )
    time.sleep(0.6)
    assert len(server.arms) == int(seen[0].split("(")[1].split()[0])  # nothing after it
    assert server.takeoffs == []


def test_failsafes_off_never_reach_the_autopilot(
    link: tuple[Server, Callable[..., MavlinkVehicle]],
) -> None:
    server, make = link
    server.params.provide_param_int("NAV_DLL_ACT", 0)
    vehicle = make()
    wait_for("the failsafe parameters", lambda: vehicle.failsafes() is not None)
    wait_started(vehicle)
    vehicle.takeoff(5.0)
    time.sleep(0.3)
    assert any("NAV_DLL_ACT is 0 (link-loss failsafe off)" in e for e in errors(vehicle))
    assert server.arms == [] and server.takeoffs == []
