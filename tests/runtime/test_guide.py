"""The plugin guide's example is real: its code runs and its tests pass."""

from __future__ import annotations

import re
import sys
import types
from pathlib import Path
from typing import Any

GUIDE = Path(__file__).resolve().parents[2] / "docs" / "writing-a-plugin.md"


def _run_example(name: str, plugin: str, tests_code: str) -> list[str]:
    """Load the example ``plugin`` as module ``name``, run every test of ``tests_code``;
    return the names of the tests run."""
    module = types.ModuleType(name)
    exec(compile(plugin, str(GUIDE), "exec"), module.__dict__)
    sys.modules[name] = module
    try:
        tests: dict[str, Any] = {}
        exec(compile(tests_code, str(GUIDE), "exec"), tests)
        ran = [key for key, value in tests.items() if key.startswith("test_") and callable(value)]
        for key in ran:
            tests[key]()
        return ran
    finally:
        del sys.modules[name]


def test_the_guide_example_plugins_pass_their_own_tests() -> None:
    blocks = re.findall(r"```python\n(.*?)```", GUIDE.read_text(), re.S)
    assert len(blocks) == 4, "the guide has two plugins, each with its tests"
    battery, ring, ring_tests, battery_tests = blocks
    assert _run_example("battery_watch", battery, battery_tests) == [
        "test_conformance",
        "test_warns_once",
    ]
    assert _run_example("ring_watch", ring, ring_tests) == [
        "test_conformance",
        "test_sees_the_jeep_from_its_slot",
        "test_the_master_gives_the_nearest_slots",
    ]
