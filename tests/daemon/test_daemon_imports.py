"""A daemon imports only what it runs: no command-line framework, no numerics, no web
stack, no plugin discovery before a script is deployed — checked in fresh interpreters,
since whatever a test process imported before would hide it. ``actorswarm daemon`` reads
its options without typer (:mod:`actorswarm.cli.daemon_start`) exactly as the typer
command does, and hands anything else to it. Zenoh is configured for a small robot."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
import typer.main
from typer.testing import CliRunner

from actorswarm.cli.app import app
from actorswarm.cli.daemon_start import OPTIONS, parse_daemon_args
from actorswarm.daemon.launch import free_ports
from actorswarm.transport import ZenohSettings, ZenohTransport
from actorswarm.transport.zenoh_transport import SMALL_ROBOT, SMALL_ROBOT_RUNTIME

#: Never in a daemon's process (unless a plugin of a deployed script imports them).
HEAVY = (
    "typer",
    "rich",
    "click",
    "numpy",
    "scipy",
    "fastapi",
    "starlette",
    "uvicorn",
    "matplotlib",
    "importlib.metadata",
    "actorswarm.cli.app",
    "actorswarm.dsl.checker",
    "pymavlink",
    "pymap3d",
    "cryptography",
)

runner = CliRunner()


def _fresh(code: str, env: dict[str, str] | None = None) -> Any:
    """Run ``code`` in a new interpreter (with ``env`` as its environment when given); it
    prints one JSON value, returned."""
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=False,
        env=env,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout.strip().splitlines()[-1])


def test_importing_the_daemon_loads_no_heavy_module() -> None:
    loaded = _fresh(
        "import json, sys\n"
        "import actorswarm.daemon.run\n"
        f"print(json.dumps([m for m in {HEAVY!r} if m in sys.modules]))\n"
    )
    assert loaded == []


def test_the_mavlink_vehicle_loads_one_dialect_and_no_numerics() -> None:
    """``--vehicle mavlink`` loads pymavlink's generated ArduPilot dialect and nothing else
    of it: not ``mavutil`` (which loads NumPy and every dialect), not pymap3d (NumPy)."""
    loaded = _fresh(
        "import json, sys\n"
        "import actorswarm.daemon.run, actorswarm.vehicles.mavlink.vehicle\n"
        "print(json.dumps(sorted(m for m in sys.modules if m.startswith(('pymavlink', "
        "'numpy', 'pymap3d', 'serial')))))\n"
    )
    assert loaded == [
        "pymavlink",
        "pymavlink.dialects",
        "pymavlink.dialects.v20",
        "pymavlink.dialects.v20.ardupilotmega",
    ], loaded


def test_the_daemon_command_starts_the_daemon_without_the_command_line_framework(
    tmp_path: Path,
) -> None:
    """The console entry point, a real command line: options checked and turned into the
    daemon's options by the real code; only the daemon's run is replaced, to look at what
    the process holds when it would start serving."""
    config = tmp_path / "daemon.toml"
    config.write_text('swarm = "diet"\nmulticast = false\n[core]\nt_leave = 0.8\n')
    argv = ["actorswarm", "daemon", "--platform", "4", "--insecure", "--config", str(config),
            "--listen", "tcp/127.0.0.1:7999", "--state-dir", str(tmp_path / "state")]  # fmt: skip
    got = _fresh(
        "import json, sys\n"
        "import actorswarm.daemon.run as run\n"
        "seen = {}\n"
        "def fake(options):\n"
        f"    seen['heavy'] = [m for m in {HEAVY!r} if m in sys.modules]\n"
        "    seen['options'] = [options.platform, options.swarm, list(options.zenoh.listen),\n"
        "                       options.zenoh.multicast, options.config.t_leave]\n"
        "    return 0\n"
        "run.run_daemon = fake\n"
        f"sys.argv = {argv!r}\n"
        "from actorswarm.cli import main\n"
        "try:\n"
        "    main()\n"
        "except SystemExit as exc:\n"
        "    seen['code'] = exc.code\n"
        "print(json.dumps(seen))\n"
    )
    assert got == {
        "heavy": [],
        "options": [4, "diet", ["tcp/127.0.0.1:7999"], False, 0.8],
        "code": 0,
    }


def test_every_option_of_the_typer_command_is_read_the_same_way() -> None:
    """The reader's table names every option the typer command declares, no more."""
    command = typer.main.get_command(app).commands["daemon"]  # type: ignore[attr-defined]
    declared = {opt for param in command.params for opt in (*param.opts, *param.secondary_opts)}
    assert declared - {"--help"} == set(OPTIONS)


@pytest.mark.parametrize(
    "args",
    [
        [],
        ["--platform", "3"],
        ["--platform=3", "--swarm", "field", "--no-multicast", "--insecure"],
        ["--listen", "tcp/0.0.0.0:7447", "--connect", "tcp/10.0.0.1:7447", "--platform", "9",
         "--connect=tcp/10.0.0.2:7447", "--multicast", "--state-dir", "s", "--keys", "k"],
        ["--platform", "65535", "--vehicle", "sim", "--world", "w.toml", "--config", "c.toml",
         "--fleet", "1-10",
         "--transport", "zenoh"],
        ["--platform", "2", "--vehicle", "mavlink", "--mavlink", "udpin:0.0.0.0:14540",
         "--mavlink-sysid", "7", "--origin", "47.4,8.5,400"],
        ["--platform", "4", "--broadcast", "multicast", "--group", "224.0.0.9:7000",
         "--interface", "wlan0", "--lease", "2.5"],
        ["--platform", "4", "--lease=10"],
        ["--platform", "5", "--relay", "--listen", "tcp/0.0.0.0:7447"],
    ],
)  # fmt: skip
def test_a_well_formed_command_line_reads_as_typer_reads_it(
    args: list[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    passed: dict[str, Any] = {}

    def start_daemon(**options: Any) -> int:
        passed.update(options)
        return 0

    monkeypatch.setattr("actorswarm.cli.daemon_cmd.start_daemon", start_daemon)
    result = runner.invoke(app, ["daemon", *args])
    assert result.exit_code == 0, result.output
    assert parse_daemon_args(args) == passed


@pytest.mark.parametrize(
    "args",
    [
        ["--help"],
        ["--platform", "0"],
        ["--platform", "65536"],
        ["--platform", "three"],
        ["--platform", "3", "--mavlink-sysid", "256"],
        ["--platform", "3", "--mavlink-sysid", "0"],
        ["--platform"],
        ["--platform", "--swarm", "x"],
        ["--platfrm", "3"],
        ["extra"],
        ["--insecure=yes"],
        ["--platform", "3", "--platform", "4"],
        ["--", "--platform", "3"],
        ["--platform", "3", "--lease", "0.01"],
        ["--platform", "3", "--lease", "nan"],
        ["--platform", "3", "--lease", "4s"],
    ],
)
def test_anything_else_is_left_to_the_typer_command(args: list[str]) -> None:
    """Help and every usage error come from typer, as for any other command."""
    assert parse_daemon_args(args) is None


def test_help_and_usage_errors_of_the_daemon_command_are_typers(tmp_path: Path) -> None:
    env = {**os.environ, "COLUMNS": "100", "TERM": "dumb"}
    run = [sys.executable, "-m", "actorswarm", "daemon"]
    helped = subprocess.run(
        [*run, "--help"], capture_output=True, text=True, env=env, timeout=60, check=False
    )
    assert helped.returncode == 0 and "--no-multicast" in helped.stdout
    wrong = subprocess.run(
        [*run, "--platfrm", "3"], capture_output=True, text=True, env=env, timeout=60, check=False
    )
    assert wrong.returncode == 2 and "No such option" in wrong.stderr
    refused = subprocess.run(
        [*run, "--platform", "3", "--swarm", "a/b"],
        capture_output=True, text=True, env=env, timeout=60, check=False, cwd=tmp_path,
    )  # fmt: skip
    assert refused.returncode == 2 and "swarm name 'a/b'" in refused.stderr


# --- Zenoh -------------------------------------------------------------------------------


def test_zenoh_is_configured_for_a_small_robot() -> None:
    cfg = ZenohSettings(extra={"transport/link/tx/batch_size": 4096}).config()
    assert json.loads(cfg.get_json("transport/shared_memory/enabled")) is False
    assert json.loads(cfg.get_json("transport/link/rx/max_message_size")) == 1 << 20
    assert (
        json.loads(cfg.get_json("transport/link/rx/buffer_size"))
        == SMALL_ROBOT["transport/link/rx/buffer_size"]
    )
    # What a deployment says wins.
    assert json.loads(cfg.get_json("transport/link/tx/batch_size")) == 4096


def test_packets_larger_than_a_batch_cross_to_and_from_a_peer_left_at_zenohs_defaults() -> None:
    """A packet larger than the 8 KiB batch (a deploy chunk, the largest the core accepts)
    is fragmented and reassembled, both ways, with a peer configured as Zenoh ships."""
    first, second = (f"tcp/127.0.0.1:{port}" for port in free_ports(2))
    zenoh_defaults = {
        "transport/shared_memory/enabled": True,
        "transport/link/tx/batch_size": 65535,
        "transport/link/rx/buffer_size": 65535,
        "transport/link/rx/max_message_size": 1 << 30,
    }
    small: list[bytes] = []
    default: list[bytes] = []
    packets = [bytes([n % 251]) * n for n in (200, 16_000, 60_000)]
    swarm = f"batch{os.getpid()}"
    with (
        ZenohTransport(swarm, 1, ZenohSettings(listen=(first,), multicast=False)) as one,
        ZenohTransport(
            swarm, 2, ZenohSettings(connect=(first,), multicast=False, extra=zenoh_defaults),
        ) as other,
    ):  # fmt: skip
        end = time.monotonic() + 15
        while time.monotonic() < end and not (set(packets) <= set(small)):
            for data in packets:
                other.send(1, data)
            time.sleep(0.2)
            small += one.drain(100)
        assert set(packets) <= set(small)
    with (
        ZenohTransport(
            swarm, 3, ZenohSettings(listen=(second,), multicast=False, extra=zenoh_defaults),
        ) as three,
        ZenohTransport(swarm, 4, ZenohSettings(connect=(second,), multicast=False)) as ours,
    ):  # fmt: skip
        end = time.monotonic() + 15
        while time.monotonic() < end and not (set(packets) <= set(default)):
            for data in packets:
                ours.send(3, data)
            time.sleep(0.2)
            default += three.drain(100)
        assert set(packets) <= set(default)


_THREADS = (
    "import json, os, time\n"
    "from actorswarm.transport import ZenohSettings, ZenohTransport\n"
    "from actorswarm.daemon.launch import free_ports\n"
    "port, = free_ports(1)\n"
    "end = f'tcp/127.0.0.1:{port}'\n"
    "with ZenohTransport('threads', 1, ZenohSettings(listen=(end,), multicast=False)) as a, \\\n"
    "        ZenohTransport('threads', 2, ZenohSettings(connect=(end,), multicast=False)) as b:\n"
    "    got = []\n"
    "    deadline = time.monotonic() + 15\n"
    "    while not got and time.monotonic() < deadline:\n"
    "        b.send(1, b'x')\n"
    "        time.sleep(0.1)\n"
    "        got = a.drain(10)\n"
    "    names = sorted(open(f'/proc/self/task/{t}/comm').read().strip()\n"
    "                   for t in os.listdir('/proc/self/task'))\n"
    "    print(json.dumps([bool(got), os.environ.get('ZENOH_RUNTIME'),\n"
    "                      [n for n in names if n != 'python']]))\n"
)


def test_zenoh_runs_on_one_thread_unless_the_environment_says_otherwise() -> None:
    """Two sessions linked in one fresh process exchange a packet with Zenoh's pools handed
    over to the application pool of one worker; a ``ZENOH_RUNTIME`` of the environment is
    kept (two workers there, and receive and transmit pools of their own)."""
    env = {k: v for k, v in os.environ.items() if k != "ZENOH_RUNTIME"}
    delivered, runtime, threads = _fresh(_THREADS, env)
    assert delivered and runtime == SMALL_ROBOT_RUNTIME
    # app-0 is the pool's worker; app-1… are blocking threads it starts on demand for
    # the API's synchronous calls (they end when idle). No other pool has a thread.
    assert "app-0" in threads and {name.split("-")[0] for name in threads} == {"app"}
    own = "(app: (worker_threads: 2))"
    delivered, runtime, threads = _fresh(_THREADS, {**env, "ZENOH_RUNTIME": own})
    assert delivered and runtime == own
    assert {"app-0", "app-1", "rx-0", "tx-0"} <= set(threads)
