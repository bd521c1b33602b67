"""The plugin contract: params, declarations, the lifecycle driver, the context, and the
two built-in plugins."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any, ClassVar

import pytest

from actorswarm.engine.runtime import Emitted
from actorswarm.runtime.builtin import EmitAfter, Idle
from actorswarm.runtime.context import (
    CollectiveUnavailable,
    NullCollective,
    PluginContext,
    Vehicle,
    VehicleUnavailable,
)
from actorswarm.runtime.plugin import (
    BUSES,
    LIFECYCLE,
    Lifecycle,
    LifecycleError,
    LifecycleOp,
    Param,
    ParamError,
    Plugin,
    PluginDeclarationError,
)
from actorswarm.testing import FakeVehicle, drive, make_context, run_plugin

# --- Param: reading texts ----------------------------------------------------------------------

GOOD: list[tuple[Param, str, object]] = [
    (Param(kind="str"), "  hello ", "hello"),
    (Param(kind="str", choices=("local", "swarm")), "swarm", "swarm"),
    (Param(kind="str", pattern=r"[a-z]+"), "abc", "abc"),
    (Param(kind="int"), "3", 3),
    (Param(kind="int"), "-2", -2),
    (Param(kind="int"), "+4", 4),
    (Param(kind="int", minimum=0), "0", 0),
    (Param(kind="int", choices=(1, 2, 4)), "4", 4),
    (Param(kind="float"), "2", 2.0),
    (Param(kind="float"), "0.5", 0.5),
    (Param(kind="float"), "1e-3", 0.001),
    (Param(kind="float"), "-.5", -0.5),
    (Param(kind="float", minimum=0.0), "0", 0.0),
    (Param(kind="bool"), "true", True),
    (Param(kind="bool"), "Yes", True),
    (Param(kind="bool"), "ON", True),
    (Param(kind="bool"), "1", True),
    (Param(kind="bool"), "false", False),
    (Param(kind="bool"), "no", False),
    (Param(kind="bool"), "off", False),
    (Param(kind="bool"), "0", False),
    (Param(kind="point"), "200 200 20", (200.0, 200.0, 20.0)),
    (Param(kind="point"), " -1.5  0\t3e2 ", (-1.5, 0.0, 300.0)),
    (Param(kind="area"), " search ", "search"),
    (Param(kind="area"), "0 0 100 50", "0 0 100 50"),
    (Param(kind="route"), "60 10; 280 -50;", "60 10; 280 -50;"),
]

BAD: list[tuple[Param, str, str]] = [
    (Param(kind="str", key="name"), "   ", "name is empty"),
    (Param(kind="str", key="scope", choices=("local", "swarm")), "globl", 'did you mean "local"'),
    (Param(kind="str", key="scope", choices=("local", "swarm")), "x", 'one of "local", "swarm"'),
    (Param(kind="str", key="id", pattern=r"[a-z]+"), "A1", "must match the pattern [a-z]+"),
    (
        Param(kind="str", key="id", pattern=r"[a-z]+", form="lower-case letters"),
        "A1",
        "id must be lower-case letters, not 'A1'",
    ),
    (Param(kind="area", key="area"), "0 0 100", "has 3 numbers, but a rectangle is four"),
    (Param(kind="area", key="area"), "0 0 -5 10", "x_min must be below x_max"),
    (Param(kind="area", key="area"), " ", "area is empty"),
    (Param(kind="route", key="route"), "0 0; 100", "route: waypoint 2 must be two numbers"),
    (Param(kind="route", key="route"), " ", "give at least one waypoint"),
    (Param(kind="int", key="n"), "3.5", "n must be an integer such as 3, not '3.5'"),
    (Param(kind="int", key="n"), "1_000", "must be an integer"),
    (Param(kind="int", key="n"), "٣", "must be an integer"),
    (Param(kind="int", key="n"), "", "must be an integer"),
    (Param(kind="int", key="n", minimum=1), "0", "n must be ≥ 1, not '0'"),
    (Param(kind="int", key="n", choices=(1, 2)), "3", 'one of "1", "2"'),
    (Param(kind="float", key="after"), "nan", "after must be a number such as 2 or 0.5"),
    (Param(kind="float", key="after"), "inf", "must be a number"),
    (Param(kind="float", key="after"), "1e999", "must be a number"),
    (Param(kind="float", key="after"), "1,5", "must be a number"),
    (Param(kind="float", key="after"), "two", "must be a number"),
    (Param(kind="float", key="after", minimum=0.0), "-1", "after must be ≥ 0, not '-1'"),
    (Param(kind="bool", key="loop"), "maybe", "loop must be true or false, not 'maybe'"),
    (Param(kind="point", key="at"), "1 2", 'at must be three numbers "x y z"'),
    (Param(kind="point", key="at"), "1,2,3", "three numbers"),
    (Param(kind="point", key="at"), "1 2 nan", "three numbers"),
    (Param(kind="point", key="at"), "1 2 3 4", "three numbers"),
    (Param(kind="float"), "x", "the value must be a number"),
]


@pytest.mark.parametrize(("param", "text", "expected"), GOOD)
def test_param_reads_good_texts(param: Param, text: str, expected: object) -> None:
    value = param.parse(text)
    assert value == expected
    assert type(value) is type(expected)
    assert param.parse(param.format(value)) == value  # format is parse's inverse


@pytest.mark.parametrize(("param", "text", "message"), BAD)
def test_param_refuses_bad_texts_saying_why(param: Param, text: str, message: str) -> None:
    with pytest.raises(ValueError) as info:
        param.parse(text)
    assert message in str(info.value)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"kind": "complex"}, "kind 'complex' is not one of"),
        ({"kind": "float", "required": True, "default": 1.0}, "cannot have a default"),
        ({"kind": "bool", "choices": (True,)}, "choices apply to str, int or float"),
        ({"kind": "str", "choices": ()}, "choices is empty"),
        ({"kind": "int", "choices": ("a",)}, "choice 'a' is not an int"),
        ({"kind": "str", "minimum": 0}, "minimum must be a finite number"),
        ({"kind": "int", "pattern": "x"}, "pattern applies to str"),
        ({"kind": "str", "pattern": "("}, "is not a regular expression"),
        ({"kind": "int", "default": 1.5}, "default 1.5 is not an int"),
        ({"kind": "int", "default": True}, "is not an int"),
        ({"kind": "point", "default": (1, 2)}, "is not a point (three finite numbers)"),
        ({"kind": "float", "default": -1.0, "minimum": 0}, "must be ≥ 0"),
        ({"kind": "str", "default": "x", "choices": ("a", "b")}, "must be one of"),
    ],
)
def test_param_declarations_are_checked(kwargs: dict[str, Any], message: str) -> None:
    with pytest.raises(PluginDeclarationError) as info:
        Param(**kwargs)
    assert message in str(info.value)


def test_param_normalizes_defaults_and_describes_itself() -> None:
    assert Param(kind="float", default=2).default == 2.0
    assert Param(kind="point", default=[1, 2, 3]).default == (1.0, 2.0, 3.0)  # type: ignore[arg-type]
    after = EmitAfter.params["after"]
    assert after.describe().startswith("float ≥ 0, default 0: seconds of running time")
    assert EmitAfter.params["event"].describe().startswith("str, required")
    assert EmitAfter.params["scope"].describe().startswith("local|swarm, default local")
    # What the script checker reads off a rule today: required, parse, meaning.
    assert after.meaning == after.doc and callable(after.parse) and after.required is False


# --- declarations ------------------------------------------------------------------------------


class Tagged(Plugin):
    bus = "act_bus"
    resources = frozenset({"autopilot", "camera"})
    params: ClassVar[Mapping[str, Param]] = {
        "spacing": Param(kind="float", default=20.0, minimum=0.0, doc="metres between slots"),
        "slot": Param(kind="int", required=True, doc="this platform's slot"),
        "loop": Param(kind="bool", default=False),
        "home": Param(kind="point", default=(0.0, 0.0, 10.0)),
        "label": Param(kind="str"),
    }

    def step(self, ctx: PluginContext) -> None:
        pass


def test_declarations_are_bound_and_frozen() -> None:
    assert Tagged.bus in BUSES and Tagged.resources == {"autopilot", "camera"}
    assert Tagged.params["spacing"].key == "spacing"
    assert Plugin.bus == "decide_bus" and Plugin.resources == frozenset()
    assert Idle.any_bus and not Tagged.any_bus
    with pytest.raises(TypeError):
        Tagged.params["x"] = Param(kind="str")  # type: ignore[index]
    assert Tagged.declaration_problems() == []


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ({"bus": "talk_bus"}, "bus 'talk_bus' is not one of observe_bus"),
        ({"resources": {"autopilot"}}, "resources must be a frozenset"),
        ({"resources": frozenset({"auto pilot"})}, "resource 'auto pilot' is not a valid name"),
        ({"params": {"x": 3}}, "param 'x' is declared as 3, not a Param"),
        ({"params": {"bad key": Param(kind="str")}}, "param key 'bad key' is not a valid name"),
        ({"params": {"a": Param(kind="str", key="b")}}, "declared with key='b'"),
        ({"params": [1]}, "params must be a mapping"),
        ({"any_bus": "yes"}, "any_bus must be True or False"),
        ({"needs_vehicle": 1}, "needs_vehicle must be True or False"),
        ({"_drive_step": lambda self, ctx: None}, "_drive_step is the framework's driver"),
        ({"validate_params": classmethod(lambda cls, raw: {})}, "validate_params is the"),
    ],
)
def test_bad_declarations_fail_when_the_class_is_defined(
    body: dict[str, Any], message: str
) -> None:
    namespace = {"step": lambda self, ctx: None, **body}
    with pytest.raises(PluginDeclarationError) as info:
        type("Broken", (Plugin,), namespace)
    assert message in str(info.value)
    assert "Broken" in str(info.value)


def test_step_is_abstract() -> None:
    class NoStep(Plugin):
        pass

    with pytest.raises(TypeError, match="step"):
        NoStep()  # type: ignore[abstract]


# --- params ------------------------------------------------------------------------------------


def test_validate_params_fills_every_declared_key() -> None:
    values = Tagged.validate_params({"slot": "2", "spacing": "12.5"})
    assert values == {
        "spacing": 12.5,
        "slot": 2,
        "loop": False,
        "home": (0.0, 0.0, 10.0),
        "label": None,
    }
    assert list(values) == list(Tagged.params)  # declaration order


def test_validate_params_reports_every_problem_at_once() -> None:
    with pytest.raises(ParamError) as info:
        Tagged.validate_params({"spacng": "3", "loop": "perhaps", "home": "1 2"})
    err = info.value
    assert isinstance(err, ValueError)
    problems = dict(err.problems)
    assert set(problems) == {"spacng", "loop", "home", "slot"}
    assert problems["spacng"].startswith("no param 'spacng' (did you mean \"spacing\"?)")
    assert "it takes spacing, slot, loop, home, label" in problems["spacng"]
    assert problems["loop"] == "loop must be true or false, not 'perhaps'"
    assert problems["slot"] == (
        'needs the param slot (this platform\'s slot): add <param key="slot" value="..."/>'
    )
    assert str(err).startswith("Tagged: ")


def test_validate_params_of_a_plugin_without_params() -> None:
    assert Idle.validate_params({}) == {}
    with pytest.raises(ParamError, match="no param 'x'; it takes no params"):
        Idle.validate_params({"x": "1"})
    with pytest.raises(ParamError, match="must be given as text"):
        Tagged.validate_params({"slot": 3})  # type: ignore[dict-item]


def test_bind_params_lets_the_transition_win() -> None:
    values = Tagged.bind_params(
        {"slot": "1", "spacing": "5"},
        {"spacing": "7", "TargetPoint": "200 200 20"},  # TargetPoint: for another plugin
    )
    assert values["spacing"] == 7.0 and values["slot"] == 1
    with pytest.raises(ParamError, match="spacing must be ≥ 0"):
        Tagged.bind_params({"slot": "1"}, {"spacing": "-1"})
    with pytest.raises(ParamError, match="no param 'TargetPoint'"):
        Tagged.bind_params({"slot": "1", "TargetPoint": "1 2 3"})


def test_check_params_ties_params_together() -> None:
    class Band(Plugin):
        params: ClassVar[Mapping[str, Param]] = {
            "low": Param(kind="float", default=0.0),
            "high": Param(kind="float", default=10.0),
        }

        @classmethod
        def check_params(cls, values: Mapping[str, Any]) -> Iterable[tuple[str, str]]:
            if values["low"] >= values["high"]:
                yield "low", f"low ({values['low']:g}) must be below high ({values['high']:g})"

        def step(self, ctx: PluginContext) -> None:
            pass

    assert Band.validate_params({"low": "2"})["low"] == 2.0
    with pytest.raises(ParamError, match=r"low \(20\) must be below high \(10\)"):
        Band.validate_params({"low": "20"})


# --- the lifecycle driver ----------------------------------------------------------------------


class Recorder(Plugin):
    """Records every hook call."""

    def __init__(self) -> None:
        self.calls: list[str] = []
        self.n = 0

    def on_start(self, ctx: PluginContext) -> None:
        self.calls.append("start")

    def step(self, ctx: PluginContext) -> None:
        self.calls.append("step")
        self.n += 1

    def on_pause(self, ctx: PluginContext) -> None:
        self.calls.append("pause")

    def on_activate(self, ctx: PluginContext) -> None:
        self.calls.append("activate")

    def on_stop(self, ctx: PluginContext) -> None:
        self.calls.append("stop")

    def snapshot(self) -> dict[str, Any]:
        self.calls.append("snapshot")
        return {"n": self.n}

    def restore(self, state: Mapping[str, Any]) -> None:
        self.calls.append("restore")
        self.n = state["n"]


# How to bring a fresh Recorder into each state.
_PATHS: dict[Lifecycle, tuple[LifecycleOp, ...]] = {
    "new": (),
    "running": ("start",),
    "sleeping": ("start", "pause"),
    "stopped": ("start", "stop"),
}
_OPS: tuple[LifecycleOp, ...] = (
    "start",
    "step",
    "pause",
    "activate",
    "stop",
    "snapshot",
    "restore",
)


def test_the_hooks_run_in_lifecycle_order() -> None:
    ctx = make_context()
    p = Recorder()
    assert p.lifecycle == "new"
    p._drive_start(ctx)
    p._drive_step(ctx)
    p._drive_step(ctx)
    p._drive_pause(ctx)
    p._drive_activate(ctx)
    p._drive_step(ctx)
    assert p._drive_snapshot() == {"n": 3}
    p._drive_stop(ctx)
    assert p.calls == ["start", "step", "step", "pause", "activate", "step", "snapshot", "stop"]
    assert p.lifecycle in {"stopped"}


def test_a_restored_instance_resumes_with_activate() -> None:
    ctx = make_context()
    p = Recorder()
    p._drive_restore({"n": 7})
    assert p.lifecycle == "sleeping"
    assert p._drive_snapshot() == {"n": 7}
    p._drive_activate(ctx)
    p._drive_step(ctx)
    assert p.calls == ["restore", "snapshot", "activate", "step"]
    assert p.n == 8


@pytest.mark.parametrize("state", list(_PATHS))
@pytest.mark.parametrize("op", _OPS)
def test_out_of_order_calls_are_refused_and_change_nothing(
    state: Lifecycle, op: LifecycleOp
) -> None:
    ctx = make_context()
    p = Recorder()
    for step in _PATHS[state]:
        drive(p, step, ctx, {"n": 0})
    before = list(p.calls)
    if (state, op) in LIFECYCLE:
        drive(p, op, ctx, {"n": 0})
        assert p.lifecycle == LIFECYCLE[(state, op)]
        return
    with pytest.raises(LifecycleError) as info:
        drive(p, op, ctx, {"n": 0})
    err = info.value
    assert p.lifecycle == state and p.calls == before  # no hook ran
    assert (err.state, err.operation) == (state, op)
    assert str(err).startswith(f"cannot {op} plugin Recorder: it is {state}")
    legal = ", ".join(err.legal) or "nothing (build a fresh instance)"
    assert str(err).endswith(f"the legal operations are: {legal}")


def test_lifecycle_messages_give_advice() -> None:
    ctx = make_context()
    p = Recorder()
    with pytest.raises(LifecycleError, match=r"step plugin Recorder: it is new \(start it first\)"):
        p._drive_step(ctx)
    p._drive_start(ctx)
    p._drive_stop(ctx)
    with pytest.raises(LifecycleError, match="build a fresh instance to start again"):
        p._drive_start(ctx)


def test_a_failing_hook_changes_no_state_except_stop() -> None:
    class Fails(Plugin):
        fail_on = ""

        def on_start(self, ctx: PluginContext) -> None:
            if self.fail_on == "start":
                raise RuntimeError("no GPS")

        def on_stop(self, ctx: PluginContext) -> None:
            raise RuntimeError("stuck")

        def step(self, ctx: PluginContext) -> None:
            pass

    ctx = make_context()
    p = Fails()
    p.fail_on = "start"
    with pytest.raises(RuntimeError, match="no GPS"):
        p._drive_start(ctx)
    assert p.lifecycle == "new"
    p.fail_on = ""
    p._drive_start(ctx)
    with pytest.raises(RuntimeError, match="stuck"):
        p._drive_stop(ctx)
    assert p.lifecycle in {"stopped"}  # unloaded whatever happened


def test_a_hook_cannot_drive_its_own_plugin() -> None:
    class Reentrant(Plugin):
        def step(self, ctx: PluginContext) -> None:
            self._drive_stop(ctx)

    ctx = make_context()
    p = Reentrant()
    p._drive_start(ctx)
    with pytest.raises(LifecycleError, match="called from inside its own step hook"):
        p._drive_step(ctx)
    assert p.lifecycle == "running"


def test_snapshot_must_be_a_dict_and_deadlines_a_time() -> None:
    class Odd(Plugin):
        def step(self, ctx: PluginContext) -> None:
            pass

        def snapshot(self) -> dict[str, Any]:
            return [1, 2]  # type: ignore[return-value]

        def next_deadline(self) -> float | None:
            return "soon"  # type: ignore[return-value]

    ctx = make_context()
    p = Odd()
    assert p._drive_next_deadline() is None  # not running: no deadline asked
    p._drive_start(ctx)
    with pytest.raises(TypeError, match=r"snapshot\(\) returned list"):
        p._drive_snapshot()
    with pytest.raises(TypeError, match=r"next_deadline\(\) returned 'soon'"):
        p._drive_next_deadline()


# --- the context -------------------------------------------------------------------------------


def test_emit_collects_well_formed_events() -> None:
    ctx = make_context(actor="Search", platform=4)
    ctx.emit("found")
    ctx.emit("done", scope="swarm", bid=2, data={"at": [1, 2]})
    assert ctx.emitted == (
        Emitted(event="found", actor="Search"),
        Emitted(event="done", scope="swarm", bid=2.0, data={"at": [1, 2]}, actor="Search"),
    )
    assert len(ctx.drain()) == 2
    assert ctx.drain() == []
    assert not ctx.emitted


@pytest.mark.parametrize(
    ("args", "kwargs", "message"),
    [
        (("bad name",), {}, "the event name 'bad name' is not valid"),
        (("",), {}, "is not valid"),
        (("go",), {"scope": "everyone"}, 'scope must be "local" or "swarm"'),
        (("go",), {"bid": float("nan")}, "bid must be a finite number"),
        (("go",), {"bid": True}, "bid must be a finite number"),
    ],
)
def test_emit_refuses_malformed_events(
    args: tuple[Any, ...], kwargs: dict[str, Any], message: str
) -> None:
    ctx = make_context()
    with pytest.raises(ValueError) as info:
        ctx.emit(*args, **kwargs)
    assert message in str(info.value)
    assert ctx.emitted == ()


def test_context_defaults_and_helpers() -> None:
    ctx = PluginContext(now=5.0, platform=2, actor="A")
    assert ctx.params == {} and ctx.blackboard == {} and ctx.vehicle is None
    assert ctx.index == 0 and ctx.data is None
    assert isinstance(ctx.collective, NullCollective)
    assert ctx.rng.random() == PluginContext(now=0, platform=2, actor="B").rng.random()
    with pytest.raises(VehicleUnavailable, match="actor 'A' on platform 2: this plugin needs"):
        ctx.require_vehicle()
    vehicle = FakeVehicle()
    assert make_context(vehicle=vehicle).require_vehicle() is vehicle
    with pytest.raises(AttributeError):
        ctx.colour = "red"  # type: ignore[attr-defined]  # slots: no stray attributes
    assert "platform=2" in repr(ctx)


def test_null_collective_explains_itself() -> None:
    ctx = make_context()
    with pytest.raises(CollectiveUnavailable, match=r"barrier\(4, 2\): this plugin context has no"):
        ctx.collective.barrier(4, 2)
    with pytest.raises(CollectiveUnavailable, match="pass collective="):
        ctx.collective.claim_role("leader", 1)
    with pytest.raises(CollectiveUnavailable):
        ctx.collective.release_role("leader")


def test_make_context_validates_and_merges_params() -> None:
    ctx = make_context(
        EmitAfter, params={"event": "go", "after": "2"}, transition_params={"after": "3"}
    )
    assert ctx.params == {"event": "go", "after": 3.0, "spread_per_platform": 0.0, "scope": "local"}
    with pytest.raises(ParamError, match="needs the param event"):
        make_context(EmitAfter)
    assert make_context(params={"anything": 1}).params == {"anything": 1}


def test_blackboard_is_shared_by_the_plugins_of_an_actor() -> None:
    board: dict[str, Any] = {}
    a, b = make_context(blackboard=board), make_context(blackboard=board)
    a.blackboard["target"] = (1.0, 2.0, 0.0)
    assert b.blackboard["target"] == (1.0, 2.0, 0.0)


def test_fake_vehicle_is_a_vehicle_and_moves() -> None:
    v = FakeVehicle(cruise_speed=2.0, climb_rate=1.0, drain_per_second=0.01)
    assert isinstance(v, Vehicle)
    assert v.mode == "landed"
    v.takeoff(3.0)
    for _ in range(4):
        v.advance(1.0)
    assert v.position() == (0.0, 0.0, 3.0) and v.mode == "holding"
    v.goto(4.0, 0.0, 3.0)
    v.advance(1.0)
    assert v.position() == (2.0, 0.0, 3.0) and v.velocity() == (2.0, 0.0, 0.0)
    v.goto(4.0, 0.0, 3.0, speed=10.0)
    v.advance(1.0)
    assert v.position() == (4.0, 0.0, 3.0) and v.goal is None
    v.hold()
    v.land()
    for _ in range(3):
        v.advance(1.0)
    assert v.position()[2] == 0.0 and v.mode == "landed"
    assert v.battery() == pytest.approx(1 - 0.01 * 9)
    assert v.commands == [
        ("takeoff", 3.0),
        ("goto", 4.0, 0.0, 3.0, None),
        ("goto", 4.0, 0.0, 3.0, 10.0),
        ("hold",),
        ("land",),
    ]
    with pytest.raises(ValueError, match="speed must be a positive number"):
        v.goto(0, 0, 0, speed=-1)
    with pytest.raises(ValueError, match="three finite numbers"):
        v.goto(float("nan"), 0, 0)
    with pytest.raises(ValueError, match="altitude must be positive"):
        v.takeoff(0)


# --- the built-ins -----------------------------------------------------------------------------


def _emit_after(platform: int = 1, **params: str) -> tuple[EmitAfter, PluginContext]:
    ctx = make_context(EmitAfter, params={"event": "go", **params}, platform=platform, now=10.0)
    return EmitAfter(), ctx


def test_idle_does_nothing_anywhere() -> None:
    ctx = make_context(Idle)
    p = Idle()
    assert run_plugin(p, ctx, steps=100) == []
    assert p._drive_snapshot() == {} and p._drive_next_deadline() is None
    assert Idle.any_bus and Idle.resources == frozenset() and not Idle.needs_vehicle


def test_emit_after_fires_once_after_its_delay() -> None:
    p, ctx = _emit_after(platform=3, after="1", spread_per_platform="0.5")  # 2.5 s
    p._drive_start(ctx)
    assert p._drive_next_deadline() == 12.5
    fired = [(ctx.now, e) for _ in range(40) for e in run_plugin(p, ctx, steps=1, dt=0.5)]
    assert fired == [(12.5, Emitted(event="go", actor="test"))]
    assert p._drive_next_deadline() is None
    assert p._drive_snapshot() == {"remaining": 0.0, "fired": True}


def test_emit_after_zero_fires_on_the_first_step_and_honours_scope() -> None:
    p, ctx = _emit_after(scope="swarm")
    p._drive_start(ctx)
    p._drive_step(ctx)  # same instant as the start
    assert ctx.drain() == [Emitted(event="go", scope="swarm", actor="test")]


def test_emit_after_negative_spread_means_at_once() -> None:
    p, ctx = _emit_after(platform=5, after="1", spread_per_platform="-1")
    p._drive_start(ctx)
    assert p._drive_next_deadline() == 10.0


def test_emit_after_does_not_count_paused_time() -> None:
    p, ctx = _emit_after(after="3")
    p._drive_start(ctx)  # t=10, fires at 13 if never paused
    assert run_plugin(p, ctx, steps=1, dt=1.0) == []  # t=11: 2 s left
    p._drive_pause(ctx)
    assert p._drive_next_deadline() is None  # a sleeping plugin has no deadline
    assert p._drive_snapshot() == {"remaining": 2.0, "fired": False}
    ctx.now = 100.0
    p._drive_activate(ctx)
    assert p._drive_next_deadline() == 102.0
    assert run_plugin(p, ctx, steps=1, dt=1.5) == []
    assert run_plugin(p, ctx, steps=1, dt=0.5) == [Emitted(event="go", actor="test")]


def test_emit_after_snapshot_resumes_in_a_fresh_instance() -> None:
    p, ctx = _emit_after(after="5")
    p._drive_start(ctx)
    run_plugin(p, ctx, steps=2, dt=1.0)  # t=12: 3 s left
    state = p._drive_snapshot()
    assert state == {"remaining": 3.0, "fired": False}
    fresh = EmitAfter()
    fresh._drive_restore(state)
    assert fresh._drive_snapshot() == state
    ctx.now = 50.0  # another host, another clock
    fresh._drive_activate(ctx)
    assert fresh._drive_next_deadline() == 53.0
    with pytest.raises(LifecycleError):
        fresh._drive_start(ctx)  # a restored plugin resumes, it does not begin again


@pytest.mark.parametrize(
    "state",
    [{}, {"remaining": -1, "fired": False}, {"remaining": 1}, {"remaining": "1", "fired": True}],
)
def test_emit_after_refuses_unreadable_snapshots(state: dict[str, Any]) -> None:
    with pytest.raises(ValueError, match=r"core\.emit_after: a snapshot must read"):
        EmitAfter()._drive_restore(state)


def test_emit_after_params_match_the_design() -> None:
    params = EmitAfter.params
    assert list(params) == ["event", "after", "spread_per_platform", "scope"]
    assert params["event"].required
    assert (params["after"].default, params["after"].minimum) == (0.0, 0.0)
    assert params["spread_per_platform"].default == 0.0
    assert (params["scope"].default, params["scope"].choices) == ("local", ("local", "swarm"))
    with pytest.raises(ParamError, match=r"event must be an event name \(a letter or _"):
        EmitAfter.validate_params({"event": "two words"})
