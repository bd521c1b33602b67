"""The node's parts: its two roles share one interface and are swapped when it claims or
steps down, so ``is_master`` always says which one it holds."""

from __future__ import annotations

import inspect

from actorswarm.core.node import Node
from actorswarm.core.node.duties import MasterDuties, MemberDuties
from actorswarm.sim.swarm import SimSwarm

#: What one role does that the other has no part in: the master decides master-bound
#: messages and sends out what its tables decided; a member takes its master's replies.
OWN = {MasterDuties: {"decide", "flush", "to_member"}, MemberDuties: {"take"}}


def _interface(cls: type) -> dict[str, inspect.Signature]:
    return {
        name: inspect.signature(member)
        for name, member in vars(cls).items()
        if inspect.isfunction(member) and not name.startswith("_") and name not in OWN[cls]
    }


def test_the_master_and_the_member_duties_have_one_interface() -> None:
    master, member = _interface(MasterDuties), _interface(MemberDuties)
    assert master.keys() == member.keys()
    for name, signature in master.items():
        assert signature == member[name], name
    assert len(master) >= 15, sorted(master)  # the node's calls, not a trivial pair


def _holds_its_role(node: Node) -> bool:
    expected = MasterDuties if node.is_master else MemberDuties
    return type(node._role) is expected


def test_a_failover_swaps_the_roles_and_is_master_follows() -> None:
    swarm = SimSwarm(5, seed=3)
    swarm.run_until(3.0)
    assert swarm.current_masters() == [1]
    assert all(_holds_its_role(node) for node in swarm.nodes.values())
    assert type(swarm.node(1)._role) is MasterDuties
    assert type(swarm.node(2)._role) is MemberDuties
    swarm.crash(1)
    swarm.run_until(6.0)
    assert swarm.current_masters() == [2]
    assert all(_holds_its_role(node) for node in swarm.nodes.values())
    assert type(swarm.node(2)._role) is MasterDuties


def test_a_master_that_steps_down_holds_the_member_duties() -> None:
    swarm = SimSwarm(4, seed=5)
    swarm.partition([[1, 2], [3, 4]])
    swarm.run_until(3.0)
    assert sorted(swarm.current_masters()) == [1, 3]
    swarm.partition([[1, 2, 3, 4]])
    swarm.run_until(8.0)
    assert swarm.current_masters() == [1]
    assert type(swarm.node(3)._role) is MemberDuties
    assert not swarm.node(3).is_master
    assert all(_holds_its_role(node) for node in swarm.nodes.values())


def test_the_handshake_alone_waits_for_every_report_and_syncs_once() -> None:
    from actorswarm.core.node.handshake import Handshake

    handshake = Handshake()
    assert handshake.deadlines() == (None, None) and not handshake.expired(99.0)
    handshake.restart(bulletin=7)
    handshake.open({3, 2}, deadline=5.0, sync_at=1.0)
    assert handshake.awaited == 2 and handshake.deadlines() == (5.0, 1.0)
    assert handshake.syncs_due(0.5) == []
    assert handshake.syncs_due(1.0) == [2, 3]
    assert handshake.syncs_due(2.0) == []  # once per handshake
    assert not handshake.reported(2)  # 3 still awaited
    assert handshake.reported(3)  # the last one: the handshake may finish
    assert handshake.settled() and not handshake.expired(4.9) and handshake.expired(5.0)
    assert not handshake.close()  # nobody was still awaited
    # A member that reported, left and comes back in the same epoch is rejoining, once.
    handshake.left(3, restarted=False)
    assert not handshake.has_reported(3)
    assert handshake.forget_rejoining(3) and not handshake.forget_rejoining(3)
    # A newcomer opens a closed handshake again until its timeout.
    handshake.wait_for(9, now=10.0, timeout=2.0)
    assert handshake.deadlines() == (12.0, None) and handshake.awaited == 1
    assert handshake.close()  # 9 never reported


def test_the_master_tables_alone_start_a_term_empty_but_for_the_firings_decided() -> None:
    from actorswarm.core.barrier import BarrierMaster
    from actorswarm.core.config import CoreConfig
    from actorswarm.core.node.outbox import MasterOutbox
    from actorswarm.core.node.tables import MasterTables
    from actorswarm.core.wire import BarrierRequest

    def new_barriers(outbox: MasterOutbox) -> BarrierMaster:
        return BarrierMaster(CoreConfig(), outbox, resolve_need=lambda k, p, n: n, platform=1)

    def fired_twice() -> MasterTables:
        tables = MasterTables(1, new_barriers)
        tables.hold()
        assert not tables.roles.ready
        tables.become_ready(0.0, 2)
        assert tables.roles.ready
        for key in (9, 10):
            request = BarrierRequest(key=key, generation=0, need={0: 1}, bid=0.0, epoch=2)
            tables.barriers.request(1, request, 0.0, 2)
        return tables

    assert fired_twice().outbox.take(), "the firings wait in the outbox until routed"
    tables = fired_twice()
    decided = tables.barriers.decided(1)
    assert [record.key for record in decided] == [9, 10]
    before = tables.barriers
    tables.new_term()  # the two firings were decided but never routed
    assert tables.barriers is not before and not tables.roles.ready
    assert tables.outbox.take() == []  # what was never routed goes with the old tables
    assert tables.barriers.decided(1) == decided  # what was decided is kept


def test_the_failures_alone_become_events_and_a_lost_master_bound_message_restates() -> None:
    from actorswarm.core.config import CoreConfig
    from actorswarm.core.events import DeliveryFailed
    from actorswarm.core.node.failures import Failures
    from actorswarm.core.ready import Collector, DeliveryFailure
    from actorswarm.core.wire import AppMessage, RoleRelease

    out = Collector()
    failures = Failures(out, CoreConfig())
    failures.report()  # nothing given up: nothing told
    assert out.events == [] and not failures.take_restate()
    out.failures.append(DeliveryFailure(5, AppMessage(topic="t", body=b""), "left"))
    failures.report()
    assert out.events == [
        DeliveryFailed(dst=5, kind="AppMessage", reason="the destination left the swarm")
    ]
    assert out.failures == [] and not failures.take_restate()
    out.failures.append(DeliveryFailure(None, RoleRelease(role="r")))  # master-bound, deadline
    failures.report()
    assert failures.take_restate() and not failures.take_restate()  # taken once
