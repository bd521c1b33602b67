"""End to end: two daemons fly a task script through ``--vehicle ros2`` robots (each a
kinematic ROS 2 robot in its own process) while this test, a separate rclpy process, sees
every platform's pose and actor on the ground bridge's topics (``gs ros2``), fires the
operator's event through the bridge, and raises a perception event on a ROS 2 topic that a
``ros2.topic_event`` plugin turns into a collective switch."""

from __future__ import annotations

import asyncio
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from tests.ros2.helpers import until
from tests.ros2.test_vehicle import robot

from actorswarm.daemon.launch import LocalSwarm

pytestmark = pytest.mark.rclpy


def _bridge(swarm: LocalSwarm) -> subprocess.Popen[str]:
    cmd = [sys.executable, "-m", "actorswarm", "gs", "ros2", "--commands", "--poll", "0.3",
           "--swarm", swarm.swarm, "--keys", str(swarm.keys), "--no-multicast"]  # fmt: skip
    for endpoint in swarm.endpoints:
        cmd += ["--connect", endpoint]
    return subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True)


def test_daemons_fly_ros2_robots_seen_and_commanded_over_ros2(
    ros_domain: int, tmp_path: Path
) -> None:

    with (
        LocalSwarm(tmp_path, 2, swarm="e2e") as swarm,
        robot("/e2e/p1/robot", "--at", "0,0"),
        robot("/e2e/p2/robot", "--at", "6,0"),
    ):
        for p in swarm.platforms:
            swarm.start(p, "--vehicle", "ros2")
        swarm.wait(
            "both robots' poses in status.json",
            lambda: all(swarm.status(p).get("vehicle", {}).get("link") == "up" for p in (1, 2)),
            timeout=20,
        )
        script = str(Path(__file__).with_name("e2e.xml"))
        state = ["--state", str(tmp_path / "gs.json")]
        deployed = swarm.gs("deploy", script, "--expect", "2", *state)
        assert deployed.returncode == 0, deployed.stdout + deployed.stderr
        assert swarm.gs("start", *state).returncode == 0
        bridge = _bridge(swarm)
        try:
            seen, published_at = asyncio.run(_watch_and_command())
        finally:
            bridge.terminate()
            _, bridge_log = bridge.communicate(timeout=15)
        switched = [
            e for p in (1, 2) for e in swarm.events(p, "transition") if e["on"] == "seen_event"
        ]
        started = swarm.events(1, "started")[0]
        # A clean stop closes the node (an executor thread left at exit would abort).
        assert swarm.stop(1) == 0
        assert swarm.events(1, "stopped")
        ros_meters = swarm.status(1)["ros2"]  # written at the stop
    assert started["vehicle"] == "ros2" and started["ros2"] == "/e2e/p1/platform"
    # The node's counters in status.json: the robot's poses (only the newest kept, the rest
    # dropped by design) and the perception topic (nothing dropped); no error.
    assert ros_meters["node"] == "/e2e/p1/platform" and ros_meters["errors"] == 0, ros_meters
    topics = ros_meters["topics"]
    pose = topics["/e2e/p1/robot/pose"]
    assert pose["keep"] == 1 and pose["received"] > 10, topics
    detections = topics["/e2e/detections"]
    assert detections["keep"] >= 100 and detections["received"] >= 1, topics  # "person"
    assert detections["dropped"] == detections["readers_dropped"] == 0, topics
    assert all(c["undecodable"] == 0 for c in topics.values()), topics
    for p in (1, 2):
        assert seen[f"p{p}/actor"] == ["Hover", "Watch", "Found"], (seen, bridge_log)
    # Where each robot is, in the mission frame: above its start, at the take-off height
    # within the take-off plugin's tolerance (1 m: it holds where it got within it).
    assert seen["p1/pose"][:2] == pytest.approx((0.0, 0.0), abs=0.2)
    assert seen["p2/pose"][:2] == pytest.approx((6.0, 0.0), abs=0.2)
    assert all(3.0 <= seen[f"p{p}/pose"][2] <= 4.2 for p in (1, 2)), seen
    assert "operator (ROS 2): event go_event sent to platforms [1, 2]" in bridge_log
    assert len(switched) == 2 and all(e["to"] == "Found" for e in switched)
    # The latency from the ROS 2 message to the last platform's switch (same host clock).
    latency = max(e["t"] for e in switched) - published_at
    assert 0 < latency < 2.0, latency
    print(f"ROS 2 perception message -> collective switch of 2: {1000 * latency:.0f} ms")


async def _watch_and_command() -> tuple[dict[str, Any], float]:
    """What a ROS 2 user's node does: watch the bridge's topics, send the operator's event
    through it, publish a detection."""
    from std_msgs.msg import String

    from actorswarm.ros2.node import RosNode

    node = RosNode("watcher")
    node.start()
    seen: dict[str, Any] = {"p1/actor": [], "p2/actor": []}
    inlets = {
        name: node.subscribe(f"/e2e/{name}", kind, qos=qos)
        for name, kind, qos in (
            ("p1/pose", "geometry_msgs/msg/PoseStamped", "reliable"),
            ("p2/pose", "geometry_msgs/msg/PoseStamped", "reliable"),
            ("p1/actor", "std_msgs/msg/String", "latched"),
            ("p2/actor", "std_msgs/msg/String", "latched"),
        )
    }

    def look(actor: str) -> bool:
        for name, inlet in inlets.items():
            for message in inlet.take():
                if name.endswith("pose"):
                    p = message.pose.position
                    seen[name] = (p.x, p.y, p.z)
                elif not seen[name] or seen[name][-1] != message.data:
                    seen[name].append(message.data)
        return all(seen[f"p{p}/actor"][-1:] == [actor] for p in (1, 2))

    try:
        assert await until(lambda: look("Hover"), 30.0), seen
        event = node.publisher("/e2e/event", "std_msgs/msg/String")
        for _ in range(200):  # until the bridge's subscription matched and the event went
            event.publish(String(data="go_event"))
            if await until(lambda: look("Watch"), 0.5):
                break
        assert look("Watch"), seen
        detections = node.publisher("/e2e/detections", "std_msgs/msg/String")
        await asyncio.sleep(1.0)  # the plugins' subscriptions match the publisher
        detections.publish(String(data="cat"))  # filtered out
        published_at = time.monotonic()
        detections.publish(String(data="person"))
        assert await until(lambda: look("Found"), 10.0), seen
        return seen, published_at
    finally:
        node.close()
