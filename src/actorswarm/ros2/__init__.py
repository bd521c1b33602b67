"""ROS 2 beside the swarm: the optional extra ``actorswarm[ros2]``.

Theory of operation
-------------------
ROS 2 is a neighbour of the swarm, not its transport: the platforms keep their own protocol
over Zenoh, and this package puts what they do on ROS 2 topics and lets ROS 2 software act
on them. Nothing here is imported unless a ROS 2 feature is asked for (``actorswarm gs
ros2``, a daemon's ``--ros2`` or ``--vehicle ros2``); the rest of actorswarm never imports
ROS. Whichever ``rclpy`` is importable is used — the PyPI wheels of the extra (x86-64
Linux, ROS 2 Kilted) or a sourced ROS 2 installation (Jazzy or newer): :func:`~actorswarm.
ros2.load.load_rclpy` says plainly when there is none or it is too old.

* :mod:`~actorswarm.ros2.node`: one ROS 2 node with its own executor thread. Its callbacks
  never run swarm code: a message goes into a bounded queue (the oldest dropped and counted
  when a publisher floods) and the asyncio loop is woken with ``call_soon_threadsafe``, once
  however many messages come before it runs.
* :mod:`~actorswarm.ros2.platform`: the node of a daemon, handed to plugins as ``ctx.ros2``
  (subscribe, publish, call services), and the built-in plugins ``ros2.topic_event`` and
  ``ros2.publish_state`` (:mod:`~actorswarm.ros2.plugins`).
* :mod:`~actorswarm.ros2.vehicle`: ``--vehicle ros2``, a vehicle whose autopilot or simulator
  speaks ROS 2 (pose in, position setpoints out, optional ``std_srvs/Trigger`` take-off and
  landing), with profiles for Aerostack2 and MAVROS.
* :mod:`~actorswarm.ros2.bridge`: ``actorswarm gs ros2``, the swarm as the ground station
  knows it, on topics under ``/<swarm>/``, and the operator's actions as ROS 2 services when
  enabled.

Only the message packages of ``common_interfaces`` and ``std_srvs`` are used.
"""

from actorswarm.ros2.load import Ros2Error, Ros2Unavailable

__all__ = ["Ros2Error", "Ros2Unavailable"]
