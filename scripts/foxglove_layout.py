"""Write the Foxglove layout shipped for recordings (src/actorswarm/recording/foxglove-layout.json).

The layout is built with the Foxglove SDK's layout classes (the ``foxglove`` extra), so its
panel settings are the ones Foxglove defines; the JSON file is committed, so a user needs no
SDK to import it. Run it again after changing the channels:

    .venv/bin/python scripts/foxglove_layout.py            # write the file
    .venv/bin/python scripts/foxglove_layout.py --check    # exit 1 when the file differs
"""

from __future__ import annotations

import argparse
import json
import sys

import foxglove.layouts as fl

from actorswarm.recording import LAYOUT


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


def text() -> str:
    """The layout file's text (stable: sorted keys, two-space indentation)."""
    return json.dumps(json.loads(layout().to_json()), indent=2, sort_keys=True) + "\n"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare, do not write")
    args = parser.parse_args()
    if args.check:
        same = LAYOUT.exists() and LAYOUT.read_text() == text()
        print(f"{LAYOUT}: {'up to date' if same else 'differs: run without --check'}")
        return 0 if same else 1
    LAYOUT.write_text(text())
    print(f"wrote {LAYOUT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
