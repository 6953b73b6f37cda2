"""The rig: plant, controller and recorder on two CAN buses, in lockstep.

Lockstep (docs/design.md): each control period the rig sends SYNC(T) on both
buses after the period's feedback; the controller runs one tick per SYNC and
ends it with a heartbeat on both buses; the plant handles the commands that
came before the heartbeats (they are in bus order) and only then steps the
physics. A heartbeat that does not come within ``deadline_s`` of wall time is
a deadline miss: reported in the trace and the summary, never waited on.

With the in-process controller (the default, on python-can's virtual bus)
the rig hands the controller the turn itself instead of sleeping: the same
frames in the same order, just no thread switches. Over a real transport
(SocketCAN) the plant holds each bus's frames until both heartbeats are in
and then takes them in the virtual bus's order (hil/bus/held_bus.py): the same
bytes in the recording on every transport.

``RigConfig(realtime=True)`` is not lockstep: hil/run/realtime.py.
"""
from __future__ import annotations

import json
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path

import can
import numpy as np

from wheelleg.controller import params as P
from wheelleg.controller.node import ControllerNode
from wheelleg.dbc import CAN1, CAN2, all_dbc_files, load_bus
from wheelleg.emulators.physics import MODEL_DIR, Physics
from wheelleg.emulators.plant import Plant, PlantConfig
from wheelleg.hil.record.candump import CandumpWriter
from wheelleg.hil.bus.held_bus import HeldBus
from wheelleg.hil.bus.recorder import Recorder, RecordingBus
from wheelleg.hil.run.scenario import Scenario
from wheelleg.hil.record.trace import TraceWriter
from wheelleg.hil.bus.transport import open_bus

_RIG_DB = load_bus(CAN1)
_SYNC = _RIG_DB.get_message_by_name("SYNC")
_HEARTBEAT = _RIG_DB.get_message_by_name("Heartbeat")

@dataclass
class RigConfig:
    """How to run: transport, channels (CAN1 = wheels, CAN2 = joints), seed, timing."""

    interface: str = "virtual"
    channels: tuple = ("vcan0", "vcan1")
    seed: int = 0
    period_s: float = P.CONTROL_PERIOD
    physics_dt_s: float = 0.001
    in_process_controller: bool = True  # False: an external `wheelleg controller` answers
    deadline_s: float = 0.5  # wall-clock bound for the heartbeats of one tick
    realtime: bool = False  # plant at wall-clock pace, controller on its own timer (hil/run/realtime.py)
    record_debug: bool = True  # the in-process controller's internals on /controller/debug
    decode: bool = True  # also write /decoded/ channels (raw frames are always recorded)
    plant: PlantConfig = field(default_factory=PlantConfig)

@dataclass
class RunOutcome:
    trace_path: Path
    log_path: Path
    ticks: int
    deadline_misses: int
    wall_s: float
    sim_s: float
    timing: dict | None = None  # real-time mode: {"controller": ..., "plant": ...} (hil/run/loop_timing.py)

def git_revision() -> str:
    try:
        out = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                             cwd=Path(__file__).parent, timeout=5)
        return out.stdout.strip() or "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"

def _open_bus(config: RigConfig, channel: str) -> can.BusABC:
    return open_bus(config.interface, channel)

class Rig:
    """One scenario run: build everything, step it, record it."""

    def __init__(self, scenario: Scenario, config: RigConfig, out_dir: Path):
        self.scenario, self.config = scenario, config
        out_dir.mkdir(parents=True, exist_ok=True)
        self.trace_path = out_dir / f"{scenario.name}.mcap"
        self.log_path = out_dir / f"{scenario.name}.log"
        self.names = {CAN1: config.channels[0], CAN2: config.channels[1]}
        self.rng = np.random.default_rng(config.seed)
        self.physics = Physics(terrain=scenario.terrain, timestep_s=config.physics_dt_s,
                               overrides=config.plant.overrides)
        scenario.start(self.physics)
        # the buses first: a missing vcan fails before any file is written
        self._raw = {k: _open_bus(config, ch) for k, ch in self.names.items()}
        attachments = self._attachments()
        if config.plant.overrides_dict():  # the model this run compiled; its overrides are in the metadata
            attachments.append(("plant_model.xml", self.physics.spec.to_xml().encode(), "application/xml"))
        self.trace = TraceWriter(self.trace_path, metadata=self._metadata(),
                                 attachments=attachments,
                                 dbs={self.names[CAN1]: load_bus(CAN1), self.names[CAN2]: load_bus(CAN2)},
                                 decode=config.decode)
        self.log = CandumpWriter(self.log_path)
        self.recorder = Recorder(self.trace, self.log)
        # Real transports deliver each socket's frames at their own pace: hold them
        # until both heartbeats are in, then serve them in the virtual bus's order.
        lockstep_real = config.interface != "virtual" and not config.realtime
        self._held = {k: HeldBus(b) for k, b in self._raw.items()} if lockstep_real else {}
        self.plant_buses = {k: RecordingBus(self._held.get(k, b), self.names[k], self.recorder, self._watch)
                            for k, b in self._raw.items()}
        self.plant = Plant(self.physics, self.plant_buses, self.rng, config.plant)
        self.controller = None
        if config.in_process_controller and not config.realtime:  # real time: hil/run/realtime.py
            self.controller = ControllerNode(_open_bus(config, self.names[CAN1]),
                                             _open_bus(config, self.names[CAN2]),
                                             sync=True, period_s=config.period_s)
        self._heartbeat_seen = {CAN1: -1, CAN2: -1}
        self.deadline_misses = 0
        self.controller_died = False  # the in-process controller raised (see _service_controller)
        self.tick = 0

    # -- metadata ------------------------------------------------------------
    def _metadata(self) -> dict:
        params = {k: v for k, v in vars(P).items() if k.isupper()}
        return {"run": {"scenario": self.scenario.name, "seed": str(self.config.seed),
                        "control_period_s": repr(self.config.period_s),
                        "physics_dt_s": repr(self.config.physics_dt_s),
                        "duration_s": repr(self.scenario.duration_s),
                        "interface": self.config.interface, "can1": self.names[CAN1],
                        "can2": self.names[CAN2], "git_revision": git_revision(),
                        "controller_params": json.dumps(params, sort_keys=True, default=repr),
                        "plant_overrides": json.dumps(self.config.plant.overrides_dict(), sort_keys=True)}}

    @staticmethod
    def _attachments() -> list:
        files = [(p.name, p.read_bytes(), "text/x-dbc") for p in all_dbc_files()]
        files += [(p.name, p.read_bytes(), "application/xml") for p in sorted(MODEL_DIR.glob("*.xml"))]
        return files

    # -- lockstep ------------------------------------------------------------
    def _watch(self, channel: str, msg: can.Message) -> bool:
        self._note_heartbeat(CAN1 if channel == self.names[CAN1] else CAN2, msg)
        return True

    def _note_heartbeat(self, bus: str, msg: can.Message) -> None:
        if msg.arbitration_id == _HEARTBEAT.frame_id and not msg.is_extended_id and msg.dlc == 8:
            try:
                self._heartbeat_seen[bus] = _HEARTBEAT.decode(bytes(msg.data))["Tick"]
            except Exception:
                pass  # a malformed heartbeat counts as none: the deadline catches it

    def _send_sync(self, tick: int, t_s: float) -> None:
        data = _SYNC.encode({"Tick": tick})
        for bus in self.plant_buses.values():
            bus.send(can.Message(arbitration_id=_SYNC.frame_id, data=data, is_extended_id=False,
                                 timestamp=t_s, check=False))

    def _serve_plant(self, t_s: float) -> None:
        for node in self.plant.nodes.values():
            node.service(t_s)

    def _await_heartbeats(self, tick: int, t_s: float) -> bool:
        if not self._held:
            return self._await_heartbeats_virtual(tick, t_s)
        deadline = time.monotonic() + self.config.deadline_s
        while True:
            for bus, held in self._held.items():
                for msg in held.gather():
                    self._note_heartbeat(bus, msg)
            done = all(seen == tick for seen in self._heartbeat_seen.values())
            if done or time.monotonic() > deadline:
                break
            if self.controller is not None:
                self._service_controller()  # its SYNC may have been in flight
            time.sleep(0.00005)
        self._serve_plant(t_s)  # CAN1's held frames, then CAN2's: the virtual bus's order
        return done

    def _await_heartbeats_virtual(self, tick: int, t_s: float) -> bool:
        deadline = time.monotonic() + self.config.deadline_s
        while True:
            self._serve_plant(t_s)
            if all(seen == tick for seen in self._heartbeat_seen.values()):
                return True
            if self.controller is not None or time.monotonic() > deadline:
                return False
            time.sleep(0.00005)

    def step_tick(self) -> None:
        cfg = self.config
        tick, t_s = self.tick, self.tick * cfg.period_s
        self.recorder.now_ns = round(t_s * 1e9)
        self._apply_actions(t_s)
        self._send_sync(tick, t_s)
        if self.controller is not None:
            self._service_controller()
        if not self._await_heartbeats(tick, t_s):
            self.deadline_misses += 1
            self.trace.event(self.recorder.now_ns, "deadline_miss", tick=tick)
        self._record_debug()
        substeps = round(cfg.period_s / cfg.physics_dt_s)
        for k in range(substeps):
            now = t_s + k * cfg.physics_dt_s
            self.plant.step(now)
            self.recorder.now_ns = round((now + cfg.physics_dt_s) * 1e9)
            self._serve_plant(now + cfg.physics_dt_s)
        self.trace.sim_state(self.recorder.now_ns, self.physics.ground_truth())
        self.tick += 1

    def _service_controller(self) -> None:
        """Give the in-process controller its turn; an exception kills it, as it would the robot's program.

        The exception is an event (``controller_exception``) and the rig goes on
        without a controller: no more heartbeats (deadline misses), and the
        devices keep what they were last told, as on the robot.
        """
        if self.controller_died:
            return
        try:
            self.controller.service()
        except Exception as exc:  # noqa: BLE001 - recorded, never hidden
            self.controller_died = True
            self.trace.event(self.recorder.now_ns, "controller_exception", tick=self.tick,
                             error=f"{type(exc).__name__}: {exc}")

    def _record_debug(self) -> None:
        if self.controller is None or not self.config.record_debug:
            return
        result = self.controller.last_result
        if result is not None and result.debug:
            self.trace.message("/controller/debug", self.recorder.now_ns, result.debug, "ControllerDebug")

    # -- scenario actions ------------------------------------------------------
    _pending: list | None = None

    def _apply_actions(self, t_s: float) -> None:
        if self._pending is None:
            self._pending = sorted(self.scenario.timeline, key=lambda a: a.t_s)
        while self._pending and self._pending[0].t_s <= t_s + 1e-9:
            action = self._pending.pop(0)
            fields = action.fn(self) or {}
            self.trace.event(self.recorder.now_ns, action.kind, **fields)

    def run(self) -> RunOutcome:
        if self.config.realtime:
            return self._run_realtime()
        ticks = round(self.scenario.duration_s / self.config.period_s)
        wall0 = time.perf_counter()
        try:
            for _ in range(ticks):
                self.step_tick()
        finally:
            self.close()
        return RunOutcome(self.trace_path, self.log_path, ticks, self.deadline_misses,
                          time.perf_counter() - wall0, ticks * self.config.period_s)

    def _run_realtime(self) -> RunOutcome:
        from wheelleg.hil.run.realtime import RealtimeRun

        try:
            ticks, sim_s, wall_s, timing = RealtimeRun(self).run()
        finally:
            self.close()
        misses = timing.get("controller", {}).get("missed_deadlines", 0)
        return RunOutcome(self.trace_path, self.log_path, ticks, misses, wall_s, sim_s, timing)

    def close(self) -> None:
        if self.controller is not None:
            for bus in self.controller.buses.values():
                bus.shutdown()
        for bus in self._raw.values():
            bus.shutdown()
        self.recorder.load.sample(self.recorder.now_ns, final=True)  # the run's last window
        self.trace.finish()
        self.log.close()
