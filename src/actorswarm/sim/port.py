"""A simulated platform's packets on the simulated radio, sealed and checked as a daemon's.

:class:`RadioPort` is one platform's :class:`~actorswarm.transport.base.Transport` on a
:class:`~actorswarm.sim.radio.SimRadio`; :class:`SimKeys` are the simulated swarm's keys,
derived from the run's seed (a run replays, packet for packet, tag for tag). A simulated
host puts a :class:`~actorswarm.security.pipeline.Pipeline` between each endpoint and its
port, with a guard made by :meth:`SimKeys.guard`, so every simulated packet costs what a
real one does: one HMAC to seal it, a frame check, one HMAC and one body decode to take it
— except that the receivers of one broadcast share the frame check and the HMAC
(:class:`~actorswarm.security.guard.VerdictMemo`): they would compute the same verdict on
the same bytes.

``security="insecure"`` makes guards that check only the frame (the cost of a swarm run
with ``--insecure``).
"""

from __future__ import annotations

import hashlib
from typing import Any, Literal

from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PrivateKey

from actorswarm.security.guard import PacketGuard, Role, VerdictMemo

__all__ = ["RadioPort", "Security", "SimKeys"]

#: How a simulated swarm protects its packets: with keys of its own, or not at all.
Security = Literal["keys", "insecure"]


class RadioPort:
    """Platform ``platform``'s transport on ``radio`` (a :class:`SimRadio`)."""

    __slots__ = ("platform", "radio")

    def __init__(self, radio: Any, platform: int) -> None:
        self.radio = radio
        self.platform = platform

    def send(self, dst: int | None, data: bytes, *, urgent: bool = False, kind: str = "") -> None:
        """Put ``data`` on the air to ``dst`` (None: broadcast); the radio has no priorities,
        so ``urgent`` changes nothing; ``kind`` labels the radio's traffic counters."""
        self.radio.send(self.platform, dst, data, kind)


class SimKeys:
    """The simulated swarm's keys, from ``seed``: a swarm key and the ground station's
    Ed25519 pair (``security="keys"``), or none (``"insecure"``)."""

    __slots__ = ("_memos", "_private", "_swarm_key", "security")

    def __init__(self, seed: int, security: Security = "keys") -> None:
        if security not in ("keys", "insecure"):
            raise ValueError(f"security must be 'keys' or 'insecure', got {security!r}")
        self.security: Security = security
        self._swarm_key = hashlib.sha256(f"actorswarm sim {seed}: swarm key".encode()).digest()
        self._private = Ed25519PrivateKey.from_private_bytes(
            hashlib.sha256(f"actorswarm sim {seed}: ground station".encode()).digest()
        )
        # One verdict memo per size limit, shared by every guard made here: the receivers
        # of a broadcast check the same bytes with the same keys, so the frame check and
        # the HMAC are done once per packet instead of once per receiver.
        self._memos: dict[int, VerdictMemo] = {}

    def guard(self, role: Role = "platform", *, max_bytes: int) -> PacketGuard:
        """A new guard (its own replay windows) for one platform or the ground station."""
        if self.security == "insecure":
            return PacketGuard.insecure(role=role, max_bytes=max_bytes)
        return PacketGuard(
            self._swarm_key,
            self._private.public_key(),
            gs_private_key=self._private if role == "ground" else None,
            role=role,
            max_bytes=max_bytes,
            memo=self._memos.setdefault(max_bytes, VerdictMemo()),
        )
