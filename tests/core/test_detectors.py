"""Leave detectors: the fixed timeout and the phi accrual detector, and how one is chosen."""

from __future__ import annotations

import itertools

import pytest

from actorswarm.core.config import CoreConfig
from actorswarm.core.membership.detectors import FixedTimeout, PhiAccrual, make_detector

INTERVAL = 0.1
MIN_STD = 0.02
Z_AT_8 = 5.612001243305506  # standard normal quantile of 1 - 1e-8


def _phi(threshold: float = 8.0, window: int = 100) -> PhiAccrual:
    return PhiAccrual(
        threshold=threshold, window=window, min_std=MIN_STD, expected_interval=INTERVAL
    )


def _feed(detector: PhiAccrual, times: list[float]) -> float:
    deadline = 0.0
    for t in times:
        deadline = detector.observe(t)
    return deadline


@pytest.mark.parametrize(
    ("t_leave", "beats", "deadline"),
    [
        (0.5, [0.0], 0.5),
        (0.5, [0.0, 0.1, 0.35], 0.85),
        (0.3, [1.0, 1.0], 1.3),
        (2.0, [5.0, 7.5], 9.5),
    ],
)
def test_fixed_timeout_deadline_is_last_plus_t_leave(
    t_leave: float, beats: list[float], deadline: float
) -> None:
    detector = FixedTimeout(t_leave)
    got = [detector.observe(t) for t in beats][-1]
    assert got == pytest.approx(deadline), f"heartbeats {beats}: deadline {got}, want {deadline}"


def test_fixed_timeout_suspicion_is_silence() -> None:
    detector = FixedTimeout(0.5)
    detector.observe(2.0)
    assert detector.suspicion(1.5) == 0.0, "no negative silence"
    assert detector.suspicion(2.0) == 0.0
    assert detector.suspicion(2.3) == pytest.approx(0.3)


def test_phi_is_zero_before_any_heartbeat() -> None:
    assert _phi().phi(10.0) == 0.0


def test_phi_grows_with_silence() -> None:
    detector = _phi()
    _feed(detector, [i * INTERVAL for i in range(20)])
    last = 19 * INTERVAL
    levels = [detector.phi(last + dt) for dt in (0.0, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3)]
    assert all(a < b for a, b in itertools.pairwise(levels)), (
        f"phi must grow strictly with silence, got {levels}"
    )
    assert detector.suspicion(last + 0.2) == detector.phi(last + 0.2)


@pytest.mark.parametrize("threshold", [1.0, 3.0, 8.0, 12.0])
@pytest.mark.parametrize(
    "gaps",
    [
        [],
        [0.1] * 30,
        [0.05, 0.15] * 15,
        [0.1, 0.1, 0.4, 0.1, 0.2],
    ],
    ids=["fresh", "regular", "jittery", "irregular"],
)
def test_phi_deadline_is_where_phi_crosses_threshold(threshold: float, gaps: list[float]) -> None:
    detector = _phi(threshold)
    t = 0.0
    times = [t]
    for gap in gaps:
        t += gap
        times.append(t)
    deadline = _feed(detector, times)
    eps = 1e-4
    below, above = detector.phi(deadline - eps), detector.phi(deadline + eps)
    assert below < threshold <= above, (
        f"phi({deadline - eps:.5f})={below:.4f}, phi({deadline + eps:.5f})={above:.4f}; "
        f"threshold {threshold} must lie between"
    )


def test_regular_heartbeats_give_interval_plus_z_min_std() -> None:
    detector = _phi()
    times = [i * INTERVAL for i in range(200)]  # the seed intervals are pushed out
    deadline = _feed(detector, times)
    expected = times[-1] + INTERVAL + Z_AT_8 * MIN_STD
    assert deadline == pytest.approx(expected, abs=1e-6), (
        f"regular 0.1 s heartbeats: deadline {deadline - times[-1]:.6f} s after the last, "
        f"want interval + z*min_std = {expected - times[-1]:.6f}"
    )


def test_jittery_heartbeats_give_later_deadline_than_regular() -> None:
    regular, jittery = _phi(), _phi()
    t_reg = [i * INTERVAL for i in range(101)]
    t_jit = [0.0]
    for i in range(100):
        t_jit.append(t_jit[-1] + (0.05 if i % 2 else 0.15))
    d_reg = _feed(regular, t_reg) - t_reg[-1]
    d_jit = _feed(jittery, t_jit) - t_jit[-1]
    assert d_jit > d_reg + 0.1, (
        f"same mean interval, std 0.05 vs ~0: jittery wait {d_jit:.3f} s, regular {d_reg:.3f} s"
    )


def test_fresh_phi_detector_judges_like_a_regular_peer() -> None:
    deadline = _phi().observe(3.0)
    assert 3.0 + INTERVAL < deadline < 3.0 + 0.5, f"first deadline {deadline} not sensible"


def test_phi_window_forgets_old_intervals() -> None:
    detector = _phi(window=10)
    t = 0.0
    for _ in range(10):
        t += 1.0  # slow phase
        detector.observe(t)
    for _ in range(10):
        t += INTERVAL  # fast phase fills the whole window
        deadline = detector.observe(t)
    assert deadline - t == pytest.approx(INTERVAL + Z_AT_8 * MIN_STD, abs=1e-6), (
        "after a full window of 0.1 s intervals the 1 s ones must be forgotten"
    )


def test_phi_duplicate_heartbeat_time_is_not_an_interval() -> None:
    detector = _phi()
    times = [i * INTERVAL for i in range(200)]
    once = _feed(detector, times)
    again = detector.observe(times[-1])
    assert again == pytest.approx(once), "a zero interval must not be pushed"


@pytest.mark.parametrize(
    ("changes", "kind"),
    [
        ({}, FixedTimeout),
        ({"detector": "timeout"}, FixedTimeout),
        ({"detector": "phi"}, PhiAccrual),
    ],
)
def test_make_detector_picks_by_config(changes: dict[str, str], kind: type) -> None:
    detector = make_detector(CoreConfig(**changes))  # type: ignore[arg-type]
    assert isinstance(detector, kind), f"{changes}: got {type(detector).__name__}"


def test_make_detector_passes_settings() -> None:
    timeout = make_detector(CoreConfig(t_leave=0.7))
    assert timeout.observe(1.0) == pytest.approx(1.7)
    phi = make_detector(CoreConfig(detector="phi", phi_threshold=3.0, phi_min_std=0.05))
    assert isinstance(phi, PhiAccrual)
    deadline = 0.0
    for i in range(200):
        deadline = phi.observe(i * 0.1)
    assert phi.phi(deadline) == pytest.approx(3.0, abs=1e-3), "threshold from the config"
    assert deadline - 19.9 > 0.1 + 2.9 * 0.05, "min_std from the config (z(3) ~ 3.09)"
