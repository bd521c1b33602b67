"""The ``actorswarm`` command line (see :mod:`actorswarm.cli.app`)."""

from __future__ import annotations

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

        options = parse_daemon_args(args[1:])
        if options is not None:
            try:
                code = start_daemon(**options)
            except KeyboardInterrupt:  # before the daemon's own signal handlers: as typer
                print("\nAborted!", file=sys.stderr)
                code = 1
            raise SystemExit(code)
    from actorswarm.cli.app import main as full

    full()
