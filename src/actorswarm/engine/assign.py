"""Slot assignment: which member of a released group takes which slot.

The master knows where each chosen member is (each request carries its position) and,
through the successor actor's plugins (:meth:`~actorswarm.runtime.plugin.Plugin.
group_points`), where the slots are. :func:`assign_slots` pairs them by one of two costs,
each solved exactly as a linear assignment problem by
:func:`scipy.optimize.linear_sum_assignment` (a few milliseconds for a thousand members):

* **Least total distance** (``squared=False``), for members that each fly to their place
  on their own (a search's strips, a goto's grid): no two straight paths cross, since
  uncrossing two crossing paths would make the total shorter (the triangle inequality).
* **Least total squared distance** (``squared=True``), for members that close on their
  places *in step* (:attr:`~actorswarm.runtime.plugin.Plugin.group_in_step`: the
  formations, whose members close the gap to a slot in proportion): member ``i`` is at
  ``x_i + s·(g_i - x_i)`` when the group is a fraction ``s`` of the way. The least sum of
  squares means no two members would gain by swapping slots, which is
  ``(x_i - x_j)·(g_i - g_j) ≥ 0`` for every pair, and then their distance at every ``s``
  is at least ``min(|x_i - x_j|, |g_i - g_j|) / √2`` (expand the square: the cross term is
  not negative). Members that start apart and slots that are apart keep apart on the way:
  slots ``spacing`` apart, from a shape whose members were ``spacing`` apart, keep at least
  ``0.71·spacing`` at every instant of a change in step (the concurrent assignment of
  Turpin, Michael and Kumar, "CAPT", 2014). The least plain sum only rules out crossing
  paths, and lets two members in step converge to within any distance: one flies past
  another's slot just as that one arrives (tests/engine/test_assign.py crafts one). The
  squared cost also weighs the longest path most, so no member is left with a much longer
  flight than the rest.

Ties are broken the same way on every master (the solver is deterministic), so a master
that takes over a release mid-way scatters the same slots.
"""

from __future__ import annotations

import importlib.machinery
import importlib.util
import os
from collections.abc import Callable, Sequence
from typing import Any

__all__ = ["assign_slots", "warm_up"]


def warm_up() -> None:
    """Load what :func:`assign_slots` needs (NumPy and the solver), so that its first call
    does not: a real daemon calls it from a worker thread once a script that hands out
    slots is deployed (:mod:`actorswarm.daemon.prefetch`), never on its loop."""
    _solver()


_loaded: list[Callable[..., tuple[Any, Any]]] = []


def _solver() -> Callable[..., tuple[Any, Any]]:
    """SciPy's ``linear_sum_assignment``, loaded once. It is one C extension,
    ``scipy/optimize/_lsap``: imported through :mod:`scipy.optimize` it brings every SciPy
    optimizer with it (48 MiB, 0.6 s idle and up to 2 s on a busy 2-core host), so the
    extension is loaded alone from its file (0.04 MiB, under a millisecond) — the very
    function ``scipy.optimize`` exports. Should SciPy's layout change, the package import
    is the fallback."""
    if _loaded:
        return _loaded[0]
    import numpy  # noqa: F401  # the extension needs NumPy's C API

    solve: Callable[..., tuple[Any, Any]]
    try:
        solve = _lsap_alone()
    except (ImportError, OSError, AttributeError):
        from scipy.optimize import linear_sum_assignment

        solve = linear_sum_assignment
    _loaded.append(solve)
    return solve


def _lsap_alone() -> Callable[..., tuple[Any, Any]]:
    spec = importlib.util.find_spec("scipy")
    if spec is None or not spec.submodule_search_locations:
        raise ImportError("SciPy is not installed")
    for root in spec.submodule_search_locations:
        for suffix in importlib.machinery.EXTENSION_SUFFIXES:
            path = os.path.join(root, "optimize", "_lsap" + suffix)
            if os.path.exists(path):
                ext = importlib.util.spec_from_file_location("_lsap", path)
                if ext is None or ext.loader is None:
                    continue
                module = importlib.util.module_from_spec(ext)
                ext.loader.exec_module(module)
                solve: Callable[..., tuple[Any, Any]] = module.linear_sum_assignment
                return solve
    raise ImportError("SciPy's _lsap extension was not found")


def assign_slots(
    positions: Sequence[Sequence[float]],
    points: Sequence[Sequence[float]],
    *,
    squared: bool = False,
) -> list[int]:
    """For member ``i`` at ``positions[i]`` (``(x, y)`` or ``(x, y, z)``; only x and y
    count), the 1-based slot whose point (``points[j]``, ``(x, y)``) it should take, so that
    the sum of the horizontal distances (``squared``: of their squares) is least (module
    docstring). There must be at least as many points as members (ValueError otherwise);
    with more, the extra slots stay empty."""
    n, m = len(positions), len(points)
    if n > m:
        raise ValueError(f"{n} members cannot share {m} slots")
    if n == 0:
        return []
    # Loaded here: NumPy and the solver weigh ~16 MiB in a daemon that, unless it is a
    # master releasing a formation, never needs them.
    linear_sum_assignment = _solver()
    import numpy as np

    here = np.asarray([(float(p[0]), float(p[1])) for p in positions])
    there = np.asarray([(float(p[0]), float(p[1])) for p in points])
    squares = ((here[:, None, :] - there[None, :, :]) ** 2).sum(axis=-1)
    rows, cols = linear_sum_assignment(squares if squared else np.sqrt(squares))
    out = [0] * n
    for r, c in zip(rows.tolist(), cols.tolist(), strict=True):
        out[r] = c + 1
    return out
