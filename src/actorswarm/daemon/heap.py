"""Giving the heap a daemon freed back to the system (glibc's ``malloc_trim``).

A daemon's one-off work (its imports, checking a deployed script, loading its plugins)
allocates and frees a few MiB of small objects. glibc's ``free`` gives memory back only
from the top of the heap, so the pages freed below a live object stay resident: about
1 MiB of a daemon's ``RssAnon`` after its start, and again after a deploy
(docs/benchmarks/README.md, "Daemon memory and imports"). ``malloc_trim(0)`` hands every
whole free page back (``madvise``); it takes a fraction of a millisecond on a daemon's heap.

:class:`HeapTrim` does it at a moment the daemon chooses: asked for (:meth:`HeapTrim.due`)
after such work, done at the next wake (:meth:`HeapTrim.wake`), so the work's garbage is
gone by then. Elsewhere than on glibc (musl, macOS) it does nothing.
"""

from __future__ import annotations

from collections.abc import Callable


def _malloc_trim() -> Callable[[], object] | None:
    """glibc's ``malloc_trim(0)``, or None where the C library has none."""
    try:
        import ctypes  # only here: 0.2 MiB a daemon without glibc need not pay
    except ImportError:  # an interpreter built without ctypes
        return None
    try:
        libc = ctypes.CDLL(None)
    except OSError:
        return None
    trim = getattr(libc, "malloc_trim", None)
    if trim is None:
        return None
    trim.argtypes = [ctypes.c_size_t]
    trim.restype = ctypes.c_int
    return lambda: trim(0)


class HeapTrim:
    """Trims the heap at the next wake after :meth:`due` was called (and on the first
    wake: the start-up's imports).

    Contract: :meth:`wake` trims at most once per call to :meth:`due` (plus the first), and
    never raises; ``trims`` counts the trims done. ``enabled=False`` (or a C library without
    ``malloc_trim``) makes every call a no-op."""

    def __init__(self, *, enabled: bool = True) -> None:
        self._trim = _malloc_trim() if enabled else None
        self._due = self._trim is not None
        self.trims = 0

    @property
    def available(self) -> bool:
        """Whether this C library can trim."""
        return self._trim is not None

    def due(self) -> None:
        """Some one-off work just freed memory: trim at the next wake."""
        self._due = self._trim is not None

    def wake(self) -> None:
        """Called on every wake of the daemon's loop: trim if due."""
        if not self._due or self._trim is None:
            return
        self._due = False
        self._trim()
        self.trims += 1


__all__ = ["HeapTrim"]
