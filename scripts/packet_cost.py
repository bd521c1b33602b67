#!/usr/bin/env python3
"""What the packet guard costs per packet (docs/benchmarks/README.md, "Per-packet cost").
Run with the project's interpreter, from the repository:

    .venv/bin/python scripts/packet_cost.py [--rounds 15] [--packets 2000]
    .venv/bin/python scripts/packet_cost.py --src /tmp/before   # another checkout

For three packets the core sends often (a member's heartbeat, a star master's heartbeat
with its roster changes and succession, a reliable barrier request) it times, per packet:
``seal`` (a platform's guard tags what the core encoded), ``check`` (a platform's guard
takes a sealed packet: frame, tag, replay window, body), ``check forged`` (a packet with a
wrong tag: what a flood of forgeries costs a platform) and, for reference, ``wire.decode``
alone. Each figure is the median of ``--rounds`` rounds of ``--packets`` packets, with the
lowest and highest round, in microseconds. Only the guard's public API is used, so the
same script measures an older checkout (``--src DIR`` puts ``DIR/src`` first on the path:
``git archive COMMIT src | tar -x -C DIR``). Prints one JSON object per figure.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any


def _rounds(fn: Callable[[int], None], packets: int, rounds: int) -> dict[str, float]:
    """Per-packet microseconds over ``rounds`` rounds of ``fn(packets)``."""
    fn(packets // 4)  # warm-up
    per: list[float] = []
    for _ in range(rounds):
        start = time.perf_counter()
        fn(packets)
        per.append((time.perf_counter() - start) / packets * 1e6)
    return {"median_us": statistics.median(per), "min_us": min(per), "max_us": max(per)}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=15)
    parser.add_argument("--packets", type=int, default=2000)
    parser.add_argument("--src", type=Path, default=None)
    args = parser.parse_args(argv)
    if args.src is not None:
        sys.path.insert(0, str(args.src / "src"))

    from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PrivateKey

    from actorswarm.core import wire
    from actorswarm.security.guard import PacketGuard

    key = bytes(range(32))
    public = Ed25519PrivateKey.generate().public_key()
    bodies: dict[str, Any] = {
        "member heartbeat": wire.Heartbeat(is_master=False, epoch=3, master=1, count=77),
        "master heartbeat": wire.Heartbeat(
            is_master=True,
            epoch=3,
            master=1,
            count=77,
            roster=120,
            size=29,
            changes=[(p, 1) for p in range(2, 18)],
            succession=[2, 3, 4, 5],
        ),
        "barrier request": wire.Data(
            dst=1,
            channel=wire.TO_MASTER,
            seq=5,
            floor=3,
            epoch=3,
            payload=wire.BarrierRequest(key=4, generation=2, need={0: 2, 1: 8}, bid=0.25),
        ),
    }
    for name, body in bodies.items():
        raws = [
            wire.encode(swarm="bench", sender=7, incarnation=2, seq=s + 1, body=body)
            for s in range(args.packets)
        ]
        sealer = PacketGuard(key, public)
        sealed = [sealer.seal(r) for r in raws]
        forged = [PacketGuard(bytes(32 - i for i in range(32)), public).seal(r) for r in raws]

        def seal(n: int, raws: list[bytes] = raws) -> None:
            g = PacketGuard(key, public)
            for r in raws[:n]:
                g.seal(r)

        def check(n: int, sealed: list[bytes] = sealed) -> None:
            g = PacketGuard(key, public)
            for s in sealed[:n]:
                g.check(s, 0.0)

        def check_forged(n: int, forged: list[bytes] = forged) -> None:
            g = PacketGuard(key, public)
            for f in forged[:n]:
                g.check(f, 0.0)

        def decode(n: int, sealed: list[bytes] = sealed) -> None:
            for s in sealed[:n]:
                wire.decode(s)

        for what, fn in (
            ("seal", seal),
            ("check", check),
            ("check forged", check_forged),
            ("wire.decode", decode),
        ):
            figure = _rounds(fn, args.packets, args.rounds)
            row = {"packet": name, "bytes": len(sealed[0]), "op": what}
            print(json.dumps(row | {k: round(v, 3) for k, v in figure.items()}), flush=True)


if __name__ == "__main__":
    main()
