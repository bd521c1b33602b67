"""Helpers of the ROS 2 tests: wait for a condition while the loop runs."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable


async def until(condition: Callable[[], bool], timeout: float, step: float = 0.02) -> bool:
    """Wait (yielding to the loop) until ``condition()`` or ``timeout`` seconds."""
    end = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > end:
            return False
        await asyncio.sleep(step)
    return True
