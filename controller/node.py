"""The controller as the robot runs it: frames in, one tick, frames out.

``Controller`` is the program without I/O: ``on_frame`` takes each received
frame, ``tick`` returns the frames to send (the rig's replay feeds it recorded
frames the same way). ``ControllerNode`` puts it on its two buses with the
clock of ``can_node.CanNode`` (SYNC lockstep or free-running).
Each tick ends with a heartbeat on both buses.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import can

from wheelleg.controller import constants as C
from wheelleg.controller import detect
from wheelleg.controller import messages
from wheelleg.controller import posture
from wheelleg.controller import support
from wheelleg.controller.can_node import CanNode
from wheelleg.controller import params as P
from wheelleg.controller.chassis import ChassisController, Command
from wheelleg.controller.legs import Attitude
from wheelleg.controller.jump import JumpSequencer, Phase
from wheelleg.controller.recovery import Phase as RecoveryPhase
from wheelleg.controller.recovery import RecoverySequencer
from wheelleg.controller.modes import ENABLED, Inputs, Mode, Switch, next_mode
from wheelleg.controller.state import CAN1, CAN2, BusState
from wheelleg.controller.telemetry import LastOutput, debug_record

_DEVICE_OF_JOINT = {j.motor_id: j.name for j in C.JOINTS}
_DEVICE_OF_WHEEL = {w.esc_id: w.name for w in C.WHEELS}
_SWITCH = {int(s): s for s in Switch}  # the operator's Mode number -> Switch (a dict: no Enum call a tick)
# the modes a tick asks about, as module names: in CPython 3.11 an Enum member's lookup on its
# class costs ~10 times a global's, and a tick made some 20 of them
_STAND_UP, _BALANCE, _MOVE, _JUMP, _AIRBORNE, _FALLEN = (Mode.STAND_UP, Mode.BALANCE, Mode.MOVE, Mode.JUMP,
                                                         Mode.AIRBORNE, Mode.FALLEN)
IN_THE_AIR = frozenset({Mode.JUMP, Mode.AIRBORNE})  # "fallen" judged with the wider limits
ON_THE_WHEELS = frozenset({Mode.BALANCE, Mode.MOVE})  # standing or driving: the trim runs, stance is sized
_ESTOP_SWITCH = Switch.ESTOP
_MOTOR_IDS = tuple(j.motor_id for j in C.JOINTS)  # the joints' torque frames go out in this order
_TORQUE_CONSTANT = C.M3508_TORQUE_CONSTANT  # N m/A at the wheel
_LEFT_Y, _RIGHT_Y = C.LEG_PLANE_Y, -C.LEG_PLANE_Y  # m, each leg's plane (posture.body_clearance's side_y)
_HALF_PI = math.pi / 2


@dataclass
class TickResult:
    """What one tick decided: frames per bus (heartbeat last) and a summary.

    ``debug`` is ``telemetry.debug_record`` of a run tick's output (empty on
    other ticks, or when the controller records no debug).
    """

    frames: dict = field(default_factory=lambda: {CAN1: [], CAN2: []})
    mode: Mode = Mode.IDLE
    report: detect.Report | None = None
    debug: dict = field(default_factory=dict)


class Controller:
    """The design document's chassis and detect tasks over CAN frames, without I/O.

    Around the mode machine (controller/modes.py): the jump and recovery phase
    tables (jump.py, recovery.py), the support-force off-ground estimate
    (support.py), the body-on-the-ground check (posture.py) and the C620 watch
    (detect.EscWatch).

    Between ticks it keeps its last run tick's output in ``last`` (typed,
    kept through disabled ticks); ``record_debug`` only chooses whether a
    tick's result carries the debug projection of it.
    """

    def __init__(self, period_s: float = P.CONTROL_PERIOD, record_debug: bool = True):
        self.period_s = period_s
        self.record_debug = record_debug
        self.bus = BusState()
        self.chassis = ChassisController(period_s)
        self.mode = Mode.IDLE
        self._last_buttons = (False, False, False)  # reenable, jump, jump forward
        self.last: LastOutput | None = None  # the last run tick's output, read by the next ticks
        self.support = {leg: support.SupportEstimator(period_s) for leg in ("left", "right")}
        self.fn = {"left": 0.0, "right": 0.0}  # N, this tick's support force estimates
        self.contact = support.ContactDebounce(period_s)
        self.jump = JumpSequencer(period_s)
        self.recovery = RecoverySequencer(period_s)
        self._recovery_limit = P.RECOVERY_FALL_PITCH  # rad from upright past which a recovery has fallen again
        self._jump_forward = False  # the jump asked for is JumpForward
        self.reenable = detect.ReenableRequest(P.REENABLE_WINDOW_S)
        self.esc_watch = {w.esc_id: detect.EscWatch(P.ESC_CURRENT_TOLERANCE_A, P.ESC_MISMATCH_S,
                                                    P.ESC_BACK_EMF_FRACTION, P.ESC_COMMAND_WINDOW)
                          for w in C.WHEELS}

    def on_frame(self, msg: can.Message, bus: str, now_s: float) -> int | None:
        """Take one received frame; returns the SYNC tick counter if it is a SYNC."""
        return self.bus.update(msg, bus, now_s)

    def prepare(self) -> None:
        """What the first frames would build (their layouts), built now: before a free-running loop."""
        self.bus.prepare()

    def last_seen(self) -> dict[str, float]:
        """Device name -> when it was last heard (s, controller clock): joints, wheels, imu, remote."""
        bus, seen = self.bus, {}
        for motor_id, fb in bus.joints.items():  # loops, not comprehensions: no frame each a tick
            seen[_DEVICE_OF_JOINT[motor_id]] = fb.received_s
        for esc_id, fb in bus.wheels.items():
            seen[_DEVICE_OF_WHEEL[esc_id]] = fb.received_s
        seen["imu"] = bus.imu.received_s
        seen["remote"] = bus.operator.received_s
        return seen

    def tick(self, tick: int, now_s: float) -> TickResult:
        sensed = self.chassis.observe(self.bus)  # the bus does not change within a tick
        faulted = self._faulted(now_s)
        report = detect.check(self.last_seen(), now_s, faulted)
        inputs = self._inputs(report.balance_ok, now_s, sensed.att if sensed is not None else None)
        previous, self.mode = self.mode, next_mode(self.mode, inputs)
        mode = self.mode
        enabled = mode in ENABLED
        if enabled:
            self.reenable.consume()
        result = TickResult(mode=mode, report=report)
        if mode == _JUMP and previous != _JUMP:
            self.jump.start(forward=self._jump_forward)
        elif previous == _AIRBORNE and mode == _BALANCE:
            self.chassis.touchdown(self.bus, keep_spot=True)
        if mode == _STAND_UP and previous != _STAND_UP and self._lying():
            self.recovery.start()
            self._recovery_limit = self._fallen_again_past()
        elif mode != _STAND_UP:
            self.recovery.stop()
        if enabled and previous not in ENABLED:
            self._enable(result, now_s)
        elif enabled:
            self._run(result, now_s, sensed)
        else:
            self._disabled(result, now_s)
        hb = messages.heartbeat(
            tick, int(mode), report.warning_level, report.offline_mask, report.offline_count,
            motors_enabled=enabled, off_ground=mode == _AIRBORNE,
            fallen=mode == _FALLEN, fault_latched=bool(faulted), bad_frames=self.bus.bad_frames,
            t_s=now_s)
        result.frames[CAN1].append(hb)
        result.frames[CAN2].append(hb)
        return result

    def _faulted(self, now_s: float) -> set:
        """Devices reporting a fault: CyberGear fault bits, a C620 caught not following its command."""
        faulted = set()
        for motor_id, fb in self.bus.joints.items():
            if fb.faults:
                faulted.add(_DEVICE_OF_JOINT[motor_id])
        asked = self.reenable.pending(now_s)  # the operator asked: trust the ESCs again, watch anew
        for esc_id, watch in self.esc_watch.items():
            if asked:
                watch.clear()
            fb = self.bus.wheels[esc_id]
            fresh = now_s - fb.received_s <= 2 * self.period_s  # stale feedback is detect's business
            if fresh and watch.update(fb.current, fb.speed, now_s):
                faulted.add(_DEVICE_OF_WHEEL[esc_id])
        return faulted

    def _wheel_frame(self, currents_a: dict, now_s: float) -> can.Message:
        """The C620 current frame; remembers what it asked (clamped as sent) for the ESC watch."""
        for esc, watch in self.esc_watch.items():
            watch.commanded(messages.esc_current(currents_a.get(esc, 0.0)))
        return messages.wheel_currents(currents_a, t_s=now_s)

    # -- mode inputs -----------------------------------------------------------
    def _inputs(self, devices_ok: bool, now_s: float, att: Attitude | None = None) -> Inputs:
        """The mode machine's inputs; ``att``: the attitude ``observe`` saw this tick (None: read it)."""
        op = self.bus.operator
        reenable_edge = op.reenable and not self._last_buttons[0]
        jump_edge = op.jump and not self._last_buttons[1]
        forward_edge = op.jump_forward and not self._last_buttons[2]
        self._last_buttons = (op.reenable, op.jump, op.jump_forward)
        if jump_edge or forward_edge:
            self._jump_forward = forward_edge
        if att is None:
            att = self.chassis.attitude(self.bus)
        in_air = self.mode in IN_THE_AIR  # tumbling in the air: wider limits
        pitch_limit, roll_limit = (P.FALL_PITCH_AIR, P.FALL_ROLL_AIR) if in_air else (P.FALL_PITCH, P.FALL_ROLL)
        fallen = abs(att.pitch) > pitch_limit or abs(att.roll) > roll_limit
        fallen = fallen or (self.mode in ENABLED and self._body_down(att))
        stood = False
        if self.mode == _STAND_UP:
            stood, fallen = self._stand_up_inputs(att, fallen)
        switch = _SWITCH.get(op.mode, _ESTOP_SWITCH)  # an unknown switch position is treated as E-stop
        reenable = self.reenable.update(reenable_edge, self.mode not in ENABLED, now_s)
        return Inputs(switch=switch, devices_ok=devices_ok, reenable=reenable,
                      jump=jump_edge or forward_edge, fallen=fallen, stood_up=stood,
                      off_ground=self.contact.airborne, jump_done=self.jump.done, can_rise=not fallen)

    def _stand_up_inputs(self, att: Attitude, fallen: bool) -> tuple[bool, bool]:
        """(stood up, fallen) while standing up, from the last run tick's legs."""
        if self.recovery.active:  # righting itself from lying: only a second tumble counts
            return False, not posture.recoverable(att.roll, att.pitch, -1.0, self._recovery_limit, P.FALL_ROLL)
        if self.last is None:
            return False, fallen
        left, right = self.last.leg_lengths_m()
        # the mean leg length: on uneven ground roll levelling sets the legs apart
        stood = abs(0.5 * (left + right) - self.bus.operator.leg_length) < 0.01 and abs(att.pitch) < 0.1
        return stood, fallen or any(abs(theta) > P.FALL_THETA for theta in self.last.leg_angles_rad())

    def _body_down(self, att: Attitude) -> bool:
        """The body box rests on the floor (posture.body_clearance from last tick's legs)."""
        if self.last is None:
            return False
        (left_m, right_m), (left_rad, right_rad) = self.last.leg_lengths_m(), self.last.leg_angles_rad()
        legs = ((_LEFT_Y, left_m, _HALF_PI - left_rad + att.pitch),
                (_RIGHT_Y, right_m, _HALF_PI - right_rad + att.pitch))
        return posture.body_clearance(att.roll, att.pitch, legs) < P.BODY_GROUND_CLEARANCE

    # -- what each kind of tick sends --------------------------------------------
    def _enable(self, result: TickResult, now_s: float) -> None:
        """Stop-and-clear, MIT run mode, enable: the CyberGear start sequence."""
        for joint in C.JOINTS:
            result.frames[CAN2] += [messages.joint_stop(joint.motor_id, clear_fault=True, t_s=now_s),
                                    messages.joint_run_mode(joint.motor_id, 0, t_s=now_s),
                                    messages.joint_enable(joint.motor_id, t_s=now_s)]
        result.frames[CAN1].append(self._wheel_frame({}, now_s))
        self.chassis.reset(self.bus)
        self.contact.reset()

    def _run(self, result: TickResult, now_s: float, sensed=None) -> None:
        cmd = self._command()
        out = self.chassis.step(self.bus, cmd, sensed)
        self._update_support(out.legs)
        joint_frames, hip_torque = result.frames[CAN2], out.hip_torque
        for motor_id in _MOTOR_IDS:
            joint_frames.append(messages.joint_torque(motor_id, hip_torque[motor_id], now_s))
        currents = {}
        for esc, torque_nm in out.wheel_torque.items():
            currents[esc] = torque_nm / _TORQUE_CONSTANT
        result.frames[CAN1].append(self._wheel_frame(currents, now_s))
        self.last = LastOutput(out.report, dict(self.fn), self.jump.phase)
        if self.record_debug:
            result.debug = debug_record(self.last)

    def _command(self) -> Command:
        """What the chassis does this tick, by mode."""
        op = self.bus.operator
        mode = self.mode
        moving = mode == _MOVE
        cmd = Command(speed=op.speed if moving else 0.0, yaw_rate=op.yaw_rate if moving else 0.0,
                      leg_length=op.leg_length, pitch=op.pitch, roll=op.roll,
                      trim=mode in ON_THE_WHEELS)
        if mode == _AIRBORNE:
            cmd.airborne, cmd.air_pitch_hold, cmd.leg_length = True, True, P.AIR_LEG_LENGTH
        elif mode == _JUMP:
            self._jump_command(cmd)
        elif mode == _STAND_UP and self.recovery.active:
            self._recovery_command(cmd)
        return cmd

    def _lying(self) -> bool:
        """On its nose or tail past the fall limit, not on its side or back: stand-up starts with a recovery."""
        att = self.chassis.attitude(self.bus)
        return posture.recoverable(att.roll, att.pitch, P.FALL_PITCH, P.RECOVERY_LYING_MAX, P.FALL_ROLL)

    def _fallen_again_past(self) -> float:
        """rad from upright past which the recovery just begun has fallen again: RECOVERY_FALL_PITCH,
        or a little past where it lies when it starts further over (standing on its nose)."""
        att = self.chassis.attitude(self.bus)
        return max(P.RECOVERY_FALL_PITCH, posture.tilt_from_upright(att.roll, att.pitch) + P.RECOVERY_TILT_MARGIN)

    def _recovery_command(self, cmd: Command) -> None:
        """Fill ``cmd`` from the recovery table's phase (controller/recovery.py)."""
        lengths = self._leg_lengths_m(P.LEG_LENGTH_MAX)
        rc = self.recovery.step(lengths, self.chassis.attitude(self.bus).pitch, cmd.pitch)
        if self.recovery.entered == RecoveryPhase.TILT_UP:
            self.chassis.reset(self.bus)
        cmd.airborne, cmd.air_leg_hold = rc.airborne, False
        if rc.leg_length is not None:
            cmd.leg_length = rc.leg_length
        if rc.pitch is not None:
            cmd.pitch = rc.pitch
            self.chassis.follow_position()

    def _leg_lengths_m(self, before_first_run_m: float) -> tuple[float, float]:
        """Last run tick's leg lengths (m, left and right); ``before_first_run_m`` each before one."""
        if self.last is None:
            return (before_first_run_m, before_first_run_m)
        return self.last.leg_lengths_m()

    def _jump_command(self, cmd: Command) -> None:
        """Fill ``cmd`` from the jump table's phase (controller/jump.py)."""
        lengths = self._leg_lengths_m(P.LEG_LENGTH_NOMINAL)
        touching = max(self.fn.values()) > P.FN_ON
        last = self.last
        steady = not self._jump_forward or (last is not None and (
            abs(last.chassis.speed_m_s - P.JUMP_FORWARD_SPEED) < P.JUMP_RUN_UP_SPEED_TOL))
        angles = last.leg_angles_rad() if last is not None else (0.0, 0.0)
        pitch = last.chassis.pitch_rad if last is not None else 0.0
        jc = self.jump.step(lengths, touching, steady, angles, pitch)
        if self.jump.entered == Phase.LAND:
            self.chassis.touchdown(self.bus)
        ahead = self._jump_forward and jc.phase in (Phase.SQUAT, Phase.THRUST, Phase.RETRACT, Phase.FLIGHT)
        cmd.speed, cmd.yaw_rate = (P.JUMP_FORWARD_SPEED if ahead else 0.0), 0.0
        cmd.airborne, cmd.leg_force, cmd.hip_torque_limit = jc.airborne, jc.leg_force, jc.hip_torque_limit
        cmd.air_pitch_hold, cmd.stance_hold, cmd.air_tuck = jc.airborne, jc.stance_hold, jc.tuck
        if jc.leg_length is not None:
            cmd.leg_length = jc.leg_length

    def _update_support(self, legs: dict) -> None:
        """Fn per leg (the design document's leg_fn_cal) and the debounced off-ground state."""
        imu = self.bus.imu
        accel_z = support.vertical_accel(imu.quat, imu.accel)
        for leg, state in legs.items():
            self.fn[leg] = self.support[leg].update(support.leg_measurement(self.bus.joints, leg, state), accel_z)
        self.contact.update(self.fn["left"], self.fn["right"],
                            support.estimate_trusted(state.theta for state in legs.values()))
        if self.mode in ON_THE_WHEELS:  # on its wheels: what the legs carry sizes a jump
            self.jump.observe_stance(self.fn["left"], self.fn["right"])

    def _disabled(self, result: TickResult, now_s: float) -> None:
        """Motors off: a stop frame to every joint each tick.

        A CyberGear only talks when spoken to, and it answers a type-1 frame to
        the last host id it saw; a type-4 stop carries ours, keeps the motor in
        reset and brings its feedback back for offline detection.
        """
        clear = self.reenable.pending(now_s)  # the operator asked: clear latched faults
        for joint in C.JOINTS:
            result.frames[CAN2].append(messages.joint_stop(joint.motor_id, clear_fault=clear, t_s=now_s))
        # the C620 holds its last command: send zero every tick
        result.frames[CAN1].append(self._wheel_frame({}, now_s))

    def shutdown_frames(self, now_s: float) -> dict:
        """Frames that leave the robot safe: every joint stopped, zero current."""
        return {CAN2: [messages.joint_stop(j.motor_id, t_s=now_s) for j in C.JOINTS],
                CAN1: [messages.wheel_currents({}, t_s=now_s)]}


class ControllerNode(CanNode):
    """The wheel-legged controller on its two buses: CAN1 = wheels (``wheels_bus``), CAN2 = joints."""

    def __init__(self, wheels_bus: can.BusABC, joints_bus: can.BusABC, *, sync: bool = True,
                 period_s: float = P.CONTROL_PERIOD, listener=None):
        super().__init__(wheels_bus, joints_bus, Controller(period_s), sync=sync, period_s=period_s,
                         listener=listener)
