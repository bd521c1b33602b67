"""How the command line's help is laid out: click's plain layout, for every command.

Typer's Rich layout reads help texts as Rich markup (``[[areas]]`` or ``IDS[@T]`` lose their
brackets), keeps the docstrings' line breaks inside paragraphs (broken lines at 80 columns)
and cuts long defaults and option names in its narrow columns (``udpin:127.0.0.1:145…``).
Click's layout rewraps each paragraph to the terminal and prints texts and defaults as
written. Applied once, in :mod:`actorswarm.cli.app`, after every command is registered.
"""

from __future__ import annotations

from typing import Any

__all__ = ["plain_help"]


def plain_help(app: Any) -> None:
    """Click's plain help layout for the typer ``app`` and each of its groups."""
    app.rich_markup_mode = None
    for group in app.registered_groups:
        if group.typer_instance is not None:
            plain_help(group.typer_instance)
