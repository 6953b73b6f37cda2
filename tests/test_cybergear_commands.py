"""CyberGear commands beyond the basic set, and ``wheelleg emulate``'s options (docs/protocols.md)."""
from __future__ import annotations

import struct
import threading
import time
import uuid

import can
import pytest

from wheelleg.dbc import cybergear as cg
from wheelleg.dbc import load_file
from wheelleg.emulators import cybergear as emu
from wheelleg.emulators.cybergear import CyberGear
from wheelleg.hil.cli import build_parser, main
from wheelleg.hil.commands import emulate

HOST = 0xFD


def request(ctype: int, motor: int = 1, data: bytes = bytes(8), host: int = HOST) -> can.Message:
    return can.Message(arbitration_id=cg.request_id(ctype, host, motor), data=data, is_extended_id=True)


def ask(motor: CyberGear, msg: can.Message, now_s: float = 0.0) -> can.Message:
    replies = motor.handle(msg, now_s)
    assert len(replies) == 1, replies
    return replies[0]


# -- type 4 shorter than 8 bytes ----------------------------------------------------------------
@pytest.mark.parametrize("dlc", range(0, 8))
def test_a_short_stop_stops(dlc):
    """The manual gives the stop's data (all zero; byte0 = 1 also clears faults), not its length."""
    motor = CyberGear(motor_id=1)
    ask(motor, request(cg.T_ENABLE))
    reply = cg.parse_reply_id(ask(motor, request(cg.T_STOP, data=bytes(dlc))).arbitration_id)
    assert motor.mode == emu.MODE_RESET and (reply.ctype, reply.mode) == (cg.T_FEEDBACK, emu.MODE_RESET)


@pytest.mark.parametrize("dlc, clears", [(0, False), (1, True), (3, True)])
def test_a_short_stop_clears_a_fault_only_with_byte0_1(dlc, clears):
    motor = CyberGear(motor_id=1)
    motor.inject_fault("FaultOverTemp")
    ask(motor, request(cg.T_STOP, data=bytes([1, 0, 0])[:dlc]))
    assert (motor.faults == frozenset()) == clears


# -- wheelleg emulate options --------------------------------------------------------------------
def test_a_uid_wider_than_64_bits_is_refused_with_one_line(capsys):
    assert main(["emulate", "cybergear", "-i", "virtual", "-c", "x", "--uid", hex(1 << 64)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "uid must fit the 64-bit MCU id" in err


def test_a_64_bit_uid_is_sent_whole():
    motor = CyberGear(motor_id=3, uid=0xFFFF_FFFF_FFFF_FFFE)
    assert int.from_bytes(ask(motor, request(cg.T_DEVICE_ID, 3)).data, "little") == 0xFFFF_FFFF_FFFF_FFFE


@pytest.mark.parametrize("argv, message", [
    (["--id", "1", "--id", "1"], "--id given twice"),
    (["--id", "1", "--id", "2", "--uid", "5"], "--uid names one motor"),
    (["--host", "300"], "host id must be 0..255"),
])
def test_bad_option_combinations_are_one_line_errors(capsys, argv, message):
    assert main(["emulate", "cybergear", "-i", "virtual", "-c", "x", *argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err


def test_one_process_emulates_a_robots_four_motors():
    channel = f"emulate-{uuid.uuid4().hex}"
    args = build_parser().parse_args(["emulate", "cybergear", "-i", "virtual", "-c", channel,
                                      "--id", "1", "--id", "2", "--id", "3", "--id", "4"])
    stop, result = threading.Event(), {}
    thread = threading.Thread(target=lambda: result.update(rc=emulate.run(args, stop)))
    driver = can.Bus(interface="virtual", channel=channel)
    thread.start()
    try:
        seen = {}
        deadline = time.monotonic() + 20.0  # bounds a hang only
        while len(seen) < 4 and time.monotonic() < deadline:
            for motor in range(1, 5):
                if motor not in seen:
                    driver.send(request(cg.T_DEVICE_ID, motor))
            while (reply := driver.recv(timeout=0.2)) is not None:
                seen[cg.reply_motor(reply.arbitration_id)] = cg.target(reply.arbitration_id)
        assert seen == {1: cg.DEVICE_ID_TARGET, 2: cg.DEVICE_ID_TARGET, 3: cg.DEVICE_ID_TARGET, 4: cg.DEVICE_ID_TARGET}
    finally:
        stop.set()
        thread.join(timeout=20.0)
        driver.shutdown()
    assert result["rc"] == 0


# -- run modes 7 (quick move) and 4 (zero return), types 0x14 (brake) and 5 (calibration) --------
WRITE = cg.T_PARAM_WRITE


def run(motor: CyberGear, seconds: float, t0: float = 0.0, dt: float = 0.001) -> tuple[float, list]:
    """Step the shaft alone; returns the end time and the frames the motor sent unasked."""
    t, out = t0, []
    for _ in range(round(seconds / dt)):
        motor.step_alone(dt, t + dt)
        t += dt
        out += motor.periodic(t)
    return t, out


def quick_move(run_flag: int, speed_raw: int) -> bytes:
    """The official debugger's jog bytes (run_mode 7, run flag, big-endian speed), as captured."""
    return bytes([0x05, 0x70, 0, 0, 7, run_flag]) + speed_raw.to_bytes(2, "big")


def test_quick_move_runs_at_the_jog_speed_and_its_stop_halts_it():
    motor = CyberGear(motor_id=1)
    ask(motor, request(cg.T_ENABLE))
    fb = ask(motor, request(WRITE, data=quick_move(1, 0x9554)))  # +5 rad/s, truncated as the debugger sends it
    assert cg.parse_reply_id(fb.arbitration_id).ctype == cg.T_FEEDBACK and motor.run_mode == 7
    t, _ = run(motor, 1.0)
    assert motor.shaft.speed == pytest.approx(5.0, abs=0.2)
    ask(motor, request(WRITE, data=quick_move(0, 0x7FFF)))
    run(motor, 1.0, t)
    assert abs(motor.shaft.speed) < 0.1 and motor.run_mode == 7


def test_the_jog_turns_a_stopped_motor_without_an_enable():
    """The debugger's jog buttons send only the run_mode-7 write: its run flag starts a motor in reset mode."""
    motor = CyberGear(motor_id=1)
    fb = ask(motor, request(WRITE, data=quick_move(1, 0x9554)))
    assert cg.parse_reply_id(fb.arbitration_id).mode == 2  # the answer already says run
    t, _ = run(motor, 1.0)
    assert motor.shaft.speed == pytest.approx(5.0, abs=0.2)
    ask(motor, request(WRITE, data=quick_move(0, 0x7FFF)))
    run(motor, 1.0, t)
    assert abs(motor.shaft.speed) < 0.1
    motor.inject_fault("FaultOverTemp")
    ask(motor, request(WRITE, data=quick_move(1, 0x9554)))
    assert motor.mode == 0  # a latched fault still keeps it stopped


def test_quick_move_from_the_dbc_reads_back_run_mode_7_and_runs_backwards():
    motor = CyberGear(motor_id=1)
    jog = load_file(cg.ID_DBC).get_message_by_name("CG_QuickMove")
    data = jog.encode({"Index": 0x7005, "RunMode": 7, "Run": 1, "Speed": -5.0})
    assert data == quick_move(1, 0x6AAA)  # the debugger's capture for -5 rad/s
    ask(motor, request(WRITE, data=data))
    reply = ask(motor, request(cg.T_PARAM_READ, data=bytes([0x05, 0x70] + [0] * 6)))
    assert reply.data[0:2] == b"\x05\x70" and reply.data[4] == 7
    ask(motor, request(cg.T_ENABLE))
    run(motor, 1.0)
    assert motor.shaft.speed == pytest.approx(-5.0, abs=0.2)


def test_zero_return_drives_the_shaft_back_to_the_zero():
    motor = CyberGear(motor_id=1)
    motor.shaft.angle = 1.5
    ask(motor, request(cg.T_SET_ZERO, data=bytes([1] + [0] * 7)))
    motor.shaft.angle = 2.5  # 1 rad from the zero
    ask(motor, request(WRITE, data=bytes([0x05, 0x70, 0, 0, 4, 0, 0, 0])))
    ask(motor, request(cg.T_ENABLE))
    assert motor.run_mode == 4
    run(motor, 3.0)
    assert motor.mech_pos == pytest.approx(0.0, abs=0.02)


def test_brake_answers_mode_3_and_stops_a_spinning_shaft_until_enabled_again():
    motor = CyberGear(motor_id=1)
    motor.params["run_mode"] = 2
    ask(motor, request(cg.T_ENABLE))
    motor.params["spd_ref"] = 3.0
    t, _ = run(motor, 1.0)
    assert motor.shaft.speed == pytest.approx(3.0, abs=0.2)
    reply = cg.parse_reply_id(ask(motor, request(cg.T_BRAKE)).arbitration_id)
    assert (reply.ctype, reply.mode) == (cg.T_FEEDBACK, emu.MODE_BRAKE)
    assert motor.firmware_torque() < 0.0  # the shorted windings brake
    t, _ = run(motor, 1.0, t)
    assert abs(motor.shaft.speed) < 0.05 and motor.mode == emu.MODE_BRAKE
    assert cg.parse_reply_id(ask(motor, request(cg.T_ENABLE)).arbitration_id).mode == emu.MODE_RUN
    run(motor, 1.0, t)
    assert motor.shaft.speed == pytest.approx(3.0, abs=0.2)


def test_calibration_answers_cali_mode_then_sends_the_offset_once():
    motor = CyberGear(motor_id=1)
    motor.inject_fault("FaultNotCalibrated")
    ask(motor, request(cg.T_STOP, data=bytes([1] + [0] * 7)))
    reply = cg.parse_reply_id(ask(motor, request(cg.T_CALIBRATE)).arbitration_id)
    assert (reply.ctype, reply.mode) == (cg.T_FEEDBACK, emu.MODE_CALI)
    t, out = run(motor, emu.CALIBRATION_S * 0.9)
    assert out == [] and motor.mode == emu.MODE_CALI
    _, out = run(motor, emu.CALIBRATION_S * 0.2, t)
    assert len(out) == 1
    rid = cg.parse_reply_id(out[0].arbitration_id)
    assert (rid.ctype, rid.motor_id, rid.host) == (cg.T_CALIBRATE, 1, HOST)
    assert struct.unpack("<f", out[0].data[0:4])[0] == pytest.approx(emu.ELEC_OFFSET_RAD)
    assert motor.mode == emu.MODE_RESET


def test_a_stop_aborts_a_calibration():
    motor = CyberGear(motor_id=1)
    ask(motor, request(cg.T_CALIBRATE))
    ask(motor, request(cg.T_STOP))
    assert run(motor, emu.CALIBRATION_S * 2)[1] == [] and motor.mode == emu.MODE_RESET
