"""Transport adapters (docs/design.md §2): how a platform's packets reach the others.

A transport is thin: ``send(dst, data, urgent=...)`` (``dst`` None broadcasts), a way to
hand over what arrived (:class:`ZenohTransport` keeps it in bounded ring channels until the
host's loop drains them, one batch per wake: :class:`~actorswarm.transport.base.Receiver`),
``close()``, and a context manager. It moves opaque bytes; the collective core above it
does the rest (membership, reliable delivery), and the security layer between them
authenticates every packet. :class:`ZenohTransport` is the one
for real robots; the simulator's radio (:mod:`actorswarm.sim.radio`) is the in-process one.
"""

from actorswarm.transport.zenoh_transport import (
    RX_CAPACITY,
    ZenohSettings,
    ZenohTransport,
    key_prefix,
)

__all__ = ["RX_CAPACITY", "ZenohSettings", "ZenohTransport", "key_prefix"]
