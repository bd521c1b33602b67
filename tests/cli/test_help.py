"""Every command's help, rendered at 80 columns, reads right: nothing of its text eaten as
markup, no paragraph broken before the line is full, nothing cut off, no type names in place
of a value's name, and defaults shown."""

from __future__ import annotations

import itertools
import re
from collections.abc import Iterator
from typing import Any

import pytest
import typer.main
from typer.testing import CliRunner

from actorswarm import __version__
from actorswarm.cli.app import app

WIDTH = 80


def _commands() -> Iterator[tuple[list[str], Any]]:
    def walk(cmd: Any, path: list[str]) -> Iterator[tuple[list[str], Any]]:
        yield path, cmd
        for name, sub in getattr(cmd, "commands", {}).items():
            yield from walk(sub, [*path, name])

    yield from walk(typer.main.get_command(app), [])


COMMANDS = list(_commands())


def _help(path: list[str]) -> str:
    result = CliRunner().invoke(app, [*path, "--help"], env={"COLUMNS": str(WIDTH)})
    assert result.exit_code == 0, result.output
    return result.output


def _flat(text: str) -> str:
    return " ".join(text.split())


def _words(text: str) -> set[str]:
    """Bracketed tokens (``[[areas]]``, ``IDS[@T]``, ``[core]``): what markup would eat."""
    return {m.group(0) for m in re.finditer(r"\S*\[[^\]\s]*\]+\S*", text)}


def _option_text(lines: list[str], opt: str) -> str:
    """The help of option ``opt``: its line and the ones indented under it."""
    out: list[str] = []
    for line in lines[lines.index("Options:") :]:
        if out and (not line.strip() or len(line) - len(line.lstrip()) <= 2):
            break
        head = line[2:] if line.startswith("  ") and not line.startswith("   ") else ""
        if out or head.startswith((f"{opt} ", f"{opt},", f"{opt}/")) or head.strip() == opt:
            out.append(line)
    return _flat(" ".join(out))


@pytest.mark.parametrize(("path", "cmd"), COMMANDS, ids=[" ".join(p) or "-" for p, _ in COMMANDS])
def test_help_reads_right_at_80_columns(path: list[str], cmd: Any) -> None:
    shown = _help(path)
    flat = _flat(shown)
    where = f"actorswarm {' '.join(path)} --help:\n{shown}"
    lines = shown.splitlines()
    assert all(len(line) <= WIDTH for line in lines), where
    assert "…" not in shown, "something was cut off: " + where
    assert "\\[" not in shown, "an escape shown as written: " + where
    options = shown.split("\nOptions:\n", 1)[-1]
    assert "<list[" not in options, "a type name where the value's name should be: " + where
    assert not re.search(r"\s\.(\s|$)", shown), "a dangling ' .': " + where
    # Texts as written: every bracketed token of the command's and its options' help.
    texts = [cmd.help or ""] + [getattr(p, "help", None) or "" for p in cmd.params]
    for text in texts:
        for word in _words(text):
            assert word.replace("\\[", "[") in flat, f"{word!r} was eaten: {where}"
    # No paragraph broken before its line was full: the next line's first word would have
    # fitted on this one (same indentation: the same paragraph or option text).
    for line, after in itertools.pairwise(lines):
        if not line.strip() or not after.strip() or line.rstrip().endswith(":"):
            continue
        indent = len(line) - len(line.lstrip())
        if indent != len(after) - len(after.lstrip()) or (indent == 2 and "  " in line.strip()):
            continue
        first = after.split()[0]
        assert len(line.rstrip()) + 1 + len(first) > WIDTH, (
            f"broken early before {first!r}: {line!r}\n{where}"
        )
    # Defaults shown: every option with a value by default says which.
    for param in cmd.params:
        if getattr(param, "is_flag", False) or param.required or param.name == "help":
            continue
        if param.default not in (None, "") and param.show_default is not False:
            opt = param.opts[0]
            assert "default" in _option_text(lines, opt), f"{opt}: no default shown: {where}"


def test_the_version_option_says_the_version() -> None:
    result = CliRunner().invoke(app, ["--version"])
    assert result.exit_code == 0 and result.output.strip() == f"actorswarm {__version__}"
