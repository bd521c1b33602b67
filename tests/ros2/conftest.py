"""ROS 2 tests: real rclpy, DDS discovery kept on this machine, one domain per test.

They run in .venv-ros2 (``make ros2-test``, which ``make test`` runs); in an environment
without rclpy the tests marked ``rclpy`` skip, saying so. Every test that starts rclpy —
here or in a child process — gets ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` (no discovery
traffic leaves the host) and a ``ROS_DOMAIN_ID`` of its own (no cross-talk with other tests,
parallel workers or other users of the machine).
"""

from __future__ import annotations

import importlib.util
import itertools
import os

import pytest

HAVE_RCLPY = importlib.util.find_spec("rclpy") is not None

#: Domain IDs 1-100 (Fast DDS's port ranges), spread by process so that two test
#: processes on one host rarely draw the same ones.
_domains = itertools.count((os.getpid() * 7) % 100)


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "rclpy: needs a real rclpy (make ros2-test)")


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    if HAVE_RCLPY:
        return
    skip = pytest.mark.skip(reason="no rclpy here: make ros2-test runs these in .venv-ros2")
    for item in items:
        if "rclpy" in item.keywords:
            item.add_marker(skip)


@pytest.fixture
def ros_domain(monkeypatch: pytest.MonkeyPatch) -> int:
    """A domain of this test's own, set (with localhost-only discovery) in the environment
    that this process's rclpy and its children read."""
    domain = 1 + next(_domains) % 100
    monkeypatch.setenv("ROS_DOMAIN_ID", str(domain))
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    monkeypatch.delenv("ROS_STATIC_PEERS", raising=False)
    return domain
