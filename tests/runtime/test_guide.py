"""The plugin guide's example is real: its code runs and its tests pass."""

from __future__ import annotations

import re
import sys
import types
from pathlib import Path
from typing import Any

GUIDE = Path(__file__).resolve().parents[2] / "docs" / "writing-a-plugin.md"


def test_the_guide_example_plugin_passes_its_own_tests() -> None:
    blocks = re.findall(r"```python\n(.*?)```", GUIDE.read_text(), re.S)
    assert len(blocks) == 2, "the guide has the plugin and its tests"
    module = types.ModuleType("battery_watch")
    exec(compile(blocks[0], str(GUIDE), "exec"), module.__dict__)
    sys.modules["battery_watch"] = module
    try:
        tests: dict[str, Any] = {}
        exec(compile(blocks[1], str(GUIDE), "exec"), tests)
        tests["test_conformance"]()
        tests["test_warns_once"]()
    finally:
        del sys.modules["battery_watch"]
