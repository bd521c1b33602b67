"""The security package's public surface and its place in the layers (docs/design.md §2)."""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import actorswarm.security
from actorswarm.security import guard

ABOVE = {"engine", "runtime", "dsl", "sim", "ground", "cli", "world", "plugins", "transport"}


def test_all_names_exist() -> None:
    missing = [n for n in actorswarm.security.__all__ if not hasattr(actorswarm.security, n)]
    assert not missing
    assert len(set(actorswarm.security.__all__)) == len(actorswarm.security.__all__)


def _imports(path: Path) -> set[str]:
    names: set[str] = set()
    for node in ast.parse(path.read_text()).body:
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module)
    return names


def test_security_sits_on_the_core_only() -> None:
    root = Path(importlib.import_module("actorswarm.security").__file__ or "").parent
    for path in root.glob("*.py"):
        for name in _imports(path):
            parts = name.split(".")
            if parts[0] == "actorswarm":
                assert parts[1] in {"core", "security"}, f"{path.name} imports {name}"


def test_the_guard_is_sans_io() -> None:
    forbidden = {"os", "time", "socket", "threading", "asyncio", "random", "pathlib", "datetime"}
    bad = {n.split(".")[0] for n in _imports(Path(guard.__file__))} & forbidden
    assert not bad, f"guard.py imports {bad}: time and bytes are its only inputs"
