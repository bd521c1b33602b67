"""Application workloads that exercise the core inside a :class:`~actorswarm.sim.swarm.SimSwarm`.

They stand in for the task engine until it exists, and drive the scenario tests, the seeded
campaign and the demo: barrier rounds (every live platform keeps passing a barrier), role
churn (platforms claim and release a role with a quota) and application messages. Each
draws its randomness from its own seeded ``random.Random``, so runs stay replayable.
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field

from actorswarm.core.node import Node
from actorswarm.core.wire import NEED_ALL
from actorswarm.sim.swarm import SimSwarm


@dataclass(slots=True)
class BarrierRounds:
    """Every ``every`` seconds, each live platform without a pending request on ``key`` asks
    to pass it again (``need`` participants; NEED_ALL: every live platform in the master's
    view). Platforms listed in ``only`` are the only ones taking part, when given.
    ``renew``: each request may be counted for the open generation instead of refused as
    stale (:attr:`~actorswarm.core.wire.BarrierRequest.renew`, what the task engine asks)."""

    swarm: SimSwarm
    key: int = 1
    need: int = NEED_ALL
    every: float = 0.2
    start: float = 1.0
    stop: float = float("inf")
    timeout: float | None = None
    only: frozenset[int] | None = None
    renew: bool = False
    requests: int = 0

    def install(self) -> BarrierRounds:
        if self.need == NEED_ALL and self.only is None:
            # Every live platform asks: a firing must choose the master's whole view.
            self.swarm.checker.all_keys.add(self.key)
        self.swarm.at(self.start, self._round)
        return self

    def _round(self) -> None:
        now = self.swarm.now
        if now > self.stop:
            return
        for p, node in self.swarm.nodes.items():
            if self.only is not None and p not in self.only:
                continue
            if self.key not in node.barriers.pending:
                self.swarm.call(p, self._ask)
        self.swarm.at(now + self.every, self._round)

    def _ask(self, node: Node) -> None:
        self.requests += 1
        node.request_barrier(
            self.key, self.need, self.swarm.now, timeout=self.timeout, renew=self.renew
        )


@dataclass(slots=True)
class RoleChurn:
    """Every ``every`` seconds one random live platform claims ``role`` (or, if it holds it,
    releases it with probability ``release_p``)."""

    swarm: SimSwarm
    seed: int
    role: str = "leader"
    quota: int = 1
    every: float = 0.3
    start: float = 1.0
    stop: float = float("inf")
    release_p: float = 0.3
    rng: random.Random = field(init=False)

    def install(self) -> RoleChurn:
        self.rng = random.Random(f"roles:{self.seed}")
        self.swarm.at(self.start, self._step)
        return self

    def _step(self) -> None:
        now = self.swarm.now
        if now > self.stop:
            return
        live = sorted(self.swarm.nodes)
        if live:
            p = self.rng.choice(live)
            node = self.swarm.node(p)
            if self.role in node.roles.held:
                if self.rng.random() < self.release_p:
                    self.swarm.call(p, lambda n: n.release_role(self.role, now))
            elif self.role not in node.roles.claims:
                self.swarm.call(p, lambda n: n.claim_role(self.role, self.quota, now))
        self.swarm.at(now + self.every, self._step)


@dataclass(slots=True)
class AppChatter:
    """Every ``every`` seconds a random live platform sends a uniquely numbered app message
    to a random other platform or to the master."""

    swarm: SimSwarm
    seed: int
    every: float = 0.1
    start: float = 1.0
    stop: float = float("inf")
    sent: int = 0
    rng: random.Random = field(init=False)

    def install(self) -> AppChatter:
        self.rng = random.Random(f"app:{self.seed}")
        self.swarm.at(self.start, self._step)
        return self

    def _step(self) -> None:
        now = self.swarm.now
        if now > self.stop:
            return
        live = sorted(self.swarm.nodes)
        if len(live) >= 2:
            src = self.rng.choice(live)
            dst = self.rng.choice([*live, None])
            if dst != src:
                self.sent += 1
                body = f"{src}:{self.sent}".encode()
                self.swarm.call(src, lambda n: n.send_app(dst, "chat", body, now))
        self.swarm.at(now + self.every, self._step)
