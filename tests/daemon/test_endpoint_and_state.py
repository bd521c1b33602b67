"""The daemon's sans-IO pieces: the platform endpoint and its state directory, driven by a
hand-made clock and an in-memory network (no Zenoh, no process)."""

from __future__ import annotations

from pathlib import Path

from actorswarm.core.wire import GROUND_STATION, Packet
from actorswarm.daemon.endpoint import Endpoint, PlatformEndpoint
from actorswarm.daemon.state import StateDir
from actorswarm.ground.station import GroundStation
from actorswarm.security.guard import PacketGuard
from actorswarm.security.pipeline import Pipeline

#: Three platforms start in A and switch to B together on go_event.
SCRIPT = Path(__file__).with_name("three.xml").read_bytes()


class Net:
    """Endpoints wired together as daemons are: each behind a pipeline (an insecure guard:
    the frame only), fed one batch per step — a platform's output sent after every packet,
    as the daemon's loop does — then ticked, its output sent. Every packet reaches its
    destination (or everyone else) after ``latency``; time advances in steps of ``dt``."""

    def __init__(self, endpoints: dict[int, Endpoint], latency: float = 0.005) -> None:
        self.endpoints = endpoints
        self.latency = latency
        self.now = 0.0
        self.in_flight: list[tuple[float, int, bytes]] = []
        self.pipelines = {
            src: Pipeline(endpoint, _Port(self, src), PacketGuard.insecure())
            for src, endpoint in endpoints.items()
        }

    def run(self, until: float, dt: float = 0.005) -> None:
        while self.now < until:
            self.now = round(self.now + dt, 9)
            due = [p for p in self.in_flight if p[0] <= self.now]
            self.in_flight = [p for p in self.in_flight if p[0] > self.now]
            for dst, pipeline in self.pipelines.items():
                batch = [data for _, to, data in due if to == dst]
                pipeline.receive_all(batch, self.now, flush_each=dst != GROUND_STATION)
            for src, endpoint in self.endpoints.items():
                endpoint.tick(self.now)
                self.pipelines[src].flush()


class _Port:
    """Platform ``src``'s transport on the :class:`Net`."""

    def __init__(self, net: Net, src: int) -> None:
        self.net = net
        self.src = src

    def send(self, dst: int | None, data: bytes, *, urgent: bool = False, kind: str = "") -> None:
        net = self.net
        targets = [dst] if dst is not None else [p for p in net.endpoints if p != self.src]
        for to in targets:
            net.in_flight.append((net.now + net.latency, to, data))


def _swarm(tmp_path: Path) -> tuple[Net, dict[int, PlatformEndpoint], GroundStation]:
    platforms = {
        p: PlatformEndpoint(
            p, swarm="t", incarnation=0, now=0.0, store=StateDir(tmp_path / f"s{p}").backups
        )
        for p in (1, 2, 3)
    }
    station = GroundStation(swarm="t", incarnation=7)
    endpoints: dict[int, Endpoint] = {**platforms, GROUND_STATION: station}
    return Net(endpoints), platforms, station


def _running(platforms: dict[int, PlatformEndpoint]) -> dict[int, tuple[str, ...]]:
    return {p: e.runtime.running() for p, e in platforms.items()}


def test_platform_endpoints_deploy_start_and_switch_together(tmp_path: Path) -> None:
    net, platforms, station = _swarm(tmp_path)
    net.run(2.0)  # join and elect
    assert {p.node.master for p in platforms.values()} == {1}
    sha = station.deploy(SCRIPT, [1, 2, 3], net.now)
    net.run(net.now + 0.5)
    assert station.missing(sha) == []
    station.start(net.now)
    net.run(net.now + 0.5)
    assert {p: e.runtime.running() for p, e in platforms.items()} == dict.fromkeys(
        (1, 2, 3), ("A",)
    )
    station.event("go_event", net.now, platforms=[1, 2, 3])
    net.run(net.now + 0.5)
    assert {p: e.runtime.running() for p, e in platforms.items()} == dict.fromkeys(
        (1, 2, 3), ("B",)
    )
    assert "PlatformEndpoint(platform=1" in repr(platforms[1])


def test_a_restarted_platform_rejoins_its_script_from_the_state_dir(tmp_path: Path) -> None:
    state = StateDir(tmp_path / "p1")
    assert state.next_incarnation() == 0 and state.next_incarnation() == 1
    sha = state.save_script(SCRIPT)
    state.set_running(sha)
    assert state.running() == sha and state.script(sha) == SCRIPT
    endpoint = PlatformEndpoint(1, swarm="t", incarnation=state.next_incarnation(), now=0.0)
    endpoint.engine.adopt(SCRIPT)
    assert endpoint.engine.rejoin(sha, 0.0) is False, "no backup: the initial actors start"
    assert endpoint.runtime.running() == ("A",)
    assert endpoint.node.incarnation == 2


def test_the_state_dir_keeps_when_the_task_began(tmp_path: Path) -> None:
    """A restarted daemon goes on in the task it ran: the start's instant on the shared
    clock is kept beside the script's hash, and reaches the plugins on its new clock."""
    state = StateDir(tmp_path / "p1")
    sha = state.save_script(SCRIPT)
    state.set_running(sha, 1_796_000_000.5)
    assert state.running() == sha and state.began() == 1_796_000_000.5
    endpoint = PlatformEndpoint(1, swarm="t", incarnation=state.next_incarnation(), now=0.0)
    endpoint.engine.clock_offset = lambda: 1_796_000_000.0
    endpoint.engine.adopt(SCRIPT)
    endpoint.engine.rejoin(sha, 40.0, began=state.began())
    assert endpoint.runtime.task_start == 0.5
    # A file of an older daemon (the hash alone), or a second line that is no time.
    for text in (f"{sha}\n", f"{sha}\nnan\n", f"{sha}\nsoon\n", f"{sha}\n-3\n"):
        (state.path / "running").write_text(text)
        assert state.running() == sha and state.began() is None, text
    state.set_running(sha)
    assert state.running() == sha and state.began() is None


def test_the_state_dir_survives_damage(tmp_path: Path) -> None:
    state = StateDir(tmp_path / "p")
    (state.path / "incarnation").write_text("garbage")
    assert state.next_incarnation() == 0, "a corrupt counter restarts from 0"
    sha = state.save_script(SCRIPT)
    (state.path / "scripts" / f"{sha}.xml").write_bytes(b"tampered")
    assert state.script(sha) is None, "content that does not match its hash is not used"
    assert state.running() is None
    assert oct(state.path.stat().st_mode & 0o777) == "0o700"


def test_replay_windows_survive_a_restart_and_damage(tmp_path: Path) -> None:
    """What a daemon accepted before a restart is still a replay after it."""
    from actorswarm.core.wire import Heartbeat, encode
    from actorswarm.security import PacketGuard, init_keys, load_keys

    init_keys(tmp_path / "keys")
    keys = load_keys(tmp_path / "keys")
    sender = PacketGuard.from_keys(keys)
    recorded = [
        sender.seal(
            encode(swarm="t", sender=2, incarnation=4, seq=seq, body=Heartbeat(False, 1, 1))
        )
        for seq in (1, 2, 3)
    ]
    before = PacketGuard.from_keys(keys)
    assert all(before.check(data, 0.0) is not None for data in recorded)
    state = StateDir(tmp_path / "p")
    state.save_replay_windows(before.replay_snapshot())

    after = PacketGuard.from_keys(keys)  # the restarted daemon
    after.restore_replay(StateDir(tmp_path / "p").replay_windows(), 10.0)
    assert [after.check(data, 10.0) for data in recorded] == [None, None, None]
    assert after.rejected["replay"] == 3
    fresh = encode(swarm="t", sender=2, incarnation=4, seq=4, body=Heartbeat(False, 1, 1))
    assert after.check(sender.seal(fresh), 10.0) is not None, "new packets still pass"

    (state.path / "replay.json").write_text('{"2": [4]}')
    assert state.replay_windows() == {}, "a damaged file protects nothing, and starts"
    (state.path / "replay.json").write_text("not json")
    assert state.replay_windows() == {}


def _carried_out_before_each_packet(batch: list[bytes], each: bool) -> tuple[list[int], list[str]]:
    """How many commands the engine had carried out when each packet of ``batch`` reached
    the node, handed over with ``flush_each=each``; and every command, in order."""
    endpoint = PlatformEndpoint(1, swarm="t", incarnation=0, now=0.0)
    seen: list[int] = []
    receive = endpoint.node.receive_packet

    def spy(packet: Packet, now: float) -> None:
        seen.append(len(endpoint.engine.commands))
        receive(packet, now)

    endpoint.node.receive_packet = spy  # type: ignore[method-assign]
    pipeline = Pipeline(endpoint, _Port(Net({}), 1), PacketGuard.insecure())
    assert pipeline.receive_all(batch, 0.1, flush_each=each) == len(batch)
    pipeline.flush()
    return seen, [c.event for c in endpoint.engine.commands]


def test_the_engine_reacts_to_each_packet_before_the_next() -> None:
    """Two operator commands arrive in one batch. Taken after every packet (the daemon's
    loop), the engine has carried out the first when the second reaches the node; taken
    once after the batch, it would not have."""
    station = GroundStation(swarm="t", incarnation=7)
    station.event("first", 0.0, platforms=[1])
    station.event("second", 0.0, platforms=[1])
    batch = [out.data for out in station.ready().packets]
    assert len(batch) == 2
    assert _carried_out_before_each_packet(batch, True) == ([0, 1], ["first", "second"])
    assert _carried_out_before_each_packet(batch, False) == ([0, 0], ["first", "second"])
