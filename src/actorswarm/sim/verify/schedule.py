"""One run's fault schedule, drawn from a profile by its seed, and its replay command.

A :class:`Schedule` is a list of independent :class:`Item` s — the radio's loss, its delay,
a crash (with its reboot), a partition (with its heal), an autopilot's fault, an operator's
event moved — so that :mod:`~actorswarm.sim.verify.minimize` can take any of them away and
run again. Every item is an ``actorswarm sim`` option: :meth:`Schedule.sim_options` is
the command that replays the run, bit for bit.

:func:`draw` is deterministic: the same profile, seed, platforms, duration and events give
the same schedule (its random stream is its own, seeded by a string of the seed).
"""

from __future__ import annotations

import math
import random
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Literal

from actorswarm.sim.radio import LinkModel
from actorswarm.sim.tasksim import Fault, GroundEvent
from actorswarm.sim.vehicle_faults import VehicleFault
from actorswarm.sim.verify.profile import FaultProfile, Range

__all__ = ["DEFAULT_LATENCY_MS", "Item", "Schedule", "draw"]

#: ``actorswarm sim``'s default one-way latency: what the radio has without a delay item.
DEFAULT_LATENCY_MS = 10.0

ItemKind = Literal["loss", "delay", "kill", "partition", "vehicle", "shift"]


@dataclass(frozen=True, slots=True)
class Item:
    """One fault of a schedule: ``text`` says it for people, ``options`` for ``sim``."""

    kind: ItemKind
    text: str
    options: tuple[str, ...]
    #: loss: (p,); delay: (latency_ms, jitter_ms); shift: (event index, new time).
    values: tuple[float, ...] = ()
    faults: tuple[Fault, ...] = ()
    vehicle: VehicleFault | None = None


@dataclass(frozen=True, slots=True)
class Schedule:
    """The operator's ``events`` (as planned) and the fault ``items`` of one run."""

    seed: int
    events: tuple[GroundEvent, ...]
    items: tuple[Item, ...] = field(default=())

    def only(self, items: Iterable[Item]) -> Schedule:
        """The same run with only ``items`` (a subset of this one's)."""
        return Schedule(self.seed, self.events, tuple(items))

    def link(self) -> LinkModel:
        loss = next((i.values[0] for i in self.items if i.kind == "loss"), 0.0)
        latency, jitter = next(
            (i.values for i in self.items if i.kind == "delay"), (DEFAULT_LATENCY_MS, 0.0)
        )
        return LinkModel(loss=loss, latency=latency / 1000.0, jitter=jitter / 1000.0)

    def ground_events(self) -> list[GroundEvent]:
        """The operator's events at their times in this run (moved where an item says)."""
        moved = {int(i.values[0]): i.values[1] for i in self.items if i.kind == "shift"}
        return [GroundEvent(e.name, moved.get(n, e.t), e.ids) for n, e in enumerate(self.events)]

    def faults(self) -> list[Fault]:
        return [f for i in self.items for f in i.faults]

    def vehicle_faults(self) -> tuple[VehicleFault, ...]:
        return tuple(i.vehicle for i in self.items if i.vehicle is not None)

    def sim_options(self) -> list[str]:
        """The ``actorswarm sim`` options of this run (after the script, the world and the
        duration): the seed, the radio, the events, then every fault."""
        out = ["--seed", str(self.seed)]
        link = self.link()
        if link.loss:
            out += ["--loss", f"{link.loss:.12g}"]
        if link.latency * 1000.0 != DEFAULT_LATENCY_MS:
            out += ["--latency", f"{link.latency * 1000.0:.12g}"]
        if link.jitter:
            out += ["--jitter", f"{link.jitter * 1000.0:.12g}"]
        for e in self.ground_events():
            ids = "" if e.ids is None else ":" + ",".join(str(i) for i in sorted(e.ids))
            out += ["--event", f"{e.name}@{e.t:.12g}{ids}"]
        for item in self.items:
            if item.kind not in ("loss", "delay", "shift"):
                out += item.options
        return out


def draw(
    profile: FaultProfile,
    seed: int,
    platforms: Sequence[int],
    duration: float,
    events: Sequence[GroundEvent],
    *,
    vehicles: bool,
) -> Schedule:
    """The schedule of run ``seed``: each fault drawn from ``profile`` (module docstring of
    :mod:`~actorswarm.sim.verify.profile`) for a swarm of ``platforms`` running ``duration``
    seconds with the operator's ``events``; autopilot faults only when ``vehicles``."""
    d = _Drawer(profile, random.Random(f"task verify {seed}"), list(platforms), duration)
    items = d.radio() + d.kills(events) + d.partitions()
    if vehicles:
        items += d.vehicles()
    items += d.shifts(events)
    return Schedule(seed, tuple(events), tuple(items))


@dataclass(slots=True)
class _Drawer:
    """The draws of one schedule, in a fixed order (so a seed always gives the same)."""

    profile: FaultProfile
    rng: random.Random
    platforms: list[int]
    duration: float

    def span(self, r: Range) -> float:
        return r[0] if r[0] == r[1] else self.rng.uniform(*r)

    def when(self) -> float:
        """A time anywhere in the profile's window of the run."""
        return round(self.rng.uniform(0.0, self.end), 2)

    @property
    def end(self) -> float:
        return self.profile.run.window * self.duration

    def count(self, mean: float) -> int:
        """A Poisson-distributed count (Knuth's method: the means here are small)."""
        if mean <= 0:
            return 0
        limit, k, p = math.exp(-mean), 0, self.rng.random()
        while p > limit:
            k += 1
            p *= self.rng.random()
        return k

    def radio(self) -> list[Item]:
        radio, out = self.profile.radio, []
        loss = round(self.span(radio.loss), 3)
        if loss > 0:
            out.append(Item("loss", f"{loss:.1%} packet loss", ("--loss", f"{loss:.12g}"), (loss,)))
        latency, jitter = (
            round(self.span(radio.latency_ms), 1),
            round(self.span(radio.jitter_ms), 1),
        )
        if (latency, jitter) != (DEFAULT_LATENCY_MS, 0.0):
            out.append(
                Item(
                    "delay",
                    f"latency {latency:.12g} ms, jitter {jitter:.12g} ms",
                    ("--latency", f"{latency:.12g}", "--jitter", f"{jitter:.12g}"),
                    (latency, jitter),
                )
            )
        return out

    def kills(self, events: Sequence[GroundEvent]) -> list[Item]:
        k, out = self.profile.kills, []
        for _ in range(self.count(k.rate)):
            master = self.rng.random() < k.master
            who = 0 if master else self.rng.choice(k.platforms or self.platforms)
            name = "the master" if master else f"platform {who}"
            if events and self.rng.random() < k.after_event:
                event = self.rng.choice(events)
                t = round(min(event.t + self.span(k.after_event_s), self.end), 2)
                why = f" ({t - event.t:.2f} s after {event.name})"
            else:
                t, why = self.when(), ""
            ids = frozenset() if master else frozenset({who})
            faults = [Fault("kill", t, ids, master)]
            text = f"{name} killed at {t:.12g} s{why}"
            if self.rng.random() < k.restart:
                back = round(t + self.span(k.restart_after_s), 2)
                if back <= self.duration:
                    faults.append(Fault("restart", back, ids, master))
                    text += f", rebooted at {back:.12g} s"
            options = tuple(o for f in faults for o in f.option())
            out.append(Item("kill", text, options, faults=tuple(faults)))
        return out

    def partitions(self) -> list[Item]:
        p, out = self.profile.partitions, []
        for _ in range(self.count(p.rate)):
            if len(self.platforms) < 2:
                break
            n = round(len(self.platforms) * self.span(p.size))
            n = max(1, min(len(self.platforms) - 1, n))
            side = frozenset(self.rng.sample(self.platforms, n))
            t = self.when()
            faults = [Fault("partition", t, side)]
            text = f"{n} platform(s) cut off at {t:.12g} s"
            if self.rng.random() < p.heal:
                back = round(t + self.span(p.heal_after_s), 2)
                if back <= self.duration:
                    faults.append(Fault("heal", back))
                    text += f", healed at {back:.12g} s"
            options = tuple(o for f in faults for o in f.option())
            out.append(Item("partition", text, options, faults=tuple(faults)))
        return out

    def vehicles(self) -> list[Item]:
        v, out = self.profile.vehicles, []
        for platform in self.platforms:
            ids = frozenset({platform})
            drawn: list[tuple[VehicleFault, str]] = []
            if self.rng.random() < v.late:
                t = round(min(self.span(v.late_s), self.duration), 1)
                drawn.append(
                    (VehicleFault("late", ids, t), f"ready to take off only at {t:.12g} s")
                )
            if self.rng.random() < v.refuse:
                drawn.append((VehicleFault("refuse", ids), "never arms"))
            if self.rng.random() < v.drain:
                factor = round(self.span(v.drain_factor), 2)
                drawn.append((VehicleFault("drain", ids, factor), f"battery drains {factor:.12g}×"))
            for fault, text in drawn:
                out.append(
                    Item(
                        "vehicle",
                        f"platform {platform}'s autopilot {text}",
                        tuple(fault.option()),
                        vehicle=fault,
                    )
                )
        return out

    def shifts(self, events: Sequence[GroundEvent]) -> list[Item]:
        e, out = self.profile.events, []
        for n, event in enumerate(events):
            if self.rng.random() >= e.shift:
                continue
            t = round(min(max(event.t + self.span(e.shift_s), 0.0), self.duration), 2)
            if t != event.t:
                out.append(
                    Item(
                        "shift",
                        f"{event.name} at {t:.12g} s instead of {event.t:.12g} s",
                        ("--event", f"{event.name}@{t:.12g}"),
                        (float(n), t),
                    )
                )
        return out
