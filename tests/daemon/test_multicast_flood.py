"""Four processes on one multicast group stay quiet: Zenoh 1.10 floods a group whose
members declare the same key expression (thousands of packets a second, measured with four
bare sessions in separate processes), which every key's tail and each member's own pattern
avoid (:mod:`actorswarm.transport.zenoh_transport`). Counted on the loopback of a network
namespace of the test's own, which only these processes use: needs root and ``ip``, as
``tests/daemon/test_netns.py`` (CI runs both as root); skipped with the reason otherwise."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from actorswarm.bench.daemons import read_interface_packets

ROOT = Path(__file__).resolve().parents[2]

#: One member: platform ``argv[1]`` on the group through ``lo``, open for ``argv[2]`` s,
#: with a star's traffic: platform 1 broadcasts, the others send to it, 10 a second.
MEMBER = """
import sys, time
from actorswarm.transport import ZenohSettings, ZenohTransport
settings = ZenohSettings(multicast=False, broadcast="multicast", interface="lo")
with ZenohTransport("flood", int(sys.argv[1]), settings) as t:
    end = time.monotonic() + float(sys.argv[2])
    while time.monotonic() < end:
        me = int(sys.argv[1])
        t.send(None if me == 1 else 1, b"heartbeat")
        time.sleep(0.1)
        t.drain(1000)
"""


def _run(*cmd: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(cmd, capture_output=True, text=True, timeout=15, check=False)


@pytest.fixture
def namespace(tmp_path: Path) -> Iterator[str]:
    if os.geteuid() != 0:
        pytest.skip("a network namespace needs root (CAP_NET_ADMIN); CI runs this as root")
    if shutil.which("ip") is None:
        pytest.skip("`ip` (iproute2) is not installed: run scripts/system-deps.sh as root")
    name = f"aswflood{os.getpid()}"
    made = _run("ip", "netns", "add", name)
    if made.returncode != 0:
        pytest.skip(f"network namespaces are unavailable here: {made.stderr.strip()}")
    try:
        up = _run("ip", "-n", name, "link", "set", "lo", "up")
        assert up.returncode == 0, up.stderr
        yield name
    finally:
        _run("ip", "netns", "del", name)


def _lo_packets(namespace: str, where: Path) -> int:
    dev = _run("ip", "netns", "exec", namespace, "cat", "/proc/net/dev")
    assert dev.returncode == 0, dev.stderr
    where.write_text(dev.stdout)
    return read_interface_packets("lo", where)


def test_four_members_of_a_group_send_only_what_they_are_asked_to(
    namespace: str, tmp_path: Path
) -> None:
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    members = [
        subprocess.Popen(
            ["ip", "netns", "exec", namespace, sys.executable, "-c", MEMBER, str(p), "9"],
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
        )
        for p in (1, 2, 3, 4)
    ]
    try:
        time.sleep(5)  # every member up and joined (Zenoh's import and open take a while)
        before = _lo_packets(namespace, tmp_path / "dev")
        time.sleep(2)
        rate = (_lo_packets(namespace, tmp_path / "dev") - before) / 2
    finally:
        outputs = [m.communicate(timeout=30)[0].decode(errors="replace") for m in members]
    assert all(m.returncode == 0 for m in members), outputs
    # Asked for: 4 members x 10 packets a second, and 4 joins a second each: 56.
    assert 20 < rate < 150, f"{rate:.0f} packets a second on the group's loopback"
