"""A TCP forwarder that delays what it carries: a radio link's latency where the kernel has
no ``sch_netem`` (:mod:`netns_lab`).

``python delay_proxy.py LISTEN_PORT TARGET_HOST TARGET_PORT DELAY_MS`` listens on
127.0.0.1:LISTEN_PORT (in the namespace it runs in) and forwards every connection to
TARGET_HOST:TARGET_PORT, each chunk of bytes, in each direction, ``DELAY_MS`` after it was
read, in order. So a message over one such link arrives one delay later, as over a radio
of that one-way latency; what is not emulated is the delay of TCP's own acknowledgements
(the proxy acknowledges at once), which matters only to how fast a lossy link retransmits.
A LISTEN_PORT of 0 takes a free one. Prints ``ready PORT`` once listening; runs until
killed.
"""

from __future__ import annotations

import asyncio
import contextlib
import sys
from collections import deque


async def _pump(reader: asyncio.StreamReader, writer: asyncio.StreamWriter, delay: float) -> None:
    """Copy ``reader`` to ``writer``, each chunk ``delay`` seconds after it was read."""
    loop = asyncio.get_running_loop()
    queue: deque[tuple[float, bytes]] = deque()
    more = asyncio.Event()
    done = False

    async def send() -> None:
        while queue or not done:
            if not queue:
                more.clear()
                await more.wait()
                continue
            due, data = queue[0]
            wait = due - loop.time()
            if wait > 0:
                await asyncio.sleep(wait)
            queue.popleft()
            writer.write(data)
            await writer.drain()
        writer.close()

    sender = asyncio.create_task(send())
    try:
        while data := await reader.read(65536):
            queue.append((loop.time() + delay, data))
            more.set()
    except ConnectionError:
        pass
    finally:
        done = True
        more.set()
    with contextlib.suppress(ConnectionError):
        await sender


async def _serve(port: int, host: str, target: int, delay: float) -> None:
    async def connected(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        try:
            far_reader, far_writer = await asyncio.open_connection(host, target)
        except OSError:
            writer.close()
            return
        await asyncio.gather(_pump(reader, far_writer, delay), _pump(far_reader, writer, delay))

    server = await asyncio.start_server(connected, "127.0.0.1", port)
    print("ready", server.sockets[0].getsockname()[1], flush=True)
    async with server:
        await server.serve_forever()


def main(argv: list[str]) -> int:
    if len(argv) != 4:
        print(__doc__, file=sys.stderr)
        return 2
    port, host, target, delay_ms = int(argv[0]), argv[1], int(argv[2]), float(argv[3])
    asyncio.run(_serve(port, host, target, delay_ms / 1000.0))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
