"""The master's tallies of an open generation follow its requests through any sequence of
requests, re-requests and departures (they replace recounts that made a switch O(N²))."""

from __future__ import annotations

from collections import Counter

from hypothesis import given, settings
from hypothesis import strategies as st

from actorswarm.core.barrier.shared import OpenGeneration
from actorswarm.core.wire import NEED_ALL, BarrierRequest

_requests = st.builds(
    lambda part, count, timeout: BarrierRequest(
        key=1, generation=0, need={part: count, 1 - part: 2}, part=part, timeout=timeout
    ),
    st.integers(0, 1),
    st.sampled_from([1, 3, NEED_ALL]),
    st.one_of(st.none(), st.floats(0.5, 9.0)),
)
_steps = st.lists(
    st.tuples(st.integers(1, 6), st.one_of(st.none(), _requests)), min_size=1, max_size=40
)


@settings(max_examples=300, deadline=None)
@given(_steps)
def test_tallies_match_a_recount_after_every_step(
    steps: list[tuple[int, BarrierRequest | None]],
) -> None:
    inst = OpenGeneration(0)
    for platform, req in steps:
        if req is None:
            inst.drop(platform)
        else:
            inst.put(platform, req)
        reqs = list(inst.requests.values())
        assert inst.parts == Counter(r.part for r in reqs)
        assert inst.pairs == Counter(pair for r in reqs for pair in r.need.items())
        timeouts = [r.timeout for r in reqs if r.timeout is not None]
        assert inst.timeout() == (min(timeouts) if timeouts else None)


def test_a_departure_of_the_shortest_timeout_lengthens_it() -> None:
    inst = OpenGeneration(0)
    inst.put(1, BarrierRequest(key=1, generation=0, need={0: 2}, timeout=1.0))
    inst.put(2, BarrierRequest(key=1, generation=0, need={0: 2}, timeout=4.0))
    assert inst.timeout() == 1.0
    inst.drop(1)
    assert inst.timeout() == 4.0
    inst.drop(2)
    assert inst.timeout() is None
    assert inst.parts == {} and inst.pairs == {}
