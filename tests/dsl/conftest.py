"""The example scripts: every ``examples/*.xml`` of this repository, which every version
must keep accepting."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
REPO_EXAMPLES = REPO / "examples"


def example_params() -> list[object]:
    """Every example script as a test parameter."""
    return [
        pytest.param(path, id=f"examples/{path.name}")
        for path in sorted(REPO_EXAMPLES.glob("*.xml"))
    ]


def pytest_generate_tests(metafunc: pytest.Metafunc) -> None:
    if "example" in metafunc.fixturenames:
        metafunc.parametrize("example", example_params())
