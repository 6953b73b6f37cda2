"""Message builders: the frames the controller sends, built from the DBC.

Pure functions of their arguments (plus the cached DBC): no bus I/O here
(cantools' split between encoding and I/O). Every layout comes from dbc/.
"""
from __future__ import annotations

import can

from wheelleg.controller import constants as C
from wheelleg.controller.bounds import within
from wheelleg.dbc import cybergear as cg
from wheelleg.dbc import CAN1, CAN2, load_bus, truncating_raw
from wheelleg.dbc.codec import MessageCodec

_CAN1 = load_bus(CAN1)
_CAN2 = load_bus(CAN2)
_MOTION = _CAN2.get_message_by_name("CG_MotionCmd")
_STOP = _CAN2.get_message_by_name("CG_Stop")
_ENABLE = _CAN2.get_message_by_name("CG_Enable")
_WRITE = _CAN2.get_message_by_name("CG_ParamWrite")
_ESC_CMD = _CAN1.get_message_by_name("C620_Cmd_1_4")
_HEARTBEAT = _CAN1.get_message_by_name("Heartbeat")
_MOTION_ZERO_RAW = {s.name: truncating_raw(s, 0.0) for s in _MOTION.signals}
_MOTION_ZERO_RAW["Kp"] = 0
_MOTION_ZERO_RAW["Kd"] = 0
_MOTION_DATA = _MOTION.encode(_MOTION_ZERO_RAW, scaling=False)
_MOTION_CODEC = MessageCodec.of(_MOTION)
# compiled encoders (wheelleg.dbc.codec): the same bytes as cantools' encode, ~10 us less a frame
_MOTION_PAYLOAD = _MOTION_CODEC.encoder(dict.fromkeys(("PosRef", "VelRef", "Kp", "Kd"), "truncated"))
_ESC_SLOTS = tuple(f"ESC{i}_Current" for i in range(1, 5))
_ESC_PAYLOAD = MessageCodec.of(_ESC_CMD).encoder(dict.fromkeys(_ESC_SLOTS, "raw"))
# (offset, scale) of each slot, read once: cantools' signal attributes are properties
_ESC_STEPS = tuple((s.offset, s.scale) for s in (_ESC_CMD.get_signal_by_name(name) for name in _ESC_SLOTS))
_C620_LIMIT_A = C.C620_CURRENT_LIMIT
_ESC_CMD_ID, _HEARTBEAT_ID = _ESC_CMD.frame_id, _HEARTBEAT.frame_id  # read once: cantools properties
_HEARTBEAT_PAYLOAD = MessageCodec.of(_HEARTBEAT).encoder(dict.fromkeys(
    ("Tick", "Mode", "WarningLevel", "OfflineCount", "OfflineMask", "MotorsEnabled", "OffGround", "Fallen",
     "FaultLatched", "BadFrames"), "raw"))


def _frame(arbitration_id: int, data: bytes, extended: bool, t_s: float) -> can.Message:
    # python-can's parameters by position (timestamp, arbitration_id, is_extended_id): cheaper than by keyword
    return can.Message(t_s, arbitration_id, extended, data=data)


def joint_torque(motor_id: int, torque_nm: float, t_s: float = 0.0) -> can.Message:
    """CyberGear type-1 motion command carrying only a torque (Kp = Kd = 0)."""
    return _frame(cg.motion_id(torque_nm, motor_id), _MOTION_DATA, True, t_s)


def joint_mit(motor_id: int, position_rad: float, velocity_rad_s: float, kp: float, kd: float,
              torque_nm: float, t_s: float = 0.0) -> can.Message:
    """CyberGear type-1 motion command with the whole MIT law: the motor applies
    kp (position - q) + kd (velocity - qdot) + torque (N m/rad, N m s/rad, N m).

    Set points and gains in the payload, the torque in the identifier, each
    clamped to its field by the manual's truncating encoder (``dbc.codec.truncate``).
    """
    data = _MOTION_PAYLOAD(position_rad, velocity_rad_s, kp, kd)
    return _frame(cg.motion_id(torque_nm, motor_id), data, True, t_s)


def joint_enable(motor_id: int, t_s: float = 0.0) -> can.Message:
    """CyberGear type-3 enable."""
    return _frame(cg.request_id(cg.T_ENABLE, C.CG_HOST_ID, motor_id), _ENABLE.encode({}), True, t_s)


def joint_stop(motor_id: int, clear_fault: bool = False, t_s: float = 0.0) -> can.Message:
    """CyberGear type-4 stop; ``clear_fault`` also clears latched faults."""
    data = _STOP.encode({"ClearFault": int(clear_fault)})
    return _frame(cg.request_id(cg.T_STOP, C.CG_HOST_ID, motor_id), data, True, t_s)


def joint_run_mode(motor_id: int, run_mode: int, t_s: float = 0.0) -> can.Message:
    """CyberGear type-18 write of run_mode (0 = operation/MIT mode)."""
    data = _WRITE.encode({"Index": 0x7005, "run_mode": run_mode}, strict=False)
    return _frame(cg.request_id(cg.T_PARAM_WRITE, C.CG_HOST_ID, motor_id), data, True, t_s)


def esc_current(amps: float) -> float:
    """The current (A) a C620 command carries for ``amps``: clamped to the ESC's range."""
    return within(amps, -_C620_LIMIT_A, _C620_LIMIT_A)


def _esc_raw(slot: int, amps: float) -> int:
    """The raw value of ESC slot ``slot`` (0..3) commanding ``amps`` (A): cantools' encode,
    round((value - offset) / scale), of the clamped current (NaN raises ValueError there as here)."""
    offset, scale = _ESC_STEPS[slot]
    return int(round((esc_current(amps) - offset) / scale))


_ESC_ZERO_RAWS = tuple(_esc_raw(slot, 0.0) for slot in range(4))  # every slot at 0 A


def wheel_currents(currents_a: dict[int, float], t_s: float = 0.0) -> can.Message:
    """C620 0x200 frame: ``currents_a`` maps ESC id 1..4 to amperes (others 0)."""
    raws = list(_ESC_ZERO_RAWS)
    for esc_id, amps in currents_a.items():
        if 1 <= esc_id <= 4:  # (cantools' encode ignores other names)
            raws[esc_id - 1] = _esc_raw(esc_id - 1, amps)
    return _frame(_ESC_CMD_ID, _ESC_PAYLOAD(*raws), False, t_s)


def heartbeat(tick: int, mode: int, warning_level: int, offline_mask: int, offline_count: int,
              *, motors_enabled: bool, off_ground: bool, fallen: bool, fault_latched: bool,
              bad_frames: int, t_s: float = 0.0) -> can.Message:
    """The controller's heartbeat (rig.dbc), sent on both buses at the end of a tick."""
    # min(level, 15) and min(count, 15) written out (bounds.py: the builtin's call costs more)
    data = _HEARTBEAT_PAYLOAD(tick & 0xFFFFFFFF, mode, warning_level if warning_level < 15 else 15,
                              offline_count if offline_count < 15 else 15,
                              offline_mask & 0xFF, int(motors_enabled), int(off_ground), int(fallen),
                              int(fault_latched), bad_frames & 0xF)
    return _frame(_HEARTBEAT_ID, data, False, t_s)
