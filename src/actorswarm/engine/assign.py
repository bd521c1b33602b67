"""Slot assignment: which member of a released group takes which slot.

The master knows where each chosen member is (each request carries its position) and,
through the successor actor's plugins (:meth:`~actorswarm.runtime.plugin.Plugin.
group_points`), where the slots are. :func:`assign_slots` pairs them so that the total
distance flown is least — the linear assignment problem, solved exactly by
:func:`scipy.optimize.linear_sum_assignment` (a few milliseconds for a thousand members).
The least total distance has a property a swarm needs: no two straight paths from members
to their slots cross, since uncrossing two crossing paths would make the total shorter
(the triangle inequality). Ties are broken the same way on every master (the solver is
deterministic), so a master that takes over a release mid-way scatters the same slots.
"""

from __future__ import annotations

from collections.abc import Sequence

__all__ = ["assign_slots"]


def assign_slots(
    positions: Sequence[Sequence[float]], points: Sequence[Sequence[float]]
) -> list[int]:
    """For member ``i`` at ``positions[i]`` (``(x, y)`` or ``(x, y, z)``; only x and y
    count), the 1-based slot whose point (``points[j]``, ``(x, y)``) it should take, so that
    the sum of the horizontal distances is least. There must be at least as many points as
    members (ValueError otherwise); with more, the extra slots stay empty."""
    n, m = len(positions), len(points)
    if n > m:
        raise ValueError(f"{n} members cannot share {m} slots")
    if n == 0:
        return []
    # Imported here: NumPy and SciPy weigh ~85 MB in a daemon that, unless it is a master
    # releasing a formation, never needs them.
    import numpy as np
    from scipy.optimize import linear_sum_assignment

    here = np.asarray([(float(p[0]), float(p[1])) for p in positions])
    there = np.asarray([(float(p[0]), float(p[1])) for p in points])
    cost = np.linalg.norm(here[:, None, :] - there[None, :, :], axis=-1)
    rows, cols = linear_sum_assignment(cost)
    out = [0] * n
    for r, c in zip(rows.tolist(), cols.tolist(), strict=True):
        out[r] = c + 1
    return out
