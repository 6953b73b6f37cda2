"""The rig: plant, controller and recorder on two CAN buses, stepped by a schedule.

The schedule (hil/run/schedule.py: lockstep on the in-process bus or held on
a real transport; hil/run/realtime.py: real time) owns the run's clock and
calls the rig's public steps: ``apply_actions``, ``send_sync``,
``service_controller``, ``serve_plant``, ``record_debug``, ``record_state``.
Each plant-side bus end is built once from its stages: the bus's frame
faults (``BusFaults``), the recorder, the schedule's lockstep watch.
"""
from __future__ import annotations

import gc
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import can
import numpy as np

from wheelleg.controller.bus_args import per_bus_kwargs
from wheelleg.dbc import CAN1, CAN2, all_dbc_files, load_file
from wheelleg.dbc.codec import MessageCodec
from wheelleg.emulators.plant import PlantConfig
from wheelleg.hil import robots
from wheelleg.hil.bus.frame_faults import BusFaults
from wheelleg.hil.bus.plant_bus import PlantBus
from wheelleg.hil.bus.recorder import Recorder
from wheelleg.hil.bus.transport import open_bus
from wheelleg.hil.program import COMMAND, Program
from wheelleg.hil.program import process as program_process
from wheelleg.hil.program.process import ProgramExited, ProgramProcess, command_argv, tail_line
from wheelleg.hil.record.candump import CandumpWriter
from wheelleg.hil.record.run_metadata import run_record
from wheelleg.hil.record.trace import TraceWriter
from wheelleg.hil.run.scenario import Scenario
from wheelleg.hil.run.schedule import HeldLockstep, Lockstep, NoController
from wheelleg.hil.watch.scene import QposRecorder

_SYNC = load_file("rig.dbc").get_message_by_name("SYNC")  # every robot's lockstep frame
_SYNC_CODEC = MessageCodec.of(_SYNC)  # compiled: cantools' encode costs ~10 us a tick
_SYNC_ID = _SYNC.frame_id  # read once: a cantools property
SETTLE_SLICE = 32  # noted frames one real-time housekeeping piece settles (~0.1 ms)
REALTIME_BACKLOG = 128  # noted frames (~10 ms of them) past which real time settles a slice per frame noted

@dataclass
class RigConfig:
    """How to run: transport, channels (CAN1 then CAN2: the robot's two buses), seed, timing."""

    interface: str = "virtual"
    channels: tuple = ("vcan0", "vcan1")
    seed: int = 0
    period_s: float | None = None  # control period (s); None: the robot's (wheelleg.hil.robots)
    physics_dt_s: float = 0.001
    in_process_controller: bool = True  # False: another process answers (a command program, --external-controller)
    program: Program = field(default_factory=Program)  # which program (hil/program): python, a library, a command
    deadline_s: float = 0.5  # wall s a lockstep tick waits for a silent external program's heartbeats
    patience_s: float | None = None  # wall s it waits for one that answered its last tick; None: schedule.PATIENCE_S
    realtime: bool = False  # plant at wall-clock pace, controller on its own timer (hil/run/realtime.py)
    record_debug: bool = True  # the in-process controller's internals on /controller/debug
    decode: bool = False  # also write /decoded/ topics live (readers derive them from the raw frames anyway)
    trace_flush_s: float | None = 1.0  # wall s a killed run may lose; None: chunks close by size and bus time only
    bus_kwargs: dict = field(default_factory=dict)  # more keyword arguments for python-can's bus
    plant: PlantConfig = field(default_factory=PlantConfig)
    epoch_ns: int = 0  # ns since 1970 that the candump log's time 0 stands for (the trace keeps the run's time)

@dataclass
class RunOutcome:
    trace_path: Path
    log_path: Path
    ticks: int
    deadline_misses: int
    wall_s: float
    sim_s: float
    timing: dict | None = None  # real-time mode: {"controller": ..., "plant": ...} (hil/run/loop_timing.py)
    startup_s: float | None = None  # wall s from the command's start (imports, model build) to the first tick
    verdict_wall_s: float | None = None  # wall s from the first tick to the checks' verdict (trace read back)

def _open_bus(config: RigConfig, channel: str) -> can.BusABC:
    index = config.channels.index(channel)  # 0: CAN1, 1: CAN2
    return open_bus(config.interface, channel, **per_bus_kwargs(config.interface, config.bus_kwargs, index))


def _schedule(config: RigConfig):
    """Real time, lockstep held on a real transport, or lockstep on the in-process bus."""
    if config.realtime:
        from wheelleg.hil.run.realtime import Realtime  # noqa: PLC0415 (threads only when asked for)

        return Realtime(config.period_s, config.physics_dt_s)
    # Real transports deliver each socket's frames at their own pace: hold them
    # until both heartbeats are in, then serve them in the virtual bus's order.
    kind = Lockstep if config.interface == "virtual" else HeldLockstep
    return kind(config.period_s, config.physics_dt_s, config.deadline_s, config.patience_s)


def run_paths(out_dir: Path, scenario_name: str) -> tuple[Path, Path]:
    """Where a run of ``scenario_name`` into ``out_dir`` writes its MCAP trace and its candump log."""
    return out_dir / f"{scenario_name}.mcap", out_dir / f"{scenario_name}.log"


class Rig:
    """One scenario run: build everything, step it, record it."""

    def __init__(self, scenario: Scenario, config: RigConfig, out_dir: Path, progress=None):
        """``progress(t_s)``, if given, is called once per tick (hil/run/progress.py)."""
        self.robot = robot = robots.get(scenario.robot)
        robot.check_overrides(config.plant.overrides_dict())
        if config.period_s is None:
            config = replace(config, period_s=robot.control_period_s)
        self.scenario, self.config = scenario, config
        self.progress = progress
        out_dir.mkdir(parents=True, exist_ok=True)
        self.trace_path, self.log_path = run_paths(out_dir, scenario.name)
        self.names = {CAN1: config.channels[0], CAN2: config.channels[1]}
        self.rng = np.random.default_rng(config.seed)
        self.physics = robot.build_physics(scenario.terrain, config.physics_dt_s, config.plant.overrides)
        scenario.start(self.physics)
        # the buses first: a missing vcan fails before any file is written
        self._raw = {k: _open_bus(config, ch) for k, ch in self.names.items()}
        self.schedule = _schedule(config)
        self.process = None  # a command program's process (started by ``run``)
        if config.program.kind == COMMAND:
            argv = command_argv(list(config.program.words), config.interface, self.names)
            self.process = ProgramProcess(argv, out_dir / f"{scenario.name}.program.log")
        self.clock = self.schedule.clock
        attachments = self._attachments()
        if config.plant.overrides_dict():  # the model this run compiled; its overrides are in the metadata
            attachments.append(("plant_model.xml", self.physics.spec.to_xml().encode(), "application/xml"))
        self.trace = TraceWriter(self.trace_path, metadata=self._metadata(),
                                 attachments=attachments,
                                 dbs={self.names[role]: db for role, db in robot.databases().items()},
                                 decode=config.decode, sim_state_fields=robot.sim_state_fields,
                                 flush_interval_s=config.trace_flush_s,
                                 decode_batch=1 if config.realtime else 256,  # a real-time loop must not stall
                                 write_behind=config.realtime,
                                 defer_close=config.realtime)  # closed in the slack between steps
        self.log = CandumpWriter(self.log_path, epoch_ns=config.epoch_ns)
        # real time settles the noted frames in slices in the slack between steps (``housekeeping``);
        # past REALTIME_BACKLOG noted frames (no slack came) a slice settles at each frame noted
        self.recorder = Recorder([self.trace, self.log], self.clock, list(self.names.values()), load_to=self.trace,
                                 batch=REALTIME_BACKLOG if config.realtime else 1024,
                                 slice_size=SETTLE_SLICE if config.realtime else None)
        self.bus_faults = {k: BusFaults(self.clock) for k in self._raw}
        self.plant_buses = {}
        for k, raw in self._raw.items():
            end = self.schedule.bus_end(k, raw)
            self.plant_buses[k] = PlantBus(end, self.names[k], self.recorder,
                                           [self.bus_faults[k], self.schedule.watches[k]])
        self.plant = robot.build_plant(self.physics, self.plant_buses, self.rng, config.plant)
        self.controller = None
        if config.in_process_controller and not config.realtime:  # real time: hil/run/realtime.py
            self.controller = config.program.node_factory(robot)(
                {role: _open_bus(config, name) for role, name in self.names.items()}, True, config.period_s)
        self.qpos = QposRecorder(self.physics.model, self.physics.data.qpos)  # /sim/qpos: drawing it again
        self.watchers = []  # objects with ``on_state(rig, state)``, each period after the state (hil/watch/)
        self.stop_requested = False  # a watcher ends the run early (the viewer's window closed)
        self.deadline_misses = 0
        self.controller_died = False  # the in-process controller raised (see service_controller)
        self.tick = 0
        self._pending = sorted(scenario.timeline, key=lambda a: a.t_s)  # actions not yet applied
        # What is built now (the MuJoCo model, the codecs and DBC databases, the devices, the
        # modules) lives the whole run: frozen, the cyclic collector stops walking it at every
        # older-generation collection (-2.6 % instructions a balance tick). ``close`` unfreezes,
        # so that a process that runs many rigs (the test suite) still frees each one.
        gc.freeze()

    # -- metadata ------------------------------------------------------------
    def _metadata(self) -> dict:
        cfg = self.config
        return {"run": run_record(scenario=self.scenario.name, seed=cfg.seed, control_period_s=cfg.period_s,
                                  physics_dt_s=cfg.physics_dt_s, duration_s=self.scenario.duration_s,
                                  interface=cfg.interface, channels=self.names,
                                  plant_overrides=cfg.plant.overrides_dict(), epoch_ns=cfg.epoch_ns,
                                  robot=self.robot.name),
                "program": self._program_record()}

    def _program_record(self) -> dict:
        """Which program ran and how its ticks are seen: its heartbeats (lockstep), its loop's
        tick log (in-process real time) or only its frames on the bus (another process in real time)."""
        cfg = self.config
        judged_by = "bus" if cfg.realtime and not cfg.in_process_controller else \
            "tick_log" if cfg.realtime else "heartbeat"
        if not cfg.in_process_controller and cfg.program.kind != COMMAND:  # --external-controller
            return {"kind": "external", "program": "another process on the buses", "judged_by": judged_by}
        return cfg.program.record(judged_by, self.process.argv if self.process is not None else None)

    def _attachments(self) -> list:
        dbcs = {p.name: p for p in (*all_dbc_files(), *self.robot.dbc_paths())}  # the rig's and its robot's
        files = [(name, p.read_bytes(), "text/x-dbc") for name, p in dbcs.items()]
        files += [(p.name, p.read_bytes(), "application/xml") for p in self.robot.model_files()]
        return files

    # -- the steps a schedule takes --------------------------------------------
    def send_sync(self, tick: int, t_s: float) -> None:
        """SYNC(``tick``) on both buses: the controller's turn."""
        data = _SYNC_CODEC.encode_raw({"Tick": tick})
        for bus in self.plant_buses.values():
            # python-can's parameters by position (timestamp, arbitration_id, is_extended_id,
            # is_remote_frame, is_error_frame, channel, dlc, data): a third cheaper than by keyword
            bus.send(can.Message(t_s, _SYNC_ID, False, False, False, None, None, data))
        self.tick = tick

    def repeat_sync(self, tick: int, t_s: float) -> None:
        """SYNC(``tick``) again on both buses, past the record (straight onto the transport): for a
        program still starting when the recorded one went out (``Lockstep.await_contact``). Its
        answer is recorded as if to the first: the log is the one the program would have made
        had it been listening."""
        data = _SYNC_CODEC.encode_raw({"Tick": tick})
        for bus in self._raw.values():
            bus.send(can.Message(t_s, _SYNC_ID, False, False, False, None, None, data))

    def serve_plant(self, t_s: float) -> None:
        """Every device node handles what is on its bus by ``t_s``."""
        for node in self.plant.nodes.values():
            node.service(t_s)

    def deadline_miss(self, tick: int) -> None:
        self.deadline_misses += 1
        self.trace.event(self.clock.now_ns, "deadline_miss", tick=tick)

    def record_state(self) -> None:
        """The physics' ground truth at the clock's time."""
        now_ns = self.clock.now_ns
        state = self.physics.ground_truth()
        self.trace.sim_state(now_ns, state)
        self.qpos.maybe(self.trace, now_ns)
        for watcher in self.watchers:
            watcher.on_state(self, state)

    def service_controller(self) -> None:
        """Give the in-process controller its turn; an exception kills it, as it would the robot's program.

        The exception is an event (``controller_exception``) and the rig goes on
        without a controller: no more heartbeats (deadline misses), and the
        devices keep what they were last told, as on the robot.
        """
        if self.controller is None or self.controller_died:
            return
        try:
            self.controller.service()
        except Exception as exc:  # noqa: BLE001 - recorded, never hidden
            self.controller_died = True
            self.trace.event(self.clock.now_ns, "controller_exception", tick=self.tick,
                             error=f"{type(exc).__name__}: {exc}")

    def housekeeping_pending(self) -> bool:
        """Whether the record has work ``housekeeping`` would do."""
        return self.recorder.pending() or self.trace.housekeeping_pending()

    def housekeeping(self) -> bool:
        """One piece of the record's work that real time does in the slack between steps:
        the trace's own (``TraceWriter.housekeeping``: a finished window, a due chunk close),
        else the oldest slice of the frames noted (``Recorder.slice_size``: ``SETTLE_SLICE`` in
        real time; the wire model, the log lines, the trace's windows). The trace's first: the
        recorder has new frames after every step and would starve them until a close forced by
        size; slices: a settle of everything after a hiccup was a lump of its own. True if there
        was one."""
        if self.trace.housekeeping():
            return True
        if self.recorder.pending():
            self.recorder.settle(self.recorder.slice_size)
            return True
        return False

    def record_debug(self) -> None:
        schema = self.robot.debug_schema
        if self.controller is None or not self.config.record_debug or schema is None:
            return
        result = self.controller.last_result
        if result is not None and result.debug:
            schema = getattr(self.controller.controller, "debug_schema", schema)  # a library names its own
            self.trace.numbers("/controller/debug", self.clock.now_ns, result.debug, schema)  # float64 each

    # -- scenario actions ------------------------------------------------------
    def apply_actions(self, t_s: float) -> None:
        """The scenario's actions due by ``t_s``, each an event at the clock's time; first,
        ``ProgramExited`` if a command program has ended."""
        self.check_program()
        if self.progress is not None:
            self.progress(t_s)
        pending = self._pending
        while pending and pending[0].t_s <= t_s + 1e-9:
            action = pending.pop(0)
            fields = action.fn(self) or {}
            self.trace.event(self.clock.now_ns, action.kind, **fields)

    # -- a command program's process --------------------------------------------
    def check_program(self) -> None:
        """``ProgramExited`` (after a ``program_exit`` event: status, output tail) if the program's process ended."""
        if self.process is None or self.process.exited() is None:
            return
        exc = ProgramExited(self.process.exited(), self.process.tail(), self.clock.now_ns / 1e9)
        self.trace.event(self.clock.now_ns, "program_exit", status=exc.status, output_tail=exc.tail)
        raise exc

    def _start_program(self) -> None:
        """Start a command program; in real time, wait for its first frame before the clock starts
        (its start-up is not the plant's time), ``NoController`` after ``process.START_S`` without one."""
        if self.process is None:
            return
        self.process.start()
        if not self.config.realtime:  # lockstep: the first frames wait until it has its buses open;
            self.process.await_sockets(len(self._raw), program_process.START_S)  # late, SYNC(0) is repeated
            return
        end = time.monotonic() + program_process.START_S
        while time.monotonic() < end:
            self.check_program()
            if any(bus.recv(timeout=0.01) is not None for bus in self._raw.values()):
                for bus in self._raw.values():  # what it sent before the run is not the run's
                    while bus.recv(timeout=0.0) is not None:
                        pass
                return
        raise NoController(f"the program sent nothing in {program_process.START_S:g} s on {'/'.join(self.names.values())}"
                           + self.program_output())

    def program_output(self) -> str:
        """'; its output ends: ...' from a command program's output file, or ''."""
        tail = tail_line(self.process.tail()) if self.process is not None else ""
        return f"; its output ends: {tail}" if tail else ""

    def run(self) -> RunOutcome:
        ticks = round(self.scenario.duration_s / self.config.period_s)
        wall0 = time.perf_counter()
        try:
            self._start_program()
            report = self.schedule.run(self, ticks)
        except ProgramExited:  # recorded by check_program; the checks judge the run it left
            report, ticks = None, round(self.clock.now_ns / 1e9 / self.config.period_s)
        finally:
            if self.process is not None:
                self.process.stop()
            self.close()
        wall_s = time.perf_counter() - wall0
        if report is None:  # lockstep
            if self.stop_requested:  # ended early by a watcher: the ticks run
                ticks = self.tick + 1
            return RunOutcome(self.trace_path, self.log_path, ticks, self.deadline_misses, wall_s,
                              ticks * self.config.period_s)
        ticks, sim_s, wall_s, timing = report
        misses = timing.get("controller", {}).get("missed_deadlines", 0)
        return RunOutcome(self.trace_path, self.log_path, ticks, misses, wall_s, sim_s, timing)

    def close(self) -> None:
        gc.unfreeze()  # frozen in __init__: this rig's objects may be collected again
        if self.controller is not None:
            for bus in self.controller.buses.values():
                bus.shutdown()
        for bus in self._raw.values():
            bus.shutdown()
        self.recorder.stop()
