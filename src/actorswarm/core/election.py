"""Master election rules (docs/design.md §3.2), as pure decisions the node applies.

Theory of operation
-------------------
There is no voting round. The master is the live platform with the minimum ID ("directly
appointed"), and becomes it through a handshake:

1. A platform that has listened for ``startup_wait`` seconds, follows no live master, and has
   the lowest ID in its view *claims*: it takes an epoch greater than any it has seen and
   announces it in its heartbeats and in a reliable ``Sync`` to every member.
2. A member follows a master whose epoch is greater than the one it follows — unless it
   follows a live master with a lower ID (that one will out-bid the newcomer) — and answers
   ``Sync`` with a ``Report`` of its pending state. The handshake is complete when every
   member of the master's view has reported; only then does the master fire barriers or
   grant roles, so no state of the previous master is lost or contradicted.
3. When two masters hear each other (a healed partition), the one with the higher ID steps
   down at once; the lower one claims again with an epoch above both, so every member of both
   former partitions follows it.

*Sticky* (the default): a lower ID that joins does not take over a healthy master.
``takeover_on_join`` gives the paper's behaviour, where the lowest ID always claims.

Epochs only grow on a platform (within one incarnation), which the simulator checks.

The decisions are tables of :class:`Rule` rows, :data:`HEARTBEAT_RULES` and :data:`CLAIM_RULES`;
``python -m actorswarm.docgen.election`` renders them into docs/collective-core.md.
"""

from __future__ import annotations

import enum
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Final, Generic, NamedTuple, TypeVar


class OnHeartbeat(enum.Enum):
    """What a platform does on hearing a peer's heartbeat."""

    IGNORE = "ignore"
    FOLLOW = "follow"  # follow the sender, a master, in its epoch
    STEP_DOWN = "step_down"  # I am master, the sender is a master with a lower ID: give up
    RECLAIM = "reclaim"  # I am master and someone has an epoch >= mine: claim above it
    DEMOTED = "demoted"  # the master I follow is master no more: follow whom it follows


class Role(enum.Enum):
    """A platform's place in the election, from its own state (see :func:`role_of`)."""

    MASTER = "master"
    FOLLOWER = "follower"  # follows a live master
    MASTERLESS = "masterless"  # follows no live master: booting, master lost, cut off


def role_of(is_master: bool, master: int | None, master_alive: bool) -> Role:
    """The role of a platform: master, following a known live master, or neither."""
    if is_master:
        return Role.MASTER
    if master is not None and master_alive:
        return Role.FOLLOWER
    return Role.MASTERLESS


#: The role a platform has after carrying out each action (None: unchanged). One that steps
#: down follows the sender next (FOLLOW); one whose master was demoted, that one's master.
ENTERS: Final[Mapping[OnHeartbeat, Role | None]] = {
    OnHeartbeat.IGNORE: None,
    OnHeartbeat.FOLLOW: Role.FOLLOWER,
    OnHeartbeat.STEP_DOWN: Role.MASTERLESS,
    OnHeartbeat.RECLAIM: Role.MASTER,
    OnHeartbeat.DEMOTED: Role.MASTERLESS,
}

In = TypeVar("In")
Out = TypeVar("Out")


@dataclass(frozen=True, slots=True)
class Rule(Generic[In, Out]):
    """A table row: for a platform in one of ``roles``, if ``test`` holds (``when`` says it
    in words), the decision is ``then``, because ``why``."""

    name: str
    roles: frozenset[Role]
    when: str
    test: Callable[[In], bool]
    then: Out
    why: str


def by_role(rules: tuple[Rule[In, Out], ...]) -> Mapping[Role, tuple[Rule[In, Out], ...]]:
    """``rules`` split by role, in order. Each table ends every role with a catch-all row."""
    return {role: tuple(rule for rule in rules if role in rule.roles) for role in Role}


def first_match(rules: tuple[Rule[In, Out], ...], given: In) -> Rule[In, Out]:
    """The first of ``rules`` (all for one role) whose test ``given`` passes."""
    for rule in rules:
        if rule.test(given):
            return rule
    raise AssertionError("no rule matched: a table must end every role with a catch-all row")


_MASTER: Final = frozenset({Role.MASTER})
_FOLLOWER: Final = frozenset({Role.FOLLOWER})
_MASTERLESS: Final = frozenset({Role.MASTERLESS})
_MEMBER: Final = frozenset({Role.FOLLOWER, Role.MASTERLESS})


class Hearing(NamedTuple):
    """The inputs of :func:`on_heartbeat`: this platform's state and the heartbeat heard."""

    self_id: int
    is_master: bool
    epoch: int
    master: int | None  # the master of this platform's epoch (itself when it is master)
    master_alive: bool  # whether this platform still follows ``master``
    sender: int
    sender_is_master: bool
    sender_epoch: int
    #: Whether this platform suspects ``master``: silent past its suspicion time, not yet
    #: past its leave time (which under loss waits for many more missed heartbeats).
    master_suspected: bool = False
    #: The master the sender follows (0: none), as its heartbeat says.
    sender_master: int = 0


#: How a platform reacts to a heartbeat (or a ``Sync``, which shows a master): first match.
HEARTBEAT_RULES: Final[tuple[Rule[Hearing, OnHeartbeat], ...]] = (
    Rule(
        "H1", _MASTER, "a master with a lower ID",
        lambda h: h.sender_is_master and h.sender < h.self_id,
        OnHeartbeat.STEP_DOWN, "the lowest ID is master; it claims again above both epochs",
    ),
    Rule(
        "H2", _MASTER, "an epoch above mine",
        lambda h: h.sender_epoch > h.epoch,
        OnHeartbeat.RECLAIM, "a master holds the highest epoch of its component",
    ),
    Rule(
        "H3", _MASTER, "a master (higher ID) of my epoch",
        lambda h: h.sender_is_master and h.sender_epoch == h.epoch,
        OnHeartbeat.RECLAIM, "claiming above it makes its members follow me",
    ),
    Rule(
        "H3b", _MASTER, "a member of my epoch that follows another master",
        lambda h: (
            not h.sender_is_master and h.sender_epoch == h.epoch
            and h.sender_master not in (0, h.self_id)
        ),
        OnHeartbeat.RECLAIM,
        "two partitions claimed the same epoch and its master stepped down before I heard it"
        " (H1): its members' firings of that epoch are not mine; claiming above both makes"
        " every member report to me",
    ),
    Rule(
        "H4", _MEMBER, "a non-master heartbeat of my epoch's master, epoch ≥ mine",
        lambda h: not h.sender_is_master and h.sender == h.master and h.sender_epoch >= h.epoch,
        OnHeartbeat.DEMOTED,
        "it is master no more (an older epoch is a late packet from before its claim)",
    ),
    Rule(
        "H5", _FOLLOWER, "a master, higher epoch, ID above my master's, which I do not suspect",
        lambda h: (
            h.sender_is_master and h.sender_epoch > h.epoch
            and h.master is not None and h.master < h.sender and not h.master_suspected
        ),
        OnHeartbeat.IGNORE, "my master outranks it and will claim above its epoch",
    ),
    Rule(
        "H6", _MEMBER, "a master with a higher epoch",
        lambda h: h.sender_is_master and h.sender_epoch > h.epoch,
        OnHeartbeat.FOLLOW,
        "the newest claim wins; epochs only grow (a claim while I suspect my master confirms"
        " the suspicion: the claimant's own detector fired; if my master lives, it claims"
        " above the claimant and I follow it back)",
    ),
    Rule(
        "H7", _MASTERLESS, "a master of my epoch",
        # (``master_alive`` without a known ``master`` still follows someone: no FOLLOW.)
        lambda h: h.sender_is_master and h.sender_epoch == h.epoch and not h.master_alive,
        OnHeartbeat.FOLLOW,
        "my master is lost (or back after a false alarm): one of my epoch is as good as any,"
        " and following it keeps epochs monotonic",
    ),
    Rule(
        "H8", frozenset(Role), "anything else",
        lambda h: True,
        OnHeartbeat.IGNORE, "an older epoch, an ordinary member, or my master as before",
    ),
)  # fmt: skip
_HEARTBEAT_BY_ROLE: Final = by_role(HEARTBEAT_RULES)


def on_heartbeat(
    *,
    self_id: int,
    is_master: bool,
    epoch: int,
    master: int | None,
    master_alive: bool,
    sender: int,
    sender_is_master: bool,
    sender_epoch: int,
    master_suspected: bool = False,
    sender_master: int = 0,
) -> OnHeartbeat:
    """Decide how to react to ``sender``'s heartbeat (``sender_is_master``, ``sender_epoch``).

    ``master`` is the master of this platform's epoch (itself when it is master), and
    ``master_alive`` whether this platform still follows it (False after it left the view),
    ``master_suspected`` whether it has been silent past its suspicion time.
    A master must always hold the highest epoch of its component, so a master that hears an
    epoch at least as high as its own claims again. The decision of :data:`HEARTBEAT_RULES`.
    """
    rules = _HEARTBEAT_BY_ROLE[role_of(is_master, master, master_alive)]
    h = Hearing(
        self_id,
        is_master,
        epoch,
        master,
        master_alive,
        sender,
        sender_is_master,
        sender_epoch,
        master_suspected,
        sender_master,
    )
    return first_match(rules, h).then


class Claimant(NamedTuple):
    """The inputs of :func:`should_claim`."""

    self_id: int
    lowest_peer: int | None  # the lowest ID in the view (None when alone)
    is_master: bool
    master: int | None  # the master this platform follows
    master_alive: bool
    takeover_on_join: bool
    listened: float  # how long this incarnation has been up
    startup_wait: float


#: Whether a platform claims the master role now: first match.
CLAIM_RULES: Final[tuple[Rule[Claimant, bool], ...]] = (
    Rule("C1", _MASTER, "always", lambda c: True, False, "I am master already"),
    Rule(
        "C2", _MEMBER, "listened less than `startup_wait`",
        lambda c: c.listened < c.startup_wait, False, "a master or a lower ID may yet speak",
    ),
    Rule(
        "C3", _MEMBER, "a lower ID in my view",
        lambda c: c.lowest_peer is not None and c.lowest_peer < c.self_id, False,
        "the lowest ID claims, not I",
    ),
    Rule(
        "C4", _MASTERLESS, "no lower ID in my view", lambda c: True, True,
        "the live platform with the lowest ID is master",
    ),
    Rule(
        "C5", _FOLLOWER, "`takeover_on_join`, my ID below my master's",
        lambda c: c.takeover_on_join and c.master is not None and c.self_id < c.master, True,
        "the paper's behaviour: the lowest ID always takes over",
    ),
    Rule(
        "C6", _FOLLOWER, "anything else", lambda c: True, False,
        "sticky: a lower ID that joins does not take over a healthy master",
    ),
)  # fmt: skip
_CLAIM_BY_ROLE: Final = by_role(CLAIM_RULES)


def should_claim(
    *,
    self_id: int,
    lowest_peer: int | None,
    is_master: bool,
    master: int | None,
    master_alive: bool,
    takeover_on_join: bool,
    listened: float,
    startup_wait: float,
) -> bool:
    """Whether this platform should claim the master role now (:data:`CLAIM_RULES`).

    ``lowest_peer`` is the lowest ID in the view (None when alone); ``listened`` is how long
    this incarnation has been up.
    """
    rules = _CLAIM_BY_ROLE[role_of(is_master, master, master_alive)]
    c = Claimant(
        self_id, lowest_peer, is_master, master, master_alive, takeover_on_join, listened,
        startup_wait,
    )  # fmt: skip
    return first_match(rules, c).then
