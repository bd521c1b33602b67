"""A small ROS 2 robot for the tests, run as its own process: a kinematic point that flies
towards the latest PoseStamped setpoint at a fixed speed and publishes its pose.

``python -m tests.ros2.robot NAMESPACE [--at X,Y] [--speed M/S] [--pose-type TYPE]``:
subscribes ``NAMESPACE/setpoint``, publishes ``NAMESPACE/pose`` (PoseStamped, or Odometry
with ``--pose-type odometry``) at 20 Hz, and serves ``NAMESPACE/takeoff`` and
``NAMESPACE/land`` (std_srvs/Trigger: climb 3 m; descend to the ground). Prints ``ready``
once its node is up. Runs until SIGTERM.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import signal
import sys
import threading


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("namespace")
    parser.add_argument("--at", default="0,0")
    parser.add_argument("--speed", type=float, default=8.0)
    parser.add_argument("--pose-type", choices=("pose", "odometry"), default="pose")
    args = parser.parse_args()

    import rclpy
    from geometry_msgs.msg import PoseStamped
    from nav_msgs.msg import Odometry
    from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
    from std_srvs.srv import Trigger

    rclpy.init(args=["--ros-args", "--disable-external-lib-logs"])
    node = rclpy.create_node("robot", namespace=args.namespace, enable_rosout=False)
    x, y = (float(v) for v in args.at.split(","))
    state = {"p": [x, y, 0.0], "goal": [x, y, 0.0]}
    pose_cls = Odometry if args.pose_type == "odometry" else PoseStamped
    pub = node.create_publisher(pose_cls, "pose", 10)
    dt = 0.05

    def on_setpoint(msg: PoseStamped) -> None:
        p = msg.pose.position
        state["goal"] = [p.x, p.y, p.z]

    def takeoff(request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        state["goal"] = [state["p"][0], state["p"][1], 3.0]
        response.success, response.message = True, "taking off"
        return response

    def land(request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        state["goal"] = [state["p"][0], state["p"][1], 0.0]
        response.success, response.message = True, "landing"
        return response

    def tick() -> None:
        p, g = state["p"], state["goal"]
        d = math.dist(p, g)
        step = min(d, args.speed * dt)
        if d > 0:
            state["p"] = [a + (b - a) * step / d for a, b in zip(p, g, strict=True)]
        msg = pose_cls()
        msg.header.stamp = node.get_clock().now().to_msg()
        msg.header.frame_id = "map"
        pose = msg.pose.pose if args.pose_type == "odometry" else msg.pose
        pose.position.x, pose.position.y, pose.position.z = state["p"]
        pose.orientation.w = 1.0
        pub.publish(msg)

    node.create_subscription(PoseStamped, "setpoint", on_setpoint, 10)
    node.create_service(Trigger, "takeoff", takeoff)
    node.create_service(Trigger, "land", land)
    node.create_timer(dt, tick)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    print("ready", flush=True)
    stop.wait()
    with contextlib.suppress(ExternalShutdownException):
        executor.shutdown(timeout_sec=1.0)
    spinner.join(2.0)
    node.destroy_node()
    rclpy.try_shutdown()
    sys.exit(0)


if __name__ == "__main__":
    main()
