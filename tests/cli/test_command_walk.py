"""Every command, walked with the usual mistakes: no traceback, one short error, exit 2.

The commands are enumerated from the typer app, so a new command is walked too; one that
none of the mistakes below applies to must be named in :data:`NOTHING_TO_GET_WRONG`. The
mistakes, by the option they go to: a missing input file, an output path that cannot be
written (its directory is a file) or an existing file where a directory is expected, a busy
port or endpoint, a key directory that is a file.
"""

from __future__ import annotations

import signal
import socket
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import typer.main
from typer.testing import CliRunner

from actorswarm.cli.app import app

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "ready_barrier.xml"

#: Commands none of the mistakes applies to.
NOTHING_TO_GET_WRONG = {"version", "swarm campaign"}

#: Inputs that must exist (arguments and options).
INPUTS = {"file", "files", "recording", "results", "--world", "--config", "--script", "--replay",
          "--daemons-from"}  # fmt: skip
#: Outputs: files, or (DIRS) directories.
OUTPUTS = {"--out", "out", "--json", "--record", "--plot", "--state", "--state-dir", "--dir"}
DIRS = {("demo", "--out"), ("plot", "--out"), ("bench table1", "--out"),
        ("bench table2", "--out"), ("bench table3", "--out"), ("bench all", "--out"),
        ("bench report", "--out"), ("bench table1", "--dir"), ("bench table2", "--dir"),
        ("bench table3", "--dir"), ("bench all", "--dir"), ("bench daemons", "--dir"),
        ("daemon", "--state-dir")}  # fmt: skip
KEY_DIRS = {"--keys", ("keys init", "--dir"), ("keys show", "--dir")}
PORTS = {"--port", "--listen"}

#: What a command needs to get as far as the mistake (its required values, and options that
#: keep it local and short: no multicast, no waiting for a swarm).
GS = ["--insecure", "--no-multicast", "--timeout", "0.2"]
BASE: dict[str, list[str]] = {
    "daemon": ["--platform", "1", "--insecure", "--no-multicast"],
    "autopilot": ["--home", "47.4,8.5,500"],
    "launch": ["{missing}"],
    "sim": ["{example}", "--duration", "1"],
    "demo": ["--platforms", "2"],
    "plot": ["{recording}"],
    "web": ["--replay", "{recording}"],
    "bench report": ["{missing}"],
    "bench plot": ["{missing}", "--out", "{tmp}/x.png"],
    "task check": ["{example}"],
    "task graph": ["{example}"],
    "gs deploy": ["{example}", "--expect", "1", *GS],
    "gs event": ["go", *GS],
    "gs force": ["A", "--to", "B", *GS],
    "gs pause": ["A", *GS],
    "gs activate": ["A", *GS],
    "gs stop": ["A", *GS],
    "gs record": ["{tmp}/rec.jsonl", "--insecure", "--no-multicast", "--duration", "0.2"],
}
#: Options that only make sense together with the one under test.
WITH = {("sim", "--port"): ["--serve"], ("demo", "--port"): ["--serve"]}


def _commands() -> Iterator[tuple[str, Any]]:
    def walk(cmd: Any, path: list[str]) -> Iterator[tuple[str, Any]]:
        if hasattr(cmd, "commands"):
            for name, sub in cmd.commands.items():
                yield from walk(sub, [*path, name])
        else:
            yield " ".join(path), cmd

    yield from walk(typer.main.get_command(app), [])


def _kind(command: str, name: str) -> str | None:
    if name in KEY_DIRS or (command, name) in KEY_DIRS:
        return "keydir"
    if name in INPUTS:
        return "missing"
    if (command, name) in DIRS:
        return "existing"
    if name in OUTPUTS:
        return "unwritable"
    if name in PORTS:
        return "busy"
    return None


def _cases() -> list[tuple[str, str, str]]:
    cases = []
    for command, cmd in _commands():
        found = False
        for param in cmd.params:
            if getattr(param, "is_flag", False):
                continue
            name = param.opts[0] if param.opts and param.opts[0].startswith("-") else param.name
            kind = _kind(command, name)
            if kind is not None:
                cases.append((command, name, kind))
                found = True
        assert found or command in NOTHING_TO_GET_WRONG, (
            f"{command}: no usual mistake applies; walk it or name it in NOTHING_TO_GET_WRONG"
        )
    return cases


@pytest.fixture(scope="module")
def places(tmp_path_factory: pytest.TempPathFactory) -> Iterator[dict[str, Any]]:
    tmp = tmp_path_factory.mktemp("walk")
    afile = tmp / "afile"
    afile.write_text("not a directory\n")
    recording = tmp / "run.jsonl"
    result = CliRunner().invoke(
        app, ["sim", str(EXAMPLE), "--duration", "1", "--no-world", "--record", str(recording)]
    )
    assert recording.exists(), result.output
    tcp = socket.socket()
    tcp.bind(("127.0.0.1", 0))
    tcp.listen(1)
    udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    udp.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as pymavlink binds
    udp.bind(("127.0.0.1", 0))
    yield {
        "tmp": tmp,
        "afile": afile,
        "recording": recording,
        "tcp": tcp.getsockname()[1],
        "udp": udp.getsockname()[1],
    }
    tcp.close()
    udp.close()


def _value(command: str, name: str, kind: str, places: dict[str, Any]) -> str:
    tmp, afile = places["tmp"], places["afile"]
    if kind == "missing":
        return str(tmp / "no-such-file.xml")
    if kind in ("existing", "keydir"):
        return str(afile)
    if kind == "unwritable":
        return str(afile / "x.out")  # its directory is a file
    if command == "autopilot":
        return f"udpin:127.0.0.1:{places['udp']}"
    if name == "--listen":
        return f"tcp/127.0.0.1:{places['tcp']}"
    return str(places["tcp"])


def _args(command: str, name: str, kind: str, places: dict[str, Any]) -> list[str]:
    fill = {
        "missing": str(places["tmp"] / "missing.toml"),
        "example": str(EXAMPLE),
        "recording": str(places["recording"]),
        "tmp": str(places["tmp"]),
    }
    base = [a.format(**fill) for a in BASE.get(command, [])]
    if kind == "keydir" and "--insecure" in base:
        base.remove("--insecure")  # the keys are read only without it
    value = _value(command, name, kind, places)
    if not name.startswith("-"):  # an argument: replace the base's first one
        positional = [i for i, a in enumerate(base) if not a.startswith("-")][:1]
        if positional and (i := positional[0]) == 0:
            base[i] = value
        else:
            base.insert(0, value)
        extra: list[str] = []
    else:
        if name in base:
            i = base.index(name)
            del base[i : i + 2]
        extra = [name, value]
    return [*command.split(), *base, *extra, *WITH.get((command, name), [])]


CASES = _cases()


@pytest.mark.parametrize(("command", "name", "kind"), CASES, ids=[f"{c}:{n}" for c, n, _ in CASES])
def test_a_mistake_gets_one_line_not_a_traceback(
    command: str, name: str, kind: str, places: dict[str, Any], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("XDG_STATE_HOME", str(places["tmp"] / "state"))
    monkeypatch.setenv("XDG_CONFIG_HOME", str(places["tmp"] / "config"))
    args = _args(command, name, kind, places)

    def too_long(signum: int, frame: object) -> None:
        raise TimeoutError(f"actorswarm {' '.join(args)}: still running after 20 s")

    # A mistake not caught runs the command for real (a daemon until stopped): cut it.
    previous = signal.signal(signal.SIGALRM, too_long)
    signal.alarm(20)
    try:
        result = CliRunner().invoke(app, args)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    shown = f"$ actorswarm {' '.join(args)}\n{result.output}"
    assert "Traceback" not in result.output, shown
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        import traceback

        raise AssertionError(
            shown + "".join(traceback.format_exception(result.exception))
        ) from result.exception
    assert result.exit_code == 2, shown
    if "Usage:" in result.output:  # typer's own usage error, in its box: clean too
        assert "No such option" not in result.output, "the test's command line is wrong"
        return
    lines = [line for line in result.output.splitlines() if line.strip()]
    errors = [line for line in lines if not line.startswith("WARNING: --insecure")]
    assert 1 <= len(errors) <= 3, shown  # a line, and at most the hint of what to do
