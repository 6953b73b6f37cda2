"""Damiao DM-J emulator: the reply rules and choices of emulators/damiao.py, each model's ranges, its faults."""
from __future__ import annotations

import math
import struct

import can
import pytest

from wheelleg.dbc import load_file
from wheelleg.emulators.damiao import FAULTS, MODELS, Damiao

DB = load_file("damiao.dbc")
ENABLE, DISABLE, ZERO, CLEAR = (bytes([0xFF] * 7 + [c]) for c in (0xFC, 0xFD, 0xFE, 0xFB))


def msg(can_id: int, data: bytes, **kw) -> can.Message:
    return can.Message(arbitration_id=can_id, data=data, is_extended_id=kw.pop("extended", False), **kw)


def reg(esc: int, op: int, rid: int, value: bytes = bytes(4)) -> can.Message:
    return msg(0x7FF, bytes([esc & 0xFF, esc >> 8, op, rid]) + value)


def state(reply: can.Message) -> int:
    return reply.data[0] >> 4


def test_each_models_mit_ranges_and_peak_torque():
    for name, (tmax, peak) in {"DM-J4310-2EC": (10, 7), "DM-J4340-2EC": (28, 27), "DM-J8009P-2EC": (54, 40)}.items():
        m = Damiao(name, esc_id=1)
        m.handle(msg(1, ENABLE), 0.0)
        full = DB.get_message_by_name("DM_MitCmd").encode({"PosRef": 0, "VelRef": 0, "Kp": 0, "Kd": 0,
                                                          "TorqueRef": 10}, strict=False)
        data = full[:6] + bytes([full[6] | 0x0F, 0xFF])  # the torque field's top: +TMAX
        (reply,) = m.handle(msg(1, data), 0.0)
        assert m.firmware_torque(0.0) == pytest.approx(peak) and MODELS[name].tmax == tmax
        raw = ((reply.data[4] & 0xF) << 8) | reply.data[5]
        assert raw * 2 * tmax / 4095 - tmax == pytest.approx(peak, abs=2 * tmax / 4095)


def test_only_standard_dlc8_frames_at_its_ids_are_answered():
    m = Damiao(esc_id=5, master_id=0x15)
    assert m.handle(msg(5, ENABLE, extended=True), 0.0) == []
    assert m.handle(msg(5, ENABLE[:7]), 0.0) == []
    assert m.handle(msg(6, ENABLE), 0.0) == [] and not m.enabled
    (reply,) = m.handle(msg(0x105, ENABLE), 0.0)  # a special frame at another mode's id is taken
    assert reply.arbitration_id == 0x15 and state(reply) == 1 and reply.data[0] & 0xF == 5
    assert m.handle(msg(0x205, struct.pack("<ff", 1.0, 0.0)), 0.0) == []  # speed command in MIT mode: silence
    assert m.handle(reg(6, 0x33, 21), 0.0) == []  # a register frame for ESC_ID 6


def test_register_read_write_refusals_and_store():
    m = Damiao(esc_id=1)
    (r,) = m.handle(reg(1, 0x55, 4, struct.pack("<f", 30.0)), 0.0)
    assert bytes(r.data) == bytes([1, 0, 0x55, 4]) + struct.pack("<f", 30.0)
    (r,) = m.handle(reg(1, 0x55, 16, struct.pack("<I", 99)), 0.0)  # NPP is read only
    assert struct.unpack("<I", r.data[4:])[0] == 14
    (r,) = m.handle(reg(1, 0x55, 10, struct.pack("<I", 9)), 0.0)  # CTRL_MODE outside 1..4
    assert struct.unpack("<I", r.data[4:])[0] == 1
    (r,) = m.handle(reg(1, 0x55, 4, struct.pack("<f", math.nan)), 0.0)
    assert struct.unpack("<f", r.data[4:])[0] == 30.0
    assert m.handle(reg(1, 0x33, 99), 0.0) == []  # no register 99
    m.handle(msg(1, ENABLE), 0.0)
    assert m.handle(reg(1, 0xAA, 1), 0.0) == []  # store only while disabled
    m.handle(msg(1, DISABLE), 0.0)
    (r,) = m.handle(reg(1, 0xAA, 1), 0.0)
    assert bytes(r.data[:4]) == bytes([1, 0, 0xAA, 1])


def test_position_speed_and_speed_modes_reach_their_targets():
    m = Damiao("DM-J4310-2EC", esc_id=1)
    m.handle(reg(1, 0x55, 10, struct.pack("<I", 2)), 0.0)
    m.handle(msg(0x101, ENABLE), 0.0)
    m.handle(msg(0x101, struct.pack("<ff", 1.5, 3.0)), 0.0)
    peak_speed = 0.0
    for k in range(3000):
        m.step_alone(0.001, (k + 1) * 0.001)
        peak_speed = max(peak_speed, abs(m.shaft.speed))
    assert m.position == pytest.approx(1.5, abs=0.02) and peak_speed < 3.3  # within its speed limit
    m.handle(reg(1, 0x55, 10, struct.pack("<I", 3)), 0.0)  # a mode change disables
    assert not m.enabled
    m.handle(msg(0x201, ENABLE), 0.0)
    m.handle(msg(0x201, struct.pack("<f", -5.0) + bytes(4)), 0.0)
    for k in range(2000):
        m.step_alone(0.001, 3 + (k + 1) * 0.001)
    assert m.shaft.speed == pytest.approx(-5.0, abs=0.1)


def test_back_emf_line_caps_the_speed_at_no_load():
    m = Damiao("DM-J4340-2EC", esc_id=1)
    m.handle(msg(1, ENABLE), 0.0)
    m.handle(msg(1, bytes([0x7F, 0xFF, 0x7F, 0xF0, 0, 0, 0x0F, 0xFF])), 0.0)  # full feed-forward torque
    for k in range(3000):
        m.step_alone(0.001, (k + 1) * 0.001)
    assert 0.9 * MODELS["DM-J4340-2EC"].no_load_speed_rad_s < m.shaft.speed <= MODELS["DM-J4340-2EC"].no_load_speed_rad_s


def test_zero_timeout_faults_and_clear():
    m = Damiao(esc_id=1)
    m.shaft.angle = 2.0
    m.handle(msg(1, ZERO), 0.0)
    assert m.position == 0.0
    m.handle(reg(1, 0x55, 9, struct.pack("<I", 2000)), 0.0)  # 0.1 s
    m.handle(msg(1, ENABLE), 0.0)
    m.handle(msg(1, bytes([0x7F, 0xFF, 0x7F, 0xF0, 0, 0, 0x07, 0xFF])), 0.0)
    m.advance(0.05, 0.05)
    assert m.enabled
    m.advance(0.1, 0.15)
    (r,) = m.handle(reg(1, 0xCC, 0), 0.2)
    assert state(r) == FAULTS["lost_comm"] and m.firmware_torque(0.2) == 0.0
    (r,) = m.handle(msg(1, ENABLE), 0.2)
    assert state(r) == FAULTS["lost_comm"]  # enable refused while the fault is latched
    (r,) = m.handle(msg(1, CLEAR), 0.2)
    assert state(r) == 0
    hot = Damiao(esc_id=1)
    hot.temperature_c = 121.0
    hot.advance(0.001, 0.001)
    assert hot.fault == FAULTS["rotor_over_temp"]
    low = Damiao(esc_id=1, supply_v=9.0)
    low.advance(0.001, 0.001)
    assert low.fault == FAULTS["under_voltage"]
    with pytest.raises(ValueError, match="unknown Damiao fault"):
        low.inject_fault("melted")


def test_mit_layout_matches_damiao_motor_encoder():
    dm = pytest.importorskip("damiao_motor.core.motor")
    driver = dm.DaMiaoMotor(1, 0, bus=None, motor_type="8009")
    data = driver.encode_cmd_msg(pos=1.0, vel=-3.0, torq=12.0, kp=40.0, kd=0.8)
    m = Damiao("DM-J8009P-2EC", esc_id=1)
    m.handle(msg(1, ENABLE), 0.0)
    m.handle(msg(1, data), 0.0)
    p, v, kp, kd, tau = m._target
    assert p == pytest.approx(1.0, abs=4e-4) and v == pytest.approx(-3.0, abs=0.03)
    assert kp == pytest.approx(40.0, abs=0.13) and kd == pytest.approx(0.8, abs=0.002) and tau == pytest.approx(12, abs=0.03)
    (reply,) = m.handle(msg(1, data), 0.0)
    decoded = driver.decode_sensor_feedback(bytes(reply.data))
    assert decoded["status"] == "ENABLED" and decoded["can_id"] == 1 and decoded["t_rotor"] == 25.0
