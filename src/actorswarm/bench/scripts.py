"""The task scripts of the paper's benchmarks (Tables I and II), for simulated and real runs.

Every actor is a plugin group of ``plugins`` plugins spread over the four buses — the
paper's "one plugin / five plugins" — so a switch instantiates, starts and steps that many.
Actors are named after the plugin count (``A5``): a new script version for another count,
deployed on a running swarm, stops the old actors and starts fresh ones.

* :func:`table1_script`: every platform alternates ``A ⇄ B`` at a period by local events
  (:class:`~actorswarm.bench.alternate.EmitOnEntry`; no barrier), forever.
* :func:`table2_script`: ``go`` takes every platform A → B on one barrier of the whole swarm
  (``sysNum="all"``) and ``back`` brings it home the same way; ``split`` sent to two
  platforms branches them together to C (``sysNum="2"``) and ``rejoin`` brings them back.
"""

from __future__ import annotations

from actorswarm.bench.alternate import EMIT_ON_ENTRY
from actorswarm.dsl.model import BUSES

__all__ = ["BACK", "GO", "REJOIN", "SPLIT", "actor_names", "table1_script", "table2_script"]


def _group(plugins: int, first: str = "") -> str:
    """``plugins`` plugins spread over the buses: ``first`` (a plugin element) then
    ``core.idle`` for the rest."""
    if plugins < 1:
        raise ValueError(f"an actor needs at least one plugin, not {plugins}")
    slots = [first] if first else []
    slots += ["<Plugin><_P_Name>core.idle</_P_Name></Plugin>"] * (plugins - len(slots))
    buses: dict[str, list[str]] = {bus: [] for bus in BUSES}
    for i, plugin in enumerate(slots):
        buses[BUSES[i % len(BUSES)]].append(plugin)
    return "".join(
        f"<Bus><_P_Name>{bus}</_P_Name>{''.join(items)}</Bus>"
        for bus, items in buses.items()
        if items
    )


def actor_element(name: str, plugins: int, first: str = "") -> str:
    """An ``<Actor>`` of ``plugins`` plugins spread over the buses, ``first`` among them."""
    group = _group(plugins, first)
    return f"<Actor><_P_Name>{name}</_P_Name><OODAConfig>{group}</OODAConfig></Actor>"


def platforms_element(size: int, actor: str) -> str:
    """Platforms ``1..size``, each starting in ``actor``."""
    if size < 1:
        raise ValueError(f"a swarm needs at least one platform, not {size}")
    ids = "1" if size == 1 else f"1-{size}"
    return f'<_PlatformActorConfig><platform id="{ids}" actor="{actor}"/></_PlatformActorConfig>'


def actor_names(plugins: int) -> tuple[str, str, str]:
    """The actors of a script for ``plugins`` plugins. Named after the count, so that a new
    script version for another count stops the old actors and starts fresh ones, rather
    than keeping the sleeping instances of the old plugin groups."""
    return f"A{plugins}", f"B{plugins}", f"C{plugins}"


def table1_script(size: int, plugins: int, period: float = 1.0) -> str:
    """Table I for platforms ``1..size``: each alternates ``A<n> ⇄ B<n>`` every ``period``
    seconds of running time by a local event (:class:`~actorswarm.bench.alternate.
    EmitOnEntry`, which counts down again on every switch back), one platform per
    transition; each actor has ``plugins`` plugins, the emitter among them."""
    a, b, _ = actor_names(plugins)

    def emitter(event: str) -> str:
        return (
            f"<Plugin><_P_Name>{EMIT_ON_ENTRY}</_P_Name>"
            f'<param key="event" value="{event}"/><param key="after" value="{period:g}"/>'
            "</Plugin>"
        )

    return (
        f'<TaskScript name="bench-table1-p{plugins}" version="{plugins}"><_ActorsConfig>'
        + actor_element(a, plugins, emitter("to_b"))
        + actor_element(b, plugins, emitter("to_a"))
        + "</_ActorsConfig><_TaskConfig>"
        f'<actor name="{a}"><transition name="to_b" sysNum="1"><successor actor="{b}"/>'
        "</transition></actor>"
        f'<actor name="{b}"><transition name="to_a" sysNum="1"><successor actor="{a}"/>'
        "</transition></actor>"
        "</_TaskConfig>" + platforms_element(size, a) + "</TaskScript>"
    )


#: Table II's events: (event, barrier key) — ``go`` A → B and ``back`` B → A for the whole
#: swarm; ``split`` A → C and ``rejoin`` C → A for two platforms.
GO = ("go", 1)
BACK = ("back", 2)
SPLIT = ("split", 3)
REJOIN = ("rejoin", 4)


def table2_script(size: int, plugins: int, timeout: float = 30.0) -> str:
    """Table II for platforms ``1..size``, every actor of ``plugins`` ``core.idle``
    plugins: ``go``/``back`` take every platform ``A<n> → B<n> → A<n>`` on one barrier of
    the whole swarm each; ``split`` takes the two platforms it is sent to ``A<n> → C<n>``
    together and ``rejoin`` brings them back."""
    a, b, c = actor_names(plugins)

    def transition(event: tuple[str, int], dst: str, num: str) -> str:
        return (
            f'<transition name="{event[0]}" barrierKey="{event[1]}" sysNum="{num}" '
            f'timeout="{timeout:g}"><successor actor="{dst}"/></transition>'
        )

    return (
        f'<TaskScript name="bench-table2-p{plugins}" version="{plugins}"><_ActorsConfig>'
        + actor_element(a, plugins)
        + actor_element(b, plugins)
        + actor_element(c, plugins)
        + "</_ActorsConfig><_TaskConfig>"
        + f'<actor name="{a}">{transition(GO, b, "all")}{transition(SPLIT, c, "2")}</actor>'
        + f'<actor name="{b}">{transition(BACK, a, "all")}</actor>'
        + f'<actor name="{c}">{transition(REJOIN, a, "2")}</actor>'
        + "</_TaskConfig>"
        + platforms_element(size, a)
        + "</TaskScript>"
    )
