"""Replay a recorded run into a fresh controller and find the first frame it sends differently.

The model is openpilot's process replay: the inputs of a recorded run (every
frame that reached the controller, in order, with the same controller clock)
go into today's controller, and what it sends is compared with what the
recorded controller sent, frame by frame and signal by signal.

Ticks come from the controller's own frames: each tick ends with its heartbeat
on both buses (rig.dbc ``Heartbeat``), so the frames the controller sent after
the previous heartbeat up to this one are one tick's answer, and the inputs
recorded before that answer are what it had heard.

- sync mode (a rig trace or rig log: SYNC frames on both buses): a real
  ``ControllerNode`` in sync mode runs over two in-memory buses
  (``MemoryBus``); its own SYNC handling stamps the frames and decides the
  tick, exactly as in the rig. A bus's inputs up to and including the tick's
  SYNC on that bus are delivered (each bus keeps its order): in lockstep the
  controller ticks on SYNC with what it has heard, and what the devices send
  after it is for the next tick, even when it is on the wire before the
  controller's commands (the rig's log is in the wire's order,
  hil/bus/wire_order.py). Without that SYNC in the recording, the inputs
  before the tick's first frame on that bus.
- free-run mode (a robot's candump log, no SYNC): the log's timestamps are
  the controller clock (ns since the log's first frame); ``Controller`` gets
  each input frame before the tick's first controller frame in the log, then
  ``tick(T, t)`` with T from the recorded heartbeat and t the time of that
  first frame. The robot's loop cannot be re-timed from a log, so the log's
  tick boundaries are taken as they are.

Exit-worthy problems (the file cannot be replayed) raise ``TraceError``.
"""
from __future__ import annotations

import collections
import math
from dataclasses import dataclass, field

import can

from wheelleg import dbc
from wheelleg.controller.modes import Mode
from wheelleg.dbc import cybergear as cg
from wheelleg.hil import robots
from wheelleg.hil.analyze.bug_report import environment_warnings
from wheelleg.hil.record.run_metadata import plant_overrides, rerun_command
from wheelleg.hil.record.decode import FrameDecoder
from wheelleg.hil.record.frame import Frame
from wheelleg.hil.record.sources import (CAN1, CAN2, CONTROLLER_NODES, DBS, HEARTBEAT, ROLES,
                              TraceError, Recording, heartbeat_tick, is_heartbeat, is_sync,
                              open_recording, sent_by_controller, sync_tick)

_START_MODES = (Mode.IDLE, Mode.ESTOP)  # what a fresh controller can report on its first tick


class MemoryBus(can.BusABC):
    """An in-memory bus end: frames put in ``inbox`` are received, sent frames land in ``sent``."""

    def __init__(self, channel: str):
        super().__init__(channel=channel)
        self.channel_info = f"replay {channel}"
        self.inbox: collections.deque[can.Message] = collections.deque()
        self.sent: list[can.Message] = []

    def _recv_internal(self, timeout):
        return (self.inbox.popleft() if self.inbox else None), False

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        self.sent.append(msg)

    def take_sent(self) -> list[can.Message]:
        out, self.sent = self.sent, []
        return out


# -- the schedule: which inputs come before which tick --------------------------------------
@dataclass
class TickStep:
    """One recorded tick: inputs to deliver first, then the frames the controller sent."""

    tick: int  # heartbeat Tick in the recording
    t_ns: int  # recording time of the tick's first controller frame
    inputs: list[Frame]
    expected: dict[str, list[int]]  # role -> indices into Recording.frames (heartbeat last)


@dataclass
class Schedule:
    mode: str  # "sync" | "free-run"
    steps: list[TickStep]
    trailing: dict[str, list[int]]  # controller frames after the last heartbeat (not compared)
    skipped_inputs: int = 0  # CAN FD frames: a classic-CAN socket never delivers them
    notes: list[str] = field(default_factory=list)


def _groups(frames: list[Frame], dbs: dict):
    """Per role: [(tick, [frame indices])] closed by each heartbeat; inputs; leftovers.
    ``dbs``: the robot's bus databases (which frames are the controller's)."""
    groups = {r: [] for r in ROLES}
    pending = {r: [] for r in ROLES}
    inputs = []
    for i, f in enumerate(frames):
        if sent_by_controller(f, dbs):
            pending[f.bus].append(i)
            if is_heartbeat(f):
                groups[f.bus].append((heartbeat_tick(f), pending[f.bus]))
                pending[f.bus] = []
        else:
            inputs.append(i)
    return groups, inputs, pending


def _check_pairing(source: Recording, groups: dict) -> list[str]:
    """Raise unless both buses show the same heartbeat ticks; trims a last tick cut off by the file's end."""
    if not groups[CAN1] and not groups[CAN2]:
        raise TraceError(f"{source.path}: no controller frames (DBC senders {sorted(CONTROLLER_NODES)}, "
                         "heartbeat 0x%03X): replay needs the controller's own frames in the "
                         "recording to know its ticks" % HEARTBEAT.frame_id)
    notes = []
    longer = max(ROLES, key=lambda r: len(groups[r]))
    shorter = CAN2 if longer == CAN1 else CAN1
    if len(groups[longer]) == len(groups[shorter]) + 1 and groups[longer][-1][0] not in \
            {t for t, _ in groups[shorter]}:  # the recording ends between the two heartbeats of a tick
        tick, _ = groups[longer].pop()
        notes.append(f"tick {tick} not compared: the recording ends before its heartbeat on {shorter}")
    ticks = {r: [t for t, _ in groups[r]] for r in ROLES}
    for k in range(max(len(ticks[CAN1]), len(ticks[CAN2]))):
        a = ticks[CAN1][k] if k < len(ticks[CAN1]) else None
        b = ticks[CAN2][k] if k < len(ticks[CAN2]) else None
        if a != b:
            role, tick = (CAN1, a) if b is None or (a is not None and a < b) else (CAN2, b)
            other = CAN2 if role == CAN1 else CAN1
            frame = source.frames[groups[role][k][1][-1]]
            raise TraceError(f"{source.path}: controller frames missing: heartbeat of tick {tick} on "
                             f"{role} ({source.channels[role]}, {frame.where()}) but not on {other} "
                             f"({source.channels[other]}); the recording lost frames of the controller")
        if k and a <= ticks[CAN1][k - 1]:
            frame = source.frames[groups[CAN1][k][1][-1]]
            raise TraceError(f"{source.path}: heartbeat tick goes from {ticks[CAN1][k - 1]} to {a} at "
                             f"{frame.where()}: the controller restarted; cut the recording there")
    return notes


# A log written by the controller itself (python-can's CanutilsLogWriter via
# ``python -m wheelleg.controller --log``) is in the order the controller handled the
# frames, each received frame stamped when the bus delivered it: a frame read
# after a tick's sends is stamped before them. Steps back up to this bound are
# that reordering (file order is what replay uses); larger ones are a broken
# clock or spliced logs.
BACKSTEP_LIMIT_NS = 100_000_000


def _check_order(source: Recording) -> list[str]:
    """Raise on time going backwards on an interface; notes for small reordering steps."""
    last: dict[str, Frame] = {}
    worst, count = 0, 0
    for f in source.frames:
        prev = last.get(f.channel)
        if prev is not None and f.t_ns < prev.t_ns:
            if prev.t_ns - f.t_ns > BACKSTEP_LIMIT_NS:
                raise TraceError(f"{source.path}: time goes backwards on {f.channel}: {prev.where()} "
                                 f"({prev.t_ns / 1e9:.6f} s) then {f.where()} ({f.t_ns / 1e9:.6f} s)")
            worst, count = max(worst, prev.t_ns - f.t_ns), count + 1
            continue  # keep the latest time as the reference
        last[f.channel] = f
    if not count:
        return []
    return [f"{count} frame(s) stamped up to {worst / 1e6:.3f} ms before the frame logged ahead of them "
            "(the writer logged them in the order the controller read them); replay keeps the file order"]


def _check_drops(source: Recording) -> None:
    if not source.drops:
        return
    d = source.drops[0]
    after = f", after t={d.after_t_ns / 1e9:.6f} s" if d.after_t_ns is not None else ""
    total = sum(x.dropped for x in source.drops)
    raise TraceError(f"{source.path}: the log lost {total} frame(s) in {len(source.drops)} DROPCOUNT "
                     f"notice(s); first: {d.dropped} on {d.channel or '?'} at line {d.line_no}{after}. "
                     "The controller heard frames the log does not have, so replay cannot be trusted "
                     "past that point (--allow-drops replays anyway)")


def detect_mode(source: Recording) -> str:
    """'sync' when SYNC frames reach the controller on both buses, else 'free-run'."""
    seen = {f.bus for f in source.frames if is_sync(f) and not sent_by_controller(f, source.dbs)}
    return "sync" if seen >= set(ROLES) else "free-run"


def build_schedule(source: Recording, mode: str | None = None, allow_drops: bool = False) -> Schedule:
    """Split the recording into ticks; raises ``TraceError`` when it cannot be replayed."""
    if not allow_drops:
        _check_drops(source)
    if not source.frames:
        raise TraceError(f"{source.path}: no CAN frames on {sorted(source.channels.values())}")
    order_notes = _check_order(source)
    groups, inputs, trailing = _groups(source.frames, source.dbs)
    order_notes += _check_pairing(source, groups)
    mode = mode or detect_mode(source)
    frames = source.frames
    usable = [i for i in inputs if not frames[i].is_fd]
    per_bus = {r: collections.deque(i for i in usable if frames[i].bus == r) for r in ROLES}
    syncs = _sync_positions(frames, usable) if mode == "sync" else {}
    steps = []
    for (tick, idx1), (_, idx2) in zip(groups[CAN1], groups[CAN2]):
        expected = {CAN1: idx1, CAN2: idx2}
        first = min(idx1[0], idx2[0])
        delivered = []
        for role in ROLES:
            bound = first
            if mode == "sync":  # just after this tick's SYNC, else at the tick's first frame on the bus
                bound = syncs.get((role, tick), expected[role][0] - 1) + 1
            queue = per_bus[role]
            while queue and queue[0] < bound:
                delivered.append(queue.popleft())
        if mode != "sync":
            delivered.sort()  # free-run: the log's order across buses
        steps.append(TickStep(tick, frames[first].t_ns, [frames[i] for i in delivered], expected))
    return Schedule(mode, steps, trailing, len(inputs) - len(usable), order_notes)


def _sync_positions(frames: list[Frame], inputs: list[int]) -> dict[tuple[str, int], int]:
    """(bus, tick) -> index of the first SYNC with that tick on that bus."""
    out: dict[tuple[str, int], int] = {}
    for i in inputs:
        if is_sync(frames[i]):
            out.setdefault((frames[i].bus, sync_tick(frames[i])), i)
    return out


# -- comparing frames ------------------------------------------------------------------------
def _controller_signals() -> dict[str, tuple[float, str]]:
    """Signal name -> (scale, unit) over every message a controller node sends, the CyberGear id
    fields included (a type-1 command's TorqueRef lives in its id): the default robot's buses
    (CyberGear, C620 and rig frames); every registered robot's controller sends a subset."""
    out = {}
    for db in (*DBS.values(), dbc.load_file(cg.ID_DBC)):
        for message in db.messages:
            if CONTROLLER_NODES.intersection(message.senders or ()):
                for s in message.signals:
                    out.setdefault(s.name, (float(s.scale), s.unit or ""))
    return out


SIGNALS = _controller_signals()


def default_tolerances() -> dict[str, float]:
    """1 LSB for every scaled signal the controller sends (float rounding between machines)."""
    return {name: abs(scale) for name, (scale, _) in SIGNALS.items() if not float(scale).is_integer()}


def parse_tolerance(text: str) -> tuple[str, float]:
    """'TorqueRef=0.01' (signal units) or 'TorqueRef=2lsb'; 'Message.Signal=...' also works."""
    key, sep, value = text.partition("=")
    key, value = key.strip(), value.strip().lower()
    if not sep or not key or not value:
        raise ValueError(f"tolerance {text!r}: expected SIGNAL=VALUE, e.g. TorqueRef=0.001 or TorqueRef=1lsb")
    name = key.rpartition(".")[2]
    try:
        if value.endswith("lsb"):
            if name not in SIGNALS:
                raise ValueError(f"tolerance {text!r}: no controller signal {name!r} to take an LSB from")
            amount = float(value[:-3]) * abs(SIGNALS[name][0])
        else:
            amount = float(value)
    except ValueError as exc:
        raise ValueError(str(exc) if "tolerance" in str(exc) else f"tolerance {text!r}: bad number") from None
    if not math.isfinite(amount) or amount < 0:
        raise ValueError(f"tolerance {text!r}: must be a finite number >= 0")
    return key, amount


@dataclass(frozen=True)
class Difference:
    """The first place where the replayed controller sent something else."""

    tick: int
    controller_time_s: float
    t_ns: int  # recording time of the expected frame (or of the tick)
    bus: str
    channel: str
    arbitration_id: int | None
    is_extended: bool
    message: str  # DBC message name ('?' when the DBC does not know the frame)
    signal: str  # a signal name, or <missing frame>, <extra frame>, <message>, <payload>
    expected: object
    got: object
    tolerance: float = 0.0
    unit: str = ""
    where: str = ""  # 'line 123' in a log

    def describe(self) -> str:
        ident = "-" if self.arbitration_id is None else (
            f"0x{self.arbitration_id:08X}" if self.is_extended else f"0x{self.arbitration_id:03X}")
        unit = f" {self.unit}" if self.unit else ""
        head = (f"first difference at tick {self.tick} (controller time {self.controller_time_s:.6f} s, "
                f"recorded at {self.t_ns / 1e9:.6f} s{', ' + self.where if self.where else ''})")
        body = (f"  bus {self.bus} ({self.channel})  id {ident}  message {self.message}\n"
                f"  signal {self.signal}: expected {_show(self.expected)}{unit}, got {_show(self.got)}{unit}")
        if isinstance(self.expected, (int, float)) and isinstance(self.got, (int, float)):
            body += f"  (|diff| {abs(self.got - self.expected):.6g} > tolerance {self.tolerance:.6g})"
        return head + "\n" + body


def _show(value) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, (bytes, bytearray)):
        return value.hex().upper() or "(empty)"
    return str(value)


def _decode(decoder: FrameDecoder, role: str, arbitration_id: int, is_extended: bool, data: bytes):
    hit = decoder.decode(role, arbitration_id, is_extended, data)
    return (hit[0].name, hit[1]) if hit is not None else ("?", None)


def _tolerance(tolerances: dict, message: str, signal: str) -> float:
    return tolerances.get(f"{message}.{signal}", tolerances.get(signal, 0.0))


def _frame_difference(decoder: FrameDecoder, role: str, exp: Frame | None, got: can.Message | None,
                      tolerances: dict):
    """(signal, expected, got, tolerance, unit, message name) of the first mismatch, or None;
    ``decoder``: the robot's (role -> database)."""
    if exp is None:
        name, _ = _decode(decoder, role, got.arbitration_id, got.is_extended_id, bytes(got.data))
        return "<extra frame>", "nothing", f"{name} {_ident(got.arbitration_id, got.is_extended_id)}", 0.0, "", name
    if got is None:
        name, _ = _decode(decoder, role, exp.arbitration_id, exp.is_extended, exp.data)
        return "<missing frame>", f"{name} {_ident(exp.arbitration_id, exp.is_extended)}", "nothing", 0.0, "", name
    got_data = bytes(got.data[:got.dlc])
    if (exp.arbitration_id, exp.is_extended, exp.dlc, exp.data) == \
            (got.arbitration_id, got.is_extended_id, got.dlc, got_data):
        return None
    exp_name, exp_values = _decode(decoder, role, exp.arbitration_id, exp.is_extended, exp.data)
    got_name, got_values = _decode(decoder, role, got.arbitration_id, got.is_extended_id, got_data)
    if exp_name != got_name or exp_values is None or got_values is None:
        return ("<message>", f"{exp_name} {_ident(exp.arbitration_id, exp.is_extended)} {exp.data.hex().upper()}",
                f"{got_name} {_ident(got.arbitration_id, got.is_extended_id)} {got_data.hex().upper()}",
                0.0, "", exp_name)
    for signal in dict.fromkeys([*exp_values, *got_values]):
        a, b = exp_values.get(signal), got_values.get(signal)
        tol = _tolerance(tolerances, exp_name, signal)
        if a is None or b is None:
            if a is not b:
                return signal, a, b, tol, SIGNALS.get(signal, (1, ""))[1], exp_name
        elif abs(b - a) > tol + 1e-12 * max(abs(a), abs(b)):
            return signal, a, b, tol, SIGNALS.get(signal, (1, ""))[1], exp_name
    if all(tolerances.get(s, 0.0) == 0.0 for s in exp_values) and exp.dlc == got.dlc:
        return "<payload>", exp.data, got_data, 0.0, "", exp_name  # bits no signal covers
    return None


def _ident(arbitration_id: int, extended: bool) -> str:
    return f"0x{arbitration_id:08X}" if extended else f"0x{arbitration_id:03X}"


# -- replaying -------------------------------------------------------------------------------
@dataclass
class ReplayResult:
    source: Recording
    schedule: Schedule
    period_s: float
    ticks: int = 0  # ticks compared
    frames: int = 0  # controller frames compared (recorded)
    differing_ticks: int = 0
    differing_frames: int = 0
    first: Difference | None = None
    warnings: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    sent: list[dict[str, list[can.Message]]] = field(default_factory=list)  # per step, for --update
    debug: list[dict] = field(default_factory=list)  # controller internals per step, for --update
    decoder: FrameDecoder | None = None  # the recording's robot's (role -> database)

    @property
    def identical(self) -> bool:
        return self.first is None


def _memory_buses() -> dict[str, MemoryBus]:
    return {role: MemoryBus(f"replay-{role}") for role in ROLES}


class SyncDriver:
    """A program's controller node in sync mode on in-memory buses; ``build_controller``: its node
    factory (``Robot.build_controller``, ``wheelleg.hil.program.Program.node_factory``)."""

    def __init__(self, build_controller, period_s: float, t0_ns: int):
        self.buses = _memory_buses()
        self.node = build_controller(self.buses, True, period_s)

    def step(self, step: TickStep):
        for f in step.inputs:
            self.buses[f.bus].inbox.append(f.message())
        ticked = self.node.service()
        sent = {role: bus.take_sent() for role, bus in self.buses.items()}
        result = self.node.last_result if ticked else None
        return sent, (self.node.now() if ticked else math.nan), (result.debug if result else {})

    def close(self) -> None:
        for bus in self.buses.values():
            bus.shutdown()


class FreeRunDriver:
    """A program's controller without I/O (its node's ``controller``: ``on_frame``, ``tick``) with the
    log's timestamps as its clock (ns since the log's first frame)."""

    def __init__(self, build_controller, period_s: float, t0_ns: int):
        buses = _memory_buses()
        self.controller = build_controller(buses, False, period_s).controller
        for bus in buses.values():  # the node only made the controller: its buses are never used
            bus.shutdown()
        self.t0_ns = t0_ns

    def clock(self, t_ns: int) -> float:
        return (t_ns - self.t0_ns) / 1e9

    def step(self, step: TickStep):
        for f in step.inputs:
            self.controller.on_frame(f.message(), f.bus, self.clock(f.t_ns))
        now = self.clock(step.t_ns)
        result = self.controller.tick(step.tick, now)
        return {role: list(result.frames[role]) for role in ROLES}, now, result.debug

    def close(self) -> None:
        pass


def driver_for(schedule: Schedule):
    """The driver class that feeds a program the recording's inputs in its schedule's mode."""
    return SyncDriver if schedule.mode == "sync" else FreeRunDriver


def recorded_period(source: Recording, period_s: float | None = None) -> float:
    """``period_s``, else the recording's control period, else its robot's."""
    return period_s or _recorded_period(source) or robots.get(source.robot).control_period_s


def replay(path_or_source, *, tolerances: dict | None = None, exact: bool = False,
           channels: dict | None = None, period_s: float | None = None, allow_drops: bool = False,
           keep_sent: bool = False, robot: str | None = None, build_controller=None) -> ReplayResult:
    """Replay a trace or log into a fresh controller of its robot; see the module docstring.

    ``tolerances``: signal (or 'Message.Signal') -> allowed |difference| in signal
    units, on top of ``default_tolerances()`` unless ``exact``. ``robot``: whose
    recording (default: the trace's record, else the default robot). ``build_controller``: the
    program replayed (its node factory; default the robot's Python program). Raises ``TraceError``.
    """
    source = path_or_source if isinstance(path_or_source, Recording) else \
        open_recording(path_or_source, channels, robot=robot)
    spec = robots.get(source.robot)
    schedule = build_schedule(source, allow_drops=allow_drops)
    period = period_s or _recorded_period(source) or spec.control_period_s
    result = ReplayResult(source, schedule, period, warnings=environment_warnings(source),
                          decoder=FrameDecoder(source.dbs))
    result.notes += _schedule_notes(source, schedule, period)
    tol = {} if exact else default_tolerances()
    tol.update(tolerances or {})
    t0 = min(f.t_ns for f in source.frames)
    driver = driver_for(schedule)(build_controller or spec.build_controller, period, t0)
    try:
        for step in schedule.steps:
            sent, now, debug = driver.step(step)
            _compare_step(result, step, sent, now, tol)
            if keep_sent:
                result.sent.append(sent)
                result.debug.append(debug)
    finally:
        driver.close()
    return result


def _compare_step(result: ReplayResult, step: TickStep, sent: dict, now: float, tol: dict) -> None:
    source, frames = result.source, result.source.frames
    result.ticks += 1
    found = []
    for role in ROLES:
        expected = [frames[i] for i in step.expected[role]]
        result.frames += len(expected)
        got = sent.get(role, [])
        for j in range(max(len(expected), len(got))):
            exp = expected[j] if j < len(expected) else None
            diff = _frame_difference(result.decoder, role, exp, got[j] if j < len(got) else None, tol)
            if diff is None:
                continue
            result.differing_frames += 1
            anchor = exp or expected[-1]
            found.append((anchor.t_ns, role, exp or anchor, diff))
    if not found:
        return
    result.differing_ticks += 1
    if result.first is None:
        t_ns, role, frame, (signal, a, b, tol_value, unit, name) = min(found, key=lambda x: x[:2])
        if math.isnan(now):
            signal, a, b = "<no tick>", f"tick {step.tick}", "the controller did not tick on these inputs"
        is_frame = signal not in ("<extra frame>",)
        result.first = Difference(step.tick, now if not math.isnan(now) else step.tick * result.period_s,
                                  t_ns, role, source.channels[role],
                                  frame.arbitration_id if is_frame else None, frame.is_extended,
                                  name, signal, a, b, tol_value, unit, frame.where() if frame.line_no else "")


def _recorded_period(source: Recording) -> float | None:
    try:
        value = float(source.run.get("control_period_s", ""))
    except ValueError:
        return None
    return value if math.isfinite(value) and value > 0 else None


def _schedule_notes(source: Recording, schedule: Schedule, period: float) -> list[str]:
    notes = list(schedule.notes)
    frames = source.frames
    overrides = plant_overrides(source.run)
    if overrides:  # replay feeds the recorded frames, so the plant needs no rebuilding; a rerun does
        notes.append(f"recorded on a changed plant ({', '.join(f'{k}={v!r}' for k, v in overrides.items())}); "
                     f"to run it again: {rerun_command(source.run)}")
    if schedule.steps and source.robot == robots.DEFAULT:  # its modes: controller/modes.py
        first = frames[schedule.steps[0].expected[CAN1][-1]]
        mode = HEARTBEAT.decode(first.data, decode_choices=False)["Mode"]
        if mode not in _START_MODES:
            name = Mode(mode).name if mode in Mode._value2member_map_ else str(mode)
            notes.append(f"warning: the recording starts with the controller in mode {name} "
                         f"(tick {schedule.steps[0].tick}); a fresh controller starts in IDLE, so replay "
                         "diverges at once: record from the controller's start")
    left = sum(len(v) for v in schedule.trailing.values())
    if left:
        notes.append(f"{left} controller frame(s) after the last heartbeat not compared (shutdown frames?)")
    if schedule.skipped_inputs:
        notes.append(f"{schedule.skipped_inputs} CAN FD frame(s) not delivered (a classic CAN socket drops them)")
    if source.truncated:
        notes.append("the trace was not closed (writer killed): replaying what it holds")
    if source.ignored_channels:
        notes.append(f"frames on other interfaces ignored: {source.ignored_channels}")
    if schedule.mode == "free-run" and len(schedule.steps) > 2:
        s0, s1 = schedule.steps[0], schedule.steps[-1]
        if s1.tick > s0.tick:
            measured = (s1.t_ns - s0.t_ns) / 1e9 / (s1.tick - s0.tick)
            if abs(measured - period) > 0.2 * period:
                notes.append(f"warning: the log ticks every {measured * 1e3:.3f} ms, the controller's "
                             f"period is {period * 1e3:.3f} ms (--period)")
    return notes
