"""Shared pieces of the web ground station's tests: small simulated swarms, and a headless
Chromium (Debian's ``chromium`` package, driven by Playwright) for the end-to-end tests.

The browser tests are skipped, with the reason, when Playwright or Chromium is missing; CI
installs both (``scripts/system-deps.sh`` and the ``dev`` extra).
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from actorswarm.dsl import load
from actorswarm.sim.tasksim import TaskSim
from actorswarm.web import SimSource, Timeouts

ROOT = Path(__file__).resolve().parents[2]
BRANCH_MERGE = ROOT / "examples" / "branch_merge.xml"
CHROMIUM = os.environ.get("ACTORSWARM_CHROMIUM", "/usr/bin/chromium")


def pytest_configure(config: pytest.Config) -> None:
    # Starlette's test client asks for httpx's successor when the plain httpx is
    # installed; the tests work the same with either.
    config.addinivalue_line("filterwarnings", "ignore:.*install `httpx2`")


@pytest.fixture
def branch_merge() -> Callable[..., SimSource]:
    """``make(speed=..., auto_start=...)``: the paper's branch-and-merge script on ten
    platforms without a world, as a source; commands time out quickly."""

    def make(*, speed: float = 4.0, auto_start: bool = True, seed: int = 1) -> SimSource:
        sim = TaskSim(load(BRANCH_MERGE), seed=seed, auto_start=auto_start)
        return SimSource(sim, speed=speed, timeouts=Timeouts(deploy=5.0, command=4.0))

    return make


def _browser_missing() -> str | None:
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "Playwright for Python is not installed (pip install -e '.[dev]')"
    if not (os.path.exists(CHROMIUM) or shutil.which(CHROMIUM)):
        return f"no Chromium at {CHROMIUM} (apt-get install chromium, or set ACTORSWARM_CHROMIUM)"
    return None


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    """One headless Chromium for the end-to-end tests of a module. Not for the session:
    Playwright's sync API keeps an event loop running in the worker's main thread while it
    is open, and a later test of another module in the same worker that runs one of its own
    (``asyncio.run``, a command in process) would be refused."""
    reason = _browser_missing()
    if reason is not None:
        pytest.skip(reason)
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        chromium = pw.chromium.launch(
            executable_path=CHROMIUM,
            headless=True,
            # Containers have no user namespaces for the sandbox, and a small /dev/shm.
            args=["--no-sandbox", "--disable-dev-shm-usage", "--disable-gpu"],
        )
        try:
            yield chromium
        finally:
            chromium.close()


@pytest.fixture
def page(browser: Any) -> Iterator[Any]:
    """A fresh page at the size of an operator's screen; page errors fail the test."""
    context = browser.new_context(viewport={"width": 1600, "height": 1000})
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    try:
        yield page
    finally:
        context.close()
    assert not errors, f"the page raised: {errors}"
