"""A platform whose links come and go is named once in the daemon's log (daemon/flap.py)."""

from __future__ import annotations

from actorswarm.daemon.flap import FLAP_TIMES, FLAP_WINDOW_S, FlapWatch


def test_a_member_dropping_out_three_times_in_a_minute_is_named_once_per_window() -> None:
    watch = FlapWatch(1)
    assert watch.observe(0.0, [2, 3], 1) == []
    lines = []
    for k in range(5):  # out and back every 10 s
        lines += watch.observe(10.0 * k + 5.0, [2], 1)
        lines += watch.observe(10.0 * k + 6.0, [2, 3], 1)
    assert len(lines) == 1
    (line,) = lines
    assert line["platform"] == 3
    assert line["times"] == FLAP_TIMES
    assert line["seconds"] == 20.0
    assert "platform 3 dropped out of the swarm 3 times in 20 s" in line["why"]
    assert watch.counts(46.0) == {3: 5}
    # A window after it was said, still flapping (35, 45 and 90 s): said again.
    again = watch.observe(90.0, [2], 1)
    assert [x["platform"] for x in again] == [3]


def test_a_platform_losing_its_master_again_and_again_says_so_of_itself() -> None:
    watch = FlapWatch(3)
    lines = []
    for k in range(3):
        t = 10.0 * k
        lines += watch.observe(t, [1, 2], 1)
        lines += watch.observe(t + 0.5, [], None)  # master lost
        lines += watch.observe(t + 0.8, [], 3)  # its own master for a moment
        lines += watch.observe(t + 1.0, [1, 2], 1)  # following 1 again: not a loss
    # The others left its view with its master each time: its own links, not theirs.
    assert len(lines) == 1
    assert lines[0]["platform"] == 3
    assert lines[0]["why"].startswith("this platform lost its master 3 times in 20 s")


def test_a_failover_and_a_partition_are_not_flapping() -> None:
    watch = FlapWatch(2)
    assert watch.observe(0.0, [1, 3, 4], 1) == []
    assert watch.observe(5.0, [3, 4], None) == []  # the master died
    assert watch.observe(6.0, [3, 4], 2) == []  # and this one took over
    assert watch.observe(20.0, [3], 2) == []  # a partition
    assert watch.observe(40.0, [3, 4], 2) == []  # healed
    # The dead master left the view as this platform lost it: counted as its own loss.
    assert watch.counts(40.0) == {2: 1, 4: 1}


def test_drops_further_apart_than_the_window_are_not_counted_together() -> None:
    watch = FlapWatch(1)
    lines = []
    for k in range(4):
        t = k * FLAP_WINDOW_S * 0.6
        lines += watch.observe(t, [2, 3], 1)
        lines += watch.observe(t + 1.0, [2], 1)
    assert lines == []
