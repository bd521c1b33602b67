"""A deployed script's plugins, and the slot assignment's solver when a plugin hands out
slots, are loaded by :func:`~actorswarm.daemon.prefetch.prefetch` (a daemon calls it in a
worker thread at deploy) — not lazily in the daemon's loop when an actor starts or a master
releases a formation, which silenced a master for over a second on a busy host. Each case
in a fresh interpreter, so that nothing is loaded before."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

_PROBE = """
import json, sys
from actorswarm.daemon.prefetch import prefetch
from actorswarm.dsl import load
from actorswarm.engine import assign
def state():
    out = {m: m in sys.modules for m in ("actorswarm.plugins.formation", "scipy.optimize")}
    out["solver"] = bool(assign._loaded)
    return out
before = state()
loaded = prefetch(load(sys.argv[1]))
print(json.dumps({"before": before, "loaded": loaded, "after": state()}))
"""


def _probe(script: Path) -> dict[str, object]:
    out = subprocess.run(
        [sys.executable, "-c", _PROBE, str(script)],
        capture_output=True,
        text=True,
        check=True,
        cwd=ROOT,
    )
    result: dict[str, object] = json.loads(out.stdout.strip().splitlines()[-1])
    return result


def test_a_formation_script_loads_its_plugins_and_the_slot_solver() -> None:
    result = _probe(ROOT / "examples" / "mavlink_two.xml")
    nothing = {"actorswarm.plugins.formation": False, "scipy.optimize": False, "solver": False}
    assert result["before"] == nothing
    # The solver alone, not SciPy's optimizers (48 MiB) through scipy.optimize.
    assert result["after"] == {**nothing, "actorswarm.plugins.formation": True, "solver": True}
    loaded = result["loaded"]
    assert isinstance(loaded, list)
    assert "formation.line" in loaded and loaded[-1] == "slot assignment"


def test_a_script_without_slots_does_not_load_the_solver() -> None:
    result = _probe(ROOT / "examples" / "branch_merge.xml")
    assert result["after"] == {
        "actorswarm.plugins.formation": False,
        "scipy.optimize": False,
        "solver": False,
    }
    assert "slot assignment" not in result["loaded"]  # type: ignore[operator]
