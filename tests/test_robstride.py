"""RobStride emulator: what differs from the CyberGear (emulators/robstride.py): scales, commands 22-25, modes."""
from __future__ import annotations

import struct

import can
import pytest

from wheelleg.dbc import cybergear as cg
from wheelleg.emulators.cybergear import MODE_RESET, MODE_RUN
from wheelleg.emulators.robstride import MODELS, RobStride

HOST = 0xFD
MAGIC = bytes(range(1, 7))


def req(ctype: int, motor: int = 1, data: bytes = bytes(8), host: int = HOST, extra: int | None = None) -> can.Message:
    mid = (host if extra is None else extra) << 8
    return can.Message(arbitration_id=(ctype << 24) | mid | motor, data=data, is_extended_id=True)


def write(motor: RobStride, index: int, value: bytes) -> None:
    (reply,) = motor.handle(req(18, motor.motor_id, index.to_bytes(2, "little") + bytes(2) + value), 0.0)
    assert cg.comm_type(reply.arbitration_id) == 2


def test_mit_torque_in_the_id_uses_the_models_range():
    for model, peak in (("RS01", 17.0), ("RS03", 60.0), ("RS04", 120.0)):
        m = RobStride(model, motor_id=1)
        m.handle(req(3), 0.0)
        full = (0xFFFF << 8) | 1  # torque field at its top: +peak
        m.handle(can.Message(arbitration_id=(1 << 24) | full, data=bytes([0x7F, 0xFF, 0x7F, 0xFF, 0, 0, 0, 0]),
                             is_extended_id=True), 0.0)
        assert m.firmware_torque() == pytest.approx(peak) == MODELS[model].line.torque_limit_nm


def test_cybergear_only_types_are_silent():
    m = RobStride("RS02", motor_id=1)
    for ctype in (2, 5, 8, 9, 19, 20):
        assert m.handle(req(ctype), 0.0) == [], ctype
    write(m, 0x7005, bytes([7, 1, 0x80, 0]))  # CyberGear's quick move is not a RobStride run mode
    assert m.run_mode == 0


def test_save_baud_protocol_need_their_magic_and_answer():
    m = RobStride("RS01", motor_id=1)
    assert m.handle(req(22, data=bytes(8)), 0.0) == []
    write(m, 0x700B, struct.pack("<f", 9.0))
    (r,) = m.handle(req(22, data=bytes(range(1, 9))), 0.0)
    assert cg.comm_type(r.arbitration_id) == 2 and m.saved_params["limit_torque"] == 9.0
    assert m.handle(req(23, data=bytes(6) + bytes([2, 0])), 0.0) == []
    (r,) = m.handle(req(23, data=MAGIC + bytes([2, 0])), 0.0)
    assert cg.comm_type(r.arbitration_id) == 0 and m.baud_code == 2
    (r,) = m.handle(req(25, data=MAGIC + bytes([2, 0])), 0.0)
    assert cg.comm_type(r.arbitration_id) == 0 and m.protocol == 2


def test_active_reporting_every_epscan_time():
    m = RobStride("RS01", motor_id=4)
    assert m.periodic(0.0) == []
    write(m, 0x7026, struct.pack("<HH", 3, 0))  # 10 ms + 2 x 5 ms
    (r,) = m.handle(req(24, motor=4, data=MAGIC + bytes([1, 0])), 0.0)
    times = [k * 0.001 for k in range(1, 101) if m.periodic(k * 0.001)]
    assert times[0] == 0.001  # the first report at once, then on the 20 ms grid
    assert times[1:] == pytest.approx([0.02, 0.04, 0.06, 0.08, 0.1])
    m.handle(req(24, motor=4, data=MAGIC + bytes([0, 0])), 0.1)
    assert not any(m.periodic(0.1 + k * 0.001) for k in range(1, 50))


def test_csp_and_profile_position_use_their_speed_limits():
    for run_mode, limit_index in ((5, 0x7017), (1, 0x7024)):
        m = RobStride("RS03", motor_id=1)
        write(m, 0x7005, bytes([run_mode, 0, 0, 0]))
        write(m, limit_index, struct.pack("<f", 1.5))
        m.handle(req(3), 0.0)
        write(m, 0x7016, struct.pack("<f", 2.0))
        top = 0.0
        for k in range(4000):
            m.step_alone(0.001, (k + 1) * 0.001)
            top = max(top, m.shaft.speed)
        assert m.mech_pos == pytest.approx(2.0, abs=0.03) and top < 1.6


def test_can_timeout_drops_a_running_motor_to_reset():
    m = RobStride("RS01", motor_id=1)
    write(m, 0x7028, struct.pack("<I", 2000))  # 0.1 s
    m.handle(req(3), 0.0)
    m.advance(0.05, 0.05)
    assert m.mode == MODE_RUN
    m.advance(0.1, 0.15)
    assert m.mode == MODE_RESET


def test_unknown_model():
    with pytest.raises(ValueError, match="unknown RobStride model"):
        RobStride("RS09")


def test_zero_and_id_change_as_the_cybergear():
    """Type 6 (neither published driver has a call for it) and type 7, inherited from the CyberGear."""
    m = RobStride("RS02", motor_id=1)
    m.shaft.angle = 1.0
    (r,) = m.handle(req(6, data=bytes([1]) + bytes(7)), 0.0)
    assert cg.comm_type(r.arbitration_id) == 2 and m.mech_pos == 0.0
    (r,) = m.handle(req(7, extra=(9 << 8) | HOST), 0.0)
    assert cg.comm_type(r.arbitration_id) == 0 and cg.reply_motor(r.arbitration_id) == 9 and m.motor_id == 9
    assert r.data == (0x5253_0000_0000_0001).to_bytes(8, "little")  # its UID: "RS" and the id it was made with
