"""The one place where the command line turns an expected error into one line.

Every command is wrapped (:func:`guard_commands`, :func:`run_guarded`): an error that bad
input causes — a path that cannot be read or written, a port already taken, a key
directory that is not one, or any of the project's own error types, which carry a message
meant for the user — is printed on stderr as one line naming the thing and what to do, and
the command exits with :data:`EXIT_ERROR`. Anything else is a bug and keeps its traceback.
Free of typer, so ``actorswarm daemon`` uses it without loading the rest of the command
line.
"""

from __future__ import annotations

import errno
import functools
import sys
from collections.abc import Callable
from typing import Any, TypeVar

__all__ = ["EXIT_ERROR", "explain", "guard_commands", "guarded", "run_guarded"]

#: The exit status of a command that could not do what it was asked (a path, a port, a
#: file's content): the same as for a bad command line.
EXIT_ERROR = 2

F = TypeVar("F", bound=Callable[..., Any])

#: What to do about an OSError, by errno.
_ADVICE = {
    errno.EADDRINUSE: "choose another port (0 picks a free one where the option allows)",
    errno.EADDRNOTAVAIL: "choose an address of this machine",
    errno.EACCES: "choose a path (or port) you may use",
    errno.EPERM: "choose a path (or port) you may use",
    errno.EROFS: "choose a writable place",
    errno.ENOSPC: "free some space or choose another place",
    errno.EEXIST: "choose another name or remove it first",
    errno.ENOENT: "check the path (its directory must exist)",
    errno.ENOTDIR: "a part of the path is a file, not a directory",
    errno.EISDIR: "give a file, not a directory",
}


def _os_line(exc: OSError) -> str:
    what = exc.strerror or str(exc)
    if exc.filename is None:
        # Raised with a message of our own (web's "cannot listen on ..."), or a socket's.
        text = str(exc) if not exc.strerror else f"{exc.strerror}"
        advice = _ADVICE.get(exc.errno or 0)
        return f"{text}; {advice}" if advice and advice not in text else text
    name = str(exc.filename)
    if exc.filename2 is not None:
        name = f"{name} -> {exc.filename2}"
    advice = _ADVICE.get(exc.errno or 0)
    return f"{name}: {what}" + (f"; {advice}" if advice else "")


def _is_zenoh(exc: BaseException) -> bool:
    return type(exc).__module__.split(".")[0] in ("zenoh", "_zenoh")


def _zenoh_line(exc: BaseException) -> str:
    import re

    # Zenoh's messages end each part with the Rust source location: not for the user.
    text = re.sub(r" at \S+\.rs:\d+\.?\]?", "", " ".join(str(exc).split())).strip()
    if "Address already in use" in text:
        where = re.search(r"bound to (\S+?):?\s*\[", text)
        endpoint = where.group(1) if where else "the --listen endpoint"
        return (
            f"cannot listen on {endpoint}: Address already in use; choose another --listen "
            "endpoint (or stop the process that holds it)"
        )
    group = re.search(r"UDP link bound to udp/(\S+?):?\s*\[\S+ (.*?)\]?$", text)
    if group is not None and group.group(1).split(".")[0].isdigit():
        first = int(group.group(1).split(".")[0])
        if 224 <= first <= 239:
            place = group.group(1).replace("#iface=", " on interface ")
            return (
                f"cannot join the multicast group {place}: {group.group(2)}; give "
                "--interface IF (a network interface that carries multicast), or put every "
                "platform and ground station on the mesh (--broadcast mesh)"
            )
    return f"the network layer (Zenoh) refused: {text}; check the --listen/--connect endpoints"


def explain(exc: BaseException) -> str | None:
    """The one line for an expected error ``exc``; None when it is a bug (keep the
    traceback)."""
    if isinstance(exc, OSError):
        return _os_line(exc)
    if _is_zenoh(exc):
        return _zenoh_line(exc)
    module = type(exc).__module__
    if isinstance(exc, Exception) and module.split(".")[0] == "actorswarm":
        # The project's own error types carry a message for the user.
        return str(exc).strip().strip('"') or type(exc).__name__
    return None


def run_guarded(call: Callable[[], int]) -> int:
    """``call()``'s exit status, or :data:`EXIT_ERROR` after printing the one line of an
    expected error (see :func:`explain`)."""
    try:
        return call()
    except Exception as exc:
        line = explain(exc)
        if line is None:
            raise
        print(line, file=sys.stderr, flush=True)
        return EXIT_ERROR


def guarded(command: F) -> F:
    """``command`` with its expected errors turned into one line and :data:`EXIT_ERROR`
    (``SystemExit``; typer's own exits pass through)."""

    @functools.wraps(command)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return command(*args, **kwargs)
        except Exception as exc:
            line = explain(exc)
            if line is None:
                raise
            print(line, file=sys.stderr, flush=True)
            raise SystemExit(EXIT_ERROR) from None

    return wrapper  # type: ignore[return-value]


def guard_commands(app: Any) -> None:
    """Wrap every command of the typer ``app`` and of its groups in :func:`guarded` (once:
    at the end of :mod:`actorswarm.cli.app`, after every command is registered)."""
    for info in app.registered_commands:
        if info.callback is not None and not getattr(info.callback, "_guarded", False):
            info.callback = guarded(info.callback)
            info.callback._guarded = True
    for group in app.registered_groups:
        if group.typer_instance is not None:
            guard_commands(group.typer_instance)
