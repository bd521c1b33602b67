"""Data-driven scenarios of the collective core: parse a scenario file, run it, render its log.

A scenario file is a list of commands, a line ``----``, then the log the run must produce
(see README.md in this directory for the format and the command set). The commands drive a
seeded :class:`~actorswarm.sim.swarm.SimSwarm` in virtual time; the log is a deterministic
text rendering of what the platforms reported, with times rounded to 10 ms.

Only the public interface of the simulator and of :class:`~actorswarm.core.node.Node` is used
(events drained into ``SimSwarm.log``, ``Node.view``, ``Node.members.suspects``,
``Node.counters``, ...), so the scenarios keep working while the core's internals move.

Replay one scenario, or regenerate the expected part of some (all when none are named)::

    python -m tests.scenarios.interpreter tests/scenarios/failover.txt
    python -m tests.scenarios.interpreter --rewrite [FILES]
"""

from __future__ import annotations

import argparse
import dataclasses
import difflib
import sys
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from actorswarm.core import (
    NEED_ALL,
    AppReceived,
    BarrierFired,
    BarrierReleased,
    BarrierStaleNotice,
    BecameMaster,
    ConfigError,
    CoreConfig,
    DeliveryFailed,
    HandshakeComplete,
    MasterChanged,
    MemberJoined,
    MemberLeft,
    Node,
    RoleDenied,
    RoleGranted,
    RoleRevoked,
    SteppedDown,
)
from actorswarm.sim import LinkModel, SimSwarm

__all__ = [
    "SEPARATOR",
    "Scenario",
    "ScenarioError",
    "diff",
    "load",
    "main",
    "parse",
    "run",
    "write",
]

#: The line between the commands and the expected log.
SEPARATOR = "----"
#: The directory of the scenario files.
HERE = Path(__file__).resolve().parent
#: Period of the observer that notices suspicions and watched views (they raise no event).
POLL = 0.01

_CONFIG_FIELDS = {f.name for f in dataclasses.fields(CoreConfig)}
_LINK_FIELDS = {f.name for f in dataclasses.fields(LinkModel)} - {"burst"}


class ScenarioError(Exception):
    """A scenario file that cannot be parsed or run; the message starts with ``file:line:``."""


# --- parsing ----------------------------------------------------------------------------------

Action = Callable[["Runner"], None]


@dataclass(frozen=True, slots=True)
class Command:
    """One command line: at virtual time ``at`` (None: a top-level command) do ``action``."""

    line: int
    at: float | None
    action: Action


@dataclass(slots=True)
class Scenario:
    """A parsed scenario file: its command part verbatim, the commands, the expected log
    (None when the file has no ``----`` line yet)."""

    path: Path
    head: str
    platforms: list[int]
    seed: int
    config: CoreConfig
    link: LinkModel
    commands: list[Command]
    expected: str | None
    watched: set[int] = field(default_factory=set)

    def where(self, line: int) -> str:
        return f"{self.path}:{line}"


def _ids(text: str) -> list[int]:
    """``3``, ``1,2,5`` or ``2-4`` (combinable: ``1-3,7``) as a sorted list of IDs."""
    out: set[int] = set()
    for raw in text.split(","):
        part = raw.strip()
        try:
            if "-" in part:
                low, high = (int(x) for x in part.split("-", 1))
                if low > high:
                    raise ValueError
                out.update(range(low, high + 1))
            else:
                out.add(int(part))
        except ValueError:
            raise ValueError(f"bad platform list {text!r} (e.g. 3, 1,2,5 or 2-4)") from None
    if not out or min(out) < 1:
        raise ValueError(f"bad platform list {text!r}: platform IDs start at 1")
    return sorted(out)


def _value(text: str) -> int | float | bool | str:
    if text in ("true", "false"):
        return text == "true"
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def _options(args: Sequence[str], allowed: Iterable[str]) -> dict[str, str]:
    names = set(allowed)
    out: dict[str, str] = {}
    for arg in args:
        name, eq, value = arg.partition("=")
        if not eq or not value:
            raise ValueError(f"expected name=value, got {arg!r}")
        if name not in names:
            raise ValueError(f"unknown option {name!r} (known: {', '.join(sorted(names))})")
        if name in out:
            raise ValueError(f"option {name!r} given twice")
        out[name] = value
    return out


def _number(text: str, what: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"{what} must be a number, got {text!r}") from None
    if not value >= 0 or value == float("inf"):
        raise ValueError(f"{what} must be a finite number >= 0, got {text!r}")
    return value


def _link_changes(options: dict[str, str]) -> dict[str, object]:
    return {name: _value(value) for name, value in options.items()}


def parse(text: str, path: Path) -> Scenario:
    """Parse a scenario file's text; :class:`ScenarioError` (``file:line: reason``) if bad."""
    lines = text.splitlines()
    head_end = len(lines)
    expected: str | None = None
    for i, line in enumerate(lines):
        if line.strip() == SEPARATOR:
            head_end = i
            expected = "".join(f"{x}\n" for x in lines[i + 1 :])
            break
    head = "".join(f"{x}\n" for x in lines[:head_end])
    parser = _Parser(path)
    for number, raw in enumerate(lines[:head_end], start=1):
        stripped = raw.strip()
        if not stripped or stripped.startswith("#"):
            continue
        try:
            parser.command(number, stripped)
        except ValueError as exc:
            raise ScenarioError(f"{path}:{number}: {exc}") from None
    if parser.swarm is None:
        raise ScenarioError(f"{path}:1: no 'swarm' command")
    ran = False  # whether a `run` follows (scanning backwards)
    for command in reversed(parser.commands):
        if command.at is None:
            ran = True
        elif not ran or command.at > parser.clock:
            raise ScenarioError(
                f"{path}:{command.line}: this never happens: no 'run' reaches "
                f"{command.at:g} after it"
            )
    platforms, seed, config, link = parser.swarm
    return Scenario(
        path=path,
        head=head,
        platforms=platforms,
        seed=seed,
        config=config,
        link=link,
        commands=parser.commands,
        expected=expected,
        watched=parser.watched,
    )


class _Parser:
    """Turns command lines into :class:`Command` objects, checking what can be checked
    before the run (known platforms, times that move forward)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.swarm: tuple[list[int], int, CoreConfig, LinkModel] | None = None
        self.commands: list[Command] = []
        self.watched: set[int] = set()
        self.known: set[int] = set()
        self.clock = 0.0  # the latest `run` time so far

    def command(self, line: int, text: str) -> None:
        words = text.split()
        verb, args = words[0], words[1:]
        if verb == "swarm":
            self._swarm(args)
            return
        if self.swarm is None:
            raise ValueError("the first command must be 'swarm'")
        if verb == "watch":
            if len(args) != 1:
                raise ValueError("usage: watch IDS")
            ids = self._known(args[0])
            self.watched.update(ids)
            return
        if verb == "run":
            if len(args) != 1:
                raise ValueError("usage: run T")
            t = _number(args[0], "run time")
            if t <= self.clock:
                raise ValueError(f"run {args[0]}: time must grow (already ran to {self.clock:g})")
            self.clock = t
            self.commands.append(Command(line, None, lambda r: r.run_until(t)))
            return
        if verb != "at":
            raise ValueError(
                f"unknown command {verb!r} (commands: swarm, watch, run, at T <action>)"
            )
        if len(args) < 2:
            raise ValueError("usage: at T ACTION [ARGS]")
        t = _number(args[0], "time")
        if t < self.clock:
            raise ValueError(f"at {args[0]}: already ran to {self.clock:g}")
        action = self._action(args[1], args[2:])
        self.commands.append(Command(line, t, action))

    def _known(self, text: str) -> list[int]:
        ids = _ids(text)
        unknown = sorted(set(ids) - self.known)
        if unknown:
            raise ValueError(f"unknown platform(s) {unknown} (not in the swarm, never added)")
        return ids

    def _swarm(self, args: list[str]) -> None:
        if self.swarm is not None:
            raise ValueError("only one 'swarm' command per file")
        if not args:
            raise ValueError("usage: swarm N|IDS [seed=S] [name=value ...]")
        first = args[0]
        platforms = list(range(1, int(first) + 1)) if first.isdigit() else _ids(first)
        if not platforms:
            raise ValueError("a swarm needs at least one platform")
        options = _options(args[1:], {"seed"} | _CONFIG_FIELDS | _LINK_FIELDS)
        seed_text = options.pop("seed", "0")
        if not seed_text.isdigit():
            raise ValueError(f"seed must be a non-negative integer, got {seed_text!r}")
        config_changes = {k: _value(v) for k, v in options.items() if k in _CONFIG_FIELDS}
        link_changes = _link_changes({k: v for k, v in options.items() if k in _LINK_FIELDS})
        try:
            config = CoreConfig.from_mapping(config_changes)
        except ConfigError as exc:
            raise ValueError(f"core setting: {exc}") from None
        try:
            link = LinkModel(**link_changes)  # type: ignore[arg-type]
        except (TypeError, ValueError) as exc:
            raise ValueError(f"link setting: {exc}") from None
        self.swarm = (platforms, int(seed_text), config, link)
        self.known.update(platforms)

    def _action(self, verb: str, args: list[str]) -> Action:
        if verb in ("crash", "restart"):
            if len(args) != 1:
                raise ValueError(f"usage: at T {verb} IDS")
            ids = self._known(args[0])
            return lambda r: r.fault(verb, ids)
        if verb == "add":
            if len(args) != 1:
                raise ValueError("usage: at T add IDS")
            ids = _ids(args[0])
            taken = sorted(set(ids) & self.known)
            if taken:
                raise ValueError(f"platform(s) {taken} already in the swarm (use restart)")
            self.known.update(ids)
            return lambda r: r.fault("add", ids)
        if verb == "partition":
            groups = [self._known(g.strip()) for g in " ".join(args).split("|")]
            if len(groups) < 2:
                raise ValueError("usage: at T partition IDS | IDS [| IDS ...]")
            seen: set[int] = set()
            for group in groups:
                if seen & set(group):
                    raise ValueError(f"platform(s) {sorted(seen & set(group))} in two groups")
                seen.update(group)
            return lambda r: r.partition(groups)
        if verb == "heal":
            if args:
                raise ValueError("usage: at T heal")
            return lambda r: r.heal()
        if verb == "link":
            changes = _link_changes(_options(args, _LINK_FIELDS))
            if not changes:
                raise ValueError("usage: at T link name=value ...")
            assert self.swarm is not None
            try:  # validate now, against the swarm's link, so the error names the line
                dataclasses.replace(self.swarm[3], **changes)  # type: ignore[arg-type]
            except (TypeError, ValueError) as exc:
                raise ValueError(f"link setting: {exc}") from None
            return lambda r: r.relink(changes)
        if verb == "barrier":
            return self._barrier(args)
        if verb == "show":
            if args:
                raise ValueError("usage: at T show")
            return lambda r: r.show()
        raise ValueError(
            f"unknown action {verb!r} "
            "(actions: crash, restart, add, partition, heal, link, barrier, show)"
        )

    def _barrier(self, args: list[str]) -> Action:
        options = _options(args, {"key", "need", "by", "timeout"})
        if "key" not in options:
            raise ValueError("usage: at T barrier key=K [need=all|N] [by=IDS] [timeout=S]")
        if not options["key"].isdigit():
            raise ValueError(f"key must be a non-negative integer, got {options['key']!r}")
        key = int(options["key"])
        need_text = options.get("need", "all")
        if need_text == "all":
            need = NEED_ALL
        elif need_text.isdigit() and int(need_text) > 0:
            need = int(need_text)
        else:
            raise ValueError(f"need must be 'all' or a positive integer, got {need_text!r}")
        by_text = options.get("by", "all")
        by = None if by_text == "all" else self._known(by_text)
        timeout = _number(options["timeout"], "timeout") if "timeout" in options else None
        return lambda r: r.barrier(key, need, need_text, by, timeout)


def load(path: Path) -> Scenario:
    return parse(path.read_text(encoding="utf-8"), path)


# --- running ----------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class _Line:
    """One line of the log before grouping: at ``t``, ``who`` (a platform label, or "" for
    what the scenario itself did) reported ``text``."""

    t: float
    who: str
    text: str


def _label(platform: int, incarnation: int) -> str:
    return f"p{platform}" if incarnation == 0 else f"p{platform}#{incarnation}"


def _ranges(ids: Iterable[int]) -> str:
    """``1-5,7``: a sorted list of IDs with runs of three or more collapsed."""
    values = sorted(set(ids))
    parts: list[str] = []
    i = 0
    while i < len(values):
        j = i
        while j + 1 < len(values) and values[j + 1] == values[j] + 1:
            j += 1
        if j - i >= 2:
            parts.append(f"{values[i]}-{values[j]}")
        else:
            parts.extend(str(v) for v in values[i : j + 1])
        i = j + 1
    return ",".join(parts) if parts else "-"


def describe(platform: int, event: object) -> str | None:
    """The log text of one core event (None: not worth a line)."""
    match event:
        case MemberJoined(platform=p, incarnation=inc):
            return f"join {_label(p, inc)}"
        case MemberLeft(platform=p, incarnation=inc, reason=reason):
            return f"leave {_label(p, inc)} ({reason})"
        case MasterChanged(master=None, epoch=epoch):
            return f"no master (epoch {epoch})"
        case MasterChanged(master=m, epoch=epoch):
            return None if m == platform else f"follow p{m} epoch={epoch}"
        case BecameMaster(epoch=epoch):
            return f"MASTER epoch={epoch}"
        case SteppedDown(epoch=epoch, to=to):
            return f"step down epoch={epoch} to p{to}"
        case HandshakeComplete(epoch=epoch, members=members):
            return f"handshake complete epoch={epoch} members={members}"
        case BarrierFired():
            order = sorted(event.chosen, key=lambda p: event.chosen[p])
            text = (
                f"fire key={event.key} gen={event.generation} epoch={event.epoch} "
                f"{event.outcome} chosen={','.join(f'p{p}' for p in order) or '-'}"
            )
            if event.not_chosen:
                text += f" not-chosen={','.join(f'p{p}' for p in sorted(event.not_chosen))}"
            return text + (" (completion)" if event.completion else "")
        case BarrierReleased():
            text = f"pass key={event.key} gen={event.generation}"
            if event.outcome != "complete":
                text += f" {event.outcome}"
            if not event.chosen:
                return text + " not-chosen"
            part = f"part={event.part} " if event.part else ""
            return f"{text} {part}index={event.index}/{event.size}"
        case BarrierStaleNotice(key=key, generation=gen, current=current):
            return f"stale key={key} gen={gen} current={current}"
        case RoleGranted(role=role):
            return f"role granted {role}"
        case RoleDenied(role=role, holders=holders):
            return f"role denied {role} holders={_ranges(holders)}"
        case RoleRevoked(role=role):
            return f"role revoked {role}"
        case DeliveryFailed(dst=dst, kind=kind, reason=reason):
            return f"delivery failed to {'master' if dst is None else f'p{dst}'} {kind}: {reason}"
        case AppReceived(sender=sender, topic=topic):
            return f"app from p{sender} {topic}"
    return repr(event)  # an event kind this renderer does not know yet: shown as is


class Runner:
    """Runs one scenario on a :class:`SimSwarm` and collects its log lines."""

    def __init__(self, scenario: Scenario) -> None:
        self.scenario = scenario
        self.swarm = SimSwarm(
            scenario.platforms,
            seed=scenario.seed,
            config=scenario.config,
            link=scenario.link,
        )
        self.lines: list[_Line] = []
        self._cursor = 0  # entries of swarm.log already taken
        self._line = 0  # the command being run, for error messages
        # What the observer saw last, per (platform, incarnation).
        self._suspects: dict[tuple[int, int], frozenset[int]] = {}
        self._views: dict[tuple[int, int], tuple[int, ...]] = {}
        self._roster_requests: dict[tuple[int, int], int] = {}
        self._polls = 0
        self.swarm.at(0.0, self._poll)

    # --- the log ----------------------------------------------------------------------------

    def _sync(self) -> None:
        """Take the swarm's new log entries (events and faults) into the lines."""
        log = self.swarm.log
        while self._cursor < len(log):
            entry = log[self._cursor]
            self._cursor += 1
            if isinstance(entry.event, str):
                if entry.event == "crash":
                    self.lines.append(_Line(entry.t, "", f"crash p{entry.platform}"))
                elif entry.event == "restart":
                    label = _label(entry.platform, entry.incarnation)
                    self.lines.append(_Line(entry.t, "", f"boot {label}"))
                # partitions and heals are logged by the runner, in its own notation
                continue
            text = describe(entry.platform, entry.event)
            if text is not None:
                self.lines.append(_Line(entry.t, _label(entry.platform, entry.incarnation), text))

    def note(self, who: str, text: str) -> None:
        self._sync()
        self.lines.append(_Line(self.swarm.now, who, text))

    def _poll(self) -> None:
        """Suspicions, and the views and roster requests of watched platforms, raise no
        event: look at them every POLL seconds (read only: the run is not changed)."""
        live: set[tuple[int, int]] = set()
        for platform, node in self.swarm.nodes.items():
            me = (platform, node.incarnation)
            live.add(me)
            who = _label(*me)
            suspects = frozenset(node.members.suspects)
            before = self._suspects.get(me, frozenset())
            for peer in sorted(suspects - before):
                self.note(who, f"suspect {self._peer(node, peer)}")
            for peer in sorted(before - suspects):
                if peer in node.members.peers:  # heard again: it never left
                    self.note(who, f"clear {self._peer(node, peer)}")
            self._suspects[me] = suspects
            if platform in self.scenario.watched:
                requests = node.counters["roster_request"]
                if requests > self._roster_requests.get(me, 0):
                    self.note(who, "ask roster")
                self._roster_requests[me] = requests
                view = node.view
                if view != self._views.get(me):
                    self.note(who, f"view {_ranges(view)}")
                self._views[me] = view
        for gone in set(self._suspects) - live:
            del self._suspects[gone]
        self._polls += 1
        self.swarm.at(self._polls * POLL, self._poll)

    @staticmethod
    def _peer(node: Node, platform: int) -> str:
        peer = node.members.peers.get(platform)
        return _label(platform, 0 if peer is None else peer.incarnation)

    # --- actions ----------------------------------------------------------------------------

    def fail(self, message: str) -> ScenarioError:
        return ScenarioError(f"{self.scenario.where(self._line)}: {message}")

    def run_until(self, t: float) -> None:
        self.swarm.run_until(t)

    def fault(self, verb: str, ids: list[int]) -> None:
        for platform in ids:
            if verb == "crash":
                self.swarm.crash(platform)
            elif verb == "restart":
                self.swarm.restart(platform)
            else:
                self.swarm.add(platform)

    def partition(self, groups: list[list[int]]) -> None:
        self.swarm.partition(groups)
        self.note("", "partition " + " | ".join(_ranges(g) for g in groups))

    def heal(self) -> None:
        self.swarm.heal()
        self.note("", "heal")

    def relink(self, changes: dict[str, object]) -> None:
        radio = self.swarm.radio
        radio.model = dataclasses.replace(radio.model, **changes)  # type: ignore[arg-type]
        self.note("", "link " + " ".join(f"{k}={v}" for k, v in changes.items()))

    def barrier(
        self, key: int, need: int, need_text: str, by: list[int] | None, timeout: float | None
    ) -> None:
        nodes = self.swarm.nodes
        platforms = sorted(nodes) if by is None else by
        for platform in platforms:
            if platform not in nodes:
                raise self.fail(f"barrier: platform {platform} is not running")
            generation = self.swarm.call(
                platform, lambda n: n.request_barrier(key, need, self.swarm.now, timeout=timeout)
            )
            self.note(
                _label(platform, nodes[platform].incarnation),
                f"request key={key} gen={generation} need={need_text}",
            )

    def show(self) -> None:
        self._sync()
        self.lines.extend(self._state())

    def _state(self) -> list[_Line]:
        now = self.swarm.now
        out: list[_Line] = []
        for platform, node in sorted(self.swarm.nodes.items()):
            if node.is_master:
                role = f"master epoch={node.epoch}"
            elif node.master is None:
                role = f"no master epoch={node.epoch}"
            else:
                role = f"follows p{node.master} epoch={node.epoch}"
            out.append(
                _Line(
                    now,
                    _label(platform, node.incarnation),
                    f"state: {role} view={_ranges(node.view)}",
                )
            )
        return out

    # --- the whole run ----------------------------------------------------------------------

    def execute(self) -> str:
        for command in self.scenario.commands:
            self._line = command.line
            if command.at is None:
                try:
                    command.action(self)
                except ScenarioError:
                    raise
                except Exception as exc:
                    raise self.fail(f"{type(exc).__name__}: {exc}") from exc
            else:
                self.swarm.at(command.at, self._timed, command)
        self._sync()
        self.lines.extend(self._state())
        violations = self.swarm.finish()
        for violation in violations:
            self.lines.append(_Line(self.swarm.now, "", f"VIOLATION {violation}"))
        if not violations:
            self.lines.append(_Line(self.swarm.now, "", "invariants ok"))
        return render(self.lines)

    def _timed(self, command: Command) -> None:
        line, self._line = self._line, command.line
        try:
            command.action(self)
        except ScenarioError:
            raise
        except Exception as exc:
            raise self.fail(f"{type(exc).__name__}: {exc}") from exc
        finally:
            self._line = line


def _order(label: str) -> tuple[int, int]:
    platform, _, incarnation = label[1:].partition("#")
    return int(platform), int(incarnation or 0)


def render(lines: Iterable[_Line]) -> str:
    """One text line per time (rounded to 10 ms) and text: the platforms that reported the
    same thing in the same 10 ms share a line, unless that would move one of a platform's
    lines before another of its own (each platform's lines keep their order)."""
    out: list[str] = []
    bucket_time = ""
    bucket: list[tuple[str, list[str]]] = []  # (text, who) in order of first occurrence

    def flush() -> None:
        for text, who in bucket:
            named = sorted((w for w in set(who) if w), key=_order)
            prefix = ",".join(named) + ": " if named else ""
            out.append(f"{bucket_time:>6}  {prefix}{text}")
        bucket.clear()

    for line in lines:
        t = f"{line.t:.2f}"
        if t != bucket_time:
            flush()
            bucket_time = t
        for text, who in reversed(bucket):
            if text == line.text and bool(who[0]) == bool(line.who):
                who.append(line.who)
                break
            if line.who and line.who in who:
                bucket.append((line.text, [line.who]))
                break
        else:
            bucket.append((line.text, [line.who]))
    flush()
    return "".join(f"{x}\n" for x in out)


def run(scenario: Scenario) -> str:
    """Run a parsed scenario; its log as text."""
    return Runner(scenario).execute()


# --- files ------------------------------------------------------------------------------------


def write(scenario: Scenario, log: str) -> bool:
    """Replace the expected part of the scenario's file with ``log``; True if it changed."""
    text = f"{scenario.head}{SEPARATOR}\n{log}"
    old = scenario.path.read_text(encoding="utf-8")
    if old == text:
        return False
    scenario.path.write_text(text, encoding="utf-8")
    return True


def diff(scenario: Scenario, log: str) -> str:
    """A unified diff from the expected log to ``log`` (empty when they agree)."""
    expected = scenario.expected if scenario.expected is not None else ""
    return "".join(
        difflib.unified_diff(
            expected.splitlines(keepends=True),
            log.splitlines(keepends=True),
            f"{scenario.path.name} (expected)",
            f"{scenario.path.name} (actual)",
        )
    )


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m tests.scenarios.interpreter",
        description="Run collective-core scenario files: print their logs, or rewrite their "
        "expected part (--rewrite).",
    )
    parser.add_argument(
        "--rewrite",
        action="store_true",
        help="regenerate the expected log of each file (every scenario when none is named)",
    )
    parser.add_argument("files", nargs="*", type=Path, help="scenario files (*.txt)")
    options = parser.parse_args(argv)
    files: list[Path] = options.files
    if not files:
        if not options.rewrite:
            parser.error("name the scenario files to replay (or use --rewrite)")
        files = sorted(HERE.glob("*.txt"))
    status = 0
    for path in files:
        try:
            scenario = load(path)
            log = run(scenario)
        except (OSError, ScenarioError) as exc:
            print(f"error: {exc}", file=sys.stderr)
            status = 2
            continue
        if options.rewrite:
            changed = write(scenario, log)
            print(f"{'rewrote' if changed else 'unchanged'}: {path}")
            continue
        if len(files) > 1:
            print(f"== {path}")
        sys.stdout.write(log)
        if scenario.expected is not None and scenario.expected != log:
            print(f"{path}: differs from the expected log (--rewrite to accept)", file=sys.stderr)
            status = max(status, 1)
    return status


if __name__ == "__main__":
    sys.exit(main())
