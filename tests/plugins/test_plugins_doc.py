"""docs/plugins.md against the built-in plugins: every parameter has its row, with the
words of its ``Param.doc`` (what ``task check`` and the plugin's own help print)."""

from __future__ import annotations

import re
from importlib.metadata import entry_points
from pathlib import Path

DOC = Path(__file__).resolve().parents[2] / "docs" / "plugins.md"
#: A parameter's row: | `name` | kind | default | meaning |
ROW = re.compile(r"^\| `([A-Za-z_]+)` \| .*? \| .*? \| (.*) \|$")


def _rows() -> dict[str, list[str]]:
    rows: dict[str, list[str]] = {}
    for line in DOC.read_text(encoding="utf-8").splitlines():
        match = ROW.match(line)
        if match:
            rows.setdefault(match.group(1), []).append(match.group(2))
    return rows


def _documented_here() -> list[tuple[str, str, str]]:
    """(plugin, param, doc) of the built-ins docs/plugins.md covers (the ROS 2 plugins are
    in docs/ros2.md)."""
    found = []
    for ep in entry_points(group="actorswarm.plugins"):
        if not ep.value.startswith("actorswarm.plugins."):
            continue
        for name, param in ep.load().params.items():
            found.append((ep.name, name, param.doc))
    return sorted(found)


def test_each_parameter_has_its_row() -> None:
    documented = _documented_here()
    assert {"flight.return_home", "track.target", "formation.arrow"} <= {
        plugin for plugin, _, _ in documented
    }
    rows = _rows()
    missing = [
        f"{plugin} {name}: {doc}"
        for plugin, name, doc in documented
        if doc not in rows.get(name, [])
    ]
    assert missing == [], "rows of docs/plugins.md to write again:\n" + "\n".join(missing)
