"""What the ground station can tell the operator when platforms do not answer.

A platform that refuses a packet says nothing back: it counts the refusal by reason in its
``status.json`` (``rejected``: ``bad_tag``, ``bad_signature``, ``replay``...), and answering
would hand whoever sent it a free oracle. So the ground station reasons from what it does
observe:

* **heartbeats it verified** (:attr:`GroundStation.heard`): the platform has this swarm key
  and is in reach; or, in a star swarm, the platform is in the master's roster
  (:attr:`GroundStation.listed`): the master hears it, which says nothing of the link
  between the platform and the ground station;
* **acknowledgements** (:attr:`GroundStation.acked`): the platform accepted this session's
  packets. Heard but never acknowledging means its packets are refused — a
  ``ground_station.pub`` that is not this ground station's key (``bad_signature``), or this
  machine's clock set back (its new session looks like a replay) — or the link is one-way;
* **packets it could not verify** (the packet guard's ``rejected`` and ``refused_from``):
  heartbeats of this swarm's name under another swarm key (``bad_tag``), which the platforms
  count likewise for this ground station's packets.

:func:`explain` turns those into sentences; it decides nothing and sends nothing.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping

from actorswarm.dsl.syntax import id_ranges

__all__ = ["explain", "platforms"]

#: What a platform that refuses a command counts, and the usual reason.
_REFUSED_HINT = (
    "they refuse this ground station's packets (a platform counts them in its status.json "
    "`rejected`): `bad_signature` when its ground_station.pub is not this ground station's "
    "key — compare `actorswarm keys show` here and on a platform; `replay` when this "
    "machine's clock is behind the one of an earlier session; or the link to them is one-way"
)


def platforms(ids: Collection[int]) -> str:
    """``platform 3`` or ``platforms 1-6,9``."""
    text = id_ranges(frozenset(ids))
    return f"platform {text}" if len(ids) == 1 else f"platforms {text}"


def explain(
    swarm: str,
    *,
    targets: Collection[int],
    answered: Collection[int],
    heard: Collection[int],
    acked: Collection[int],
    rejected: Mapping[str, int],
    refused_from: Mapping[str, Collection[int]],
    listed: Collection[int] = (),
) -> list[str]:
    """Sentences for the operator about the ``targets`` that did not answer, from what the
    ground station observed (see the module docstring); empty when every target answered.

    ``heard``: platforms whose heartbeats verified, or listed in a master's roster;
    ``listed``: those of ``heard`` known only from a roster (nothing of their own reached the
    ground station); ``acked``: platforms that accepted this session's packets; ``rejected``
    and ``refused_from``: the packet guard's counts of refused packets by reason and who
    they claimed to come from."""
    silent = set(targets) - set(answered)
    if targets and not silent:
        return []
    out: list[str] = []
    foreign = rejected.get("bad_tag", 0)
    if foreign:
        claimed = refused_from.get("bad_tag", ())
        who = f" (from {platforms(claimed)}, as they claim)" if claimed else ""
        out.append(
            f"heard {foreign} packet(s) of swarm {swarm!r}{who} under a different swarm key "
            "(bad_tag): those platforms use another swarm.key and count packets under this "
            "one as bad_tag — compare `actorswarm keys show` fingerprints"
        )
    if not heard and not targets:
        if not foreign:
            out.append(
                f"no platform of swarm {swarm!r} answered: nothing was heard — check --swarm, "
                "--connect/--listen and multicast, and --broadcast (a swarm on a multicast group "
                "hears only commands on its group); a platform that hears a different swarm "
                "key counts it as bad_tag in its status.json `rejected`"
            )
        return out
    refused = sorted(p for p in silent if p in heard and p not in acked and p not in listed)
    everyone = bool(refused) and not answered and not set(acked) & set(targets)
    if refused:
        lead = "no platform accepted the command: " if everyone else ""
        out.append(f"{lead}{platforms(refused)} heard but acknowledged nothing — {_REFUSED_HINT}")
    behind = sorted(p for p in silent if p in listed and p not in acked)
    if behind:
        # A star member heartbeats to its master only: its place in the roster proves the
        # master's link to it, not this ground station's.
        out.append(
            f"{platforms(behind)} in the master's roster but acknowledged nothing, and nothing "
            "of their own reached this ground station: no working link between here and them "
            "(does this ground station connect to them? are they in its range?) — or "
            f"{_REFUSED_HINT}"
        )
    lost = sorted(p for p in silent if p in acked)
    if lost:
        out.append(
            f"{platforms(lost)} acknowledged but did not answer in time: the link is lossy or "
            "they are busy; try again with a longer --timeout"
        )
    unheard = sorted(p for p in silent if p not in heard and p not in acked)
    if unheard and everyone:
        # Star membership: members heartbeat to their master only; the ground station
        # learns them from the master's roster, which it asks for in a signed request.
        out.append(
            f"{platforms(unheard)} not heard: a star swarm's members are heard through their "
            "master's roster, which a ground station the master refuses does not get"
        )
    elif unheard:
        out.append(f"{platforms(unheard)} not heard: off, out of range, or not in swarm {swarm!r}")
    return out
