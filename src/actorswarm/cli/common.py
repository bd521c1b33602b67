"""Small parsers the command-line modules share."""

from __future__ import annotations

import typer

__all__ = ["id_list", "int_list_or_count"]


def id_list(text: str, flag: str) -> list[int]:
    """Platform IDs from ``IDS`` (``1-10,12``; ``4`` is platform 4); a clear error and exit
    2 otherwise."""
    from actorswarm.dsl.syntax import platform_ids

    try:
        return sorted(platform_ids(text.strip()))
    except ValueError as exc:
        typer.echo(f"{flag}: {exc}", err=True)
        raise typer.Exit(2) from None


def int_list_or_count(text: str, flag: str) -> list[int]:
    """Platform IDs from ``IDS`` (``1-10,12``) or ``N`` (platforms 1..N); a clear error and
    exit 2 otherwise."""
    stripped = text.strip()
    if stripped.isdigit() and "," not in stripped:
        count = int(stripped)
        if not 1 <= count <= 65535:
            typer.echo(f"{flag}: a count must be 1..65535, got {text!r}", err=True)
            raise typer.Exit(2)
        return list(range(1, count + 1))
    return id_list(stripped, flag)
