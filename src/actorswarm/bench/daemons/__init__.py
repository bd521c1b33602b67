"""Benchmark of real daemon processes on one machine (docs/design.md §8), over Zenoh on loopback.

For each swarm size it starts that many ``actorswarm daemon`` processes
(:class:`~actorswarm.daemon.launch.LocalSwarm`: a full mesh of TCP links on 127.0.0.1, packet
authentication on; with ``broadcast="multicast"``, every daemon and the ground station on
Zenoh's UDP multicast transport through ``lo`` instead), waits until every daemon has all
the others in its view and they agree on one master, and measures:

* **resources**: each daemon's resident memory (``VmRSS`` and its private part ``RssAnon``
  from ``/proc/PID/status``) and the CPU it used over a window (``utime + stime`` from
  ``/proc/PID/stat``, every thread of the process, Zenoh's included), as a percentage of one
  core; and the packets on the wire: those ``lo`` received over the window (``/proc/net/dev``
  of the network namespace the bench runs in: run it in a namespace of its own, ``ip netns
  exec``, to count the swarm's packets alone) per packet the daemons sent (one ``send`` of
  the core, a broadcast counted once, from their ``status.json``). Twice: *idle* — no
  script deployed, only heartbeats and membership — and *script* — every platform running
  actor A (one ``core.idle`` plugin, stepped at 10 Hz) with a ground station connected.
  A swarm of N daemons means N − 1 peers for each.
* **failover**: the agreed master's daemon gets SIGKILL; from the bench's clock just before
  the signal to each survivor's first ``master`` log line naming the new master. Reported:
  the new master's own line (its claim) and the *last* survivor's line (when the whole swarm
  follows the new master). The killed platform is restarted from its state directory and
  the swarm must agree again (every view full, one master) before the next repetition.
  Election is sticky, so the master killed is not always platform 1.
* **collective switch**: a ground station in this process deploys a two-actor script
  (A → B on ``go``, B → A on ``back``; each a barrier of every platform, ``sysNum="all"``),
  starts it and fires the events in turn. From the bench's clock just before the event is
  sent to the latest ``transition`` log line of the platforms (the switch time), and the
  spread between the first and the last platform switching. And the CPU the switch cost
  the swarm (:func:`~.stats.switch_cpu`: every daemon's run time, less its idle rate); on a machine
  whose cores every daemon shares, that CPU divided by the cores is about the least time the
  switch can take (less the part spent after the last platform switched).

Every time compared is :func:`time.monotonic` (CLOCK_MONOTONIC), one clock for every process
on the machine: the daemons stamp their log lines and transitions with it. A run that does
not finish is recorded with its error and counted as failed, never dropped silently; a
swarm that never agrees (a machine too small for it) still has its CPU and memory measured,
marked ``idle, not settled``, and nothing else. The figures depend on the machine: every
daemon, the ground station and the bench share its cores, which :func:`~.probe.machine_info`
describes.

The package is split by job: :mod:`.probe` reads ``/proc`` and the daemons' logs,
:mod:`.swarm` tells whether a swarm agreed and drives it, :mod:`.measure` takes the three
measurements, :mod:`.run` orchestrates them size by size, :mod:`.results` holds what they
produce (and its JSON), :mod:`.stats` and :mod:`.report` turn it into the Markdown report.
"""

from actorswarm.bench.daemons.measure import measure_failover, switch_script
from actorswarm.bench.daemons.probe import (
    LogTail,
    machine_info,
    read_cpu_ns,
    read_cpu_seconds,
    read_interface_packets,
    read_memory_kib,
    read_sleeps,
)
from actorswarm.bench.daemons.report import markdown
from actorswarm.bench.daemons.results import Settings, SizeResult, from_json, to_json
from actorswarm.bench.daemons.run import bench
from actorswarm.bench.daemons.stats import same_processes, switch_cpu
from actorswarm.bench.daemons.swarm import (
    daemons_env,
    deploy,
    describe_swarm,
    ground_session,
    settled,
    wait_stable,
)

__all__ = [
    "LogTail",
    "Settings",
    "SizeResult",
    "bench",
    "daemons_env",
    "deploy",
    "describe_swarm",
    "from_json",
    "ground_session",
    "machine_info",
    "markdown",
    "measure_failover",
    "read_cpu_ns",
    "read_cpu_seconds",
    "read_interface_packets",
    "read_memory_kib",
    "read_sleeps",
    "same_processes",
    "settled",
    "switch_cpu",
    "switch_script",
    "to_json",
    "wait_stable",
]
