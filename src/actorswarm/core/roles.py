"""Arbitration of roles with quotas (docs/design.md §3.4): "exactly one leader", "one Track actor".

Theory of operation
-------------------
A member claims a role with a quota and a bid. The master grants it while fewer than
``quota`` platforms hold it; otherwise it denies the claim and keeps it queued. When a holder
releases the role or leaves the swarm, the master grants it to the best queued claimant (lowest
bid, then lowest ID): the "leader lost" case resolves itself.

A new master rebuilds grants from the members' reports. If more platforms hold a role than
its quota allows — two partitions each granted it, then healed ("multiple leaders") — the
master keeps the best bids and revokes the rest. Until the handshake is over the master only
records claims, so it never grants a slot a silent member still holds.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

from actorswarm.core.events import RoleDenied, RoleGranted, RoleRevoked
from actorswarm.core.wire import RoleClaim, RoleDeny, RoleGrant, RoleRevoke

Reply = RoleGrant | RoleDeny | RoleRevoke


class RoleOutput(Protocol):
    """Where the role master puts its replies, given to it at construction (the node
    routes each: to this platform's own member part, or over a stream)."""

    def reply(self, platform: int, reply: Reply) -> None:
        """Send ``reply`` to ``platform``."""


@dataclass(slots=True)
class _Role:
    quota: int
    holders: dict[int, float] = field(default_factory=dict)  # platform -> bid
    waiting: dict[int, float] = field(default_factory=dict)
    denied: set[int] = field(default_factory=set)  # told "denied" once per claim


class RoleMaster:
    """The master's role table. Its replies go to ``output``."""

    def __init__(self, output: RoleOutput) -> None:
        self.roles: dict[str, _Role] = {}
        self.ready = False
        self._output = output

    def _role(self, claim: RoleClaim) -> _Role:
        role = self.roles.get(claim.role)
        if role is None:
            role = self.roles[claim.role] = _Role(claim.quota)
        else:
            role.quota = min(role.quota, claim.quota)
        return role

    def claim(self, platform: int, claim: RoleClaim) -> None:
        role = self._role(claim)
        if platform in role.holders:
            self._output.reply(platform, RoleGrant(role=claim.role))
            return
        role.waiting[platform] = claim.bid
        role.denied.discard(platform)
        if self.ready:
            self._settle(claim.role)

    def release(self, platform: int, name: str) -> None:
        role = self.roles.get(name)
        if role is None:
            return
        role.holders.pop(platform, None)
        role.waiting.pop(platform, None)
        if self.ready:
            self._settle(name)

    def report(self, platform: int, held: list[RoleClaim], claims: list[RoleClaim]) -> None:
        """A member's handshake report replaces what the master knew of it — except a
        grant this master made that the report shows as still claimed: the grant and the
        report crossed (the grant is on its way, in order, on the member's reliable stream),
        so the member will hold it; freeing the slot would grant it twice."""
        touched = set()
        claimed = {c.role for c in claims}
        crossed = set()
        for name, role in self.roles.items():
            if platform in role.holders and name in claimed:
                crossed.add(name)
                # Granted again in case the first grant was given up (a member ignores
                # a grant of a role it already holds).
                self._output.reply(platform, RoleGrant(role=name))
                continue
            if role.holders.pop(platform, None) is not None:
                touched.add(name)  # a slot it no longer holds may go to someone waiting
            role.waiting.pop(platform, None)
        for claim in held:
            self._role(claim).holders[platform] = claim.bid
        for claim in claims:
            if claim.role not in crossed:
                self._role(claim).waiting[platform] = claim.bid
        if self.ready:
            for name in sorted(touched | {c.role for c in (*held, *claims)}):
                self._settle(name)

    def member_left(self, platform: int, *, restarted: bool = False) -> None:
        """``platform`` left; its roles go to whoever waits. ``restarted``: it rebooted, and
        its new incarnation is told to drop what the old one held — a grant to the old one
        may have reached the new one (a message on its way to a platform is not tied to an
        incarnation), which would otherwise hold a role the master no longer counts."""
        touched = []
        for name, role in self.roles.items():
            if role.holders.pop(platform, None) is not None:
                touched.append(name)
                if restarted:
                    self._output.reply(platform, RoleRevoke(role=name))
            role.waiting.pop(platform, None)
        if self.ready:
            for name in touched:
                self._settle(name)

    def become_ready(self) -> None:
        self.ready = True
        for name in list(self.roles):
            self._settle(name)

    def _settle(self, name: str) -> None:
        """Bring holders within quota (revoking the worst) and fill free slots (best first)."""
        role = self.roles[name]
        if len(role.holders) > role.quota:
            ranked = sorted(role.holders.items(), key=lambda kv: (kv[1], kv[0]))
            for platform, _ in ranked[role.quota :]:
                del role.holders[platform]
                self._output.reply(platform, RoleRevoke(role=name))
        if role.waiting:
            ranked = sorted(role.waiting.items(), key=lambda kv: (kv[1], kv[0]))
            for platform, bid in ranked:
                if len(role.holders) < role.quota:
                    del role.waiting[platform]
                    role.denied.discard(platform)
                    role.holders[platform] = bid
                    self._output.reply(platform, RoleGrant(role=name))
                elif platform not in role.denied:
                    role.denied.add(platform)
                    self._output.reply(platform, RoleDeny(role=name, holders=sorted(role.holders)))

    def holders(self, name: str) -> tuple[int, ...]:
        role = self.roles.get(name)
        return tuple(sorted(role.holders)) if role else ()


class RoleMember:
    """What one platform holds and claims."""

    def __init__(self) -> None:
        self.held: dict[str, RoleClaim] = {}
        self.claims: dict[str, RoleClaim] = {}
        self._denied: set[str] = set()

    def claim(self, role: str, quota: int, bid: float) -> RoleClaim:
        if quota < 1:
            raise ValueError(f"role {role!r}: quota must be >= 1, got {quota}")
        claim = RoleClaim(role=role, quota=quota, bid=bid)
        if role not in self.held:
            self.claims[role] = claim
            self._denied.discard(role)  # a new claim is reported again if denied
        return claim

    def release(self, role: str) -> bool:
        self._denied.discard(role)
        had = self.held.pop(role, None) is not None
        return self.claims.pop(role, None) is not None or had

    def on_reply(self, reply: Reply) -> RoleGranted | RoleDenied | RoleRevoked | None:
        if isinstance(reply, RoleGrant):
            claim = self.claims.pop(reply.role, None)
            if claim is None:
                return None  # granted something no longer wanted; a release is on its way
            if reply.role in self.held:
                return None
            self.held[reply.role] = claim
            self._denied.discard(reply.role)
            return RoleGranted(role=reply.role)
        if isinstance(reply, RoleDeny):
            held = self.held.pop(reply.role, None)
            if held is not None:
                # The master counts this platform as waiting, not holding: its grant reached
                # here after the master had dropped the platform (it left, the grant was on
                # its way) and the rejoin report, made before the grant arrived, said
                # "claimed". The master's table is what the quota is kept by: hold nothing
                # and wait again, reported once (campaign seed 7671936).
                self.claims[reply.role] = held
                self._denied.add(reply.role)
                return RoleRevoked(role=reply.role)
            if reply.role not in self.claims or reply.role in self._denied:
                return None  # report a denial once per claim, not on every re-statement
            self._denied.add(reply.role)
            return RoleDenied(role=reply.role, holders=tuple(reply.holders))
        if self.held.pop(reply.role, None) is None:
            return None
        return RoleRevoked(role=reply.role)
