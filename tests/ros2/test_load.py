"""The extra is optional: nothing imports ROS unless asked; a missing or old rclpy is a
clear error."""

from __future__ import annotations

import subprocess
import sys

import pytest

from actorswarm.ros2.load import Ros2Error, Ros2Unavailable, load_rclpy, message_type


def test_the_rest_of_actorswarm_imports_no_ros() -> None:
    code = (
        "import sys, actorswarm.cli, actorswarm.daemon.run, actorswarm.web.app, "
        "actorswarm.sim.swarm, actorswarm.runtime.actor_runtime\n"
        "ros = sorted(m for m in sys.modules if m.split('.')[0] in "
        "('rclpy', 'std_msgs', 'geometry_msgs', 'actorswarm') and "
        "(m.startswith('actorswarm.ros2') or not m.startswith('actorswarm')))\n"
        "print(ros)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_missing_rclpy_says_what_to_install(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "rclpy", None)  # import rclpy now fails
    with pytest.raises(Ros2Unavailable) as info:
        load_rclpy()
    text = str(info.value)
    assert "actorswarm[ros2]" in text and "source /opt/ros/jazzy/setup.bash" in text


@pytest.mark.rclpy
def test_an_old_distro_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("ROS_DISTRO", "humble")
    with pytest.raises(Ros2Unavailable, match=r"humble.*Jazzy or newer"):
        load_rclpy()


@pytest.mark.rclpy
def test_the_wheels_rclpy_loads(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("ROS_DISTRO", raising=False)
    assert load_rclpy().__name__ == "rclpy"
    assert message_type("geometry_msgs/PoseStamped").__name__ == "PoseStamped"
    assert message_type("std_srvs/srv/Trigger").__name__ == "Trigger"


@pytest.mark.parametrize(
    ("name", "said"),
    [
        ("PoseStamped", "not a ROS 2 type name"),
        ("geometry_msgs/action/X", "not a ROS 2 type name"),
        ("px4_msgs/msg/VehicleOdometry", "px4_msgs/msg/VehicleOdometry is not installed"),
    ],
)
def test_a_bad_type_name_is_named(name: str, said: str) -> None:
    with pytest.raises(Ros2Error, match=said):
        message_type(name)
