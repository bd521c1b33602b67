"""The ``actorswarm`` command line (see :mod:`actorswarm.cli.app`)."""

from __future__ import annotations

import os
import sys

__all__ = ["main"]


def main() -> None:
    """The ``actorswarm`` command.

    ``actorswarm daemon`` with a well-formed command line starts the daemon straight away
    (:mod:`actorswarm.cli.daemon_start`): typer, rich and the modules of the other commands
    are never imported into a robot's long-running daemon process. Everything else —
    another command, ``daemon --help``, any usage error — goes to the full command line
    (:mod:`actorswarm.cli.app`).
    """
    args = sys.argv[1:]
    if args[:1] == ["daemon"]:
        from actorswarm.cli.daemon_start import parse_daemon_args, start_daemon
        from actorswarm.cli.errors import run_guarded

        options = parse_daemon_args(args[1:])
        if options is not None:
            try:
                # A busy port or a bad path: one line and exit 2, as every command.
                code = run_guarded(lambda: start_daemon(**options))
            except KeyboardInterrupt:  # before the daemon's own signal handlers: as typer
                print("\nAborted!", file=sys.stderr)
                code = 1
            _leave_now_if_closing(code)
            raise SystemExit(code)
    from actorswarm.cli.app import main as full

    try:
        full()
    except SystemExit as done:
        _leave_now_if_closing(done.code)
        raise
    _leave_now_if_closing(0)


def _leave_now_if_closing(code: object) -> None:
    """Exit with ``code`` at once, without the interpreter's shutdown, when a Zenoh
    session is still closing (a ground-station command or a stopped daemon over lossy
    links: its answers are printed or its backup written, its links' goodbyes take
    seconds; the kernel closes them at the exit). A command that opened no session never
    imported Zenoh: nothing to look at."""
    transport = sys.modules.get("actorswarm.transport.zenoh_transport")
    if transport is None or not transport.closing():
        return
    if isinstance(code, str):  # SystemExit("message"): said on stderr, status 1
        print(code, file=sys.stderr)
    status = code if isinstance(code, int) else 0 if code is None else 1
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status)
