"""Where the example scripts are: ``examples/`` of this repository, and the shared examples
beside the repository (``../shared/examples``), which every version must keep accepting."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
REPO_EXAMPLES = REPO / "examples"
SHARED_EXAMPLES = REPO / ".." / "shared" / "examples"


def example_params() -> list[object]:
    """Every example script as a test parameter; a skipped one when the shared folder is
    absent (a clone without the ``shared/`` folder beside it)."""
    params: list[object] = [
        pytest.param(path, id=f"examples/{path.name}")
        for path in sorted(REPO_EXAMPLES.glob("*.xml"))
    ]
    if SHARED_EXAMPLES.is_dir():
        params += [
            pytest.param(path, id=f"shared/{path.name}")
            for path in sorted(SHARED_EXAMPLES.glob("*.xml"))
        ]
    else:
        params.append(
            pytest.param(
                None,
                id="shared",
                marks=pytest.mark.skip(
                    reason=f"no shared examples: {SHARED_EXAMPLES.resolve()} does not exist"
                ),
            )
        )
    return params


def pytest_generate_tests(metafunc: pytest.Metafunc) -> None:
    if "example" in metafunc.fixturenames:
        metafunc.parametrize("example", example_params())
