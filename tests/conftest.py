"""Test-wide settings: property tests never fail on timing, and are reproducible in CI."""

from __future__ import annotations

import os

import pytest
from hypothesis import settings

# No per-example deadline: CI machines are shared and slow at times. In CI the examples are
# derived from the test itself (derandomize), so a run is reproducible; locally they vary,
# which finds more.
settings.register_profile("ci", deadline=None, derandomize=True, print_blob=True)
settings.register_profile("dev", deadline=None, print_blob=True)
settings.load_profile("ci" if os.environ.get("CI") else "dev")


def pytest_addoption(parser: pytest.Parser) -> None:
    # tests/scenarios: regenerate the expected logs of the scenario files instead of checking
    parser.addoption(
        "--rewrite-scenarios",
        action="store_true",
        help="rewrite the expected log of every scenario file run (tests/scenarios/*.txt)",
    )
