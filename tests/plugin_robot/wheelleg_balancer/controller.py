"""The balancer's controller: frames in, one tick, frames out (``Balancer``), on its buses (``BalancerNode``).

A tick: which devices are heard in time (wheelleg.controller.detect), the
mode (``TRANSITIONS``, a table), then in BALANCE the LQR torque (gains.py)
split between the wheels with a yaw-rate term, as C620 currents in one
0x200 frame; a heartbeat on both buses ends the tick. Every frame is read
through the rig's DBC files (c620.dbc, rig.dbc); a frame that does not decode
is counted (the heartbeat's BadFrames), never raised.

State: pitch from the IMU's quaternion, its rate from the gyro; the axle's
speed from the two wheels' rotor speed (relative to the body) plus the pitch
rate, its position integrated from that speed.
"""
from __future__ import annotations

import enum
from dataclasses import dataclass, field

import can

from wheelleg.controller import detect
from wheelleg.controller.attitude import euler_zyx
from wheelleg.controller.can_node import CanNode
from wheelleg.dbc import CAN1, CAN2, load_files
from wheelleg_balancer import constants as C
from wheelleg_balancer import params as P
from wheelleg_balancer.gains import K

BUS_FILES = {CAN1: ("c620.dbc", "rig.dbc"), CAN2: ("rig.dbc",)}
DB = load_files(BUS_FILES[CAN1])
SYNC, HEARTBEAT, OPERATOR = (DB.get_message_by_name(n) for n in ("SYNC", "Heartbeat", "Operator"))
ORIENTATION, GYRO = DB.get_message_by_name("IMU_Orientation"), DB.get_message_by_name("IMU_Gyro")
COMMAND = DB.get_message_by_name("C620_Cmd_1_4")
FEEDBACK = {DB.get_message_by_name(f"C620_Feedback_{esc}").frame_id: (name, DB.get_message_by_name(
    f"C620_Feedback_{esc}")) for name, esc in C.ESC_IDS.items()}
RULES = (detect.DeviceRule("left_wheel", P.ESC_OFFLINE_S, 4, True),
         detect.DeviceRule("right_wheel", P.ESC_OFFLINE_S, 4, True),
         detect.DeviceRule("imu", P.IMU_OFFLINE_S, 5, True),
         detect.DeviceRule("remote", P.REMOTE_OFFLINE_S, 2, True))
DEVICES = tuple(rule.name for rule in RULES)  # the heartbeat's OfflineMask bits, in order


class Mode(enum.IntEnum):
    IDLE = 0  # motors off, waiting for the remote's balance request (Operator Mode 1) with every device heard
    BALANCE = 1
    DISABLED = 2  # a device went offline or the body fell: motors off until all is well and Reenable is pressed


# (mode, event) -> next mode; events are worked out each tick (``_event``), first match wins
TRANSITIONS = {
    (Mode.IDLE, "start"): Mode.BALANCE,
    (Mode.BALANCE, "fault"): Mode.DISABLED,
    (Mode.BALANCE, "stop"): Mode.IDLE,
    (Mode.DISABLED, "reenable"): Mode.IDLE,
}


@dataclass
class TickResult:
    """One tick: frames per bus (heartbeat last), the mode, the debug record (``DEBUG_FIELDS``)."""

    frames: dict = field(default_factory=lambda: {CAN1: [], CAN2: []})
    mode: Mode = Mode.IDLE
    debug: dict = field(default_factory=dict)


DEBUG_FIELDS = {
    "mode": "operating mode (0 idle, 1 balance, 2 disabled)",
    "pitch": "body pitch from the IMU, nose down positive (rad)",
    "pitch_rate": "body pitch rate from the gyro (rad/s)",
    "x": "axle position since balancing began, integrated (m)",
    "v": "axle speed forward from the wheels and the pitch rate (m/s)",
    "x_ref": "position set point (m)",
    "torque": "the wheels' summed torque commanded (N m)",
}


class Balancer:
    """The program without I/O: ``on_frame``, ``tick``, ``shutdown_frames`` (``CanNode``'s interface)."""

    def __init__(self, period_s: float = P.CONTROL_PERIOD):
        self.period_s = period_s
        self.mode = Mode.IDLE
        self.last_seen: dict[str, float] = {}
        self.wheel_speed = {name: 0.0 for name in C.ESC_IDS}  # rad/s relative to the body, rolling forward +
        self.pitch = self.pitch_rate = self.yaw_rate = 0.0
        self.remote = {"Mode": 0, "SpeedX": 0.0, "YawRate": 0.0, "Reenable": 0}
        self.reenable_was = 0
        self.x = self.x_ref = 0.0
        self.bad_frames = 0

    # -- frames in ---------------------------------------------------------------------------------
    def on_frame(self, msg: can.Message, bus: str, now_s: float) -> int | None:
        """Take one received frame; the SYNC counter of a SYNC frame, else None. Never raises on a frame."""
        if msg.is_extended_id or msg.is_error_frame or msg.is_remote_frame:
            return None
        try:
            return self._read(msg, bus, now_s)
        except Exception:  # noqa: BLE001 - a malformed frame is counted, not fatal
            self.bad_frames += 1
            return None

    def _read(self, msg: can.Message, bus: str, now_s: float) -> int | None:
        frame_id, data = msg.arbitration_id, bytes(msg.data)
        if frame_id == SYNC.frame_id:
            return int(SYNC.decode(data)["Tick"])
        if bus != CAN1:
            return None
        if frame_id in FEEDBACK:
            name, message = FEEDBACK[frame_id]
            rpm = message.decode(data, decode_choices=False)["RotorSpeed"]
            self.wheel_speed[name] = C.WHEEL_SIGN[name] * rpm * C.RPM_TO_RAD_S / C.M3508_GEAR
            self.last_seen[name] = now_s
        elif frame_id == ORIENTATION.frame_id:
            q = ORIENTATION.decode(data)
            self.pitch = euler_zyx((q["QuatW"], q["QuatX"], q["QuatY"], q["QuatZ"]))[1]
        elif frame_id == GYRO.frame_id:
            rates = GYRO.decode(data)
            self.pitch_rate, self.yaw_rate = rates["RateY"], rates["RateZ"]
            self.last_seen["imu"] = now_s
        elif frame_id == OPERATOR.frame_id:
            self.remote.update({k: v for k, v in OPERATOR.decode(data, decode_choices=False).items()
                                if k in self.remote})
            self.last_seen["remote"] = now_s
        return None

    # -- one tick ----------------------------------------------------------------------------------
    def axle_speed(self) -> float:
        """m/s forward: the wheels turn relative to the body, which itself turns at the pitch rate."""
        relative = sum(self.wheel_speed.values()) / len(self.wheel_speed)
        return C.WHEEL_RADIUS_M * (relative + self.pitch_rate)

    def _event(self, report: detect.Report) -> str | None:
        pressed = self.remote["Reenable"] and not self.reenable_was
        self.reenable_was = self.remote["Reenable"]
        fallen = abs(self.pitch) > P.FALLEN_PITCH_RAD
        if self.mode == Mode.BALANCE:
            if not report.balance_ok or fallen:
                return "fault"
            return "stop" if self.remote["Mode"] != 1 else None
        if self.mode == Mode.DISABLED:
            return "reenable" if pressed and report.balance_ok else None
        return "start" if self.remote["Mode"] == 1 and report.balance_ok and not fallen else None

    def tick(self, tick: int, now_s: float) -> TickResult:
        report = detect.check(self.last_seen, now_s, rules=RULES)
        event = self._event(report)
        mode = TRANSITIONS.get((self.mode, event), self.mode)
        if mode == Mode.BALANCE and self.mode != Mode.BALANCE:
            self.x = self.x_ref = 0.0  # hold the spot where balancing begins
        self.mode = mode
        v = self.axle_speed()
        torque, left, right = 0.0, 0.0, 0.0
        if mode == Mode.BALANCE:
            v_ref = max(-P.MAX_SPEED_M_S, min(P.MAX_SPEED_M_S, self.remote["SpeedX"]))
            yaw_ref = max(-P.MAX_YAW_RATE_RAD_S, min(P.MAX_YAW_RATE_RAD_S, self.remote["YawRate"]))
            self.x += v * self.period_s
            self.x_ref += v_ref * self.period_s
            errors = (self.x - self.x_ref, v - v_ref, self.pitch, self.pitch_rate)
            torque = -sum(k * e for k, e in zip(K, errors))
            turn = P.YAW_RATE_GAIN_NM_S * (yaw_ref - self.yaw_rate)  # + turns left: the right wheel pushes more
            left, right = torque / 2 - turn / 2, torque / 2 + turn / 2
        result = TickResult(mode=mode)
        result.frames[CAN1].append(self.command_frame({"left_wheel": left, "right_wheel": right}, now_s))
        heartbeat = self.heartbeat_frame(tick, report, now_s)
        result.frames[CAN1].append(heartbeat)
        result.frames[CAN2].append(heartbeat)
        result.debug = {"mode": float(mode), "pitch": self.pitch, "pitch_rate": self.pitch_rate, "x": self.x,
                        "v": v, "x_ref": self.x_ref, "torque": torque}
        return result

    # -- frames out --------------------------------------------------------------------------------
    def command_frame(self, torques_nm: dict[str, float], now_s: float) -> can.Message:
        """The 0x200 current frame for the wheels' torques (N m, rolling forward +), clamped to the C620's range."""
        currents = {f"ESC{esc}_Current": 0.0 for esc in range(1, 5)}
        for name, torque in torques_nm.items():
            amps = C.WHEEL_SIGN[name] * torque / C.M3508_TORQUE_CONSTANT_NM_PER_A
            currents[f"ESC{C.ESC_IDS[name]}_Current"] = max(-C.C620_MAX_CURRENT_A, min(C.C620_MAX_CURRENT_A, amps))
        return can.Message(timestamp=now_s, arbitration_id=COMMAND.frame_id, is_extended_id=False,
                           data=COMMAND.encode(currents))

    def heartbeat_frame(self, tick: int, report: detect.Report, now_s: float) -> can.Message:
        data = HEARTBEAT.encode({"Tick": tick % 2 ** 32, "Mode": int(self.mode), "WarningLevel": report.warning_level,
                                 "OfflineCount": min(report.offline_count, 15), "OfflineMask": report.offline_mask,
                                 "MotorsEnabled": int(self.mode == Mode.BALANCE), "OffGround": 0,
                                 "Fallen": int(abs(self.pitch) > P.FALLEN_PITCH_RAD), "FaultLatched": 0,
                                 "BadFrames": min(self.bad_frames, 15)})
        return can.Message(timestamp=now_s, arbitration_id=HEARTBEAT.frame_id, is_extended_id=False, data=data)

    def shutdown_frames(self, now_s: float) -> dict:
        """Zero current to both wheels (SIGINT, SIGTERM, the end of a run)."""
        return {CAN1: [self.command_frame({name: 0.0 for name in C.ESC_IDS}, now_s)], CAN2: []}


class BalancerNode(CanNode):
    """``Balancer`` on its two buses (CAN1: wheels, IMU, remote; CAN2: the rig's lockstep frames only)."""

    def __init__(self, bus1: can.BusABC, bus2: can.BusABC, *, sync: bool = True, period_s: float = P.CONTROL_PERIOD,
                 listener=None):
        super().__init__(bus1, bus2, Balancer(period_s), sync=sync, period_s=period_s, listener=listener)
