"""The installed entry points of one group, read without :mod:`importlib.metadata`.

A platform lists the plugins of group ``actorswarm.plugins`` once, when its first script is
checked (:mod:`actorswarm.runtime.registry`, :mod:`actorswarm.dsl.plugins`).
:mod:`importlib.metadata` would do it, but it imports about forty modules (``email``,
``zipfile``, ``csv``, ``calendar``, ``tempfile``, ``importlib.resources``…) that stay in the
daemon's memory for the rest of its run: 1.2 MiB resident, for reading a few small text
files (docs/benchmarks/README.md, "Daemon memory and imports").

What an installer leaves on ``sys.path`` is what is read here, the way
:mod:`importlib.metadata` reads it: each folder on ``sys.path`` (``""`` is the current
one), in order; in it, each ``<name>-<version>.dist-info`` or ``<name>.egg-info`` folder
and its ``entry_points.txt`` (an INI text: ``[group]`` headers, ``name = value`` lines,
``#`` comments; a line without ``=``, on which :mod:`importlib.metadata` raises, is
skipped). A distribution found a second time (its normalized name seen
in an earlier folder) is skipped, as :mod:`importlib.metadata` shadows it. When
``sys.path`` holds anything this does not read (a zip archive or an egg file), the whole
listing is :mod:`importlib.metadata`'s instead, so an unusual environment never lists
less.

Contract: :func:`entry_points` gives the same entry points (name, value, distribution) as
``importlib.metadata.entry_points(group=group)`` (a test compares them on this
environment and on made-up distributions); :meth:`EntryPoint.load` imports what the value
names, as :meth:`importlib.metadata.EntryPoint.load` does.
"""

from __future__ import annotations

import importlib
import os
import re
import sys
from dataclasses import dataclass
from typing import Final

__all__ = ["Distribution", "EntryPoint", "entry_points"]

#: ``module``, ``module:attr`` or ``module:attr.attr``, then optional ``[extras]``.
_VALUE: Final = re.compile(
    r"(?P<module>[\w.]+)\s*(:\s*(?P<attr>[\w.]+)\s*)?((?P<extras>\[.*\])\s*)?$"
)
_SUFFIXES: Final = (".dist-info", ".egg-info")


@dataclass(frozen=True, slots=True)
class Distribution:
    """The installed distribution an entry point comes from: ``name`` and ``version`` as its
    folder spells them (``version`` empty when the folder's name does not carry one), and
    that folder (None when :mod:`importlib.metadata` listed it)."""

    name: str
    version: str
    path: str | None = None

    def display(self) -> str:
        """``name version`` as the distribution's own metadata spells them (``Name:`` and
        ``Version:`` of its ``METADATA`` or ``PKG-INFO``; ``waves-one`` where the folder
        says ``waves_one``), for messages; the folder's spelling when it cannot be read."""
        headers = {"Name": self.name, "Version": self.version}
        for file in ("METADATA", "PKG-INFO"):
            if self.path is None:
                break
            try:
                with open(os.path.join(self.path, file), encoding="utf-8") as text:
                    for line in text:
                        if not line.strip():
                            break  # the headers end at the first empty line
                        key, _, value = line.partition(":")
                        if key in headers and value.strip():
                            headers[key] = value.strip()
                break
            except (OSError, UnicodeDecodeError):
                continue
        return " ".join(part for part in (headers["Name"], headers["Version"]) if part)


@dataclass(frozen=True, slots=True)
class EntryPoint:
    """One entry point: ``name = value`` in ``group`` of ``dist``."""

    name: str
    value: str
    group: str
    dist: Distribution | None

    def load(self) -> object:
        """Import the module the value names and return its attribute (or the module).
        Raises ``ValueError`` for a value that names nothing importable, and whatever the
        import raises."""
        match = _VALUE.match(self.value)
        if match is None:
            raise ValueError(f"entry point {self.name!r}: {self.value!r} is not module:attr")
        obj: object = importlib.import_module(match["module"])
        attr = match["attr"]
        for part in attr.split(".") if attr else ():
            obj = getattr(obj, part)
        return obj


def entry_points(*, group: str) -> list[EntryPoint]:
    """The entry points of ``group`` of every distribution installed on ``sys.path``, in
    ``sys.path`` order (see the module's documentation)."""
    folders: list[str] = []
    for entry in sys.path:
        folder = entry or "."
        if os.path.isdir(folder):
            folders.append(folder)
        elif os.path.exists(folder):  # a zip or an egg: importlib.metadata reads those
            return _from_importlib(group)
    found: list[EntryPoint] = []
    seen: set[str] = set()
    for folder in folders:
        try:
            names = sorted(os.listdir(folder))
        except OSError:
            continue
        for info in names:
            if not info.endswith(_SUFFIXES):
                continue
            stem = info.rsplit(".", 1)[0]
            name, _, rest = stem.partition("-")
            key = _normalize(name)
            if key in seen:
                continue
            path = os.path.join(folder, info)
            if not os.path.isdir(path):
                continue
            seen.add(key)
            try:
                with open(os.path.join(path, "entry_points.txt"), encoding="utf-8") as text:
                    lines = text.read().splitlines()
            except (OSError, UnicodeDecodeError):
                continue
            dist = Distribution(name, rest.partition("-")[0], path)
            found.extend(_section(lines, group, dist))
    return found


def _section(lines: list[str], group: str, dist: Distribution) -> list[EntryPoint]:
    """The ``name = value`` pairs of section ``[group]`` of an ``entry_points.txt``."""
    out: list[EntryPoint] = []
    section = None
    for raw in lines:
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        if line.startswith("[") and line.endswith("]"):
            section = line[1:-1].strip()
            continue
        if section != group or "=" not in line:
            continue
        name, _, value = line.partition("=")
        out.append(EntryPoint(name.strip(), value.strip(), group, dist))
    return out


def _normalize(name: str) -> str:
    """A distribution's name as :mod:`importlib.metadata` compares them (PEP 503, with
    ``_``)."""
    return re.sub(r"[-_.]+", "-", name).lower().replace("-", "_")


def _from_importlib(group: str) -> list[EntryPoint]:
    from importlib import metadata

    out: list[EntryPoint] = []
    for ep in metadata.entry_points(group=group):
        dist = ep.dist
        out.append(
            EntryPoint(
                ep.name,
                ep.value,
                group,
                None if dist is None else Distribution(dist.name, dist.version),
            )
        )
    return out
