"""What recording costs the rest: the core, the task engine and the simulator import no
recording library, and recording imports the live view's SDK only when a live view is
asked for."""

from __future__ import annotations

import json
import subprocess
import sys


def _loaded(imports: str, watched: tuple[str, ...]) -> list[str]:
    code = (
        f"import json, sys\n{imports}\n"
        f"print(json.dumps([m for m in {watched!r} if m in sys.modules]))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=False
    )
    assert done.returncode == 0, done.stderr
    return list(json.loads(done.stdout.strip().splitlines()[-1]))


def test_the_core_engine_and_simulator_import_no_recording_library() -> None:
    imports = (
        "import actorswarm.core, actorswarm.engine\n"
        "import actorswarm.sim.tasksim, actorswarm.sim.record, actorswarm.sim.mission"
    )
    assert _loaded(imports, ("mcap", "foxglove", "actorswarm.recording")) == []


def test_recording_imports_the_foxglove_sdk_only_for_a_live_view() -> None:
    imports = "import actorswarm.recording, actorswarm.cli.app"
    assert _loaded(imports, ("foxglove", "actorswarm.recording.live")) == []
