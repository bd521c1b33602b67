"""Slot assignment by least total distance, and branch placement of a group's members."""

from __future__ import annotations

import itertools
import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from actorswarm.dsl import check
from actorswarm.engine.assign import assign_slots
from actorswarm.engine.plan import Plan

XY = tuple[float, float]


def _total(
    positions: list[tuple[float, float]], points: list[tuple[float, float]], slots: list[int]
) -> float:
    return sum(math.dist(p, points[s - 1]) for p, s in zip(positions, slots, strict=True))


def test_each_member_takes_the_near_slot() -> None:
    positions = [(100.0, 0.0), (0.0, 0.0), (50.0, 0.0)]
    points = [(0.0, 10.0), (50.0, 10.0), (100.0, 10.0)]
    assert assign_slots(positions, points) == [3, 1, 2]


def test_extra_slots_stay_empty_and_too_few_are_refused() -> None:
    assert assign_slots([(9.0, 9.0)], [(0.0, 0.0), (10.0, 10.0)]) == [2]
    assert assign_slots([], [(0.0, 0.0)]) == []
    with pytest.raises(ValueError, match="2 members cannot share 1 slots"):
        assign_slots([(0.0, 0.0), (1.0, 1.0)], [(0.0, 0.0)])


def _crosses(
    a: tuple[float, float], b: tuple[float, float], c: tuple[float, float], d: tuple[float, float]
) -> bool:
    """Whether segments ab and cd properly cross."""

    def side(p: XY, q: XY, r: XY) -> float:
        return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])

    return side(a, b, c) * side(a, b, d) < -1e-9 and side(c, d, a) * side(c, d, b) < -1e-9


def _apart(points: list[XY]) -> bool:
    """No two points closer than 1 mm: two slots at (almost) one place make two assignments
    equally short, and the one chosen may "cross" at that shared end."""
    return all(math.dist(p, q) > 1e-3 for p, q in itertools.combinations(points, 2))


points_st = st.lists(
    st.tuples(st.floats(-500, 500), st.floats(-500, 500)), min_size=2, max_size=7, unique=True
).filter(_apart)


@given(positions=points_st, data=st.data())
def test_the_assignment_is_optimal_and_no_two_paths_cross(
    positions: list[tuple[float, float]], data: st.DataObject
) -> None:
    points = data.draw(
        st.lists(
            st.tuples(st.floats(-500, 500), st.floats(-500, 500)),
            min_size=len(positions),
            max_size=len(positions),
            unique=True,
        ).filter(_apart)
    )
    slots = assign_slots(positions, points)
    assert sorted(slots) == list(range(1, len(points) + 1))
    best = min(
        _total(positions, points, [s + 1 for s in perm])
        for perm in itertools.permutations(range(len(points)))
    )
    assert _total(positions, points, slots) == pytest.approx(best, abs=1e-6)
    for i, j in itertools.combinations(range(len(positions)), 2):
        a, b = positions[i], points[slots[i] - 1]
        c, d = positions[j], points[slots[j] - 1]
        assert not _crosses(a, b, c, d), (i, j)


def _squares(
    positions: list[tuple[float, float]], points: list[tuple[float, float]], slots: list[int]
) -> float:
    return sum(math.dist(p, points[s - 1]) ** 2 for p, s in zip(positions, slots, strict=True))


def _closest_on_the_way(a: XY, b: XY, c: XY, d: XY) -> float:
    """The least distance of two members flying a→b and c→d in step (the same fraction of
    the way at every instant)."""
    dx, dy = a[0] - c[0], a[1] - c[1]
    ex, ey = (b[0] - d[0]) - dx, (b[1] - d[1]) - dy
    denom = ex * ex + ey * ey
    s = 0.0 if denom == 0 else min(1.0, max(0.0, -(dx * ex + dy * ey) / denom))
    return math.hypot(dx + s * ex, dy + s * ey)


@given(positions=points_st, data=st.data())
def test_the_assignment_is_optimal_and_keeps_members_apart_on_the_way(
    positions: list[tuple[float, float]], data: st.DataObject
) -> None:
    """Least sum of squared distances, and two members flying to their slots in step never
    come closer than 1/√2 of the lesser of their distances at the start and at the end."""
    points = data.draw(
        st.lists(
            st.tuples(st.floats(-500, 500), st.floats(-500, 500)),
            min_size=len(positions),
            max_size=len(positions),
            unique=True,
        ).filter(_apart)
    )
    slots = assign_slots(positions, points, squared=True)
    assert sorted(slots) == list(range(1, len(points) + 1))
    best = min(
        _squares(positions, points, [s + 1 for s in perm])
        for perm in itertools.permutations(range(len(points)))
    )
    assert _squares(positions, points, slots) == pytest.approx(best, rel=1e-9, abs=1e-6)
    for i, j in itertools.combinations(range(len(positions)), 2):
        a, b = positions[i], points[slots[i] - 1]
        c, d = positions[j], points[slots[j] - 1]
        floor = min(math.dist(a, c), math.dist(b, d)) / math.sqrt(2.0)
        assert _closest_on_the_way(a, b, c, d) >= floor - 1e-6, (i, j)


def test_a_crafted_near_miss_of_the_least_total_distance_is_avoided() -> None:
    """Two members 20 m apart on a line, slots 20 m apart just beyond: the least plain sum
    (60 m either way) may send the back one through the front one; the least squares (for
    members in step, a formation) sends each straight ahead, 20 m apart all the way."""
    positions = [(0.0, 0.0), (20.0, 0.0)]
    points = [(40.0, 0.0), (60.0, 0.0)]
    crossing = [2, 1]  # the back member to the far slot, past the front one
    assert _total(positions, points, crossing) == pytest.approx(_total(positions, points, [1, 2]))
    assert _closest_on_the_way(positions[0], points[1], positions[1], points[0]) == 0.0
    slots = assign_slots(positions, points, squared=True)
    assert slots == [1, 2]
    assert _closest_on_the_way(positions[0], points[0], positions[1], points[1]) == 20.0


SCRIPT = """<TaskScript name="p" version="1">
  <_ActorsConfig>
    <Actor><_P_Name>A</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name><Plugin><_P_Name>core.idle</_P_Name></Plugin></Bus></OODAConfig></Actor>
    <Actor><_P_Name>B</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name><Plugin><_P_Name>core.idle</_P_Name></Plugin></Bus></OODAConfig></Actor>
    <Actor><_P_Name>C</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name><Plugin><_P_Name>core.idle</_P_Name></Plugin></Bus></OODAConfig></Actor>
  </_ActorsConfig>
  <_TaskConfig>
    <actor name="A">
      <transition name="split" barrierKey="1" sysNum="10">
        <branch cnt="2"><successor actor="B"/></branch>
        <branch cnt="rest"><successor actor="C"/></branch>
      </transition>
      <transition name="two" barrierKey="2" sysNum="5">
        <branch cnt="2"><successor actor="B"/></branch>
        <branch cnt="3"><successor actor="C"/></branch>
      </transition>
    </actor>
  </_TaskConfig>
  <_PlatformActorConfig><platform id="1-10" actor="A"/></_PlatformActorConfig>
</TaskScript>"""


@pytest.mark.parametrize(
    ("event", "index", "size", "expected"),
    [
        ("split", 1, 10, (1, 2)),
        ("split", 2, 10, (2, 2)),
        ("split", 3, 10, (1, 8)),
        ("split", 10, 10, (8, 8)),
        ("split", 2, 2, (2, 2)),
        ("two", 3, 5, (1, 3)),
        ("two", 5, 5, (3, 3)),
        ("two", 7, 7, (5, 5)),  # more than the counts: the last branch takes the extra
        ("two", 0, 5, (0, 0)),
    ],
)
def test_placement_is_the_place_within_the_branch(
    event: str, index: int, size: int, expected: tuple[int, int]
) -> None:
    result = check(SCRIPT)
    assert result.script is not None, result.diagnostics
    transition = next(t for t in result.script.transitions["A"] if t.event == event)
    assert Plan.placement(transition, index, size) == expected
    slot = expected[0]
    if slot:
        target = Plan.successor(transition, index)
        assert target in ("B", "C")
