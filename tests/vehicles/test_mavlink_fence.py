"""The daemon's fence pushed to the autopilot's own geofence: the upload protocol against
the simulated autopilot over UDP loopback, and step by step (lost answers, a refusal, an
autopilot that never answers)."""

from __future__ import annotations

import threading
from typing import Any, Literal

import pytest
from tests.vehicles.helpers import free_port, wait_for

from actorswarm.vehicles.mavlink.autopilot import AutopilotOptions, SimAutopilot
from actorswarm.vehicles.mavlink.dialect import mav
from actorswarm.vehicles.mavlink.fence import (
    FenceReceiver,
    FenceUpload,
    fence_items,
    fence_params,
)
from actorswarm.vehicles.mavlink.frame import MissionFrame
from actorswarm.vehicles.mavlink.vehicle import Fence, MavlinkSettings, MavlinkVehicle

ORIGIN = MissionFrame(47.397742, 8.545594, 488.0)
BOX = Fence(-100.0, -50.0, 200.0, 150.0, 60.0)


@pytest.mark.parametrize("kind", ["ardupilot", "px4"])
def test_the_fence_reaches_the_simulated_autopilot(kind: Literal["ardupilot", "px4"]) -> None:
    port = free_port()
    sim = SimAutopilot(AutopilotOptions(f"udpin:127.0.0.1:{port}", ORIGIN, system=7, kind=kind))
    stop = threading.Event()
    thread = threading.Thread(target=sim.run, args=(stop,), daemon=True)
    thread.start()
    vehicle = MavlinkVehicle(
        MavlinkSettings(
            f"udpout:127.0.0.1:{port}",
            ORIGIN,
            system=7,
            name="platform 1",
            fence=BOX,
            push_fence=True,
        )
    )
    vehicle.start()
    try:
        wait_for("the fence", lambda: len(sim.fence.items) == 4, 5.0)
        corners = [ORIGIN.to_local(lat, lon, ORIGIN.alt)[:2] for lat, lon in sim.fence.polygon()]
        expected = [(-100.0, -50.0), (200.0, -50.0), (200.0, 150.0), (-100.0, 150.0)]
        for (x, y), (ex, ey) in zip(corners, expected, strict=True):
            assert x == pytest.approx(ex, abs=0.05) and y == pytest.approx(ey, abs=0.05)
        ceiling = "GF_MAX_VER_DIST" if kind == "px4" else "FENCE_ALT_MAX"
        wait_for("the ceiling", lambda: sim._params[ceiling] == 60.0, 3.0)
        assert vehicle.drain_errors() == []
    finally:
        vehicle.close()
        stop.set()
        thread.join(timeout=2)
        sim.close()


class _Peer:
    """Stamps the source of messages built in the test, as the link would."""

    @staticmethod
    def stamp(message: Any, system: int, component: int) -> Any:
        message._header = mav.MAVLink_header(message.id, srcSystem=system, srcComponent=component)
        return message


def _upload(**kw: Any) -> FenceUpload:
    frame = MissionFrame(47.0, 8.0, 400.0)
    items = fence_items(BOX, frame, target_system=7, target_component=1)
    return FenceUpload(items, fence_params("ardupilot", BOX.z_max), 7, 1, name="vehicle 3", **kw)


def _to_receiver(receiver: FenceReceiver, messages: list[Any]) -> list[Any]:
    out = []
    for m in messages:
        out += receiver.on_message(_Peer.stamp(m, 245, 191))
    return out


def test_the_upload_repeats_what_is_lost_and_ends_accepted() -> None:
    upload, receiver = _upload(), FenceReceiver(7)
    sets = upload.start(0.0)
    assert [m.param_id for m in sets] == ["FENCE_ALT_MAX", "FENCE_TYPE", "FENCE_ENABLE"]
    assert upload.tick(0.2) == []  # not yet time to repeat
    assert len(upload.tick(0.6)) == 3  # nothing echoed: the sets again
    for name, value in fence_params("ardupilot", BOX.z_max):
        echo = mav.MAVLink_param_value_message(name.encode(), value, 9, 3, 0)
        out = upload.on_message(echo, 0.7)
    (count,) = out
    assert count.get_type() == "MISSION_COUNT" and count.count == 4
    # The count is lost: it is sent again, then the items go one by one as asked.
    assert [m.get_type() for m in upload.tick(1.3)] == ["MISSION_COUNT"]
    pending = _to_receiver(receiver, [count])
    t = 1.4
    while pending:
        replies: list[Any] = []
        for answer in pending:
            replies += upload.on_message(answer, t)
        pending = _to_receiver(receiver, replies)
        t += 0.01
    assert upload.done and upload.error is None
    assert len(receiver.items) == 4


def test_a_refused_fence_and_a_silent_autopilot_are_errors() -> None:
    upload = _upload()
    upload.start(0.0)
    for name, value in fence_params("ardupilot", BOX.z_max):
        upload.on_message(mav.MAVLink_param_value_message(name.encode(), value, 9, 3, 0), 0.1)
    refusal = mav.MAVLink_mission_ack_message(245, 191, mav.MAV_MISSION_NO_SPACE, 1)
    assert upload.on_message(refusal, 0.2) == []
    assert upload.error == (
        "vehicle 3: the autopilot refused the fence: MAV_MISSION_NO_SPACE; its own fence is not set"
    )
    silent = _upload(deadline=2.0)
    silent.start(0.0)
    silent.tick(1.0)
    assert silent.tick(2.5) == [] and silent.phase == "failed"
    assert silent.error is not None and "did not set its fence parameters in 2 s" in silent.error


def test_the_daemon_file_turns_the_push_on(tmp_path: Any) -> None:
    from actorswarm.daemon.config import load_daemon_config

    config = tmp_path / "d.toml"
    config.write_text('vehicle = "mavlink"\nmavlink_push_fence = true\n')
    parsed, _ = load_daemon_config(config)
    assert parsed.mavlink_push_fence is True
    config.write_text('vehicle = "mavlink"\n')
    assert load_daemon_config(config)[0].mavlink_push_fence is False


def test_the_simulated_autopilot_takes_mavsdk_s_geofence_upload() -> None:
    """The receiving side against an uploader we did not write: MAVSDK's Geofence plugin
    (a ground station's) uploads an inclusion polygon to the simulated autopilot. (MAVSDK
    has no geofence server to check the uploading side against.)"""
    from mavsdk import ComponentType, Configuration, Mavsdk
    from mavsdk.plugins.geofence import (
        FenceType,
        Geofence,
        GeofenceData,
        GeofenceResult,
        Point,
        Polygon,
    )

    port = free_port()
    sim = SimAutopilot(AutopilotOptions(f"udpin:127.0.0.1:{port}", ORIGIN, system=1, kind="px4"))
    stop = threading.Event()
    thread = threading.Thread(target=sim.run, args=(stop,), daemon=True)
    thread.start()
    station = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    try:
        station.add_any_connection(f"udpout://127.0.0.1:{port}")
        wait_for("the autopilot", lambda: station.system_count() > 0, 5.0)
        corners = [(47.3977, 8.5455), (47.3977, 8.5460), (47.3980, 8.5460), (47.3980, 8.5455)]
        polygon = Polygon([Point(lat, lon) for lat, lon in corners], FenceType.INCLUSION)
        result = Geofence(station.get_systems()[0]).upload_geofence(GeofenceData([polygon], []))
        assert result == GeofenceResult.SUCCESS
        received = [v for corner in sim.fence.polygon() for v in corner]
        assert received == pytest.approx([v for corner in corners for v in corner], abs=1e-7)
    finally:
        station.destroy()
        stop.set()
        thread.join(timeout=2)
        sim.close()
