"""The controller's state parser and message builders, frame by frame."""
import math
import random

import can
import pytest

from wheelleg.controller import constants as C
from wheelleg.controller import messages
from wheelleg.controller.node import Controller
from wheelleg.controller.state import CAN1, CAN2, BusState
from wheelleg.dbc import cybergear as cg
from wheelleg.dbc import load_bus, truncating_raw

DB1, DB2 = load_bus("can1"), load_bus("can2")


def feedback(motor_id, pos=0.0, vel=0.0, torque=0.0, temp=30.0, mode=2, faults=()):
    msg = DB2.get_message_by_name("CG_Feedback")
    values = {"Pos": pos, "Vel": vel, "Torque": torque, "Temp": temp}
    raw = {s.name: truncating_raw(s, values[s.name]) if s.name != "Temp" else round(temp * 10)
           for s in msg.signals}
    return can.Message(arbitration_id=cg.reply_id(cg.T_FEEDBACK, motor_id, C.CG_HOST_ID, mode, faults),
                       data=msg.encode(raw, scaling=False), is_extended_id=True)


def std(name, **signals):
    msg = DB1.get_message_by_name(name)
    return can.Message(arbitration_id=msg.frame_id, data=msg.encode(signals, strict=False), is_extended_id=False)


def test_cybergear_feedback_is_parsed_with_mode_and_faults():
    bus = BusState()
    bus.update(feedback(2, pos=1.25, vel=-3.0, torque=2.0, faults={"FaultOverTemp"}), CAN2, 0.5)
    fb = bus.joints[2]
    assert fb.position == pytest.approx(1.25, abs=1e-3) and fb.speed == pytest.approx(-3.0, abs=2e-3)
    assert fb.torque == pytest.approx(2.0, abs=1e-3) and fb.mode == 2
    assert fb.faults == {"FaultOverTemp"} and fb.received_s == 0.5
    assert bus.bad_frames == 0


def test_wheel_feedback_speed_is_output_side_rad_s():
    bus = BusState()
    bus.update(std("C620_Feedback_1", RotorAngle=10.0, RotorSpeed=1920, TorqueCurrent=1.0, MotorTemp=40), CAN1, 0.0)
    assert bus.wheels[1].speed == pytest.approx(1920 * 2 * math.pi / 60 / C.M3508_GEAR)


def test_sync_returns_its_tick_and_operator_is_read():
    bus = BusState()
    assert bus.update(std("SYNC", Tick=42), CAN1, 0.0) == 42
    bus.update(std("Operator", Mode=2, SpeedX=1.5, YawRate=-0.5, LegLength=0.2, Pitch=0.1, Roll=0.0,
                   Jump=1, JumpForward=0, Reenable=0), CAN1, 0.0)
    op = bus.operator
    assert (op.mode, op.jump) == (2, True)
    assert op.speed == pytest.approx(1.5) and op.leg_length == pytest.approx(0.2)


@pytest.mark.parametrize("bad", [
    can.Message(arbitration_id=0x201, data=b"\x00\x01", is_extended_id=False),  # short DLC
    can.Message(arbitration_id=0x100, data=b"\x00" * 8, is_extended_id=False),  # zero quaternion
    can.Message(arbitration_id=0x201, data=bytes([0, 0, 0, 0, 0x7F, 0xFF, 0, 0]), is_extended_id=False),  # 40 A
])
def test_bad_frames_are_counted_and_ignored(bad):
    bus = BusState()
    before = (bus.wheels[1].received_s, bus.imu.quat)
    assert bus.update(bad, CAN1, 1.0) is None
    assert bus.bad_frames == 1
    assert (bus.wheels[1].received_s, bus.imu.quat) == before


def test_frames_for_other_motors_or_hosts_are_ignored_not_bad():
    bus = BusState()
    other_host = can.Message(arbitration_id=cg.reply_id(cg.T_FEEDBACK, 1, 0x00, 2), data=bytes(8),
                             is_extended_id=True)
    other_motor = feedback(9)
    for msg in (other_host, other_motor):
        bus.update(msg, CAN2, 0.0)
    assert bus.bad_frames == 0 and bus.joints[1].received_s == -math.inf


def test_random_frames_never_raise_out_of_the_controller():
    rng = random.Random(7)
    ctl = Controller()
    for i in range(3000):
        ext = rng.random() < 0.5
        msg = can.Message(arbitration_id=rng.getrandbits(29 if ext else 11), is_extended_id=ext,
                          data=bytes(rng.getrandbits(8) for _ in range(rng.randint(0, 8))))
        ctl.on_frame(msg, rng.choice([CAN1, CAN2]), i * 0.001)
        if i % 50 == 0:
            result = ctl.tick(i, i * 0.001)
            assert result.frames[CAN1][-1].arbitration_id == 0x710
    assert ctl.bus.frames == 3000


def test_disabled_controller_stops_every_joint_and_sends_zero_current():
    ctl = Controller()
    result = ctl.tick(0, 0.0)
    kinds = [cg.comm_type(m.arbitration_id) for m in result.frames[CAN2] if m.is_extended_id]
    assert kinds == [cg.T_STOP] * 4
    assert sorted(cg.target(m.arbitration_id) for m in result.frames[CAN2] if m.is_extended_id) == [1, 2, 3, 4]
    esc = [m for m in result.frames[CAN1] if m.arbitration_id == 0x200]
    assert esc and bytes(esc[0].data) == bytes(8)


def test_torque_command_id_carries_the_torque():
    msg = messages.joint_torque(3, -4.5)
    assert cg.target(msg.arbitration_id) == 3
    assert cg.motion_torque(msg.arbitration_id) == pytest.approx(-4.5, abs=24 / 65535)
