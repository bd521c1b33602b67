"""Finding ``rclpy``: the wheels of the extra, or a sourced ROS 2 installation.

:func:`load_rclpy` imports it once and checks its distribution: ROS 2 Jazzy (rclpy 7) or
newer. Humble and older ship Python 3.10 on their Ubuntu, below what actorswarm needs, and
their rclpy lacks the type-mismatch events the bridge reports. What is missing or too old is
a :class:`Ros2Unavailable` that says what to install or source.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import os
from types import ModuleType
from typing import Any, Final

__all__ = ["DISTROS", "Ros2Error", "Ros2Unavailable", "distro", "load_rclpy", "message_type"]

#: rclpy's major version -> the ROS 2 distribution it belongs to (those supported).
DISTROS: Final[dict[int, str]] = {7: "jazzy", 8: "rolling", 9: "kilted", 10: "rolling"}
#: The oldest rclpy major version supported (Jazzy).
OLDEST: Final = 7
#: Distributions known to be too old, by the ``ROS_DISTRO`` a sourced installation sets.
_OLD: Final = frozenset({"ardent", "bouncy", "crystal", "dashing", "eloquent", "foxy"})
_OLD_TOO: Final = frozenset({"galactic", "humble", "iron"})

INSTALL: Final = (
    "install the extra (pip install 'actorswarm[ros2]', x86-64 Linux) or source a ROS 2 "
    "installation, Jazzy or newer (source /opt/ros/jazzy/setup.bash), in the same shell"
)


class Ros2Error(RuntimeError):
    """Something of ROS 2 cannot be done; the message names the topic, service or type."""


class Ros2Unavailable(Ros2Error):
    """No usable ``rclpy``: the message says what to install or source."""


def _version() -> str | None:
    for name in ("rclpy", "ros-rclpy"):
        try:
            return importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            continue
    return None


def distro() -> str:
    """The ROS 2 distribution of the importable rclpy (``"kilted"``, ``"jazzy"``...), from
    ``ROS_DISTRO`` when sourced, else from rclpy's version; ``"unknown"`` when neither says."""
    named = os.environ.get("ROS_DISTRO", "").strip().lower()
    if named:
        return named
    version = _version()
    if version is None:
        return "unknown"
    return DISTROS.get(int(version.split(".")[0]), f"rclpy {version}")


def load_rclpy() -> ModuleType:
    """``rclpy``, imported; :class:`Ros2Unavailable` when it cannot be, or is too old."""
    try:
        rclpy = importlib.import_module("rclpy")
        importlib.import_module("rclpy.executors")
    except (ImportError, OSError) as exc:
        raise Ros2Unavailable(f"ROS 2 is not available (rclpy: {exc}): {INSTALL}") from None
    version = _version()
    named = os.environ.get("ROS_DISTRO", "").strip().lower()
    too_old = named in _OLD or named in _OLD_TOO
    major = version.split(".")[0] if version else ""
    if major.isdigit():
        too_old = too_old or int(major) < OLDEST
    if too_old:
        raise Ros2Unavailable(
            f"ROS 2 {distro()} (rclpy {version or '?'}) is not supported: Jazzy or newer "
            f"is needed; {INSTALL}"
        )
    return rclpy


def message_type(name: str) -> Any:
    """The message (or service) class named ``name``: ``geometry_msgs/msg/PoseStamped``
    (``geometry_msgs/PoseStamped`` is read as a message). :class:`Ros2Error` naming it when
    it is not importable."""
    parts = name.strip().split("/")
    if len(parts) == 2:
        parts = [parts[0], "msg", parts[1]]
    if len(parts) != 3 or parts[1] not in ("msg", "srv") or not all(parts):
        raise Ros2Error(
            f"{name!r} is not a ROS 2 type name: write PACKAGE/msg/NAME "
            "(e.g. geometry_msgs/msg/PoseStamped) or PACKAGE/srv/NAME"
        )
    package, kind, cls = parts
    try:
        module = importlib.import_module(f"{package}.{kind}")
        found = getattr(module, cls)
    except (ImportError, AttributeError, OSError):
        raise Ros2Error(
            f"the ROS 2 type {name} is not installed here (only common_interfaces and "
            "std_srvs come with the extra; a custom package must be sourced)"
        ) from None
    if not isinstance(found, type):
        raise Ros2Error(f"{name} is not a ROS 2 type")
    return found


def type_name(cls: type) -> str:
    """``geometry_msgs/msg/PoseStamped`` for the class of that message."""
    module = cls.__module__.split(".")
    return f"{module[0]}/{module[1]}/{cls.__name__}"
