"""The figures of the paper's §V.A (Tables I–III), to print and plot next to ours.

Table I: two platforms (ODROID-XU4, 2 GB; Jetson TX2, 8 GB), two actors alternating at
1 Hz. Memory is given as a share of the board's RAM; the MB below are that share of 2 GB
and 8 GB. Table II: TX2, swarms of 5–30, "one plugin / five plugins", each figure the mean
of ten repetitions, about 158.6 bytes per packet. Table III: our copy of the paper gives
the per-size values only as a range in the text — "the duration ranges from 382ms to
909ms", growing with the swarm size — so only the two ends are known (5 and 30).
"""

from __future__ import annotations

from typing import NamedTuple

__all__ = [
    "BYTES_PER_PACKET",
    "TABLE1",
    "TABLE2",
    "TABLE3_ENDS",
    "TABLE3_RANGE_MS",
    "Paper1",
    "Paper2",
    "table2",
]


class Paper1(NamedTuple):
    board: str
    cpu_pct: float
    memory_mb: float
    switch_ms: float


TABLE1 = (
    Paper1("ODROID-XU4", 0.25, round(0.013 * 2048, 1), 104.0),
    Paper1("Jetson TX2", 1.11, round(0.004 * 8192, 1), 105.0),
)


class Paper2(NamedTuple):
    transition_ms: float
    master_pps: float
    member_pps: float


#: (case, size, plugins) → the paper's means.
TABLE2: dict[tuple[str, int, int], Paper2] = {}
_ROWS = {
    # size: (switch ms 1/5, master 1/5, non-master 1/5, branch ms 1/5, master 1/5, non 1/5)
    5: ((352, 449), (48, 54), (35, 37), (206, 230), (48, 52), (34, 35)),
    10: ((516, 488), (156, 182), (73, 68), (268, 239), (198, 189), (67, 70)),
    15: ((546, 558), (435, 415), (114, 120), (279, 277), (441, 427), (103, 109)),
    20: ((588, 649), (575, 798), (168, 149), (418, 278), (770, 626), (144, 128)),
    25: ((1246, 1127), (1156, 1008), (178, 195), (429, 443), (1216, 1160), (179, 170)),
    30: ((1332, 1326), (1635, 1509), (220, 194), (529, 458), (1629, 1704), (209, 197)),
}
for _size, (_sw, _swm, _swn, _br, _brm, _brn) in _ROWS.items():
    for _i, _plugins in enumerate((1, 5)):
        TABLE2[("switch", _size, _plugins)] = Paper2(_sw[_i], _swm[_i], _swn[_i])
        TABLE2[("branch", _size, _plugins)] = Paper2(_br[_i], _brm[_i], _brn[_i])

BYTES_PER_PACKET = 158.6

TABLE3_RANGE_MS = (382.0, 909.0)
#: The sizes whose Table III figure the text pins down: the smallest and the largest.
TABLE3_ENDS = {5: 382.0, 30: 909.0}


def table2(case: str, size: int, plugins: int) -> Paper2 | None:
    """The paper's Table II figures for one cell; None where the paper has none."""
    return TABLE2.get((case, size, plugins))
