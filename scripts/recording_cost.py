"""What recording costs: a shipped mission simulated with and without writing its MCAP
recording, and the recording's size per simulated minute.

    .venv/bin/python scripts/recording_cost.py --mission formation --runs 3
    .venv/bin/python scripts/recording_cost.py --platforms 1000 --duration 30 --runs 1

Each run simulates the mission (as ``actorswarm demo`` does, world snapshots every 0.5 s),
then writes the recording (:func:`actorswarm.recording.write_simulation`) and reads it
back; it prints the wall time of each step, the file's size and its size per simulated
minute. ``--jsonl`` also times the older JSON Lines writer on the same run.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from actorswarm.missions import mission as find_mission
from actorswarm.recording import read_recording, write_simulation
from actorswarm.sim.mission import prepare, run_slices
from actorswarm.sim.record import write_record


def one(name: str, platforms: int | None, duration: float | None, jsonl: bool) -> dict[str, float]:
    """One run: the seconds each step took, and the recording's bytes."""
    chosen = find_mission(name)
    packets: list[tuple[float, int]] = []
    started = time.perf_counter()
    sim = prepare(chosen, platforms=platforms, packets=packets)
    report = run_slices(sim, duration or chosen.duration)
    simulated = time.perf_counter()
    assert sim.world is not None
    track = sim.world.track()
    with tempfile.TemporaryDirectory() as scratch:
        path = Path(scratch) / "record.mcap"
        write_simulation(
            path,
            report,
            meta={"mission": name},
            track=track,
            packets=packets,
            areas=sim.world.area_polygons(),
            script=(chosen.script_path.name, chosen.script_path.read_text()),
        )
        written = time.perf_counter()
        read_recording(path)
        read = time.perf_counter()
        out = {
            "sim_s": simulated - started,
            "write_s": written - simulated,
            "read_s": read - written,
            "bytes": float(path.stat().st_size),
            "sim_time_s": float(report["sim_time_s"]),
            "platforms": float(len(track.platforms)),
        }
        if jsonl:
            old = Path(scratch) / "record.jsonl"
            before = time.perf_counter()
            write_record(old, rows=track.rows(), targets=track.target_rows(),
                         transitions=report["transitions"], meta={})  # fmt: skip
            out["jsonl_write_s"] = time.perf_counter() - before
            out["jsonl_bytes"] = float(old.stat().st_size)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mission", default="formation")
    parser.add_argument("--platforms", type=int, default=None)
    parser.add_argument("--duration", type=float, default=None, help="simulated seconds")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--jsonl", action="store_true", help="time the JSON Lines writer too")
    args = parser.parse_args()
    runs = [one(args.mission, args.platforms, args.duration, args.jsonl) for _ in range(args.runs)]
    first = runs[0]
    print(f"{args.mission}: {first['platforms']:.0f} platforms, {first['sim_time_s']:.0f} s "
          f"simulated, {len(runs)} run(s)")  # fmt: skip
    for key in ("sim_s", "write_s", "read_s", "jsonl_write_s"):
        if key in first:
            values = [r[key] for r in runs]
            print(f"  {key}: median {statistics.median(values):.2f} s "
                  f"({', '.join(f'{v:.2f}' for v in values)})")  # fmt: skip
    sim_s = statistics.median(r["sim_s"] for r in runs)
    write_s = statistics.median(r["write_s"] for r in runs)
    print(f"  recording adds {write_s:.2f} s to {sim_s:.2f} s ({100 * write_s / sim_s:.1f} %)")
    per_minute = first["bytes"] / first["sim_time_s"] * 60
    print(f"  MCAP: {first['bytes'] / 1e6:.2f} MB, {per_minute / 1e6:.2f} MB per simulated minute")
    if "jsonl_bytes" in first:
        print(f"  JSON Lines: {first['jsonl_bytes'] / 1e6:.2f} MB")


if __name__ == "__main__":
    main()
