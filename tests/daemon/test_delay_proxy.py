"""The TCP forwarder that stands in for a radio's latency where the kernel has no netem
(``delay_proxy.py``, used by ``netns_lab.Radios(proxy_delay_ms=...)`` and
``scripts/multihop_bench.py --proxy-delay``): each way late by its delay, bytes in order."""

from __future__ import annotations

import asyncio
import subprocess
import sys
import time
from pathlib import Path

PROXY = Path(__file__).with_name("delay_proxy.py")


def test_the_forwarder_delays_each_way_and_keeps_the_bytes_in_order() -> None:
    async def scenario() -> tuple[list[float], bool]:
        async def echo(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
            while data := await reader.read(4096):
                writer.write(data)
                await writer.drain()
            writer.close()

        server = await asyncio.start_server(echo, "127.0.0.1", 0)
        target = server.sockets[0].getsockname()[1]
        proc = subprocess.Popen(
            [sys.executable, str(PROXY), "0", "127.0.0.1", str(target), "40"],
            stdout=subprocess.PIPE,
            text=True,
        )
        try:
            assert proc.stdout is not None
            ready, listen = proc.stdout.readline().split()
            assert ready == "ready"
            reader, writer = await asyncio.open_connection("127.0.0.1", listen)
            trips = []
            for i in range(3):
                sent = time.monotonic()
                writer.write(b"%d;" % i)
                await writer.drain()
                assert await reader.readexactly(2) == b"%d;" % i
                trips.append(time.monotonic() - sent)
            # A burst: every chunk comes back, in order, however the reads split it.
            burst = b"".join(b"%04d" % i for i in range(500))
            writer.write(burst)
            await writer.drain()
            echoed = await reader.readexactly(len(burst))
            writer.close()
            return trips, echoed == burst
        finally:
            proc.kill()
            proc.wait()
            server.close()

    trips, in_order = asyncio.run(scenario())
    # 40 ms each way: a round trip is two of them (and not much more on an idle machine).
    assert all(0.08 <= t < 0.5 for t in trips), trips
    assert in_order
