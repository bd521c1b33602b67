"""The ground bridge: what the ground station knows, on ROS 2 topics; the operator's
actions from ROS 2 only when enabled."""

from __future__ import annotations

import asyncio
import subprocess
import sys
from typing import Any

import pytest
from tests.ros2.conftest import HAVE_RCLPY
from tests.ros2.helpers import until

from actorswarm.engine import commands as cmds
from actorswarm.ground.station import GroundStation, ReplyRecord
from actorswarm.ros2.bridge import BridgeSettings, GroundBridge, GroundView


def _station(now: float) -> GroundStation:
    station = GroundStation(swarm="sw", now=now)
    for p, master in ((1, True), (2, False)):
        station.heard[p] = now
        station.state[p] = (7, master, 3)
    station.replies.append(
        ReplyRecord(
            now,
            1,
            cmds.StatusReply(
                actors={"Search": "running", "Home": "sleeping"},
                master=True,
                epoch=3,
                incarnation=7,
                script="ab" * 32,
                position=[10.0, -5.0, 12.0],
                vehicle={"link": "lost", "mode": "GUIDED"},
                roles=["tracker", "leader"],
                began=1_796_000_000.5,
            ),
        )
    )
    return station


@pytest.mark.rclpy
def test_the_bridge_publishes_what_the_ground_station_knows(ros_domain: int) -> None:
    from actorswarm.ros2.node import RosNode

    async def go() -> dict[str, Any]:
        bridge_node = RosNode("ground_bridge", "/sw")
        watcher = RosNode("watcher")
        bridge_node.start()
        watcher.start()
        try:
            inlets = {
                name: watcher.subscribe(f"/sw/{name}", kind, qos=qos)
                for name, kind, qos in (
                    ("p1/pose", "geometry_msgs/msg/PoseStamped", "reliable"),
                    ("p1/fix", "sensor_msgs/msg/NavSatFix", "reliable"),
                    ("p1/actor", "std_msgs/msg/String", "latched"),
                    ("p1/roles", "std_msgs/msg/String", "latched"),
                    ("p1/vehicle_state", "diagnostic_msgs/msg/DiagnosticArray", "reliable"),
                    ("master", "std_msgs/msg/UInt16", "latched"),
                    ("membership", "diagnostic_msgs/msg/DiagnosticArray", "reliable"),
                    ("markers", "visualization_msgs/msg/MarkerArray", "reliable"),
                )
            }
            settings = BridgeSettings(frame="mission", origin=(47.0, 8.0, 500.0))
            bridge = GroundBridge(bridge_node, "sw", settings)
            view = GroundView(t_leave=5.0)
            station = _station(100.0)
            got: dict[str, Any] = {}

            def look() -> bool:
                for name, inlet in inlets.items():
                    latest = inlet.latest()
                    if latest is not None:
                        got[name] = latest
                return len(got) == len(inlets)

            for _ in range(100):  # publishing while discovery matches the endpoints
                view.update(station, 100.0)
                bridge.publish(view)
                if station.replies == [] and len(got) < len(inlets):
                    # a fresh status each round, so the vehicle topic repeats too
                    station.replies.extend(_station(100.0).replies)
                if await until(look, 0.1):
                    break
            assert not bridge_node.drain_errors()
            return got
        finally:
            watcher.close()
            bridge_node.close()

    got = asyncio.run(go())
    pose = got["p1/pose"]
    assert pose.header.frame_id == "mission"
    assert (pose.pose.position.x, pose.pose.position.y, pose.pose.position.z) == (10, -5, 12)
    fix = got["p1/fix"]
    assert fix.latitude == pytest.approx(47.0 - 5 / 111_200, abs=1e-5)
    assert fix.longitude == pytest.approx(8.0 + 10 / 75_900, abs=2e-5)
    assert fix.altitude == pytest.approx(512.0, abs=0.01)
    assert got["p1/actor"].data == "Search"
    vehicle = got["p1/vehicle_state"].status[0]
    assert vehicle.level == b"\x02"  # ERROR: the link to the vehicle is lost
    assert {kv.key: kv.value for kv in vehicle.values}["mode"] == "GUIDED"
    assert got["master"].data == 1
    members = {s.name: s.message for s in got["membership"].status}
    assert members == {"p1": "joined", "p2": "joined"}
    assert got["p1/roles"].data == "leader,tracker"
    said = {s.name: {kv.key: kv.value for kv in s.values} for s in got["membership"].status}
    assert said["p1"]["roles"] == "leader,tracker" and said["p2"]["roles"] == ""
    labels = [m.text for m in got["markers"].markers if m.ns == "labels"]
    assert labels == ["p1 Search"]


@pytest.mark.rclpy
def test_operator_actions_are_off_unless_enabled_and_then_reach_the_station(
    ros_domain: int,
) -> None:
    from std_msgs.msg import String
    from std_srvs.srv import Trigger

    from actorswarm.ros2.node import RosNode

    async def go() -> tuple[list[str], list[tuple[str, list[int]]], bool, Any, Any]:
        loop = asyncio.get_running_loop()
        off_node = RosNode("ground_bridge_off", "/off")
        GroundBridge(off_node, "off", BridgeSettings())
        node = RosNode("ground_bridge", "/sw")
        operator = RosNode("operator")
        for n in (off_node, node, operator):
            n.start()
        sent: list[tuple[str, list[int]]] = []
        commands: list[Any] = []

        class Recorder:
            """The station's side: what the bridge asked it to send."""

            def event(self, name: str, now: float, *, platforms: list[int]) -> None:
                sent.append((name, platforms))

            def send(self, command: Any, platforms: list[int], now: float) -> None:
                sent.append((type(command).__name__, platforms))
                commands.append(command)

        try:
            bridge = GroundBridge(node, "sw", BridgeSettings(commands=True))
            bridge.enable_commands(loop, lambda action: action(Recorder(), 0.0))  # type: ignore[arg-type]
            view = GroundView(t_leave=5.0)
            view.update(_station(100.0), 100.0)
            bridge.publish(view)  # platform 1 and 2 heard: their services appear
            land = operator.call("/sw/p2/land", "std_srvs/srv/Trigger", Trigger.Request())
            await until(land.done, 10.0)
            start = operator.call("/sw/start", "std_srvs/srv/Trigger", Trigger.Request())
            await until(start.done, 10.0)
            event = operator.node.create_publisher(String, "/sw/event", 10)
            for _ in range(100):
                event.publish(String(data="go"))
                if await until(lambda: any(s[0] == "go" for s in sent), 0.1):
                    break
            # A service of the bridge without --commands: never there.
            off = operator.call(
                "/off/p1/land", "std_srvs/srv/Trigger", Trigger.Request(), timeout=1.0
            )
            await until(off.done, 3.0)
            off_answered = off._future is not None
            return bridge.actions, sent, off_answered, land.result(), start.result(), commands
        finally:
            for n in (operator, node, off_node):
                n.close()

    actions, sent, off_answered, land, start, commands = asyncio.run(go())
    assert land.success and land.message == "vehicle_land sent to platform 2"
    assert "vehicle_land sent to platform 2" in actions
    assert ("vehicle_land", [2]) in sent
    assert start.success and ("Start", [1, 2]) in sent
    # Platform 1 runs the script already: the start carries its task's clock, so that
    # platform 2, started now, joins the same task.
    starts = [c for c in commands if isinstance(c, cmds.Start)]
    assert [c.began for c in starts] == [1_796_000_000.5]
    assert ("go", [1, 2]) in sent
    assert not off_answered


@pytest.mark.skipif(HAVE_RCLPY, reason="checks the message given where rclpy is missing")
def test_gs_ros2_without_rclpy_says_what_to_install() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "actorswarm", "gs", "ros2", "--duration", "1", "--insecure"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert out.returncode == 2
    assert "actorswarm[ros2]" in out.stderr and "Traceback" not in out.stderr
