"""Frames from both buses -> what the quadruped's controller knows.

Bus 0 (``CAN1``) carries the front legs' CyberGears (ids 1..6), the IMU and
the remote (QuadOperator); bus 1 (``CAN2``) the rear legs' (ids 7..12); SYNC
on both. A motor's feedback counts only on its own bus. Every frame goes
through the wheel-legged controller's checks (``controller.state``: DLC,
finite, in range, unit quaternion, a frozen IMU not heard); a frame that fails
them is counted in ``bad_frames`` and ignored: a frame never raises out of
``QuadBusState.update``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import can

from wheelleg.controller.quadruped import constants as C
from wheelleg.controller.quadruped import params as P
from wheelleg.controller.state import (IMU_PARTS, ImuFrames, ImuReading, JointFeedback, checked_decode,
                                      prepare_layouts, take_cybergear)
from wheelleg.dbc import CAN1, CAN2, load_bus

DATABASES = {CAN1: load_bus(CAN1, robot="quadruped"), CAN2: load_bus(CAN2, robot="quadruped")}
_SYNC_ID = DATABASES[CAN1].get_message_by_name("SYNC").frame_id
_OPERATOR_ID = DATABASES[CAN1].get_message_by_name("QuadOperator").frame_id
_IMU_IDS = {DATABASES[CAN1].get_message_by_name(name).frame_id: name for name in IMU_PARTS}
BUS_OF_LEG = {leg: CAN1 if leg in C.FRONT_BUS_LEGS else CAN2 for leg in range(4)}
MOTORS_ON = {bus: frozenset(C.motor_id(leg, j) for leg in range(4) if BUS_OF_LEG[leg] == bus for j in range(3))
             for bus in (CAN1, CAN2)}


@dataclass
class QuadOperatorCommand:
    """What the remote asks (quadruped.dbc QuadOperator), SI units. Before it is heard: passive, at rest."""

    mode: int = 0  # requested mode (modes.Mode numbers)
    estop: bool = False
    vx: float = 0.0  # m/s forward
    vy: float = 0.0  # m/s left
    yaw_rate: float = 0.0  # rad/s, counter-clockwise from above
    height: float = P.HEIGHT_NOMINAL  # m
    roll: float = 0.0  # rad
    pitch: float = 0.0  # rad
    yaw: float = 0.0  # rad, relative to the balance stand's start
    received_s: float = -math.inf


@dataclass
class QuadBusState:
    """Everything the quadruped's controller has heard, updated one frame at a time."""

    motors: dict = field(default_factory=lambda: {i: JointFeedback() for i in C.MOTOR_IDS})
    imu: ImuReading = field(default_factory=ImuReading)
    operator: QuadOperatorCommand = field(default_factory=QuadOperatorCommand)
    bad_frames: int = 0
    frames: int = 0
    imu_frames: ImuFrames = field(default_factory=ImuFrames)

    @staticmethod
    def prepare() -> None:
        """Every frame layout compiled now (``prepare_layouts``), before a free-running loop starts."""
        prepare_layouts(*DATABASES.values())

    def __post_init__(self):
        # each bus's motors (id -> its JointFeedback, updated in place), made once: a feedback frame
        # may only update a motor on the bus it came from
        self._motors_on = {bus: {i: self.motors[i] for i in MOTORS_ON[bus]} for bus in MOTORS_ON}

    def update(self, msg: can.Message, bus: str, now_s: float) -> int | None:
        """Take one received frame; returns the SYNC tick when it is a SYNC."""
        self.frames += 1
        try:
            if msg.is_error_frame or msg.is_remote_frame or bus not in DATABASES:
                return None
            if msg.is_extended_id:
                take_cybergear(msg, now_s, self._motors_on[bus], C.CG_HOST_ID, DATABASES[bus])
                return None
            if msg.arbitration_id == _SYNC_ID:
                return checked_decode(DATABASES[bus], msg)["Tick"]
            if bus == CAN1:
                self._bus0(msg, now_s)
        except Exception:  # a BadFrame, or anything else: never let a frame take the controller down
            self.bad_frames += 1
        return None

    def _bus0(self, msg: can.Message, now_s: float) -> None:
        name = _IMU_IDS.get(msg.arbitration_id)
        if name is not None:
            self.imu_frames.take(self.imu, name, checked_decode(DATABASES[CAN1], msg), now_s, bytes(msg.data))
        elif msg.arbitration_id == _OPERATOR_ID:
            self._operator(checked_decode(DATABASES[CAN1], msg), now_s)

    def _operator(self, sig: dict, now_s: float) -> None:
        op = self.operator
        op.mode, op.estop = int(sig["Mode"]), bool(sig["EStop"])
        op.vx, op.vy, op.yaw_rate, op.height = sig["VelX"], sig["VelY"], sig["YawRate"], sig["Height"]
        op.roll, op.pitch, op.yaw = sig["Roll"], sig["Pitch"], sig["Yaw"]
        op.received_s = now_s
