"""The curated public surface: everything in ``__all__`` exists and is importable."""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "actorswarm"


def _packages_with_all() -> list[str]:
    """Every package of the source tree whose ``__init__`` declares ``__all__``."""
    found = []
    for init in sorted(SRC.rglob("__init__.py")):
        tree = ast.parse(init.read_text(encoding="utf-8"))
        declares = any(
            isinstance(node, ast.Assign | ast.AnnAssign)
            and any(
                isinstance(t, ast.Name) and t.id == "__all__"
                for t in (node.targets if isinstance(node, ast.Assign) else [node.target])
            )
            for node in tree.body
        )
        if declares:
            parts = init.parent.relative_to(SRC.parent).parts
            found.append(".".join(parts))
    return found


PACKAGES = _packages_with_all()


def test_every_package_with_all_is_covered() -> None:
    # the discovery itself must find the packages, or the test below checks nothing
    assert {"actorswarm", "actorswarm.core", "actorswarm.sim", "actorswarm.web"} <= set(PACKAGES)
    assert len(PACKAGES) >= 17


@pytest.mark.parametrize("module", PACKAGES)
def test_all_names_exist(module: str) -> None:
    mod = importlib.import_module(module)
    missing = [name for name in mod.__all__ if not hasattr(mod, name)]
    assert not missing, f"{module}.__all__ names missing attributes: {missing}"
    assert sorted(mod.__all__) == sorted(set(mod.__all__)), "duplicates in __all__"


def test_core_imports_no_io_modules() -> None:
    """The sans-IO core must not import clocks, sockets, threads or asyncio."""

    core = Path(importlib.import_module("actorswarm.core").__file__ or "").parent
    forbidden = {"time", "socket", "threading", "asyncio", "select", "selectors", "datetime"}
    for path in core.rglob("*.py"):  # the subpackages too (core/node/)
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            names: list[str] = []
            if isinstance(node, ast.Import):
                names = [a.name.split(".")[0] for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module:
                names = [node.module.split(".")[0]]
            bad = forbidden.intersection(names)
            assert not bad, f"{path.name} imports {bad}: the core takes time as an input"
            global_random = (
                isinstance(node, ast.Attribute)
                and isinstance(node.value, ast.Name)
                and node.value.id == "random"
                and node.attr != "Random"
            )
            assert not global_random, f"{path.name} draws global randomness: seed an rng instead"


TOP = {"cli", "bench", "web", "launch", "ros2", "recording", "docgen"}


@pytest.mark.parametrize(
    ("package", "above"),
    [
        ("core", {"engine", "runtime", "dsl", "sim", "ground", "world", "plugins", *TOP}),
        ("runtime", {"engine", "dsl", "sim", "ground", "daemon", *TOP}),
        ("world", {"engine", "dsl", "sim", "ground", "daemon", *TOP}),
        (
            "transport",
            {"core", "engine", "runtime", "dsl", "sim", "ground", "world", "daemon", *TOP},
        ),
        ("security", {"engine", "runtime", "dsl", "sim", "ground", "world", "daemon", *TOP}),
        ("ground", {"sim", "daemon", *TOP}),
    ],
)
def test_layers_only_import_downward(package: str, above: set[str]) -> None:
    """docs/design.md §2: dependencies point downward only — every import, those made for
    type checking and those made inside functions too, in every module of the package."""

    root = Path(importlib.import_module("actorswarm").__file__ or "").parent / package
    for path in root.rglob("*.py"):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                parts = node.module.split(".")
                if parts[0] == "actorswarm" and len(parts) > 1:
                    where = path.relative_to(root.parent)
                    assert parts[1] not in above, f"{where} imports {node.module}"
