"""Small parsers and checks the command-line modules share."""

from __future__ import annotations

import asyncio
from collections.abc import Collection, Coroutine
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import typer

from actorswarm.dsl import DEFAULT_MAX_BYTES

if TYPE_CHECKING:
    from actorswarm.dsl import TaskScript
    from actorswarm.world.config import WorldConfig

__all__ = [
    "check_script",
    "id_list",
    "int_list_or_count",
    "output_dir",
    "output_file",
    "output_paths",
    "read_world",
    "run_async",
]


_T = TypeVar("_T")


def run_async(coro: Coroutine[Any, Any, _T]) -> _T:
    """``asyncio.run(coro)``; in a thread of its own when this thread already runs an event
    loop (an application or a notebook calling a command in-process), where ``asyncio.run``
    would refuse to start. Its result or its exception, either way."""
    try:
        asyncio.get_running_loop()
    except RuntimeError:
        return asyncio.run(coro)
    with ThreadPoolExecutor(1, thread_name_prefix="actorswarm-cli") as pool:
        return pool.submit(asyncio.run, coro).result()


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


def read_world(path: Path) -> WorldConfig:
    """The world file at ``path``; its problem (naming the file and the key) and exit 2
    when it cannot be read or is not a valid world."""
    from actorswarm.world.config import WorldError, load_world

    try:
        return load_world(path)
    except (WorldError, OSError) as exc:
        typer.echo(str(exc), err=True)
        raise typer.Exit(2) from None


def check_script(
    path: Path,
    max_bytes: int = DEFAULT_MAX_BYTES,
    areas: Collection[str] | None = None,
    world: WorldConfig | None = None,
) -> tuple[int, TaskScript | None]:
    """Check one script, printing its diagnostics on stderr as ``FILE:LINE:COL: message``:
    (exit status, model or None). Status 2 when the file cannot be read, 1 when the script
    has errors. ``areas``: the world's area names, which every ``area`` param must use
    (None: not checked); ``world``: the world, for the safety warnings
    (:mod:`actorswarm.dsl.safety`)."""
    from actorswarm.dsl import check_file

    try:
        result = check_file(path, max_bytes=max_bytes, areas=areas, world=world)
    except OSError as exc:
        typer.echo(f"{path}: cannot read the file: {exc.strerror or exc}", err=True)
        return 2, None
    for diagnostic in result.diagnostics:
        typer.echo(str(diagnostic), err=True)
    return (0 if result.ok else 1), result.script


def output_dir(path: Path, flag: str) -> Path:
    """The directory ``path`` of option ``flag``, created when missing, checked before any
    work is done (so nothing is computed for a place that cannot hold it); a clear error
    and exit 2 when it cannot be used."""
    import os

    if path.exists() and not path.is_dir():
        typer.echo(f"{flag} {path}: is a file; give a directory (created when missing)", err=True)
        raise typer.Exit(2)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        typer.echo(f"{flag} {path}: cannot create the directory: {exc.strerror or exc}", err=True)
        raise typer.Exit(2) from None
    if not os.access(path, os.W_OK | os.X_OK):
        typer.echo(f"{flag} {path}: the directory is not writable; choose another", err=True)
        raise typer.Exit(2)
    return path


def output_file(path: Path, flag: str) -> Path:
    """The file ``path`` of option ``flag``, checked before any work is done: its directory
    is created when missing and must be writable, and it must not be a directory (an
    existing file is replaced); a clear error and exit 2 otherwise."""
    import os

    parent = path.parent
    problem = ""
    if path.is_dir():
        problem = "is a directory; give a file name"
    else:
        try:
            parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            problem = f"cannot create its directory {parent}: {exc.strerror or exc}"
        else:
            if not os.access(parent, os.W_OK | os.X_OK):
                problem = f"the directory {parent} is not writable; choose another place"
    if problem:
        typer.echo(f"{flag} {path}: {problem}", err=True)
        raise typer.Exit(2)
    return path


def output_paths(flags: dict[str, Path | None], dirs: tuple[str, ...] = ()) -> None:
    """Check every output of a command before it runs (:func:`output_file`, or
    :func:`output_dir` for the flags in ``dirs``); None and ``-`` (stdout) are skipped."""
    for flag, path in flags.items():
        if path is None or str(path) == "-":
            continue
        if flag in dirs:
            output_dir(path, flag)
        else:
            output_file(path, flag)
