"""Check a task script, or load it for the task engine.

The pipeline, each stage its own module:

1. :mod:`~actorswarm.dsl.parser` — safe XML parsing into a positioned tree (size limit,
   no DTD or entities); a failure here ends the check with one error;
2. :mod:`~actorswarm.dsl.builder` — the tree against the grammar, values against their
   syntax, into the :mod:`~actorswarm.dsl.model`;
3. :func:`~actorswarm.dsl.rules.check_references` — names, duplicates, counts, plugins and
   their buses and params (``area`` names against the world's, when it is given);
4. :func:`~actorswarm.dsl.rules.check_whole` — reachability and barrier-group feasibility,
   only once 2 and 3 found no error;
5. with a world, :func:`~actorswarm.dsl.safety.check_safety` — warnings about separation,
   the ceiling and areas the script's platforms cannot share — and
   :func:`~actorswarm.dsl.fixedwing.check_fixed_wing`: what fixed-wings cannot fly,
   :func:`~actorswarm.dsl.radio.check_radio`: platforms out of each other's radio reach, and
   :func:`~actorswarm.dsl.takeoff.check_takeoff_fault`: an actor that takes off and does
   not answer an autopilot that never lets it.

A script with any error is refused whole (docs/design.md §4): :func:`check` then returns no model
and :func:`load` raises :class:`~actorswarm.dsl.diagnostics.ScriptError`. Warnings never
refuse a script.
"""

from __future__ import annotations

import os
from collections.abc import Collection
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from actorswarm.dsl import rules
from actorswarm.dsl.builder import build
from actorswarm.dsl.diagnostics import Diagnostic, Report, ScriptError
from actorswarm.dsl.fixedwing import check_fixed_wing
from actorswarm.dsl.model import TaskScript
from actorswarm.dsl.parser import DEFAULT_MAX_BYTES, XmlError, check_size, parse_xml
from actorswarm.dsl.plugins import installed_plugins
from actorswarm.dsl.radio import check_radio
from actorswarm.dsl.safety import check_safety
from actorswarm.dsl.takeoff import check_takeoff_fault

if TYPE_CHECKING:
    from actorswarm.world.config import WorldConfig


@dataclass(frozen=True, slots=True, kw_only=True)
class CheckResult:
    """The outcome of checking one script: its ``errors`` and ``warnings`` in script order,
    and the ``script`` model when there was no error."""

    path: str
    errors: tuple[Diagnostic, ...]
    warnings: tuple[Diagnostic, ...]
    script: TaskScript | None

    @property
    def ok(self) -> bool:
        """True when the script is valid (it may still have warnings)."""
        return not self.errors

    @property
    def diagnostics(self) -> tuple[Diagnostic, ...]:
        """Errors and warnings together, in script order."""
        return tuple(sorted(self.errors + self.warnings, key=lambda d: (d.line, d.col)))


def check(
    source: str | bytes,
    *,
    path: str | os.PathLike[str] = "<script>",
    known_plugins: Collection[str] | None = None,
    max_bytes: int = DEFAULT_MAX_BYTES,
    areas: Collection[str] | None = None,
    world: WorldConfig | None = None,
) -> CheckResult:
    """Check the task script ``source`` (text, or UTF-8 bytes).

    ``path`` is only used in the diagnostics. ``known_plugins`` are the plugin names the
    script may use (default: :func:`~actorswarm.dsl.plugins.installed_plugins`).
    ``max_bytes`` caps the script's size. ``areas`` are the names of the areas of the world
    the script will run in: every ``area`` param must name one of them (or be a rectangle);
    None (the default) leaves names unchecked. ``world``: the world it will fly in, for the
    warnings of :mod:`~actorswarm.dsl.safety`. Never raises for a bad script: everything
    wrong with it is in the result.
    """
    name = os.fspath(path)
    report = Report(name)
    plugins = installed_plugins() if known_plugins is None else known_plugins
    script: TaskScript | None = None
    try:
        root = parse_xml(source, max_bytes=max_bytes)
    except XmlError as exc:
        report.error(exc.pos, exc.message)
    else:
        built = build(root, report, path=name)
        if built is not None:
            script = built.script
            rules.check_references(
                script, report, plugins, all_actors_built=built.all_actors_built, areas=areas
            )
            if not report.has_errors:
                rules.check_whole(script, report)
            if not report.has_errors and world is not None:
                check_safety(script, world, report)
                check_fixed_wing(script, world, report)
                check_radio(script, world, report)
                check_takeoff_fault(script, world, report)
    found = report.sorted()
    errors = tuple(d for d in found if d.severity == "error")
    return CheckResult(
        path=name,
        errors=errors,
        warnings=tuple(d for d in found if d.severity == "warning"),
        script=None if errors else script,
    )


def check_file(
    path: str | os.PathLike[str],
    *,
    known_plugins: Collection[str] | None = None,
    max_bytes: int = DEFAULT_MAX_BYTES,
    areas: Collection[str] | None = None,
    world: WorldConfig | None = None,
) -> CheckResult:
    """:func:`check` the file at ``path``. A file above ``max_bytes`` is refused before it
    is read. ``OSError`` (no such file, no permission) is left to the caller."""
    file = Path(path)
    size = file.stat().st_size
    try:
        check_size(size, max_bytes)
    except XmlError as exc:
        error = Diagnostic(
            path=os.fspath(path), line=exc.pos.line, col=exc.pos.col, message=exc.message
        )
        return CheckResult(path=os.fspath(path), errors=(error,), warnings=(), script=None)
    with file.open("rb") as stream:
        data = stream.read(max_bytes + 1)  # the file may have grown since stat()
    return check(
        data,
        path=path,
        known_plugins=known_plugins,
        max_bytes=max_bytes,
        areas=areas,
        world=world,
    )


def load(
    path: str | os.PathLike[str],
    *,
    known_plugins: Collection[str] | None = None,
    max_bytes: int = DEFAULT_MAX_BYTES,
    areas: Collection[str] | None = None,
) -> TaskScript:
    """The model of the valid task script at ``path``.

    Raises :class:`~actorswarm.dsl.diagnostics.ScriptError` (carrying every diagnostic)
    when the script has any error, and ``OSError`` when the file cannot be read.
    """
    result = check_file(path, known_plugins=known_plugins, max_bytes=max_bytes, areas=areas)
    if result.script is None:
        raise ScriptError(result.diagnostics)
    return result.script
