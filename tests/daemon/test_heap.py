"""HeapTrim gives freed heap pages back to the system, once per request."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from actorswarm.daemon.heap import HeapTrim


def _rss_anon_kib() -> int:
    status = Path("/proc/self/status").read_text()
    match = re.search(r"RssAnon:\s+(\d+)", status)
    assert match is not None
    return int(match.group(1))


def test_a_disabled_trim_does_nothing() -> None:
    heap = HeapTrim(enabled=False)
    heap.due()
    heap.wake()
    assert (heap.available, heap.trims) == (False, 0)


def test_it_trims_on_the_first_wake_and_once_per_request() -> None:
    heap = HeapTrim()
    if not heap.available:
        pytest.skip("this C library has no malloc_trim")
    heap.wake()
    heap.wake()
    assert heap.trims == 1, "the first wake trims the start-up's garbage, once"
    heap.due()
    heap.due()
    heap.wake()
    heap.wake()
    assert heap.trims == 2


def test_freed_pages_below_live_objects_go_back_to_the_system() -> None:
    heap = HeapTrim()
    if not heap.available:
        pytest.skip("this C library has no malloc_trim")
    heap.wake()  # start from a trimmed heap
    # 40 MB of malloc'd blocks (over pymalloc's 512-byte limit), one in ten kept alive, so
    # free() cannot give the others back from the top of the heap.
    blocks = [bytearray(2000) for _ in range(20_000)]
    kept = blocks[::10]
    del blocks
    before = _rss_anon_kib()
    heap.due()
    heap.wake()
    after = _rss_anon_kib()
    assert len(kept) == 2000
    assert before - after > 20_000, f"RssAnon {before} -> {after} KiB"
