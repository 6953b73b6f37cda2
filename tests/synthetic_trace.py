"""Hand-made recordings for the replay and inspect tests: no emulators, no MuJoCo.

``SyntheticRig`` plays the plant's part with scripted device frames around a
real ``ControllerNode`` in sync mode and records both buses the way the rig
does (``wheelleg.hil.bus.recorder.Recorder``: the wire's order and time, MCAP + candump log). ``robot_log``
writes what a candump on the robot would show: a free-running ``Controller``
(no SYNC), ticks on a jittered clock, the log's timestamps as its clock (ns
since the first frame, microsecond resolution) -- the convention replay uses.

Device frame rates: C620 feedback 1 kHz per wheel (reporting the current it was
last told, as a healthy ESC: the controller faults one that does not), IMU 500 Hz
(three frames), remote 50 Hz, one CyberGear reply per command, SYNC and
heartbeat 500 Hz.
"""
from __future__ import annotations

import math
from pathlib import Path

import can

from wheelleg import dbc
from wheelleg.controller import constants as C
from wheelleg.controller import messages
from wheelleg.controller import params as P
from wheelleg.controller.node import Controller, ControllerNode
from wheelleg.dbc import cybergear as cg
from wheelleg.dbc import truncating_raw
from wheelleg.hil.record.candump import CandumpWriter
from wheelleg.hil.bus.plant_bus import SimClock
from wheelleg.hil.bus.recorder import Recorder
from wheelleg.hil.record.frame import Frame
from wheelleg.hil.record.run_metadata import run_record
from wheelleg.hil.analyze.replay import MemoryBus
from wheelleg.hil.record.trace import TraceWriter

DB1, DB2 = dbc.load_bus("can1"), dbc.load_bus("can2")
PERIOD = P.CONTROL_PERIOD
_ESC_CMD = DB1.get_message_by_name("C620_Cmd_1_4")
REMOTE_EVERY = 10  # ticks: 50 Hz at 2 ms
# standing pose: shaft angles (rad) that give a leg length of about 0.15 m on both legs
POSE = {1: 0.3, 2: -0.3, 3: -0.3, 4: 0.3}


def _std(name: str, **values) -> can.Message:
    message = DB1.get_message_by_name(name)
    full = {s.name: values.get(s.name, 0) for s in message.signals}
    return can.Message(arbitration_id=message.frame_id, data=message.encode(full, strict=False),
                       is_extended_id=False, check=False)


class Devices:
    """Scripted device frames: a robot standing still with a slow pitch sway."""

    def __init__(self, operator_mode: int = 1, remote_silent_after: int | None = None,
                 fault_at: int | None = None):
        self.operator_mode = operator_mode
        self.remote_silent_after = remote_silent_after
        self.fault_at = fault_at  # tick from which motor 3 reports over-temperature
        self._feedback = DB2.get_message_by_name("CG_Feedback")
        self.currents = {w.esc_id: 0.0 for w in C.WHEELS}  # A each C620 was last told (and reports)

    def command(self, msg: can.Message) -> None:
        """A C620 takes its slot of the controller's 0x200 frame (and reports that current, as a healthy one)."""
        if msg.arbitration_id == _ESC_CMD.frame_id and not msg.is_extended_id:
            values = _ESC_CMD.decode(bytes(msg.data))
            self.currents = {esc: values[f"ESC{esc}_Current"] for esc in self.currents}

    def pitch(self, t_s: float) -> float:
        return 0.02 * math.sin(2 * math.pi * 1.5 * t_s)  # rad

    def wheels(self, t_s: float) -> list[can.Message]:
        return [_std(f"C620_Feedback_{w.esc_id}", RotorAngle=(37.0 * t_s * 360) % 359,
                     RotorSpeed=round(120 * math.sin(3 * t_s)), TorqueCurrent=self.currents[w.esc_id],
                     MotorTemp=35)
                for w in C.WHEELS]

    def imu(self, t_s: float) -> list[can.Message]:
        half = self.pitch(t_s) / 2
        return [_std("IMU_Orientation", QuatW=min(math.cos(half), 32767 / 32768), QuatX=0.0, QuatY=math.sin(half), QuatZ=0.0),
                _std("IMU_Gyro", RateX=0.0, RateY=0.02 * 3 * math.pi * math.cos(3 * math.pi * t_s), RateZ=0.0),
                _std("IMU_Accel", AccX=0.1, AccY=0.0, AccZ=9.81)]

    def remote(self, tick: int) -> list[can.Message]:
        if tick % REMOTE_EVERY or (self.remote_silent_after is not None and tick > self.remote_silent_after):
            return []
        return [_std("Operator", Mode=self.operator_mode, LegLength=0.17)]

    def joint_reply(self, command: can.Message, tick: int, t_s: float) -> list[can.Message]:
        """A CyberGear answers each command addressed to it with type-2 feedback."""
        if not command.is_extended_id or cg.comm_type(command.arbitration_id) == cg.T_FEEDBACK:
            return []
        motor = cg.target(command.arbitration_id)
        if motor not in POSE:
            return []
        faults = {"FaultOverTemp"} if self.fault_at is not None and tick >= self.fault_at and motor == 3 else ()
        values = {"Pos": POSE[motor] + 0.01 * math.sin(t_s + motor), "Vel": 0.01 * math.cos(t_s + motor),
                  "Torque": 0.2, "Temp": 30.0}
        raw = {s.name: truncating_raw(s, values[s.name]) if s.name != "Temp" else 300
               for s in self._feedback.signals}
        return [can.Message(arbitration_id=cg.reply_id(cg.T_FEEDBACK, motor, C.CG_HOST_ID, 2, faults),
                            data=self._feedback.encode(raw, scaling=False), is_extended_id=True, check=False)]


def run_metadata(channels=("vcan0", "vcan1"), **extra) -> dict:
    run = run_record(scenario="synthetic", seed=0, control_period_s=PERIOD, duration_s=0,
                     channels={"can1": channels[0], "can2": channels[1]})
    run.update(extra)
    return {"run": run}


def attachments() -> list:
    files = [(p.name, p.read_bytes(), "text/x-dbc") for p in dbc.all_dbc_files()]
    return files + [("robot.xml", b"<mujoco model='synthetic'/>", "application/xml")]


class SyntheticRig:
    """Scripted devices + a real sync-mode ControllerNode, recorded at the plant side."""

    def __init__(self, trace_path: Path | None, log_path: Path | None, devices: Devices | None = None,
                 channels=("vcan0", "vcan1"), metadata: dict | None = None, events: dict | None = None,
                 trace: TraceWriter | None = None):
        self.names = {"can1": channels[0], "can2": channels[1]}
        self.devices = devices or Devices()
        self.trace = trace
        if trace_path is not None:
            self.trace = TraceWriter(trace_path, metadata=metadata or run_metadata(channels),
                                     attachments=attachments(),
                                     dbs={channels[0]: DB1, channels[1]: DB2}, flush_interval_s=None)
        self.log = CandumpWriter(log_path, flush_interval_s=None) if log_path is not None else None
        self.clock = SimClock()
        self.recorder = Recorder([s for s in (self.trace, self.log) if s is not None], self.clock,
                                 list(self.names.values()), load_to=self.trace)
        self.buses = {"can1": MemoryBus("can1"), "can2": MemoryBus("can2")}
        self.node = ControllerNode(self.buses["can1"], self.buses["can2"], sync=True, period_s=PERIOD)
        self.events = events or {}  # tick -> (kind, fields)
        self.modes: list[int] = []  # controller mode per tick
        self.sent: list[dict] = []  # per tick: bus -> frames the controller sent

    def _put(self, bus: str, msg: can.Message, answers=None) -> None:
        self.recorder.sent(self.names[bus], msg, answers)
        self.buses[bus].inbox.append(msg)

    def step(self, tick: int) -> None:
        d, t = self.devices, tick * PERIOD
        self.clock.set_s(t)
        if tick in self.events and self.trace is not None:
            kind, fields = self.events[tick]
            self.trace.event(self.clock.now_ns, kind, **fields)
        for msg in d.wheels(t) + d.imu(t) + d.remote(tick):
            self._put("can1", msg)
        sync = _std("SYNC", Tick=tick)
        self._put("can1", sync)
        self._put("can2", sync)
        assert self.node.service(), f"the controller did not tick on SYNC({tick})"
        self.modes.append(int(self.node.last_result.mode))
        sent = {bus: self.buses[bus].take_sent() for bus in ("can1", "can2")}
        self.sent.append(sent)
        for msg in sent["can1"]:
            self.recorder.received(self.names["can1"], msg)
            d.command(msg)
        for msg in sent["can2"]:
            command = self.recorder.received(self.names["can2"], msg)
            for reply in d.joint_reply(msg, tick, t):
                self._put("can2", reply, command)
        if self.trace is not None:
            self.trace.sim_state(self.clock.now_ns, _truth(d.pitch(t)))
        self.clock.set_s(t + PERIOD / 2)
        for msg in d.wheels(t + PERIOD / 2):  # the C620s' second feedback of the period (1 kHz)
            self._put("can1", msg)

    def run(self, ticks: int) -> "SyntheticRig":
        for tick in range(ticks):
            self.step(tick)
        self.recorder.stop()  # the frames still on the wire model, then the trace and log closed
        for bus in self.buses.values():
            bus.shutdown()
        return self


def _truth(pitch: float) -> dict:
    from wheelleg.hil.record import schemas
    state = {k: 0.0 for k in schemas.SIM_STATE_FIELDS if k != "t"}
    state["pitch"] = pitch
    return state


def robot_log(path: Path, ticks: int, channels=("can0", "can1"), devices: Devices | None = None,
              t0_us: int = 1_700_000_000_000_000, first_tick: int = 0) -> list[int]:
    """A candump log of a free-running controller (no SYNC); returns the modes per tick.

    Tick k starts at t0 + k * period + a jitter of up to 137 us; inputs land
    in the log before the tick that reads them, replies right after each command,
    and a wheel and a joint frame between the tick's CAN1 and CAN2 frames
    (the controller reads them next tick).
    """
    d = devices or Devices()
    controller = Controller(PERIOD)
    names = {"can1": channels[0], "can2": channels[1]}
    rows: list[tuple[int, str, can.Message]] = []  # (t in us, bus, frame) in log order
    period_us = round(PERIOD * 1e6)
    start_us = t0_us - 700  # the log's first frame comes before the first tick

    def received(t_us: int, bus: str, msg: can.Message) -> None:
        rows.append((t_us, bus, msg))
        controller.on_frame(msg, bus, (t_us - start_us) / 1e6)

    modes = []
    for k in range(ticks):
        tick_us = t0_us + k * period_us + (k * 7919) % 137
        t = (tick_us - t0_us) / 1e6
        for msg in d.wheels(t):
            received(tick_us - 700 if k else start_us, "can1", msg)
        for i, msg in enumerate(d.imu(t) + d.wheels(t + 0.0005) + d.remote(k)):
            received(tick_us - 300 + i, "can1", msg)
        result = controller.tick(first_tick + k, (tick_us - start_us) / 1e6)
        modes.append(int(result.mode))
        t_us = tick_us
        for msg in result.frames["can1"]:
            rows.append((t_us, "can1", msg))
            d.command(msg)
            t_us += 1
        # frames that land while the controller is still sending: it reads them next tick
        received(t_us, "can1", d.wheels(t + 0.0002)[0])
        received(t_us, "can2", d.joint_reply(messages.joint_stop(1), k, t + 0.0002)[0])
        for msg in result.frames["can2"]:
            rows.append((t_us, "can2", msg))
            t_us += 1
            for reply in d.joint_reply(msg, k, t):
                t_us += 1
                received(t_us, "can2", reply)
    with CandumpWriter(path, flush_interval_s=None) as log:
        for t_us, bus, msg in rows:
            log.write(Frame.of(msg, names[bus], t_us * 1000))
    return modes
