"""DJI C610/M2006 and GM6020 emulators: their command slots, feedback, motor lines and `wheelleg emulate`."""
from __future__ import annotations

import math
import threading
import time
import uuid

import can
import pytest

from wheelleg.dbc import load_file
from wheelleg.emulators.dji import C610, GM6020, GM6020_MODEL, M2006
from wheelleg.hil.cli import build_parser
from wheelleg.hil.commands import emulate

C610_DB, GM_DB = load_file("c610.dbc"), load_file("gm6020.dbc")


def group_frame(db, name: str, values: dict[str, float]) -> can.Message:
    """A host's group frame from the DBC (every other slot 0)."""
    msg = db.get_message_by_name(name)
    full = {s.name: 0.0 for s in msg.signals} | values
    return can.Message(arbitration_id=msg.frame_id, data=msg.encode(full), is_extended_id=False)


def feedback(device, now_s: float = 0.0) -> dict:
    msg = device.feedback_frame(now_s)
    return {"id": msg.arbitration_id, "data": bytes(msg.data),
            **(C610_DB if device.model is M2006 else GM_DB).decode_message(msg.arbitration_id, msg.data)}


def test_c610_takes_its_slot_of_0x200_and_0x1ff_within_10_a():
    esc2, esc6 = C610(2), C610(6)
    for esc in (esc2, esc6):
        esc.handle(group_frame(C610_DB, "C610_Cmd_1_4", {"ESC2_Current": 5.0, "ESC1_Current": -3.0}), 0.0)
        esc.handle(group_frame(C610_DB, "C610_Cmd_5_8", {"ESC6_Current": -2.0}), 0.0)
    assert esc2.output_torque(0.0) == pytest.approx(5.0 * 0.18, abs=1e-3)  # 0.18 N m/A, the M2006 manual
    assert esc6.output_torque(0.0) == pytest.approx(-2.0 * 0.18, abs=1e-3)
    raw = bytes([0x7F, 0xFF] * 4)  # 32767 in every slot: clamped to 10000, 10 A
    esc2.handle(can.Message(arbitration_id=0x200, data=raw, is_extended_id=False), 0.0)
    assert esc2.motor_current(0.0) == pytest.approx(10.0)
    assert esc2.handle(can.Message(arbitration_id=0x200, data=raw[:7], is_extended_id=False), 0.0) == []


def test_c610_feedback_is_0x200_plus_id_rotor_side_without_temperature():
    esc = C610(3)
    esc.shaft.angle, esc.shaft.speed = 0.1, 2.0  # output side
    fb = feedback(esc)
    assert fb["id"] == 0x203 and fb["data"][6:] == b"\0\0"
    assert fb["RotorSpeed"] == round(2.0 * 36 * 60 / (2 * math.pi))
    assert fb["RotorAngle"] == pytest.approx(math.degrees(0.1 * 36) % 360, abs=0.05)


def test_c610_back_emf_stops_the_drive_at_no_load_speed():
    esc = C610(1)
    esc.handle(group_frame(C610_DB, "C610_Cmd_1_4", {"ESC1_Current": 10.0}), 0.0)
    for k in range(4000):
        esc.step_alone(0.001, (k + 1) * 0.001)
    no_load = 500 * 2 * math.pi / 60
    assert 0.8 * no_load < esc.shaft.speed < no_load  # runs up, never beyond the 24 V no-load speed


def test_gm6020_voltage_and_current_frames_last_one_wins():
    m = GM6020(2)
    m.handle(group_frame(GM_DB, "GM6020_Current_1_4", {"Motor2_Current": 1.5}), 0.0)
    assert m.output_torque(0.0) == pytest.approx(1.5 * 0.741, abs=1e-3)
    m.handle(group_frame(GM_DB, "GM6020_Voltage_1_4", {"Motor2_Voltage": 2500}), 0.0)
    v = 0.1 * 24.0
    assert m.motor_current(0.0) == pytest.approx(v / GM6020_MODEL.resistance_ohm, rel=1e-3)
    m.shaft.speed = v / GM6020_MODEL.back_emf  # the speed where the back-EMF equals the voltage: no current
    assert m.motor_current(0.0) == pytest.approx(0.0, abs=1e-9)
    m.handle(group_frame(GM_DB, "GM6020_Voltage_1_4", {"Motor2_Voltage": 25000}), 0.0)
    m.shaft.speed = 0.0
    assert m.motor_current(0.0) == pytest.approx(3.0)  # stall: the drive's 3 A limit


def test_gm6020_ids_5_to_7_use_0x2ff_and_0x2fe_and_report_at_0x204_plus_id():
    m = GM6020(7)
    assert m.handle(group_frame(GM_DB, "GM6020_Current_1_4", {"Motor4_Current": 2.0}), 0.0) == []
    assert m.command == 0.0
    m.handle(group_frame(GM_DB, "GM6020_Current_5_7", {"Motor7_Current": -1.0}), 0.0)
    assert m.motor_current(0.0) == pytest.approx(-1.0, abs=1e-3)
    assert feedback(m)["id"] == 0x20B
    with pytest.raises(ValueError, match="1..7"):
        GM6020(8)


def test_gm6020_feedback_reports_current_and_heats_up():
    m = GM6020(1)
    m.handle(group_frame(GM_DB, "GM6020_Current_1_4", {"Motor1_Current": 2.0}), 0.0)
    m.advance(600.0, 600.0)  # stalled for one thermal time constant
    fb = feedback(m, 600.0)
    assert fb["TorqueCurrent"] == pytest.approx(2.0, abs=1e-3)
    settle = GM6020_MODEL.heat_k_per_a2 * 2.0 ** 2
    assert fb["MotorTemp"] == round(25.0 + settle * (1 - math.exp(-1.0)))
    assert fb["id"] == 0x205


def test_command_timeout_zeroes_the_output():
    m = GM6020(1, command_timeout_s=0.1)
    m.handle(group_frame(GM_DB, "GM6020_Current_1_4", {"Motor1_Current": 2.0}), 0.0)
    assert m.output_torque(0.05) != 0.0 and m.output_torque(0.2) == 0.0


def test_feedback_every_millisecond_and_silence_when_unplugged():
    esc = C610(1)
    frames = [f for k in range(10) for f in esc.periodic(k * 0.001)]
    assert [f.arbitration_id for f in frames] == [0x201] * 10
    esc.silent = True
    assert esc.periodic(0.02) == []


@pytest.mark.parametrize("name, ids, command, check", [
    ("gm6020", ["--id", "6"], ("GM6020_Current_5_7", {"Motor6_Current": 1.0}), 0x20A),
    ("c610", ["--id", "4"], ("C610_Cmd_1_4", {"ESC4_Current": 3.0}), 0x204),
])
def test_wheelleg_emulate_serves_the_family(name, ids, command, check):
    channel = f"emulate-{name}-{uuid.uuid4().hex}"
    args = build_parser().parse_args(["emulate", name, "-i", "virtual", "-c", channel, *ids])
    stop, result = threading.Event(), {}
    thread = threading.Thread(target=lambda: result.update(rc=emulate.run(args, stop)))
    host = can.Bus(interface="virtual", channel=channel)
    db = GM_DB if name == "gm6020" else C610_DB
    thread.start()
    try:
        first = host.recv(timeout=20.0)
        assert first is not None and first.arbitration_id == check
        host.send(group_frame(db, *command))
        deadline, speed = time.monotonic() + 20.0, 0
        while speed <= 0 and time.monotonic() < deadline:
            msg = host.recv(timeout=1.0)
            if msg is not None and msg.arbitration_id == check:
                speed = db.decode_message(msg.arbitration_id, msg.data)["RotorSpeed"]
        assert speed > 0  # the command turned the shaft
    finally:
        stop.set()
        thread.join(timeout=20.0)
        host.shutdown()
    assert not thread.is_alive() and result["rc"] == 0
