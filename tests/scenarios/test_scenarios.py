"""Every scenario file of this directory (``*.txt``) as its own test case.

A case runs the file's commands and compares the log with the file's expected part; on a
mismatch it shows a unified diff and the commands that replay or accept the run. With
``pytest --rewrite-scenarios`` the expected parts are regenerated instead (review the diff
with git before committing it).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from . import interpreter

SCENARIOS = sorted(interpreter.HERE.glob("*.txt"))
ROOT = interpreter.HERE.parents[1]


def _shown(path: Path) -> str:
    """The file's path as a user at the repository root would type it."""
    return str(path.relative_to(ROOT))


@pytest.mark.parametrize("path", SCENARIOS, ids=[p.stem for p in SCENARIOS])
def test_scenario(path: Path, request: pytest.FixtureRequest) -> None:
    scenario = interpreter.load(path)
    log = interpreter.run(scenario)
    if request.config.getoption("rewrite_scenarios", default=False):
        interpreter.write(scenario, log)
        return
    if log == scenario.expected:
        return
    shown = _shown(path)
    problem = (
        "has no expected log (no '----' line)"
        if scenario.expected is None
        else "produced a log that differs from the expected one"
    )
    pytest.fail(
        f"{shown} {problem}:\n{interpreter.diff(scenario, log)}\n"
        f"replay:  python -m tests.scenarios.interpreter {shown}\n"
        f"accept:  python -m tests.scenarios.interpreter --rewrite {shown}",
        pytrace=False,
    )


def test_scenario_files_are_found() -> None:
    assert SCENARIOS, f"no scenario files (*.txt) in {interpreter.HERE}"
