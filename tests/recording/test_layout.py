"""The Foxglove layout shipped for recordings: installed with the package, naming only
channels a recording has, and the same as its generator writes."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from actorswarm.recording import LAYOUT, TOPICS

ROOT = Path(__file__).parents[2]


def test_the_layout_names_only_channels_a_recording_has() -> None:
    layout = json.loads(LAYOUT.read_text())
    assert layout["version"] == 1
    text = json.dumps(layout)
    named = set(re.findall(r'"(/[a-z/_]+)', text))
    assert named, "the layout names channels"
    assert named <= set(TOPICS), named - set(TOPICS)
    panels = set(re.findall(r'"panelType": "(\w+)"', text))
    assert panels == {"ThreeDee", "Map", "StateTransitions", "Plot", "Log"}


def test_the_layout_is_what_its_generator_writes() -> None:
    pytest.importorskip("foxglove")
    done = subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "foxglove_layout.py"), "--check"],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
