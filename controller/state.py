"""State parser: frames from both buses -> what the controller knows.

Only what the robot's own buses say reaches the controller: CyberGear type-2
feedback (and type-21 fault words) on CAN2; C620 feedback, IMU, operator and
SYNC on CAN1. IMU frames count as heard only while their payloads change
(a frozen IMU repeats them bit for bit). A frame that fails its checks (wrong DLC, undecodable, NaN or out
of its DBC range, an IMU quaternion that is not unit) is counted in
``bad_frames`` and ignored: a frame never raises out of ``BusState.update``.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import can

from wheelleg.controller import constants as C
from wheelleg.dbc import cybergear as cg
from wheelleg.dbc import CAN1, CAN2, load_bus
from wheelleg.dbc.codec import MessageCodec, SignalCodec

_DBS = {CAN1: load_bus(CAN1), CAN2: load_bus(CAN2)}
_DB1, _DB2 = _DBS[CAN1], _DBS[CAN2]
_SYNC_ID = _DB1.get_message_by_name("SYNC").frame_id
_WHEEL_BY_FEEDBACK_ID = {0x200 + w.esc_id: w for w in C.WHEELS}
IMU_PARTS = {"IMU_Orientation": "quat", "IMU_Gyro": "gyro", "IMU_Accel": "accel"}
RPM_TO_OUTPUT_RAD_S = 2 * math.pi / 60 / C.M3508_GEAR
# the layout id of a CyberGear frame's id: four feedback frames a tick, a few dozen ids a bus
_canonical_id = functools.lru_cache(maxsize=1024)(cg.canonical_id)
# what every CyberGear frame reads, as module names (no attribute lookup a frame)
_HOST_ID, _parse_reply_id, _T_FEEDBACK, _T_FAULT_WARN = C.CG_HOST_ID, cg.parse_reply_id, cg.T_FEEDBACK, cg.T_FAULT_WARN


@dataclass
class JointFeedback:
    """Latest CyberGear type-2 feedback of one hip motor (shaft side, SI)."""

    position: float = 0.0  # rad
    speed: float = 0.0  # rad/s
    torque: float = 0.0  # N m
    temperature: float = 25.0  # degC
    mode: int = 0  # 0 reset, 2 run
    faults: frozenset = frozenset()
    received_s: float = -math.inf  # controller clock time of the last good frame


@dataclass
class WheelFeedback:
    """Latest C620 feedback of one wheel drive."""

    rotor_angle: float = 0.0  # deg, 0..360 of the rotor
    speed: float = 0.0  # rad/s of the output shaft
    current: float = 0.0  # A
    temperature: float = 25.0  # degC
    received_s: float = -math.inf


@dataclass
class ImuReading:
    quat: tuple = (1.0, 0.0, 0.0, 0.0)  # w, x, y, z body->world
    gyro: tuple = (0.0, 0.0, 0.0)  # rad/s, body frame
    accel: tuple = (0.0, 0.0, 9.81)  # m/s^2 specific force, body frame
    received_s: float = -math.inf  # last time all three parts had arrived


@dataclass
class OperatorCommand:
    """What the remote asks (rig.dbc Operator). Defaults: E-stop, standing still."""

    mode: int = 0  # 0 ESTOP, 1 STAND, 2 MOVE
    jump: bool = False
    jump_forward: bool = False
    reenable: bool = False
    speed: float = 0.0  # m/s forward
    yaw_rate: float = 0.0  # rad/s, left positive
    leg_length: float = 0.17  # m
    pitch: float = 0.0  # rad, nose-down positive (IMU convention)
    roll: float = 0.0  # rad
    received_s: float = -math.inf


@dataclass
class BusState:
    """Everything the controller has heard, updated one frame at a time."""

    joints: dict = field(default_factory=lambda: {j.motor_id: JointFeedback() for j in C.JOINTS})
    wheels: dict = field(default_factory=lambda: {w.esc_id: WheelFeedback() for w in C.WHEELS})
    imu: ImuReading = field(default_factory=ImuReading)
    operator: OperatorCommand = field(default_factory=OperatorCommand)
    bad_frames: int = 0
    frames: int = 0
    _imu_frames: "ImuFrames" = field(default_factory=lambda: ImuFrames())

    @staticmethod
    def prepare() -> None:
        """Every frame layout compiled now (``prepare_layouts``), before a free-running loop starts."""
        prepare_layouts(_DB1, _DB2)

    def update(self, msg: can.Message, bus: str, now_s: float) -> int | None:
        """Take one received frame; returns the SYNC tick when it is a SYNC."""
        self.frames += 1
        try:
            if msg.is_error_frame or msg.is_remote_frame:
                return None
            if msg.is_extended_id:  # CyberGear frames, on CAN2 only
                if bus == CAN2:
                    take_cybergear(msg, now_s, self.joints, _HOST_ID, _DB2)
                return None
            if msg.arbitration_id == _SYNC_ID:
                return checked_decode(_DB1, msg)["Tick"] if bus in _DBS else None
            if bus == CAN1:
                self._can1(msg, now_s)
        except Exception:  # a BadFrame, or anything else: never let a frame take the controller down
            self.bad_frames += 1
        return None

    # -- per-bus parsers -------------------------------------------------------
    def _can1(self, msg: can.Message, now_s: float) -> None:
        wheel = _WHEEL_BY_FEEDBACK_ID.get(msg.arbitration_id)
        if wheel is not None:
            sig = checked_decode(_DB1, msg)
            fb = self.wheels[wheel.esc_id]
            fb.rotor_angle, fb.current = sig["RotorAngle"], sig["TorqueCurrent"]
            fb.speed = sig["RotorSpeed"] * RPM_TO_OUTPUT_RAD_S
            fb.temperature, fb.received_s = sig["MotorTemp"], now_s
            return
        name = _MESSAGE_NAMES.get(msg.arbitration_id)
        if name in IMU_PARTS:
            self._imu_frames.take(self.imu, name, checked_decode(_DB1, msg), now_s, bytes(msg.data))
        elif name == "Operator":
            self._operator(checked_decode(_DB1, msg), now_s)

    def _operator(self, sig: dict, now_s: float) -> None:
        op = self.operator
        op.mode, op.jump, op.jump_forward = int(sig["Mode"]), bool(sig["Jump"]), bool(sig["JumpForward"])
        op.reenable, op.speed, op.yaw_rate = bool(sig["Reenable"]), sig["SpeedX"], sig["YawRate"]
        op.leg_length, op.pitch, op.roll = sig["LegLength"], sig["Pitch"], sig["Roll"]
        op.received_s = now_s


class BadFrame(Exception):
    """A frame that failed its checks; counted, never propagated."""


def checked_decode(db, msg: can.Message, frame_id: int | None = None) -> dict:
    """DBC-decode (``db``: a cantools database) with the checks every frame gets: DLC, finite, in range.

    ``frame_id`` is the id the layout sits at when it is not the frame's own
    (a CyberGear payload sits at its type). BadFrame when a check fails.
    """
    try:
        length, decode, limits = _layout(db, msg.arbitration_id if frame_id is None else frame_id)
    except KeyError:
        raise BadFrame("unknown id") from None
    data = msg.data
    size = len(data)
    if msg.dlc != length or size < length:
        raise BadFrame("wrong DLC")
    values = decode(data if size == length else data[:length])  # bytes-like: no copy
    for name, low, high, bounded in limits:
        value = values.get(name)
        # within finite bounds excludes NaN and infinities too; else isfinite decides them
        if value is not None and not (low <= value <= high and (bounded or math.isfinite(value))):
            raise BadFrame(f"{name} out of range")
    return values


def prepare_layouts(*dbs) -> None:
    """Compile the layout of every message of ``dbs`` (cantools databases) now, not at its
    first frame: code generation costs ~1 ms a message, ~2 ms over a program's first ticks,
    which then ran late (in real time they held the GIL the plant's step waited for). ~40 ms
    for a robot's two buses: a free-running program pays it before its loop starts."""
    for db in dbs:
        for message in db.messages:
            try:
                _layout(db, message.frame_id)
            except KeyError:  # an id the database's lookup does not give (checked_decode: "unknown id")
                pass


@functools.lru_cache(maxsize=1024)
def _layout(db, frame_id: int) -> tuple:
    """(length, decode, (signal, lowest, highest, both finite) per signal) of the message at
    ``frame_id`` in ``db``.

    ``decode`` (of any bytes-like payload) is the compiled codec's (``wheelleg.dbc.codec``: cantools'
    values without choices, ~1 us a frame instead of ~10) where it compiles, else cantools'. The range takes 1e-9 of
    slack beyond the DBC's minimum and maximum; a side the DBC leaves open is infinite.
    KeyError for an id ``db`` does not know.
    """
    message = db.get_message_by_frame_id(frame_id)
    try:
        codec = MessageCodec.of(message)
        decode = codec.decode
    except ValueError:  # a layout the codec does not compile
        codec = None

        def decode(data, message=message):
            return message.decode(bytes(data), decode_choices=False)
    limits = []
    for s in message.signals:
        low = -math.inf if s.minimum is None else s.minimum - 1e-9
        high = math.inf if s.maximum is None else s.maximum + 1e-9
        if codec is None or not _always_within(codec.signals[s.name], low, high):
            limits.append((s.name, low, high, math.isfinite(low) and math.isfinite(high)))
    return message.length, decode, tuple(limits)


def _always_within(signal: SignalCodec, low: float, high: float) -> bool:
    """Whether every value the compiled codec can decode for ``signal`` lies in [low, high].

    An integer field's value is ``raw * scale + offset`` (or ``raw`` itself), monotonic in
    ``raw`` in floating point too (each rounding is): its two raw extremes bound every value,
    and none is NaN or infinite. Such a signal's check cannot fail and is left out (most of
    the controller's frames: the CyberGear feedback, gyro, accelerometer, SYNC, operator).
    An IEEE float field can hold anything.
    """
    if signal.float_format is not None:
        return False
    ends = (signal.value(signal.raw_lo), signal.value(signal.raw_hi))
    return low <= min(ends) and max(ends) <= high


def take_cybergear(msg: can.Message, now_s: float, feedback: dict, host_id: int, db) -> None:
    """Update ``feedback`` (motor id -> JointFeedback) from one CyberGear frame addressed to ``host_id``.

    Type-2 feedback sets position, speed, torque, temperature, mode and the
    fault bits of the id; a type-21 fault word with any fault set adds
    "FaultWord". Frames of other motors or to other hosts are ignored;
    ``db`` is the bus's cantools database (BadFrame when a payload fails its checks).
    """
    can_id = msg.arbitration_id
    rid = _parse_reply_id(can_id)
    fb = feedback.get(rid.motor_id)
    if fb is None or rid.host != host_id:
        return  # not one of ours, or a request from another host
    ctype = rid.ctype
    if ctype == _T_FEEDBACK:
        sig = checked_decode(db, msg, _canonical_id(can_id))
        fb.position, fb.speed, fb.torque = sig["Pos"], sig["Vel"], sig["Torque"]
        fb.temperature, fb.mode, fb.faults = sig["Temp"], rid.mode, rid.faults
        fb.received_s = now_s
    elif ctype == _T_FAULT_WARN:
        sig = checked_decode(db, msg, _canonical_id(can_id))
        if any(v for k, v in sig.items() if k.startswith("Fault")):
            fb.faults = fb.faults | {"FaultWord"}


class ImuFrames:
    """Assembles rig.dbc's three IMU frames into an ``ImuReading``, heard only while they change."""

    def __init__(self):
        self.parts: dict = {}  # part -> controller time (s) it last arrived
        self.last_data: dict = {}  # part -> last payload
        self.changed_s = -math.inf  # last time any IMU payload differed from the one before

    def take(self, imu: ImuReading, name: str, sig: dict, now_s: float, data: bytes) -> None:
        """One decoded IMU frame (message ``name``, signals ``sig``, raw ``data``) into ``imu``.

        BadFrame for a quaternion that is not unit (then nothing changes).
        """
        part = IMU_PARTS[name]
        if part == "quat":
            w, x, y, z = sig["QuatW"], sig["QuatX"], sig["QuatY"], sig["QuatZ"]
            norm = math.sqrt(w * w + x * x + y * y + z * z)
            if abs(norm - 1.0) > 0.05:
                raise BadFrame("quaternion not unit")
            imu.quat = (w / norm, x / norm, y / norm, z / norm)
        elif part == "gyro":
            imu.gyro = (sig["RateX"], sig["RateY"], sig["RateZ"])
        else:
            imu.accel = (sig["AccX"], sig["AccY"], sig["AccZ"])
        self.parts[part] = now_s
        if data != self.last_data.get(part):
            self.last_data[part] = data
            self.changed_s = now_s
        if len(self.parts) == 3:
            # a frozen IMU (hung firmware repeating its frames) is not heard: a real
            # sensor's noise changes some bit of its three frames every sample
            oldest, changed = min(self.parts.values()), self.changed_s
            imu.received_s = changed if changed < oldest else oldest  # min(oldest, changed)


_MESSAGE_NAMES = {m.frame_id: m.name for m in _DBS[CAN1].messages if not m.is_extended_frame}
