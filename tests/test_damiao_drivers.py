"""Published Damiao drivers against ``wheelleg emulate damiao``.

``damiao-motor`` (PyPI, MIT) drives the emulator in another process over
python-can's udp_multicast: its ``DaMiaoController`` opens a bus by channel
and bustype, which is then pointed at the test's multicast group (its port is
the test's), and its own API is used unchanged. ``pydamiao`` talks to a
USB-serial bridge and ``can-motor-control`` (Rust) to SocketCAN or its own
mock bus: their codecs are checked frame for frame against the emulator
instead (the payloads they build are fed to it; its replies are decoded with
their decoders).
"""
from __future__ import annotations

import struct
import time

import pytest

from drivers_helpers import Emulators, emulators, eventually  # noqa: F401 (emulators: a fixture)
from wheelleg.emulators.damiao import Damiao

can = pytest.importorskip("can")
pytest.importorskip("msgpack", reason="python-can's udp_multicast needs msgpack (pip install '.[drivers]')")

pytestmark = [pytest.mark.timeout(180)]


def _controller(emu: Emulators):
    from damiao_motor import DaMiaoController
    ctrl = DaMiaoController(channel=emu.channel, bustype="udp_multicast")
    ctrl.bus.shutdown()  # the driver opened python-can's default port; use the test's group and port
    ctrl.bus = emu.driver_bus()
    return ctrl


def _until(motor, send, check, what: str, timeout_s: float = 8.0):
    """Send ``send()`` every 10 ms (each answered by a feedback frame) until ``check(state)``."""
    def step():
        send()
        time.sleep(0.01)
        state = motor.get_states()
        return state and check(state)
    return eventually(step, timeout_s, what)


def _register(motor, rid: int):
    """Read a register afresh (the driver caches replies: ask, then wait for the new one)."""
    motor.registers.pop(rid, None)
    motor.request_register_reading(rid)
    eventually(lambda: rid in motor.registers, 3.0, f"register {rid}")
    return motor.registers[rid]


def _mode(motor, mode: int):
    motor.write_register(10, mode)
    eventually(lambda: _register(motor, 10) == mode, 3.0, f"CTRL_MODE {mode}")
    motor.enable()


@pytest.mark.slow
def test_damiao_motor_drives_every_mode_register_zero_id_fault_and_stop(emulators):
    pytest.importorskip("damiao_motor", reason="damiao-motor is not installed (pip install '.[drivers]')")
    emulators.start("damiao", "--id", "1", "--model", "DM-J4310-2EC")
    ctrl = _controller(emulators)
    try:
        motor = ctrl.add_motor(motor_id=1, feedback_id=0x00, motor_type="4310")
        motor.enable()
        motor.request_motor_feedback()
        eventually(lambda: motor.get_states().get("status") == "ENABLED", 3.0, "enabled")
        assert _register(motor, 21) == pytest.approx(12.5) and _register(motor, 23) == pytest.approx(10.0)
        motor.ensure_control_mode("MIT")  # reads CTRL_MODE 1: nothing to change
        _until(motor, lambda: motor.send_cmd_mit(target_position=1.0, stiffness=20.0, damping=1.0),
               lambda s: abs(s["pos"] - 1.0) < 0.05 and abs(s["vel"]) < 0.2, "MIT to 1 rad")
        _until(motor, lambda: motor.send_cmd_mit(feedforward_torque=0.3),
               lambda s: abs(s["torq"] - 0.3) < 0.02 and s["vel"] > 1.0, "MIT feed-forward torque")
        _mode(motor, 2)
        _until(motor, lambda: motor.send_cmd_pos_vel(target_position=-1.0, velocity_limit=5.0),
               lambda s: abs(s["pos"] + 1.0) < 0.05, "position-speed to -1 rad")
        _mode(motor, 3)
        _until(motor, lambda: motor.send_cmd_vel(target_velocity=4.0), lambda s: abs(s["vel"] - 4.0) < 0.3,
               "speed 4 rad/s")
        _mode(motor, 4)
        _until(motor, lambda: motor.send_cmd_force_pos(0.5, velocity_limit=5.0, torque_limit_ratio=0.5),
               lambda s: abs(s["pos"] - 0.5) < 0.05, "force-position to 0.5 rad")
        motor.set_acceleration(25.0)
        assert _register(motor, 4) == pytest.approx(25.0)
        motor.set_zero_position()
        _until(motor, lambda: motor.send_cmd_force_pos(0.0, 5.0, 0.5), lambda s: abs(s["pos"]) < 0.01, "zero")
        _mode(motor, 1)
        motor.set_can_timeout(50)  # 50 ms without a command: lost communication (state 0xD)
        assert _register(motor, 9) == 1000
        motor.enable()
        motor.send_cmd_mit(stiffness=1.0)
        time.sleep(0.3)
        motor.request_motor_feedback()
        eventually(lambda: motor.get_states().get("status") == "LOST_COMM", 3.0, "lost communication")
        motor.set_can_timeout(0)
        motor.clear_error()
        motor.request_motor_feedback()
        eventually(lambda: motor.get_states().get("status") == "DISABLED", 3.0, "error cleared")
        motor.set_receive_id(2)  # ESC_ID 2; then MST_ID 0x12
        motor2 = ctrl.add_motor(motor_id=2, feedback_id=0x12, motor_type="4310")
        motor2.set_feedback_id(0x12)
        motor2.enable()
        motor2.request_motor_feedback()
        eventually(lambda: motor2.get_states().get("arbitration_id") == 0x12
                   and motor2.get_states().get("status") == "ENABLED", 3.0, "answers as ESC_ID 2 to MST_ID 0x12")
        assert _register(motor2, 8) == 2 and _register(motor2, 7) == 0x12
        motor2.disable()
        motor2.request_motor_feedback()
        eventually(lambda: motor2.get_states().get("status") == "DISABLED", 3.0, "stopped")
    finally:
        ctrl.shutdown()


# -- codecs checked frame for frame --------------------------------------------------------------
def _msg(can_id: int, data: bytes):
    return can.Message(arbitration_id=can_id, data=bytes(data), is_extended_id=False)


def test_pydamiao_codec_frame_for_frame():
    from pydamiao.protocol import DamiaoProtocol as P
    from pydamiao.structs import MOTOR_LIMITS, MotorType
    from pydamiao.utils import float_to_uint, uint_to_float

    def payload(bridge: bytes) -> tuple[int, bytes]:  # the CAN id and data inside pydamiao's bridge frame
        return struct.unpack("<I", bridge[13:17])[0], bridge[21:29]

    motor = Damiao("DM-J4340-2EC", esc_id=3, master_id=0x13)
    limits = MOTOR_LIMITS[MotorType.DM4340]
    assert (limits.POS_MAX, limits.VEL_MAX, limits.TORQUE_MAX) == (12.5, 8, 28)  # the emulated model's ranges
    (reply,) = motor.handle(_msg(*payload(P.encode_basic_command(3, P.ENABLE_CMD))), 0.0)
    assert reply.arbitration_id == 0x13 and reply.data[0] == 0x13 and motor.enabled  # state 1 enabled, id 3
    assert P.decode_fault(reply.data) is None  # pydamiao knows no state 1: "enabled" is not a fault
    motor.shaft.angle, motor.shaft.speed = 0.7, -2.0
    (reply,) = motor.handle(_msg(*payload(P.encode_mit_control(3, limits, 30.0, 1.5, 1.2, 0.5, 4.0))), 0.0)
    pos, vel, torque = P.decode_status(bytes(reply.data), limits)
    assert pos == pytest.approx(0.7, abs=1e-3) and vel == pytest.approx(-2.0, abs=0.01)
    def wire(x, lo, hi, bits):  # a value as pydamiao puts it on the wire and reads it back
        return float(uint_to_float(float_to_uint(x, lo, hi, bits), lo, hi, bits))

    kp, kd = wire(30.0, 0, 500, 12), wire(1.5, 0, 5, 12)
    expect = (kp * (wire(1.2, -12.5, 12.5, 16) - 0.7) + kd * (wire(0.5, -8, 8, 12) + 2.0) + wire(4.0, -28, 28, 12))
    assert torque == pytest.approx(wire(expect, -28, 28, 12), abs=1e-4)  # the MIT law on its values, < 27 N m peak
    motor.handle(_msg(*payload(P.encode_write_param(3, 10, 2))), 0.0)  # CTRL_MODE 2 (int register)
    (reply,) = motor.handle(_msg(*payload(P.encode_read_param(3, 10))), 0.0)
    assert bytes(reply.data) == bytes([3, 0, 0x33, 10, 2, 0, 0, 0])
    (reply,) = motor.handle(_msg(*payload(P.encode_write_param(3, 25, 0.75))), 0.0)  # KP_ASR (float)
    assert reply.data[2] == 0x55 and struct.unpack("<f", reply.data[4:])[0] == pytest.approx(0.75)
    motor.handle(_msg(*payload(P.encode_basic_command(0x103, P.ENABLE_CMD))), 0.0)
    (reply,) = motor.handle(_msg(*payload(P.encode_pos_vel_control(3, 1.0, 2.0))), 0.0)
    assert motor._target[:2] == (1.0, 2.0) and reply.arbitration_id == 0x13
    assert motor.handle(_msg(*payload(P.encode_velocity_control(3, 1.0))), 0.0) == []  # not its mode: silence
    (reply,) = motor.handle(_msg(*payload(P.encode_refresh_state(3))), 0.0)
    assert P.decode_temperatures(reply.data) == (25, 25)
    motor.handle(_msg(*payload(P.encode_basic_command(0x103, P.DISABLE_CMD))), 0.0)
    (reply,) = motor.handle(_msg(*payload(P.encode_save_params(3))), 0.0)
    assert bytes(reply.data[:4]) == bytes([3, 0, 0xAA, 0x01])
    motor.inject_fault("rotor_over_temp")
    (reply,) = motor.handle(_msg(*payload(P.encode_refresh_state(3))), 0.0)
    assert P.decode_fault(reply.data).name == "COIL_OVER_TEMP"
    motor.handle(_msg(*payload(P.encode_basic_command(0x103, P.CLEAN_ERROR_CMD))), 0.0)
    assert motor.fault is None
