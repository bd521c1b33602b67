"""The invariant checker's all-or-nothing rule for barrier releases, on hand-made runs: a
pass counts for the firing that gave the platform its place, not for another firing of the
same generation (campaign seeds 2006491 and 2006860, star membership)."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any, cast

from actorswarm.core.events import BarrierFired, BarrierReleased
from actorswarm.core.node import Node
from actorswarm.sim.invariants import InvariantChecker


@dataclass
class _Platform:
    """What the checker reads of a platform."""

    platform: int
    incarnation: int = 0
    errors: list[str] = field(default_factory=list)


def _fired(generation: int, epoch: int, chosen: dict[int, tuple[int, int]]) -> BarrierFired:
    return BarrierFired(
        key=1,
        generation=generation,
        epoch=epoch,
        outcome="complete",
        chosen=chosen,
        not_chosen=(),
        completion=False,
    )


def _released(generation: int, index: int, size: int) -> BarrierReleased:
    return BarrierReleased(
        key=1,
        generation=generation,
        outcome="complete",
        chosen=True,
        part=0,
        index=index,
        size=size,
        data=None,
        gathered=(),
    )


class _Run:
    """Five platforms, all connected at the end; platform 1 may have rebooted."""

    def __init__(self) -> None:
        self.platforms = {p: _Platform(p) for p in range(1, 6)}
        self.checker = InvariantChecker(
            settle=1.0, incarnation_of=lambda p: self.platforms[p].incarnation
        )

    def event(self, t: float, platform: int, event: Any) -> None:
        self.checker.on_event(t, cast(Node, self.platforms[platform]), event)

    def finish(self) -> list[str]:
        def one_component(nodes: Iterable[int]) -> list[frozenset[int]]:
            return [frozenset(nodes)]

        nodes = cast(dict[int, Node], self.platforms)
        return self.checker.finish(20.0, nodes, one_component)


def test_a_second_firing_of_a_generation_does_not_make_the_first_one_partial() -> None:
    run = _Run()
    # Master 1 fires generation 10 for 1, 4 and 5 and passes it; nobody hears the release
    # (it is cut off) and it crashes. Rebooted, it is master again and fires generation 10
    # once more, for 5 alone, which passes it.
    run.event(4.8, 1, _fired(10, 3, {1: (0, 1), 4: (0, 2), 5: (0, 3)}))
    run.event(4.8, 1, _released(10, 1, 3))
    run.platforms[1].incarnation = 1
    run.event(8.4, 1, _fired(10, 6, {5: (0, 1)}))
    run.event(8.5, 5, _released(10, 1, 1))
    assert run.finish() == []


def test_a_rebooted_master_passing_the_same_place_again_is_not_a_pass_of_the_first() -> None:
    run = _Run()
    run.event(6.0, 1, _fired(10, 4, {1: (0, 1), 4: (0, 2), 5: (0, 3)}))
    run.event(6.0, 1, _released(10, 1, 3))
    run.platforms[1].incarnation = 1
    run.event(10.0, 1, _fired(10, 1, {1: (0, 1)}))
    run.event(10.0, 1, _released(10, 1, 1))
    assert run.finish() == []


def test_a_partial_release_is_still_found() -> None:
    run = _Run()
    run.event(4.8, 1, _fired(10, 3, {1: (0, 1), 4: (0, 2), 5: (0, 3)}))
    run.event(4.8, 1, _released(10, 1, 3))
    run.event(4.9, 5, _released(10, 3, 3))
    violations = run.finish()
    assert len(violations) == 1, violations
    assert "partial release of barrier 1/10: platform 4 was chosen (epoch 3)" in violations[0]


def test_a_partial_release_beside_a_second_firing_is_still_found() -> None:
    run = _Run()
    # 5 passed the first firing in its place: 4, chosen by it too, must pass as well.
    run.event(4.8, 1, _fired(10, 3, {1: (0, 1), 4: (0, 2), 5: (0, 3)}))
    run.event(4.9, 5, _released(10, 3, 3))
    run.platforms[1].incarnation = 1
    run.event(8.4, 1, _fired(10, 6, {2: (0, 1)}))
    run.event(8.5, 2, _released(10, 1, 1))
    violations = run.finish()
    assert any("platform 4 was chosen (epoch 3)" in v for v in violations), violations


@dataclass
class _View:
    peers: tuple[int, ...]


@dataclass
class _Master(_Platform):
    """A master as the checker reads it: its view's peers."""

    members: _View = field(default_factory=lambda: _View(()))


def test_a_barrier_of_all_that_leaves_a_member_of_the_view_out_is_found() -> None:
    checker = InvariantChecker(settle=1.0, incarnation_of=lambda p: 0, all_keys={1})
    master = cast(Node, _Master(1, members=_View((2, 3, 4))))
    checker.on_event(1.0, master, _fired(0, 1, {1: (0, 1), 2: (0, 2), 4: (0, 3), 9: (0, 4)}))
    (violation,) = checker.violations
    assert "fired barrier 1/0 of all (epoch 1) without [3] of its view" in violation
    # The whole view chosen (and a platform from beyond it too): nothing to say.
    checker.on_event(2.0, master, _fired(1, 1, {1: (0, 1), 2: (0, 2), 3: (0, 3), 4: (0, 4)}))
    assert len(checker.violations) == 1


def test_a_barrier_that_is_not_of_all_may_choose_some() -> None:
    checker = InvariantChecker(settle=1.0, incarnation_of=lambda p: 0, all_keys={2})
    master = cast(Node, _Master(1, members=_View((2, 3, 4))))
    checker.on_event(1.0, master, _fired(0, 1, {1: (0, 1), 2: (0, 2)}))
    assert checker.violations == []
