"""The quadruped's controller as the robot runs it: frames in, one tick, frames out.

``QuadController`` is the program without I/O (``on_frame``, ``tick``,
``shutdown_frames``: the interface of ``controller.can_node.CanNode``);
``QuadrupedNode`` puts it on its two buses with the same clock as the
wheel-legged robot's node (SYNC lockstep or free-running), so the rig drives
both alike.

A tick: detect (every motor, the IMU and the remote heard in time, no motor
fault), the mode machine (modes.py), the mode's joint commands (passive
damping, getup.py, balance.py, gait.py), one MIT frame per motor on its bus,
and a heartbeat on both buses. The very first tick and every start from
passive send the CyberGear start sequence (stop and clear, MIT run mode,
enable) instead of commands.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from itertools import chain

import can
import numpy as np

from wheelleg.controller import detect, messages
from wheelleg.controller.attitude import euler_zyx
from wheelleg.controller.bounds import within
from wheelleg.controller.can_node import CanNode
from wheelleg.controller.quadruped import constants as C
from wheelleg.controller.quadruped import params as P
from wheelleg.controller.quadruped.balance import BalanceStand, Posture
from wheelleg.controller.quadruped.gait import Trot, Velocity
from wheelleg.controller.quadruped.getup import GetUp, has_fallen, is_upright
from wheelleg.controller.quadruped.legs import JointCommands
from wheelleg.controller.quadruped.modes import ENABLED, Inputs, Mode, latched_after, next_mode, requested_mode
from wheelleg.controller.quadruped.sensed import Sensed, height_over_feet
from wheelleg.controller.quadruped.state import BUS_OF_LEG, QuadBusState
from wheelleg.controller.quadruped.telemetry import debug_record
from wheelleg.dbc import CAN1, CAN2

MOTOR_NAMES = {C.motor_id(leg, j): f"{C.LEGS[leg]}_{C.JOINTS[j]}" for leg in range(4) for j in range(3)}
# offline thresholds: a motor answers every 4 ms command (5 periods, as agreed with the rig), the
# IMU sends at 500 Hz, the remote at ~50 Hz (as the wheel-legged robot's detect rules)
RULES = tuple([detect.DeviceRule(name, 0.020, 4, True) for name in MOTOR_NAMES.values()]
              + [detect.DeviceRule("imu", 0.010, 5, True), detect.DeviceRule("remote", 0.100, 2, True)])
IMU_BIT, REMOTE_BIT = 12, 13  # their bits in detect's mask (after the 12 motors)
# (leg, joint, motor id, bus) of every motor in the (4, 3) arrays' order, and the ids in that order: made once
MOTORS = tuple((leg, j, C.motor_id(leg, j), BUS_OF_LEG[leg]) for leg in range(4) for j in range(3))
MOTOR_ORDER = tuple(motor for _, _, motor, _ in MOTORS)


def heartbeat_mask(detect_mask: int) -> int:
    """The heartbeat's 8-bit OfflineMask: bit leg (0..3) for any of its motors, 4 the IMU, 5 the remote."""
    mask = 0
    for leg in range(4):
        if (detect_mask >> (3 * leg)) & 0b111:
            mask |= 1 << leg
    mask |= ((detect_mask >> IMU_BIT) & 1) << 4
    mask |= ((detect_mask >> REMOTE_BIT) & 1) << 5
    return mask


@dataclass
class QuadTickResult:
    """One tick: frames per bus (heartbeat last), the mode, detect's report, the debug record."""

    frames: dict = field(default_factory=lambda: {CAN1: [], CAN2: []})
    mode: Mode = Mode.PASSIVE
    report: detect.Report | None = None
    debug: dict = field(default_factory=dict)
    commands: JointCommands | None = None


def command_rows(commands: JointCommands) -> tuple:
    """The five command arrays (q, qd, kp, kd, tau) as flat lists of Python floats in MOTOR_ORDER
    (``tolist`` gives each float64's exact value: cheaper to read than numpy scalars one at a time)."""
    return (commands.q.ravel().tolist(), commands.qd.ravel().tolist(), commands.kp.ravel().tolist(),
            commands.kd.ravel().tolist(), commands.tau.ravel().tolist())


class QuadController:
    """The quadruped's program without I/O."""

    def __init__(self, period_s: float = P.CONTROL_PERIOD, record_debug: bool = True):
        self.period_s = period_s
        self.record_debug = record_debug
        self.bus = QuadBusState()
        self.mode = Mode.PASSIVE
        self.latched = False
        self.started = False  # the motors have had their start sequence
        self.entry_pending = False  # the start sequence took the tick a mode was entered on
        self.getup = GetUp(period_s)
        self.balance = BalanceStand(period_s)
        self.trot = Trot(period_s)

    def on_frame(self, msg: can.Message, bus: str, now_s: float) -> int | None:
        """Take one received frame; returns the SYNC tick counter if it is a SYNC."""
        return self.bus.update(msg, bus, now_s)

    def prepare(self) -> None:
        """What the first frames would build (their layouts), built now: before a free-running loop."""
        self.bus.prepare()

    def last_seen(self) -> dict[str, float]:
        seen = {MOTOR_NAMES[i]: fb.received_s for i, fb in self.bus.motors.items()}
        seen["imu"] = self.bus.imu.received_s
        seen["remote"] = self.bus.operator.received_s
        return seen

    def sensed(self) -> Sensed:
        """Joint feedback as (4, 3) arrays and the IMU's attitude and rates."""
        feedback = [self.bus.motors[motor] for motor in MOTOR_ORDER]
        def array(values: list) -> np.ndarray:  # the 12 values in MOTOR_ORDER as (4, 3)
            return np.array(values, dtype=float).reshape(4, 3)
        return Sensed(array([fb.position for fb in feedback]), array([fb.speed for fb in feedback]),
                      array([fb.torque for fb in feedback]), np.array(euler_zyx(self.bus.imu.quat)),
                      np.array(self.bus.imu.gyro, dtype=float))

    def tick(self, tick: int, now_s: float) -> QuadTickResult:
        faulted = {MOTOR_NAMES[i] for i, fb in self.bus.motors.items() if fb.faults}
        report = detect.check(self.last_seen(), now_s, faulted, RULES)
        sensed = self.sensed()
        op = self.bus.operator
        inputs = Inputs(request=requested_mode(op.mode), estop=op.estop, devices_ok=report.balance_ok,
                        armed=not self.latched, upright=is_upright(sensed.rpy), fallen=has_fallen(sensed.rpy),
                        motion_done=self.getup.done, gait_settled=self.trot.settled)
        previous, self.mode = self.mode, next_mode(self.mode, inputs)
        self.latched = latched_after(self.latched, previous, self.mode, inputs)
        result = QuadTickResult(mode=self.mode, report=report)
        if not self.started or (self.mode in ENABLED and previous not in ENABLED):
            self._start_motors(result, now_s)
        else:
            result.commands = self._commands(previous, sensed)
            rows = command_rows(result.commands)
            if not all(map(math.isfinite, chain.from_iterable(rows))):
                result.commands = JointCommands.damped(P.PASSIVE_KD)  # a fault of the controller's own
                rows = command_rows(result.commands)
            self._send_commands(result, rows, now_s)
        if self.record_debug:
            result.debug = debug_record(self._summary(sensed))
        hb = messages.heartbeat(
            tick, int(self.mode), report.warning_level, heartbeat_mask(report.offline_mask), report.offline_count,
            motors_enabled=self.mode in ENABLED, off_ground=False, fallen=has_fallen(sensed.rpy),
            fault_latched=self.latched, bad_frames=self.bus.bad_frames, t_s=now_s)
        result.frames[CAN1].append(hb)
        result.frames[CAN2].append(hb)
        return result

    def _start_motors(self, result: QuadTickResult, now_s: float) -> None:
        """The CyberGear start sequence to every motor: stop and clear faults, MIT run mode, enable."""
        for leg in range(4):
            for j in range(3):
                motor = C.motor_id(leg, j)
                result.frames[BUS_OF_LEG[leg]] += [messages.joint_stop(motor, clear_fault=True, t_s=now_s),
                                                   messages.joint_run_mode(motor, 0, t_s=now_s),
                                                   messages.joint_enable(motor, t_s=now_s)]
        self.started = True
        self.entry_pending = True  # the mode's first commands come next tick, from its start

    def _commands(self, previous: Mode, sensed: Sensed) -> JointCommands:
        """This tick's joint commands by mode; a mode just entered starts its motion from where the robot is."""
        op = self.bus.operator
        entered = self.mode != previous or self.entry_pending
        self.entry_pending = False
        if self.mode == Mode.PASSIVE:
            self.getup.stop()
            return JointCommands.damped(P.PASSIVE_KD)
        if self.mode in (Mode.STAND_UP, Mode.RECOVERY_STAND):
            if entered:
                height = float(np.clip(op.height, *P.HEIGHT_RANGE))
                if self.mode == Mode.STAND_UP:
                    self.getup.start_stand_up(sensed.q, height)
                else:
                    self.getup.start_recovery(sensed, height)
            return self.getup.step(sensed)
        if self.mode == Mode.BALANCE_STAND:
            if entered:
                self.balance.start(sensed)
            return self.balance.step(sensed, Posture(op.roll, op.pitch, op.yaw, op.height))
        if entered:
            self.trot.start(sensed)
        stopping = requested_mode(op.mode) != Mode.LOCOMOTION  # finish the swing, then stand
        return self.trot.step(sensed, Velocity(op.vx, op.vy, op.yaw_rate), op.height, stopping)

    def _send_commands(self, result: QuadTickResult, rows: tuple, now_s: float) -> None:
        """One MIT frame per motor from ``command_rows``' (q, qd, kp, kd, tau) of each, tau within its limit."""
        frames, joint_mit, limit = result.frames, messages.joint_mit, C.TORQUE_LIMIT
        for (_, _, motor, bus), (q, qd, kp, kd, tau) in zip(MOTORS, zip(*rows)):
            # within: np.clip's comparisons in its order (a NaN never gets here: checked before)
            frames[bus].append(joint_mit(motor, q, qd, kp, kd, within(tau, -limit, limit), now_s))

    def _summary(self, sensed: Sensed) -> dict:
        balance, trot = self.balance, self.trot
        stance = int(sum(1 << leg for leg in range(4) if trot.was_stance[leg])) if self.mode == Mode.LOCOMOTION else 15
        return {"mode": int(self.mode), "getup_phase": int(self.getup.phase), "latched": int(self.latched),
                "roll": sensed.rpy[0], "pitch": sensed.rpy[1], "yaw": sensed.rpy[2], "height": height_over_feet(sensed.feet_level(), np.ones(4, dtype=bool)),
                "roll_ref": balance.setpoint[0], "pitch_ref": balance.setpoint[1], "yaw_ref": balance.setpoint[2],
                "height_ref": balance.setpoint[3], "vx": trot.velocity[0], "vy": trot.velocity[1],
                "vx_ref": trot.velocity_set[0], "vy_ref": trot.velocity_set[1], "yaw_rate_ref": trot.feet_yaw_rate,
                "gait_clock": trot.clock, "stance_mask": stance}

    def shutdown_frames(self, now_s: float) -> dict:
        """Frames that leave the robot safe when the program ends: every motor stopped."""
        frames = {CAN1: [], CAN2: []}
        for leg in range(4):
            for j in range(3):
                frames[BUS_OF_LEG[leg]].append(messages.joint_stop(C.motor_id(leg, j), t_s=now_s))
        return frames


class QuadrupedNode(CanNode):
    """The quadruped's controller on its two buses: CAN1 = bus 0 (front legs, IMU, remote), CAN2 = bus 1."""

    def __init__(self, bus0: can.BusABC, bus1: can.BusABC, *, sync: bool = True,
                 period_s: float = P.CONTROL_PERIOD, listener=None):
        super().__init__(bus0, bus1, QuadController(period_s), sync=sync, period_s=period_s, listener=listener)
