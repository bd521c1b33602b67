"""The same recording with its Foxglove channels protobuf-encoded (the foxglove extra), to
compare the sizes of the two encodings Foxglove reads.

    .venv/bin/actorswarm demo --out demo-out
    .venv/bin/python scripts/recording_protobuf.py demo-out/record.mcap /tmp/protobuf.mcap

Reads a recording (JSON-encoded, as the project writes it), builds the Foxglove SDK's
protobuf messages for ``/scene``, ``/trails``, ``/targets``, ``/areas``, ``/tf``, ``/fix``
and ``/log`` (the project's own channels stay JSON), writes them with the SDK's MCAP
writer, and prints both sizes and the SDK's time to write the ready-built messages.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path
from typing import Any

import foxglove
import foxglove.channels as fc
import foxglove.messages as fm
from mcap.reader import make_reader


def _vec(d: dict[str, float]) -> fm.Vector3:
    return fm.Vector3(x=d["x"], y=d["y"], z=d["z"])


def _pose(d: dict[str, Any]) -> fm.Pose:
    q = d["orientation"]
    rotation = fm.Quaternion(x=q["x"], y=q["y"], z=q["z"], w=q["w"])
    return fm.Pose(position=_vec(d["position"]), orientation=rotation)


def _colour(d: dict[str, float]) -> fm.Color:
    return fm.Color(r=d["r"], g=d["g"], b=d["b"], a=d["a"])


def _time(d: dict[str, int]) -> fm.Timestamp:
    return fm.Timestamp(d["sec"], d["nsec"])


def _entity(e: dict[str, Any]) -> fm.SceneEntity:
    return fm.SceneEntity(
        timestamp=_time(e["timestamp"]),
        frame_id=e["frame_id"],
        id=e["id"],
        lifetime=fm.Duration(0, 0),
        frame_locked=e["frame_locked"],
        metadata=[fm.KeyValuePair(key=k["key"], value=k["value"]) for k in e["metadata"]],
        arrows=[
            fm.ArrowPrimitive(
                pose=_pose(a["pose"]),
                shaft_length=a["shaft_length"],
                shaft_diameter=a["shaft_diameter"],
                head_length=a["head_length"],
                head_diameter=a["head_diameter"],
                color=_colour(a["color"]),
            )
            for a in e["arrows"]
        ],
        spheres=[
            fm.SpherePrimitive(
                pose=_pose(s["pose"]), size=_vec(s["size"]), color=_colour(s["color"])
            )
            for s in e["spheres"]
        ],
        lines=[
            fm.LinePrimitive(
                type=fm.LinePrimitiveLineType.LineStrip,
                pose=_pose(ln["pose"]),
                thickness=ln["thickness"],
                scale_invariant=ln["scale_invariant"],
                points=[fm.Point3(x=p["x"], y=p["y"], z=p["z"]) for p in ln["points"]],
                color=_colour(ln["color"]),
            )
            for ln in e["lines"]
        ],
        texts=[
            fm.TextPrimitive(
                pose=_pose(t["pose"]),
                billboard=t["billboard"],
                font_size=t["font_size"],
                scale_invariant=t["scale_invariant"],
                color=_colour(t["color"]),
                text=t["text"],
            )
            for t in e["texts"]
        ],
    )


def _message(schema: str, d: dict[str, Any]) -> Any:
    if schema == "foxglove.SceneUpdate":
        return fm.SceneUpdate(entities=[_entity(e) for e in d["entities"]])
    if schema == "foxglove.FrameTransforms":
        return fm.FrameTransforms(
            transforms=[
                fm.FrameTransform(
                    timestamp=_time(t["timestamp"]),
                    parent_frame_id=t["parent_frame_id"],
                    child_frame_id=t["child_frame_id"],
                    translation=_vec(t["translation"]),
                    rotation=fm.Quaternion(**t["rotation"]),
                )
                for t in d["transforms"]
            ]
        )
    if schema == "foxglove.LocationFix":
        return fm.LocationFix(
            timestamp=_time(d["timestamp"]),
            frame_id=d["frame_id"],
            latitude=d["latitude"],
            longitude=d["longitude"],
            altitude=d["altitude"],
        )
    if schema == "foxglove.Log":
        return fm.Log(
            timestamp=_time(d["timestamp"]),
            level=fm.LogLevel.Info,
            message=d["message"],
            name=d["name"],
        )
    return None


_CHANNELS = {
    "foxglove.SceneUpdate": fc.SceneUpdateChannel,
    "foxglove.FrameTransforms": fc.FrameTransformsChannel,
    "foxglove.LocationFix": fc.LocationFixChannel,
    "foxglove.Log": fc.LogChannel,
}


def main(source: Path, target: Path) -> None:
    context = foxglove.Context()
    writer = foxglove.open_mcap(target, allow_overwrite=True, context=context)
    channels: dict[str, Any] = {}
    ready: list[tuple[Any, Any, int]] = []
    with source.open("rb") as stream:
        for schema, channel, message in make_reader(stream).iter_messages(log_time_order=False):
            assert schema is not None
            if channel.topic not in channels:
                kind = _CHANNELS.get(schema.name)
                channels[channel.topic] = (
                    kind(channel.topic, context=context)
                    if kind is not None
                    else foxglove.Channel(channel.topic, message_encoding="json", context=context)
                )
            built = _message(schema.name, json.loads(message.data))
            ready.append((channels[channel.topic], built or message.data, message.log_time))
    started = time.perf_counter()
    for channel, built, log_time in ready:
        channel.log(built, log_time=log_time)
    writer.close()
    took = time.perf_counter() - started
    print(
        f"JSON (as written): {source.stat().st_size / 1e6:.2f} MB; protobuf: "
        f"{target.stat().st_size / 1e6:.2f} MB; {len(ready)} messages written in {took:.2f} s"
    )


if __name__ == "__main__":
    main(Path(sys.argv[1]), Path(sys.argv[2]))
