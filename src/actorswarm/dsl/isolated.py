"""A task script checked in a child process: :func:`check_isolated`.

A daemon checks every script deployed to it, and the one it kept, before it runs it. The
checker (the XML parser, the builder, the rules, the feasibility analysis, the listing of
installed plugins) is 1.1–1.4 MiB of Python a daemon would otherwise carry for as long as
it runs, for a check it makes once per mission. :func:`check_isolated` runs the checker in
a fresh interpreter (``python -m actorswarm.dsl.isolated``, with the daemon's own import
path and environment, so it finds the same plugins), which sends back the script's model
or its first diagnostic; the daemon never imports the checker. A deploy takes the child's
start-up longer (a few hundred milliseconds). :func:`check_in_process` is the same verdict
in the calling process (the simulator and the tests, where a process per platform and
deploy would cost more than it saves).

Both return the :class:`~actorswarm.dsl.model.TaskScript` or raise :class:`ScriptRefused`
with the first diagnostic, ``file:line:col: message``.
"""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
from collections.abc import Callable
from types import MappingProxyType
from typing import Any

import msgspec

from actorswarm.dsl.model import TaskScript, frozen_map

__all__ = [
    "ScriptChecker",
    "ScriptRefused",
    "check_in_process",
    "check_isolated",
    "check_isolated_async",
]

#: What a checker is: (script text, the name diagnostics give it) -> its model.
ScriptChecker = Callable[[str, str], TaskScript]

#: Longest a child check may take (seconds) before the script is refused.
CHECK_TIMEOUT = 60.0


class ScriptRefused(ValueError):
    """The script is invalid (or could not be checked); the message is the first
    diagnostic."""


class _Verdict(msgspec.Struct, frozen=True):
    """What the child sends back: the model, or why not."""

    script: TaskScript | None = None
    first: str = ""


def _first(result: Any) -> str:
    return next((str(d) for d in result.diagnostics), "the script is invalid")


def check_in_process(text: str, path: str) -> TaskScript:
    """The checker's verdict on ``text`` in this process (see the module's docstring)."""
    from actorswarm.dsl.checker import check  # imported on the first check only

    result = check(text, path=path)
    if result.script is None or not result.ok:
        raise ScriptRefused(_first(result))
    return result.script


def _encode_hook(obj: Any) -> Any:
    if isinstance(obj, MappingProxyType):
        return dict(obj)
    raise NotImplementedError(f"cannot send {type(obj).__name__}")


def _refreeze(obj: Any) -> Any:
    """The model as the checker makes it: mappings read-only again (they arrive as dicts)."""
    if isinstance(obj, dict):
        return frozen_map({k: _refreeze(v) for k, v in obj.items()})
    if isinstance(obj, tuple):
        return tuple(_refreeze(v) for v in obj)
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        changes = {f.name: _refreeze(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
        return dataclasses.replace(obj, **changes)
    return obj


def _child() -> tuple[list[str], dict[str, str]]:
    """The child's command and environment: it imports what this process would, the same
    package and the same plugins."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p)
    return [sys.executable, "-m", "actorswarm.dsl.isolated"], env


def _request(text: str, path: str) -> bytes:
    return msgspec.msgpack.encode({"text": text, "path": path})


def _answer(path: str, returncode: int, stdout: bytes, stderr: bytes) -> TaskScript:
    """The model the child sent back, or ScriptRefused saying why not."""
    if returncode != 0:
        why = stderr.decode("utf-8", errors="replace").strip().splitlines()
        raise ScriptRefused(
            f"{path}: the checker failed (exit {returncode}): {why[-1] if why else ''}"
        )
    try:
        verdict = msgspec.msgpack.decode(stdout, type=_Verdict)
    except msgspec.DecodeError as exc:
        raise ScriptRefused(f"{path}: the checker's answer is unreadable: {exc}") from exc
    if verdict.script is None:
        raise ScriptRefused(verdict.first or f"{path}: the script is invalid")
    script: TaskScript = _refreeze(verdict.script)
    return script


def check_isolated(text: str, path: str, *, timeout: float = CHECK_TIMEOUT) -> TaskScript:
    """The checker's verdict on ``text`` from a child interpreter (see the module's
    docstring). A child that fails, hangs past ``timeout`` seconds or answers garbage
    refuses the script, saying so; when no child can be started at all, the script is
    checked in this process. Blocks the caller while the child runs: an event loop uses
    :func:`check_isolated_async`."""
    command, env = _child()
    try:
        done = subprocess.run(
            command,
            input=_request(text, path),
            capture_output=True,
            timeout=timeout,
            env=env,
            check=False,
        )
    except OSError:
        # No interpreter to start (an embedded Python, a sandbox without fork): the check
        # itself matters more than the memory it keeps.
        return check_in_process(text, path)
    except subprocess.TimeoutExpired as exc:
        raise ScriptRefused(f"{path}: the checker did not answer in {timeout:g} s") from exc
    return _answer(path, done.returncode, done.stdout, done.stderr)


async def check_isolated_async(
    text: str, path: str, *, timeout: float = CHECK_TIMEOUT
) -> TaskScript:
    """:func:`check_isolated` for an event loop: the loop keeps running (heartbeats, the
    swarm's packets) while the child checks; same verdicts. A child past ``timeout`` is
    killed."""
    import asyncio

    command, env = _child()
    try:
        child = await asyncio.create_subprocess_exec(
            *command,
            stdin=asyncio.subprocess.PIPE,
            stdout=asyncio.subprocess.PIPE,
            stderr=asyncio.subprocess.PIPE,
            env=env,
        )
    except OSError:
        return check_in_process(text, path)  # as check_isolated: no child to start
    try:
        stdout, stderr = await asyncio.wait_for(child.communicate(_request(text, path)), timeout)
    except TimeoutError as exc:
        child.kill()
        await child.wait()
        raise ScriptRefused(f"{path}: the checker did not answer in {timeout:g} s") from exc
    return _answer(path, child.returncode or 0, stdout, stderr)


def main() -> None:
    """The child: a msgpack ``{"text", "path"}`` on stdin, a :class:`_Verdict` on stdout."""
    request = msgspec.msgpack.decode(sys.stdin.buffer.read(), type=dict[str, str])
    try:
        verdict = _Verdict(script=check_in_process(request["text"], request["path"]))
    except ScriptRefused as exc:
        verdict = _Verdict(first=str(exc))
    sys.stdout.buffer.write(msgspec.msgpack.Encoder(enc_hook=_encode_hook).encode(verdict))


if __name__ == "__main__":
    main()
