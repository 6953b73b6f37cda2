"""Message builders: the frames the controller sends, built from the DBC.

Pure functions of their arguments (plus the cached DBC): no bus I/O here
(cantools' split between encoding and I/O). Every layout comes from dbc/.
"""
from __future__ import annotations

import can

from wheelleg.controller import constants as C
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


def _frame(arbitration_id: int, data: bytes, extended: bool, t_s: float) -> can.Message:
    return can.Message(arbitration_id=arbitration_id, data=data, is_extended_id=extended,
                       timestamp=t_s, check=False)


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
    fields = _MOTION_CODEC.signals
    data = _MOTION_CODEC.encode_raw({
        "PosRef": fields["PosRef"].truncated(position_rad), "VelRef": fields["VelRef"].truncated(velocity_rad_s),
        "Kp": fields["Kp"].truncated(kp), "Kd": fields["Kd"].truncated(kd)})
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
    return min(max(amps, -C.C620_CURRENT_LIMIT), C.C620_CURRENT_LIMIT)


def wheel_currents(currents_a: dict[int, float], t_s: float = 0.0) -> can.Message:
    """C620 0x200 frame: ``currents_a`` maps ESC id 1..4 to amperes (others 0)."""
    values = {f"ESC{i}_Current": 0.0 for i in range(1, 5)}
    for esc_id, amps in currents_a.items():
        values[f"ESC{esc_id}_Current"] = esc_current(amps)
    return _frame(_ESC_CMD.frame_id, _ESC_CMD.encode(values, strict=False), False, t_s)


def heartbeat(tick: int, mode: int, warning_level: int, offline_mask: int, offline_count: int,
              *, motors_enabled: bool, off_ground: bool, fallen: bool, fault_latched: bool,
              bad_frames: int, t_s: float = 0.0) -> can.Message:
    """The controller's heartbeat (rig.dbc), sent on both buses at the end of a tick."""
    data = _HEARTBEAT.encode({
        "Tick": tick & 0xFFFFFFFF, "Mode": mode, "WarningLevel": min(warning_level, 15),
        "OfflineCount": min(offline_count, 15), "OfflineMask": offline_mask & 0xFF,
        "MotorsEnabled": int(motors_enabled), "OffGround": int(off_ground), "Fallen": int(fallen),
        "FaultLatched": int(fault_latched), "BadFrames": bad_frames & 0xF,
    }, strict=False)
    return _frame(_HEARTBEAT.frame_id, data, False, t_s)
