"""Test-wide settings: property tests never fail on timing, and are reproducible in CI."""

from __future__ import annotations

import asyncio
import os
from collections.abc import Callable, Coroutine
from concurrent.futures import ThreadPoolExecutor
from typing import Any, TypeVar

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


_T = TypeVar("_T")


def _run_in_thread(coro: Coroutine[Any, Any, _T]) -> _T:
    with ThreadPoolExecutor(1) as pool:
        return pool.submit(asyncio.run, coro).result()


@pytest.fixture
def run_async() -> Callable[[Coroutine[Any, Any, _T]], _T]:
    """``asyncio.run`` in a thread of its own: a browser test's session-wide Playwright
    keeps an event loop running in the main thread of the same worker, where
    ``asyncio.run`` would refuse to start."""
    return _run_in_thread
