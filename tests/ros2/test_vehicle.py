"""``--vehicle ros2`` against a kinematic ROS 2 robot in another process."""

from __future__ import annotations

import asyncio
import math
import os
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager

import pytest
from tests.ros2.helpers import until

from actorswarm.ros2.vehicle import PROFILES, Ros2VehicleSettings

pytestmark = pytest.mark.rclpy


@contextmanager
def robot(namespace: str, *args: str) -> Iterator[subprocess.Popen[str]]:
    """The test robot (tests/ros2/robot.py) in its own process, in this test's domain."""
    root = os.path.dirname(os.path.dirname(os.path.dirname(__file__)))
    proc = subprocess.Popen(
        [sys.executable, "-m", "tests.ros2.robot", namespace, *args],
        cwd=root,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout is not None and proc.stdout.readline().strip() == "ready"
        yield proc
    finally:
        proc.terminate()
        proc.wait(10)


def located(vehicle: object) -> bool:
    """What the daemon does at each wake (take the pose), then: is there one?"""
    vehicle.drain_events()  # type: ignore[attr-defined]
    return bool(vehicle.located())  # type: ignore[attr-defined]


def lost(vehicle: object, events: list[str]) -> bool:
    events.extend(vehicle.drain_events())  # type: ignore[attr-defined]
    return "vehicle_link_lost" in events


def test_the_vehicle_flies_the_robot_over_ros2(ros_domain: int) -> None:
    from actorswarm.ros2.node import RosNode
    from actorswarm.ros2.vehicle import Ros2Vehicle

    settings = Ros2VehicleSettings(
        takeoff_service="robot/takeoff",
        land_service="robot/land",
        offset=(100.0, 0.0, 0.0),
        pose_timeout=0.5,
    )

    async def go() -> dict[str, object]:
        node = RosNode("platform", "/sw/p1")
        vehicle = Ros2Vehicle(node, settings)
        vehicle.start()
        node.start()
        seen: dict[str, object] = {}
        events: list[str] = []

        def near(x: float, y: float, z: float) -> bool:
            events.extend(vehicle.drain_events())
            return math.dist(vehicle.position(), (x, y, z)) < 0.3

        try:
            with robot("/sw/p1/robot", "--at", "2,3") as proc:
                assert await until(lambda: located(vehicle), 10.0)
                seen["start"] = vehicle.position()  # the robot's (2, 3, 0), shifted
                vehicle.takeoff(5.0)
                assert await until(lambda: near(102, 3, 5), 10.0), vehicle.position()
                vehicle.goto(110.0, -4.0, 6.0)
                assert await until(lambda: near(110, -4, 6), 10.0), vehicle.position()
                seen["velocity"] = vehicle.velocity()
                vehicle.land()  # the robot's land service: down to z = 0
                assert await until(lambda: near(110, -4, 0), 10.0), vehicle.position()
                seen["status"] = vehicle.status()
                proc.terminate()
                proc.wait(10)
                assert await until(lambda: lost(vehicle, events), 5.0), events
                seen["lost"] = vehicle.status()
            seen["errors"] = vehicle.drain_errors() + node.drain_errors()
            seen["events"] = events
            return seen
        finally:
            vehicle.close()
            node.close()

    seen = asyncio.run(go())
    assert seen["start"] == (102.0, 3.0, 0.0)
    assert seen["status"] == {"link": "up", "autopilot": "ros2", "mode": "generic", "battery": None}
    assert seen["lost"]["link"] == "lost"  # type: ignore[index]
    assert seen["errors"] == []
    assert seen["events"] == ["vehicle_link_lost"]


def test_odometry_in_and_a_missing_service_named(ros_domain: int) -> None:
    from actorswarm.ros2.node import RosNode
    from actorswarm.ros2.vehicle import Ros2Vehicle

    settings = Ros2VehicleSettings(
        pose_type="nav_msgs/msg/Odometry", takeoff_service="no_such_takeoff", service_timeout=1.0
    )

    faults: list[str] = []

    async def go() -> tuple[tuple[float, float, float], list[str]]:
        node = RosNode("platform", "/sw/p2")
        vehicle = Ros2Vehicle(node, settings)
        vehicle.start()
        node.start()
        errors: list[str] = []
        try:
            with robot("/sw/p2/robot", "--at=-1,1", "--pose-type", "odometry"):
                assert await until(lambda: located(vehicle), 10.0)
                vehicle.takeoff(2.0)  # no such service: the setpoint alone flies it

                def done() -> bool:
                    vehicle.drain_events()
                    errors.extend(vehicle.drain_errors())
                    faults.extend(vehicle.drain_faults())
                    return bool(errors) and abs(vehicle.position()[2] - 2.0) < 0.2

                assert await until(done, 10.0), (vehicle.position(), errors)
                return vehicle.position(), errors
        finally:
            vehicle.close()
            node.close()

    position, errors = asyncio.run(go())
    assert position[:2] == pytest.approx((-1.0, 1.0))
    assert errors == [
        "take-off (service /sw/p2/no_such_takeoff): service "
        "/sw/p2/no_such_takeoff: not found within 1 s"
    ]
    assert faults == errors  # a take-off that failed for good: vehicle_fault_event


def test_a_pose_topic_of_another_type_is_named(ros_domain: int) -> None:
    from actorswarm.ros2.node import RosNode
    from actorswarm.ros2.vehicle import Ros2Vehicle

    async def go() -> tuple[list[str], int]:
        node = RosNode("platform", "/sw/p3")
        Ros2Vehicle(node, Ros2VehicleSettings(pose_type="nav_msgs/msg/Odometry"))
        node.start()
        errors: list[str] = []
        try:
            with robot("/sw/p3/robot"):  # publishes PoseStamped on pose
                await until(lambda: bool(errors.extend(node.drain_errors()) or errors), 10.0)
                return errors, node.errors
        finally:
            node.close()

    errors, counted = asyncio.run(go())
    assert counted >= len(errors) >= 1  # counted for status.json's ros2.errors
    assert errors and errors[0] == (
        "topic /sw/p3/robot/pose: published as geometry_msgs/msg/PoseStamped, subscribed as "
        "nav_msgs/msg/Odometry: those messages are not received"
    )


def test_profiles_name_the_anchor_topics() -> None:
    a2 = PROFILES["aerostack2"].for_platform(4)
    assert (a2.pose_topic, a2.setpoint_topic, a2.pose_qos) == (
        "/drone4/self_localization/pose",
        "/drone4/motion_reference/pose",
        "sensor",
    )
    mavros = PROFILES["mavros"].for_platform(4)
    assert mavros.setpoint_topic == "/mavros/setpoint_position/local"
    with pytest.raises(ValueError, match="the pose types are"):
        Ros2VehicleSettings(pose_type="sensor_msgs/msg/Imu")
