"""The JSON Schemas of a recording's channels.

Foxglove recognizes its well-known message types (``foxglove.SceneUpdate``,
``foxglove.FrameTransforms``, ``foxglove.LocationFix``, ``foxglove.Log``) by the schema's
name; the messages are JSON objects with the fields its documentation lists. The schemas
here describe the fields this project writes (a reader such as PlotJuggler shows the field
tree from them); the ``actorswarm.*`` ones are the project's own records, which the web
replay reads back exactly.
"""

from __future__ import annotations

import json
from typing import Any

__all__ = ["SCHEMAS", "schema_bytes"]

_NUM = {"type": "number"}
_INT = {"type": "integer"}
_STR = {"type": "string"}
_BOOL = {"type": "boolean"}


def _obj(title: str = "", **props: Any) -> dict[str, Any]:
    out: dict[str, Any] = {"type": "object", "properties": props}
    if title:
        out["title"] = title
    return out


def _arr(items: dict[str, Any]) -> dict[str, Any]:
    return {"type": "array", "items": items}


_TIME = _obj("time", sec=_INT, nsec=_INT)
_VEC3 = _obj("vector", x=_NUM, y=_NUM, z=_NUM)
_QUAT = _obj("quaternion", x=_NUM, y=_NUM, z=_NUM, w=_NUM)
_POSE = _obj("pose", position=_VEC3, orientation=_QUAT)
_COLOR = _obj("color", r=_NUM, g=_NUM, b=_NUM, a=_NUM)
_KEY_VALUE = _obj("key/value", key=_STR, value=_STR)

_ARROW = _obj(
    "arrow",
    pose=_POSE,
    shaft_length=_NUM,
    shaft_diameter=_NUM,
    head_length=_NUM,
    head_diameter=_NUM,
    color=_COLOR,
)
_SPHERE = _obj("sphere", pose=_POSE, size=_VEC3, color=_COLOR)
_LINE = _obj(
    "line",
    type=_INT,
    pose=_POSE,
    thickness=_NUM,
    scale_invariant=_BOOL,
    points=_arr(_VEC3),
    color=_COLOR,
    colors=_arr(_COLOR),
    indices=_arr(_INT),
)
_TEXT = _obj(
    "text",
    pose=_POSE,
    billboard=_BOOL,
    font_size=_NUM,
    scale_invariant=_BOOL,
    color=_COLOR,
    text=_STR,
)
_ENTITY = _obj(
    "entity",
    timestamp=_TIME,
    frame_id=_STR,
    id=_STR,
    lifetime=_TIME,
    frame_locked=_BOOL,
    metadata=_arr(_KEY_VALUE),
    arrows=_arr(_ARROW),
    cubes=_arr(_SPHERE),
    spheres=_arr(_SPHERE),
    cylinders=_arr(_obj("cylinder")),
    lines=_arr(_LINE),
    triangles=_arr(_obj("triangles")),
    texts=_arr(_TEXT),
    models=_arr(_obj("model")),
)

_PLATFORM = _obj(
    "platform",
    id=_INT,
    t=_NUM,
    x=_NUM,
    y=_NUM,
    z=_NUM,
    heading=_NUM,
    mode=_STR,
    actor=_STR,
    master=_BOOL,
    altitude=_NUM,
    speed=_NUM,
    battery={"type": ["number", "null"]},
)

#: Every schema a recording may use, by name.
SCHEMAS: dict[str, dict[str, Any]] = {
    "foxglove.SceneUpdate": _obj(
        "foxglove.SceneUpdate",
        deletions=_arr(_obj("deletion", timestamp=_TIME, type=_INT, id=_STR)),
        entities=_arr(_ENTITY),
    ),
    "foxglove.FrameTransforms": _obj(
        "foxglove.FrameTransforms",
        transforms=_arr(
            _obj(
                "transform",
                timestamp=_TIME,
                parent_frame_id=_STR,
                child_frame_id=_STR,
                translation=_VEC3,
                rotation=_QUAT,
            )
        ),
    ),
    "foxglove.LocationFix": _obj(
        "foxglove.LocationFix",
        timestamp=_TIME,
        frame_id=_STR,
        latitude=_NUM,
        longitude=_NUM,
        altitude=_NUM,
        position_covariance=_arr(_NUM),
        position_covariance_type=_INT,
    ),
    "foxglove.Log": _obj(
        "foxglove.Log",
        timestamp=_TIME,
        level=_INT,
        message=_STR,
        name=_STR,
        file=_STR,
        line=_INT,
    ),
    "actorswarm.Platforms": _obj("actorswarm.Platforms", platforms=_arr(_PLATFORM)),
    "actorswarm.Transition": _obj(
        "actorswarm.Transition",
        t=_NUM,
        platform=_INT,
        **{"from": _STR, "to": _STR},
        event=_STR,
        cause=_STR,
    ),
    "actorswarm.Masters": _obj(
        "actorswarm.Masters", t=_NUM, masters=_arr(_INT), epoch={"type": ["integer", "null"]}
    ),
    "actorswarm.Event": _obj("actorswarm.Event", t=_NUM, what=_STR, platform=_INT, text=_STR),
    "actorswarm.Metrics": _obj(
        "actorswarm.Metrics",
        platforms_up=_INT,
        packets_per_s=_NUM,
        barrier_latency_ms=_NUM,
    ),
}


def schema_bytes(name: str) -> bytes:
    """The JSON Schema ``name`` as the bytes a recording stores (KeyError: unknown)."""
    return json.dumps(SCHEMAS[name], separators=(",", ":")).encode()
