"""Write the Foxglove layout shipped for recordings, in two formats.

The layout is built with the Foxglove SDK's layout classes (the ``foxglove`` extra), so its
panel settings are the ones Foxglove defines, and written twice into
src/actorswarm/recording/: ``foxglove-layout.json`` in the format the Foxglove app exports
and imports (*Layouts → Import from file*: panels by ID in ``configById``, a binary tree of
splits in ``layout``), and ``foxglove-layout.sdk.json`` as the SDK writes it (its layout
API, notebooks). Both files are committed, so a user needs no SDK. Run it again after
changing the channels:

    .venv/bin/python scripts/foxglove_layout.py            # write the file
    .venv/bin/python scripts/foxglove_layout.py --check    # exit 1 when the file differs
"""

from __future__ import annotations

import argparse
import itertools
import json
import sys
from pathlib import Path
from typing import Any

import foxglove.layouts as fl

from actorswarm.recording import LAYOUT, LAYOUT_SDK


def layout() -> fl.Layout:
    """Scene (3D) on the left; map, the actor timeline, plots and the log on the right."""
    scene = fl.ThreeDeePanel(
        title="swarm (3D)",
        config=fl.ThreeDeeConfig(
            follow_tf="world",
            fixed_frame="world",
            topics={
                topic: fl.BaseRendererSceneUpdateTopicSettings(visible=True)
                for topic in ("/scene", "/trails", "/targets", "/areas", "/formation")
            },
        ),
    )
    map_panel = fl.MapPanel(
        title="map (/fix, with --origin)",
        config=fl.MapConfig(
            topic_config={
                "/fix": fl.MapTopicSettings(history_mode="previous", time_window_seconds=30.0)
            },
        ),
    )
    timeline = fl.StateTransitionsPanel(
        title="actors per platform",
        config=fl.StateTransitionsConfig(
            paths=[
                fl.StateTransitionsSeries(
                    value="/platforms.platforms[:]",
                    label="platform",
                    dynamic_label_field="id",
                    dynamic_value_field="actor",
                ),
            ],
            legend_display="left",
        ),
    )

    def plot(title: str, field: str) -> fl.PlotPanel:
        return fl.PlotPanel(
            title=title,
            config=fl.PlotConfig(
                paths=[
                    fl.PlotSeries(
                        value="/platforms.platforms[:]",
                        label=field,
                        dynamic_label_field="id",
                        dynamic_value_field=field,
                    )
                ],
            ),
        )

    swarm = fl.PlotPanel(
        title="swarm",
        config=fl.PlotConfig(
            paths=[
                fl.PlotSeries(value="/metrics.packets_per_s", label="packets/s"),
                fl.PlotSeries(value="/metrics.barrier_latency_ms", label="switch latency ms"),
                fl.PlotSeries(value="/metrics.platforms_up", label="platforms up"),
            ],
        ),
    )
    log = fl.LogPanel(title="log", config=fl.LogConfig(topic_to_render="/log", show_name=True))
    plots = fl.TabContainer(
        tabs=[
            fl.TabItem(title="altitude", content=plot("altitude (m)", "altitude")),
            fl.TabItem(title="speed", content=plot("speed (m/s)", "speed")),
            fl.TabItem(title="battery", content=plot("battery", "battery")),
            fl.TabItem(title="swarm", content=swarm),
        ]
    )
    right = fl.SplitContainer(
        direction="column",
        items=[
            fl.SplitItem(proportion=1, content=map_panel),
            fl.SplitItem(proportion=1, content=timeline),
            fl.SplitItem(proportion=1, content=plots),
            fl.SplitItem(proportion=1, content=log),
        ],
    )
    return fl.Layout(
        content=fl.SplitContainer(
            direction="row",
            items=[
                fl.SplitItem(proportion=3, content=scene),
                fl.SplitItem(proportion=2, content=right),
            ],
        )
    )


# The app's panel type names, by the SDK's.
_APP_PANELS = {
    "ThreeDee": "3D",
    "Map": "map",
    "StateTransitions": "StateTransitions",
    "Plot": "Plot",
    "Log": "RosOut",
}


def app_format(sdk: dict[str, Any]) -> dict[str, Any]:
    """The SDK's layout (its JSON) in the app's export format."""
    config_by_id: dict[str, Any] = {}
    ids = itertools.count(1)

    def node(content: dict[str, Any]) -> Any:
        if content["type"] == "panel":
            panel = f"{_APP_PANELS[content['panelType']]}!actorswarm{next(ids)}"
            config = dict(content.get("config") or {})
            for path in config.get("paths", []):
                path.setdefault("enabled", True)
                path.setdefault("timestampMethod", "receiveTime")
            if content.get("title"):
                config["foxglovePanelTitle"] = content["title"]
            config_by_id[panel] = config
            return panel
        if content["type"] == "tabs":
            panel = f"Tab!actorswarm{next(ids)}"
            tabs = [{"title": t["title"], "layout": node(t["content"])} for t in content["tabs"]]
            config_by_id[panel] = {"activeTabIdx": content["selectedTabIndex"], "tabs": tabs}
            return panel
        parts = [(item["proportion"], node(item["content"])) for item in content["items"]]
        return split(parts, content["direction"])

    def split(parts: list[tuple[float, Any]], direction: str) -> Any:
        """Splits of n parts as the app nests them: the first, then the rest."""
        if len(parts) == 1:
            return parts[0][1]
        share = parts[0][0] / sum(weight for weight, _ in parts)
        return {
            "first": parts[0][1],
            "second": split(parts[1:], direction),
            "direction": direction,
            "splitPercentage": round(100.0 * share, 1),
        }

    tree = node(sdk["content"])
    return {
        "configById": config_by_id,
        "globalVariables": {},
        "userNodes": {},
        "playbackConfig": {"speed": 1},
        "layout": tree,
    }


def _dump(data: dict[str, Any]) -> str:
    """Stable text: sorted keys, two-space indentation."""
    return json.dumps(data, indent=2, sort_keys=True) + "\n"


def texts() -> dict[Path, str]:
    """Each layout file's text."""
    sdk = json.loads(layout().to_json())
    return {LAYOUT: _dump(app_format(sdk)), LAYOUT_SDK: _dump(sdk)}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare, do not write")
    args = parser.parse_args()
    stale = 0
    for path, text in texts().items():
        if args.check:
            same = path.exists() and path.read_text() == text
            print(f"{path}: {'up to date' if same else 'differs: run without --check'}")
            stale += not same
        else:
            path.write_text(text)
            print(f"wrote {path}")
    return 1 if stale else 0


if __name__ == "__main__":
    sys.exit(main())
