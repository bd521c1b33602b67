"""Recordings: every run, simulated or real, as an MCAP file Foxglove opens.

* :class:`Recorder` (:mod:`.recorder`) turns a run's facts into Foxglove channels — a 3D
  scene, frame transforms, map positions, a log, numbers to plot — and the project's own
  records, for any :class:`Sink`;
* :class:`McapSink` (:mod:`.mcap_sink`) writes them to an MCAP file; :class:`LiveSink`
  (:mod:`.live`, the ``foxglove`` extra) serves them to Foxglove over its WebSocket protocol;
* :func:`write_simulation` (:mod:`.simulation`) records a finished simulation;
* :func:`read_recording` (:mod:`.reader`) reads one back (MCAP, or the older JSON Lines),
  and :mod:`.convert` writes an older one again;
* :data:`LAYOUT` is the Foxglove layout shipped for recordings (docs/recording.md).
"""

from __future__ import annotations

from pathlib import Path

from actorswarm.recording.mcap_sink import McapSink, RecordingWriteError
from actorswarm.recording.reader import is_mcap, read_recording
from actorswarm.recording.recorder import FORMAT, TOPICS, VERSION, Recorder, Sink
from actorswarm.recording.simulation import record_simulation, write_simulation

__all__ = [
    "FORMAT",
    "LAYOUT",
    "LAYOUT_SDK",
    "TOPICS",
    "VERSION",
    "McapSink",
    "Recorder",
    "RecordingWriteError",
    "Sink",
    "is_mcap",
    "read_recording",
    "record_simulation",
    "write_simulation",
]

#: The Foxglove layout for a recording, as the Foxglove app exports and imports layouts
#: (Layouts → Import from file).
LAYOUT = Path(__file__).with_name("foxglove-layout.json")
#: The same layout in the Foxglove SDK's layout format (its layout API, notebooks).
LAYOUT_SDK = Path(__file__).with_name("foxglove-layout.sdk.json")
