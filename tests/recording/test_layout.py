"""The Foxglove layout shipped for recordings, in the app's format and the SDK's: installed
with the package, naming only channels a recording has, with the panels the docs promise,
and the same as their generator writes."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from actorswarm.recording import LAYOUT, LAYOUT_SDK, TOPICS

ROOT = Path(__file__).parents[2]


def _topics(layout: dict[str, Any]) -> set[str]:
    return set(re.findall(r'"(/[a-z/_]+)', json.dumps(layout)))


def test_the_app_layout_has_the_panels_and_only_a_recordings_channels() -> None:
    layout = json.loads(LAYOUT.read_text())
    panels = layout["configById"]
    assert {panel.split("!")[0] for panel in panels} == {
        "3D", "map", "StateTransitions", "Plot", "RosOut", "Tab"
    }  # fmt: skip
    named = _topics(layout)
    assert {"/scene", "/fix", "/platforms", "/log", "/metrics"} <= named <= set(TOPICS)

    def leaves(node: Any) -> list[str]:
        if isinstance(node, str):
            return [node]
        return leaves(node["first"]) + leaves(node["second"])

    shown = leaves(layout["layout"])
    tabbed = [t["layout"] for p, c in panels.items() if p.startswith("Tab!") for t in c["tabs"]]
    assert sorted(shown + tabbed) == sorted(panels), "every panel placed, once"


def test_the_sdk_layout_names_only_a_recordings_channels() -> None:
    layout = json.loads(LAYOUT_SDK.read_text())
    assert layout["version"] == 1
    assert _topics(layout) == _topics(json.loads(LAYOUT.read_text()))
    panels = set(re.findall(r'"panelType": "(\w+)"', json.dumps(layout)))
    assert panels == {"ThreeDee", "Map", "StateTransitions", "Plot", "Log"}


def test_the_layouts_are_what_their_generator_writes() -> None:
    pytest.importorskip("foxglove")
    done = subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "foxglove_layout.py"), "--check"],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
