"""CyberGear emulator conformance: driven only through frames on a virtual bus, as a driver would.

Every request is built from the DBC and the id codec (dbc/), every reply
decoded the same way; the shaft turns alone (``step_alone``) between frames.
"""
from __future__ import annotations

import math
import signal
import struct
import subprocess
import sys
import threading
import time
import uuid

import can
import pytest

from wheelleg.controller import constants as C
from wheelleg.dbc import CYBERGEAR_FILES, load_file, truncating_raw
from wheelleg.dbc import cybergear as cg
from wheelleg.emulators import cybergear as emu
from wheelleg.emulators.cybergear import CyberGear
from wheelleg.emulators.node import DeviceNode
from wheelleg.hil.cli import build_parser, main
from wheelleg.hil.commands import emulate

HOST = 0xFD


class Driver:
    """A host on the bus: builds requests from the DBC, returns the decoded replies."""

    def __init__(self, bus: can.BusABC, node: DeviceNode, position_range: str = "12.5"):
        self.bus, self.node = bus, node
        self.db = load_file(CYBERGEAR_FILES[position_range])
        self.t = 0.0

    def msg(self, name: str):
        return self.db.get_message_by_name(name)

    def send(self, can_id: int, data: bytes = bytes(8), extended: bool = True, **kw) -> list[can.Message]:
        self.bus.send(can.Message(arbitration_id=can_id, data=data, is_extended_id=extended, **kw))
        assert self.node.service(self.t) == 1
        replies = []
        while (reply := self.bus.recv(timeout=0)) is not None:
            replies.append(reply)
        return replies

    def one(self, can_id: int, data: bytes = bytes(8), **kw) -> can.Message:
        replies = self.send(can_id, data, **kw)
        assert len(replies) == 1, replies
        return replies[0]

    # requests
    def enable(self, motor: int, host: int = HOST) -> can.Message:
        return self.one(cg.request_id(cg.T_ENABLE, host, motor))

    def stop(self, motor: int, clear: bool = False) -> can.Message:
        return self.one(cg.request_id(cg.T_STOP, HOST, motor), self.msg("CG_Stop").encode({"ClearFault": int(clear)}))

    def motion(self, motor: int, pos=0.0, vel=0.0, kp=0.0, kd=0.0, torque=0.0) -> can.Message:
        cmd = self.msg("CG_MotionCmd")
        raw = {s.name: truncating_raw(s, v) for s, v in zip(cmd.signals, (pos, vel, kp, kd))}
        return self.one(cg.motion_id(torque, motor), cmd.encode(raw, scaling=False))

    def write(self, motor: int, name: str, value) -> can.Message:
        data = self.msg("CG_ParamWrite").encode({"Index": index_of(name), name: value}, strict=False)
        return self.one(cg.request_id(cg.T_PARAM_WRITE, HOST, motor), data)

    def read(self, motor: int, name: str):
        reply = self.one(cg.request_id(cg.T_PARAM_READ, HOST, motor),
                         self.msg("CG_ParamRead").encode({"Index": index_of(name), name: 0}, strict=False))
        rid = cg.parse_reply_id(reply.arbitration_id)
        assert (rid.ctype, rid.motor_id, rid.host) == (cg.T_PARAM_READ, motor, HOST)
        decoded = self.msg("CG_ParamRead").decode(reply.data, decode_choices=False)
        assert decoded["Index"] == index_of(name)
        return decoded[name]

    def feedback(self, reply: can.Message) -> dict:
        rid = cg.parse_reply_id(reply.arbitration_id)
        assert reply.is_extended_id and reply.dlc == 8 and rid.ctype == cg.T_FEEDBACK
        return {"id": rid, **self.msg("CG_Feedback").decode(reply.data)}

    def run(self, motor: CyberGear, seconds: float, dt: float = 0.001, command=None) -> list:
        """Step the shaft alone for ``seconds``; ``command()`` (a request) each step; its replies."""
        replies = []
        for _ in range(round(seconds / dt)):
            if command is not None:
                replies.append(command())
            motor.step_alone(dt, self.t + dt)
            self.t += dt
        return replies


def index_of(name: str) -> int:
    return load_file("cybergear.dbc").get_message_by_name("CG_ParamWrite").get_signal_by_name(name).multiplexer_ids[0]


def f32(x: float) -> float:
    return struct.unpack("<f", struct.pack("<f", x))[0]


@pytest.fixture
def rig(vbus_pair):
    """One motor (id 1) on a node, and a driver; returns (driver, motor)."""
    host_bus, device_bus = vbus_pair
    motor = CyberGear(motor_id=1)
    return Driver(host_bus, DeviceNode(device_bus, [motor])), motor


# -- enable, stop, modes -------------------------------------------------------------------
def test_enable_replies_type2_in_run_mode_and_stop_returns_to_reset(rig):
    drv, motor = rig
    fb = drv.feedback(drv.enable(1))
    assert (fb["id"].motor_id, fb["id"].host, fb["id"].mode, fb["id"].faults) == (1, HOST, emu.MODE_RUN, frozenset())
    assert fb["Pos"] == pytest.approx(0.0, abs=0.001) and fb["Temp"] == pytest.approx(25.0, abs=0.1)
    fb = drv.feedback(drv.stop(1))
    assert fb["id"].mode == emu.MODE_RESET
    assert motor.output_torque(drv.t) == 0.0


def test_power_on_state_is_reset_with_run_mode_0(rig):
    drv, _ = rig
    assert drv.feedback(drv.one(cg.request_id(cg.T_FEEDBACK, HOST, 1)))["id"].mode == emu.MODE_RESET
    assert drv.read(1, "run_mode") == 0


def test_type1_in_reset_mode_replies_and_makes_no_torque(rig):
    drv, motor = rig
    fb = drv.feedback(drv.motion(1, torque=5.0))
    assert fb["id"].mode == emu.MODE_RESET and fb["Torque"] == pytest.approx(0.0, abs=0.001)
    drv.run(motor, 0.05)
    assert motor.shaft.angle == 0.0


def test_motion_command_moves_the_shaft_to_the_target(rig):
    drv, motor = rig
    drv.enable(1)
    for target in (1.0, -0.5):
        replies = drv.run(motor, 1.5, command=lambda: drv.motion(1, pos=target, kp=20.0, kd=1.0))
        assert motor.shaft.angle == pytest.approx(target, abs=0.01)
        assert drv.feedback(replies[-1])["Pos"] == pytest.approx(target, abs=0.01)
        errors = [abs(drv.feedback(r)["Pos"] - target) for r in replies]
        assert errors[len(errors) // 4] < 0.6 * errors[0]


def test_torque_feedforward_from_the_id_accelerates_as_torque_over_inertia(rig):
    drv, motor = rig
    drv.enable(1)
    shaft = motor.shaft
    replies = drv.run(motor, 0.02, dt=0.001, command=lambda: drv.motion(1, torque=-2.0))
    expected = -(2.0 - shaft.coulomb) / shaft.inertia * 0.019  # the last reply saw 19 steps
    assert drv.feedback(replies[-1])["Vel"] == pytest.approx(expected, rel=0.03)
    assert drv.feedback(replies[-1])["Torque"] == pytest.approx(-2.0, abs=0.002)


def test_torque_saturates_at_12_nm_and_at_limit_torque(rig):
    drv, motor = rig
    drv.enable(1)
    assert drv.feedback(drv.motion(1, pos=10.0, kp=500.0))["Torque"] == pytest.approx(12.0, abs=0.001)
    assert drv.feedback(drv.motion(1, pos=-10.0, kp=500.0))["Torque"] == pytest.approx(-12.0, abs=0.001)
    drv.write(1, "limit_torque", 3.0)
    assert drv.feedback(drv.motion(1, pos=10.0, kp=500.0))["Torque"] == pytest.approx(3.0, abs=0.001)


def test_motor_alone_cannot_push_the_shaft_past_30_rad_s(rig):
    drv, motor = rig
    drv.enable(1)
    speeds = [drv.feedback(r)["Vel"] for r in drv.run(motor, 2.0, dt=0.002,
                                                      command=lambda: drv.motion(1, torque=12.0))]
    assert max(speeds) <= C.CG_SPEED_LIMIT
    assert speeds[-1] > 0.9 * C.CG_SPEED_LIMIT  # it does get there: the limit is not a stall


def test_speed_mode_tracks_spd_ref(rig):
    drv, motor = rig
    drv.write(1, "run_mode", 2)
    drv.enable(1)
    drv.write(1, "limit_cur", 10.0)
    drv.write(1, "spd_ref", -5.0)
    drv.run(motor, 1.0)
    assert motor.shaft.speed == pytest.approx(-5.0, abs=0.1)


def test_position_mode_reaches_loc_ref_within_limit_spd(rig):
    drv, motor = rig
    drv.write(1, "run_mode", 1)
    drv.enable(1)
    drv.write(1, "limit_spd", 3.0)
    drv.write(1, "loc_ref", 1.5)
    peak = 0.0
    for _ in range(300):
        drv.run(motor, 0.01)
        peak = max(peak, abs(motor.shaft.speed))
    assert motor.shaft.angle == pytest.approx(1.5, abs=0.02)
    assert 2.5 < peak < 3.3  # the speed limit holds (plus the loop's overshoot)


def test_current_mode_torque_is_iq_ref_times_torque_constant(rig):
    drv, motor = rig
    drv.write(1, "run_mode", 3)
    drv.enable(1)
    drv.write(1, "iq_ref", 2.0)
    assert drv.feedback(drv.one(cg.request_id(cg.T_FEEDBACK, HOST, 1)))["Torque"] == \
        pytest.approx(2.0 * C.CG_TORQUE_CONSTANT, abs=0.001)


def test_run_mode_changes_only_in_reset_mode(rig):
    drv, _ = rig
    drv.enable(1)
    drv.write(1, "run_mode", 2)
    assert drv.read(1, "run_mode") == 0
    drv.stop(1)
    drv.write(1, "run_mode", 2)
    assert drv.read(1, "run_mode") == 2
    drv.write(1, "run_mode", 6)  # not a run mode
    assert drv.read(1, "run_mode") == 2


# -- parameters ----------------------------------------------------------------------------
WRITABLE = {"iq_ref": -7.5, "spd_ref": 12.25, "limit_torque": 4.5, "cur_kp": 0.2, "cur_ki": 0.03,
            "cur_filt_gain": 0.4, "loc_ref": -3.3, "limit_spd": 2.5, "limit_cur": 11.0,
            "loc_kp": 25.0, "spd_kp": 1.7, "spd_ki": 0.004}


@pytest.mark.parametrize("name", sorted(WRITABLE))
def test_write_then_read_returns_the_value(rig, name):
    drv, _ = rig
    fb = drv.feedback(drv.write(1, name, WRITABLE[name]))
    assert fb["id"].motor_id == 1
    assert drv.read(1, name) == f32(WRITABLE[name])


def test_read_reply_bytes_pin_the_little_endian_layout(rig):
    drv, _ = rig
    drv.write(1, "limit_spd", 2.0)
    reply = drv.one(cg.request_id(cg.T_PARAM_READ, HOST, 1), bytes.fromhex("1770000000000000"))
    assert reply.arbitration_id == 0x110001FD
    assert bytes(reply.data) == bytes.fromhex("1770000000000040")


def test_read_only_parameters_report_live_state_and_ignore_writes(rig):
    drv, motor = rig
    motor.shaft.angle, motor.shaft.speed = 20.0, -3.0
    drv.write(1, "mechPos", 1.0)
    drv.write(1, "VBUS", 12.0)
    assert drv.read(1, "mechPos") == f32(20.0)
    assert drv.read(1, "mechVel") == f32(-3.0)
    assert drv.read(1, "VBUS") == f32(24.0)
    assert drv.read(1, "rotation") == 3  # 20 rad = 3 whole turns


def test_unknown_index_read_is_silent_and_write_is_acknowledged_without_effect(rig):
    drv, motor = rig
    index_only = load_file("cybergear.dbc").get_message_by_name("CG_ParamRead").get_signal_by_name("Index")
    for index in (0x7007, 0x2005, 0x0000, 0xFFFF):
        data = index.to_bytes(2, "little") + bytes(6)
        assert drv.send(cg.request_id(cg.T_PARAM_READ, HOST, 1), data) == []
        before = dict(motor.params)
        assert drv.feedback(drv.one(cg.request_id(cg.T_PARAM_WRITE, HOST, 1), data[:4] + b"\x00\x00\x80\x3f"))
        assert motor.params == before
    assert index_only.byte_order == "little_endian"  # the bytes above follow the DBC's order


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_non_finite_float_writes_are_ignored(rig, value):
    drv, _ = rig
    drv.write(1, "limit_spd", 2.5)
    drv.write(1, "limit_spd", value)
    assert drv.read(1, "limit_spd") == 2.5


def test_out_of_range_writes_clamp_to_the_manual_range(rig):
    drv, _ = rig
    drv.write(1, "limit_torque", 50.0)
    assert drv.read(1, "limit_torque") == 12.0
    drv.write(1, "limit_spd", -4.0)
    assert drv.read(1, "limit_spd") == 0.0


# -- faults ----------------------------------------------------------------------------------
@pytest.mark.parametrize("fault", cg.FAULT_NAMES)
def test_injected_fault_shows_in_the_id_and_only_stop_with_clear_clears_it(rig, fault):
    drv, motor = rig
    drv.enable(1)
    motor.inject_fault(fault)
    fb = drv.feedback(drv.motion(1, torque=3.0))
    assert fb["id"].faults == {fault} and fb["id"].mode == emu.MODE_RESET
    assert motor.output_torque(drv.t) == 0.0
    assert drv.feedback(drv.enable(1))["id"].mode == emu.MODE_RESET  # no enable while latched
    assert drv.feedback(drv.stop(1, clear=False))["id"].faults == {fault}
    assert drv.feedback(drv.stop(1, clear=True))["id"].faults == frozenset()
    assert drv.feedback(drv.enable(1))["id"].mode == emu.MODE_RUN


def test_unknown_fault_name_is_a_clear_error():
    with pytest.raises(ValueError, match="unknown CyberGear fault"):
        CyberGear().inject_fault("FaultCoffee")


def test_type21_poll_reports_the_fault_word_little_endian(rig):
    drv, motor = rig
    poll = cg.request_id(cg.T_FAULT_WARN, HOST, 1)
    words = drv.msg("CG_FaultWarn")
    reply = drv.one(poll)
    assert reply.arbitration_id == (cg.T_FAULT_WARN << 24) | (1 << 8) | HOST
    assert not any(words.decode(reply.data).values())
    motor.inject_fault("FaultOverTemp")
    motor.inject_fault("FaultUnderVoltage")
    assert bytes(drv.one(poll).data) == bytes.fromhex("0500000000000000")
    decoded = words.decode(drv.one(poll).data)
    assert decoded["FaultOverTemp"] == 1 and decoded["FaultUnderVoltage"] == 1


def test_sustained_12_nm_stall_trips_over_temperature_near_the_overload_table(rig):
    drv, motor = rig
    drv.enable(1)
    motor.shaft.load_torque = -12.0  # a wall: the motor stalls
    trip_s, warn_seen = None, False
    while trip_s is None and drv.t < 40.0:
        fb = drv.feedback(drv.motion(1, torque=12.0))
        warn_seen |= bool(drv.msg("CG_FaultWarn").decode(drv.one(cg.request_id(cg.T_FAULT_WARN, HOST, 1)).data)
                          ["WarnOverTemp"])
        if "FaultOverTemp" in fb["id"].faults:
            trip_s = drv.t
            break
        assert abs(motor.shaft.angle) < 0.01  # a stall until the trip
        drv.run(motor, 0.1, dt=0.01)
    assert trip_s is not None and 26.0 <= trip_s <= 30.0  # the table: 12 N m for 28 s
    assert warn_seen and fb["Temp"] >= C.CG_OVER_TEMP - 0.5  # cooling since the trip
    assert fb["id"].mode == emu.MODE_RESET and motor.output_torque(drv.t) == 0.0


def test_rated_4_nm_never_trips(rig):
    """20 minutes at the rated torque, the shaft held by the plant (physics mode: advance only)."""
    drv, motor = rig
    drv.enable(1)
    drv.motion(1, torque=4.0)
    for _ in range(1200):
        drv.t += 1.0
        motor.advance(1.0, drv.t)
    fb = drv.feedback(drv.motion(1, torque=4.0))
    assert fb["id"].faults == frozenset() and fb["Torque"] == pytest.approx(4.0, abs=0.001)
    assert 45.0 < fb["Temp"] < C.CG_WARN_TEMP  # settled near 49 degC


# -- ids, zero, device id --------------------------------------------------------------------
def test_change_id_answers_type0_from_the_new_id_at_once(rig):
    drv, _ = rig
    reply = drv.one(cg.set_id_id(5, HOST, 1), b"\x01" + bytes(7))
    rid = cg.parse_reply_id(reply.arbitration_id)
    assert (rid.ctype, rid.motor_id, rid.host) == (cg.T_DEVICE_ID, 5, cg.DEVICE_ID_TARGET)
    assert drv.send(cg.request_id(cg.T_ENABLE, HOST, 1)) == []
    assert drv.feedback(drv.enable(5))["id"].motor_id == 5


def test_change_id_beyond_127_keeps_the_old_id(rig):
    drv, _ = rig
    reply = drv.one(cg.set_id_id(0xC8, HOST, 1), b"\x01" + bytes(7))
    assert cg.parse_reply_id(reply.arbitration_id).motor_id == 1


def test_device_id_request_returns_the_uid_to_0xfe(vbus_pair):
    uid = 0x0123456789ABCDEF
    motor = CyberGear(motor_id=0x7F, uid=uid)
    drv = Driver(vbus_pair[0], DeviceNode(vbus_pair[1], [motor]))
    reply = drv.one(cg.request_id(cg.T_DEVICE_ID, HOST, 0x7F), b"\x00")  # the debugger's DLC 1
    assert reply.arbitration_id == 0x00007FFE and reply.dlc == 8
    assert drv.msg("CG_DeviceId").decode(reply.data)["McuUid"] == uid
    baud = drv.one(cg.request_id(cg.T_SET_BAUD, HOST, 0x7F), drv.msg("CG_SetBaud").encode({"BaudCode": 2}))
    assert baud.arbitration_id == 0x00007FFE and motor.baud_code == 2


def test_set_zero_is_volatile_and_needs_byte0_1(rig):
    drv, motor = rig
    motor.shaft.angle = 0.7
    assert drv.feedback(drv.one(cg.request_id(cg.T_SET_ZERO, HOST, 1)))["Pos"] == pytest.approx(0.7, abs=0.001)
    reply = drv.one(cg.request_id(cg.T_SET_ZERO, HOST, 1), drv.msg("CG_SetZero").encode({"ZeroFlag": 1}))
    assert reply.data[0:2] == b"\x7f\xff"  # pos = 0 under the truncating encoder
    assert drv.read(1, "mechPos") == 0.0
    assert CyberGear(motor_id=1).mech_pos == 0.0  # a fresh power-on forgets it


def test_replies_go_to_the_requesting_host_and_type1_to_the_last_one(rig):
    drv, _ = rig
    assert cg.parse_reply_id(drv.enable(1, host=0xA2).arbitration_id).host == 0xA2
    assert cg.parse_reply_id(drv.motion(1).arbitration_id).host == 0xA2
    drv.enable(1, host=0x00)
    assert cg.parse_reply_id(drv.motion(1).arbitration_id).host == 0x00


def test_type1_before_any_host_goes_to_can_master_0(rig):
    drv, _ = rig
    assert cg.parse_reply_id(drv.motion(1).arbitration_id).host == 0x00


def test_two_motors_on_one_bus_answer_only_their_own_frames(vbus_pair):
    one, two = CyberGear(motor_id=1), CyberGear(motor_id=2)
    drv = Driver(vbus_pair[0], DeviceNode(vbus_pair[1], [one, two]))
    assert drv.feedback(drv.enable(2))["id"].motor_id == 2
    assert (one.mode, two.mode) == (emu.MODE_RESET, emu.MODE_RUN)
    assert drv.feedback(drv.motion(2, torque=1.0))["id"].motor_id == 2
    assert one.output_torque(0.0) == 0.0 and two.output_torque(0.0) == pytest.approx(1.0, abs=0.001)
    assert drv.read(1, "run_mode") == 0 and drv.read(2, "run_mode") == 0


# -- the encoder -----------------------------------------------------------------------------
def test_feedback_uses_the_truncating_encoder_and_saturates_position(rig):
    drv, motor = rig
    motor.shaft.speed = 5.0
    poll = cg.request_id(cg.T_FEEDBACK, HOST, 1)
    assert drv.one(poll).data[2:4] == b"\x95\x54"  # +5 rad/s: 38228.75 truncated (debugger capture)
    motor.shaft.speed = 0.0
    assert drv.one(poll).data[2:4] == b"\x7f\xff"
    motor.shaft.angle = 12.0
    assert drv.one(poll).data[0:2] == (0xFAE0).to_bytes(2, "big")  # the hardware check value (docs/protocols.md, type 1)
    motor.shaft.angle = 40.0
    assert drv.one(poll).data[0:2] == b"\xff\xff"  # saturates, does not wrap
    assert drv.read(1, "mechPos") == 40.0  # while mechPos keeps the multi-turn angle
    assert drv.one(poll).data[6:8] == (250).to_bytes(2, "big")  # 25.0 degC * 10


def test_4pi_position_range(vbus_pair):
    motor = CyberGear(motor_id=1, position_range="4pi")
    drv = Driver(vbus_pair[0], DeviceNode(vbus_pair[1], [motor]), position_range="4pi")
    motor.shaft.angle = 12.0
    assert drv.one(cg.request_id(cg.T_FEEDBACK, HOST, 1)).data[0:2] == (0xFA3A).to_bytes(2, "big")
    drv.enable(1)
    drv.run(motor, 1.5, command=lambda: drv.motion(1, pos=12.3, kp=20.0, kd=1.0))
    assert motor.shaft.angle == pytest.approx(12.3, abs=0.01)


def test_constructor_rejects_bad_configuration():
    with pytest.raises(ValueError, match="motor id"):
        CyberGear(motor_id=128)
    with pytest.raises(ValueError, match="position_range"):
        CyberGear(position_range="10")


# -- bad input: the real device's answer, usually silence ------------------------------------
def _state(motor: CyberGear) -> tuple:
    return (motor.mode, dict(motor.params), motor.mech_pos, motor.faults, motor.baud_code,
            motor.motor_id, motor.output_torque(0.0))


@pytest.mark.parametrize("ctype", [cg.T_MOTION, cg.T_SET_ZERO, cg.T_PARAM_READ, cg.T_PARAM_WRITE, cg.T_SET_BAUD])
@pytest.mark.parametrize("dlc", [0, 1, 7])
def test_wrong_dlc_is_silent_and_changes_nothing(rig, ctype, dlc):
    drv, motor = rig
    drv.enable(1)
    drv.motion(1, torque=1.0)
    motor.shaft.angle = 0.3
    before = _state(motor)
    can_id = cg.motion_id(5.0, 1) if ctype == cg.T_MOTION else cg.request_id(ctype, HOST, 1)
    assert drv.send(can_id, bytes([1, 0x70, 0, 0, 0, 0, 0x80, 0x3F])[:dlc]) == []
    assert _state(motor) == before


def test_frames_whose_payload_is_ignored_accept_any_dlc(rig):
    drv, _ = rig
    assert drv.feedback(drv.one(cg.request_id(cg.T_ENABLE, HOST, 1), b""))["id"].mode == emu.MODE_RUN
    assert drv.feedback(drv.one(cg.request_id(cg.T_FEEDBACK, HOST, 1), b"\x00\x00"))["id"].motor_id == 1


@pytest.mark.parametrize("ctype", [8, 10, 16, 23, 31])  # 9 and 19 answer (tests/test_cybergear_table.py)
def test_undocumented_types_are_silent(rig, ctype):
    drv, motor = rig
    drv.enable(1)
    before = _state(motor)
    assert drv.send(cg.request_id(ctype, HOST, 1)) == []
    assert _state(motor) == before


def test_frames_for_other_targets_standard_ids_and_remote_frames_are_silent(rig):
    drv, motor = rig
    before = _state(motor)
    for ctype in (0, 1, 2, 3, 4, 6, 7, 17, 18, 21, 22):
        for target in (0, 2, 0x7F, 0xFE, 0xFF):
            assert drv.send(cg.request_id(ctype, HOST, target)) == []
    assert drv.send(cg.request_id(cg.T_ENABLE, HOST, 1) & 0x7FF, extended=False) == []
    assert drv.send(0x001, extended=False) == []
    assert drv.send(cg.request_id(cg.T_ENABLE, HOST, 1), b"", is_remote_frame=True) == []
    assert _state(motor) == before
    assert motor.internal_errors == 0


# -- wheelleg emulate ------------------------------------------------------------------------
def test_wheelleg_emulate_cybergear_answers_a_driver_and_stops_cleanly():
    channel = f"emulate-{uuid.uuid4().hex}"
    args = build_parser().parse_args(["emulate", "cybergear", "--interface", "virtual", "--channel", channel,
                                      "--id", "0x05"])
    stop, result = threading.Event(), {}
    thread = threading.Thread(target=lambda: result.update(rc=emulate.run(args, stop)))
    driver = can.Bus(interface="virtual", channel=channel)
    thread.start()
    try:
        reply = None
        deadline = time.monotonic() + 20.0  # generous: only bounds a hang, asserts no timing
        while reply is None and time.monotonic() < deadline:  # until the emulator's bus exists
            driver.send(can.Message(arbitration_id=cg.request_id(cg.T_ENABLE, HOST, 5), data=bytes(8),
                                    is_extended_id=True))
            reply = driver.recv(timeout=0.2)
        assert reply is not None
        rid = cg.parse_reply_id(reply.arbitration_id)
        assert (rid.ctype, rid.motor_id, rid.host, rid.mode) == (cg.T_FEEDBACK, 5, HOST, emu.MODE_RUN)
    finally:
        stop.set()
        thread.join(timeout=20.0)
        driver.shutdown()
    assert not thread.is_alive() and result["rc"] == 0


@pytest.mark.parametrize("signame", ["SIGINT", "SIGTERM"])
def test_wheelleg_emulate_process_exits_0_on_signal(signame):
    proc = subprocess.Popen([sys.executable, "-m", "wheelleg.hil.cli", "emulate", "cybergear", "-i", "virtual",
                             "-c", "emulate-signal"], stderr=subprocess.PIPE, text=True)
    try:
        assert "Ctrl-C stops" in proc.stderr.readline()  # started and serving
        proc.send_signal(getattr(signal, signame))
        _, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, err
    assert "stopped" in err


def test_wheelleg_emulate_rejects_a_bad_id_with_a_clear_error(capsys):
    assert main(["emulate", "cybergear", "-i", "virtual", "-c", "x", "--id", "200"]) == 2
    assert "motor id must be 0..127" in capsys.readouterr().err
