"""The daemon's ROS 2 node for plugins: readers fed from the loop, a flood bounded and
counted, the built-in plugins, and the daemon's options."""

from __future__ import annotations

import asyncio
import time
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest
from tests.ros2.conftest import HAVE_RCLPY
from tests.ros2.helpers import until
from typer.testing import CliRunner

from actorswarm.cli.app import app
from actorswarm.daemon.launch import LocalSwarm
from actorswarm.ros2.daemon import ros2_options
from actorswarm.ros2.plugins import PublishState, TopicEvent, matches
from actorswarm.testing import make_context

runner = CliRunner()


def _detection(kind: str, score: float) -> Any:
    hypothesis = SimpleNamespace(class_id=kind, score=score)
    return SimpleNamespace(
        detections=[SimpleNamespace(results=[SimpleNamespace(hypothesis=hypothesis)])]
    )


@pytest.mark.parametrize(
    ("field", "op", "value", "passed"),
    [
        ("detections.0.results.0.hypothesis.class_id", "eq", "person", True),
        ("detections.0.results.0.hypothesis.class_id", "ne", "person", False),
        ("detections.0.results.0.hypothesis.score", "gt", "0.5", True),
        ("detections.0.results.0.hypothesis.score", "ge", "0.9", False),
        ("detections.0.results.0.hypothesis.class_id", "contains", "ers", True),
        ("", "any", "", True),
    ],
)
def test_the_topic_filter(field: str, op: str, value: str, passed: bool) -> None:
    assert matches(_detection("person", 0.8), field, op, value) is passed


def test_a_filter_on_a_missing_field_names_it() -> None:
    from actorswarm.ros2.load import Ros2Error

    with pytest.raises(Ros2Error, match=r"no field 'detections.1.results' \(at '1'\)"):
        matches(_detection("person", 0.8), "detections.1.results", "eq", "x")


class FakeRos:
    """``ctx.ros2`` for the plugins' unit tests: one reader per topic, what was published."""

    def __init__(self) -> None:
        self.readers: dict[str, Any] = {}
        self.published: list[tuple[str, Any]] = []
        self.reports: list[str] = []

    def subscribe(self, topic: str, type_name: str, *, qos: str = "reliable") -> Any:
        from actorswarm.ros2.platform import Reader

        self.readers[topic] = Reader(topic, 10)
        return self.readers[topic]

    def publish(self, topic: str, type_name: str, message: Any, *, qos: str = "reliable") -> None:
        self.published.append((topic, message))

    def stamp(self) -> Any:
        return SimpleNamespace(sec=0, nanosec=0)

    def report(self, text: str) -> None:
        self.reports.append(text)


def test_topic_event_emits_on_a_match_with_a_cooldown_and_reports_a_bad_field() -> None:
    params = {"topic": "det", "type": "x/msg/Y", "event": "seen", "field": "data", "op": "eq",
              "value": "person", "cooldown": "1"}  # fmt: skip
    plugin = TopicEvent()
    ros = FakeRos()
    ctx = make_context(TopicEvent, params=params, ros2=ros)
    plugin.on_start(ctx)
    reader = ros.readers["det"]
    assert plugin.next_deadline() is None  # nothing waits: the runtime's own schedule
    for data in ("cat", "person", "person"):
        reader._put(SimpleNamespace(data=data))
    assert plugin.next_deadline() == 0.0  # messages wait: step at once
    plugin.step(ctx)
    assert [e.event for e in ctx.drain()] == ["seen"]  # one: the cooldown
    ctx.now = 1.5
    reader._put(SimpleNamespace(data="person"))
    reader._put(SimpleNamespace(other=1))  # no field "data": reported once, not raised
    reader._put(SimpleNamespace(other=2))
    plugin.step(ctx)
    assert [e.event for e in ctx.drain()] == ["seen"]
    assert ros.reports == ["topic det: filter: the message has no field 'data' (at 'data')"]


def test_plugins_without_a_ros2_node_say_what_the_daemon_needs() -> None:
    ctx = make_context(
        params=TopicEvent.bind_params({"topic": "t", "type": "a/msg/B", "event": "e"})
    )
    with pytest.raises(Exception, match="start its daemon with --ros2"):
        TopicEvent().on_start(ctx)


@pytest.mark.rclpy
def test_publish_state_sends_the_actor_and_the_pose() -> None:
    ros = FakeRos()
    vehicle = SimpleNamespace(position=lambda: (1.0, 2.0, 3.0))
    ctx = make_context(PublishState, vehicle=vehicle, ros2=ros)  # type: ignore[arg-type]
    plugin = PublishState()
    plugin.on_start(ctx)
    plugin.step(ctx)
    ctx.now = 0.1  # before the next period (5 Hz): nothing
    plugin.step(ctx)
    topics = [t for t, _ in ros.published]
    assert topics == ["actor", "pose"]
    assert ros.published[0][1].data == ctx.actor
    assert ros.published[1][1].pose.position.z == 3.0


@pytest.mark.rclpy
def test_publish_state_reaches_a_ros2_subscriber_under_the_platforms_namespace(
    ros_domain: int,
) -> None:
    """A real node: the actor, published once at the start and latched, reaches a
    subscriber that comes later; the poses follow at the plugin's rate."""
    from actorswarm.ros2.node import RosNode
    from actorswarm.ros2.platform import PlatformRos

    async def go() -> tuple[Any, Any, str]:
        ros = PlatformRos(1, "sw", asyncio.get_running_loop())
        ros.start()
        watcher = RosNode("watcher")
        watcher.start()
        try:
            vehicle = SimpleNamespace(position=lambda: (1.0, 2.0, 3.0))
            ctx = make_context(PublishState, vehicle=vehicle, ros2=ros)  # type: ignore[arg-type]
            plugin = PublishState()
            plugin.on_start(ctx)  # the actor, before anyone listens
            actor = watcher.subscribe("/sw/p1/actor", "std_msgs/msg/String", qos="latched")
            pose = watcher.subscribe("/sw/p1/pose", "geometry_msgs/msg/PoseStamped")
            got: dict[str, Any] = {}

            def look() -> bool:
                for name, inlet in (("actor", actor), ("pose", pose)):
                    latest = inlet.latest()
                    if latest is not None:
                        got[name] = latest
                return len(got) == 2

            for _ in range(100):  # 0.2 s of the plugin's time a round: a pose each
                plugin.step(ctx)
                ctx.now += 0.2
                if await until(look, 0.1):
                    break
            assert not ros.drain_errors() and not watcher.drain_errors()
            return got.get("actor"), got.get("pose"), ctx.actor
        finally:
            watcher.close()
            ros.close()

    actor, pose, name = asyncio.run(go())
    assert actor is not None and actor.data == name
    assert pose is not None and pose.header.frame_id == "map"
    assert (pose.pose.position.x, pose.pose.position.y, pose.pose.position.z) == (1, 2, 3)


@pytest.mark.rclpy
def test_a_flood_is_bounded_and_counted_and_the_loop_stays_free(ros_domain: int) -> None:
    """A publisher far faster than the plugins read: the reader keeps its newest messages,
    drops and counts the rest, and the loop's other work is not held up."""
    from std_msgs.msg import Int32

    from actorswarm.ros2.node import RosNode
    from actorswarm.ros2.platform import PlatformRos

    async def go() -> tuple[list[int], int, dict[str, Any], float]:
        loop = asyncio.get_running_loop()
        ros = PlatformRos(1, "sw", loop)
        wakes = [0]
        ros.on_wake(lambda: wakes.__setitem__(0, wakes[0] + 1))
        reader = ros.subscribe("/sw/flood", "std_msgs/msg/Int32", keep=10)
        ros.start()
        flooder = RosNode("flooder")
        flooder.start()
        publisher = flooder.publisher("/sw/flood", "std_msgs/msg/Int32")
        try:
            await until(lambda: publisher.get_subscription_count() > 0, 10.0)
            worst = 0.0
            for i in range(3000):
                publisher.publish(Int32(data=i))
                if i % 20 == 0:  # the loop's latency while the flood goes on
                    t = time.monotonic()
                    await asyncio.sleep(0.001)
                    worst = max(worst, time.monotonic() - t - 0.001)
            await until(lambda: ros.node.inlets[0].received >= 500, 5.0)
            await asyncio.sleep(0.2)
            ros.pump()
            got = [m.data for m in reader.take()]
            return got, reader.dropped, ros.status(), worst
        finally:
            flooder.close()
            ros.close()

    got, dropped, status, worst = asyncio.run(go())
    assert len(got) == 10 and got == sorted(got) and got[-1] == 2999  # the newest ten
    # What the daemon's status.json says of its node (key "ros2").
    assert status["node"] == "/sw/p1/platform" and status["errors"] == 0
    inlet = status["topics"]["/sw/flood"]
    assert inlet["received"] >= 500  # DDS's own history (depth 10) drops some first
    # Every message received is accounted for: kept, or dropped by the node's queue (100)
    # or by the reader's (10), and counted.
    assert inlet["dropped"] + dropped + len(got) == inlet["received"]
    assert inlet["dropped"] > 0 and dropped == inlet["readers_dropped"] == 90
    assert worst < 0.05, worst


@pytest.mark.parametrize(
    ("args", "config", "message"),
    [
        (["--ros2-profile", "mavros"], "", "--ros2-profile needs --vehicle ros2"),
        (["--vehicle", "ros2", "--ros2-profile", "px4"], "", "the profiles are generic"),
        (["--ros2"], "[ros2]\nrate = 1000.0\n", "0.5 to 100"),
        (["--ros2"], "[ros2]\ntopic = 'x'\n", "the keys are: domain, profile"),
        (["--vehicle", "boat"], "", "none, sim, mavlink, ros2"),
    ],
)
def test_bad_ros2_options_are_refused(
    args: list[str], config: str, message: str, tmp_path: Path
) -> None:
    extra = []
    if config:
        (tmp_path / "d.toml").write_text(config)
        extra = ["--config", str(tmp_path / "d.toml"), "--vehicle", "ros2"]
    result = runner.invoke(
        app,
        ["daemon", "--platform", "1", "--insecure", "--state-dir", str(tmp_path), *args, *extra],
    )
    assert result.exit_code == 2, result.output
    assert message in result.output and "Traceback" not in result.output


def test_the_ros2_table_starts_from_the_profile() -> None:
    options = ros2_options(
        {"domain": 9, "profile": "aerostack2", "offset": [1, 2, 0], "takeoff_service": "to"},
        vehicle=True,
        profile=None,
        platform=3,
    )
    assert options.domain == 9 and options.vehicle is not None
    assert options.vehicle.pose_topic == "/drone3/self_localization/pose"
    assert options.vehicle.offset == (1.0, 2.0, 0.0)
    assert options.vehicle.takeoff_service == "to"
    assert ros2_options(None, vehicle=False, profile=None, platform=3).vehicle is None


@pytest.mark.skipif(HAVE_RCLPY, reason="checks what happens where rclpy is missing")
def test_without_rclpy_vehicle_ros2_is_refused_and_ros2_runs_on_without(tmp_path: Path) -> None:
    result = runner.invoke(
        app, ["daemon", "--platform", "1", "--insecure", "--vehicle", "ros2",
              "--state-dir", str(tmp_path)],
    )  # fmt: skip
    assert result.exit_code == 2 and "--vehicle ros2: ROS 2 is not available" in result.output
    with LocalSwarm(tmp_path, 1, secure=False) as swarm:
        swarm.start(1, "--ros2")
        swarm.wait("the daemon's status", lambda: bool(swarm.status(1)), timeout=20)
        failed = swarm.events(1, "ros2-failed")
        assert failed and "actorswarm[ros2]" in failed[0]["error"]
        assert swarm.stop(1) == 0
