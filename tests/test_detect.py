"""Offline detection and the fail-safe reaction (seed 000's detect task), without the rig."""
import math

import can
import pytest

from controller import constants as C
from controller import detect
from controller import params as P
from controller.modes import ENABLED, Mode
from controller.node import Controller
from controller.state import CAN1, CAN2
from dbc import cybergear as cg
from dbc import load_bus, truncating_raw

DB1, DB2 = load_bus("can1"), load_bus("can2")
HEARTBEAT = DB1.get_message_by_name("Heartbeat")
ALL_ONLINE = {rule.name: 0.0 for rule in detect.RULES}


# -- detect.check --------------------------------------------------------------------------
@pytest.mark.parametrize("bit,rule", list(enumerate(detect.RULES)))
def test_each_device_goes_offline_after_its_own_threshold(bit, rule):
    now = 1.0
    seen = {r.name: now for r in detect.RULES}  # everyone else heard just now
    seen[rule.name] = now - rule.offline_after_s + 1e-6
    just_in = detect.check(seen, now)
    assert just_in.offline_mask == 0 and just_in.warning_level == 0 and just_in.balance_ok
    seen[rule.name] = now - rule.offline_after_s - 1e-6
    out = detect.check(seen, now)
    assert out.offline_mask == 1 << bit and out.offline_count == 1
    assert out.warning_level == rule.warning_level and out.balance_ok == (not rule.needed_for_balance)


def test_the_highest_level_and_the_count_of_several_offline_devices():
    seen = dict(ALL_ONLINE, remote=-1.0, left_wheel=-1.0)
    report = detect.check(seen, 0.005)
    assert report.offline_count == 2
    assert report.warning_level == max(r.warning_level for r in detect.RULES if r.name in ("remote", "left_wheel"))
    assert report.offline_mask == (1 << C.DEVICES.index("remote")) | (1 << C.DEVICES.index("left_wheel"))


def test_every_device_starts_offline():
    report = detect.check({}, 0.0)
    assert report.offline_count == len(detect.RULES) and report.warning_level == 5 and not report.balance_ok


def test_a_faulted_device_counts_like_an_offline_one():
    report = detect.check(ALL_ONLINE, 0.0, faulted={"right_rear_hip"})
    assert report.offline_mask == 1 << C.DEVICES.index("right_rear_hip")
    assert report.warning_level == 4 and not report.balance_ok


def test_a_reenable_press_is_remembered_only_while_the_motors_are_off():
    req = detect.ReenableRequest(0.05)
    assert not req.update(True, motors_off=False, now_s=0.0)  # pressed while running: forgotten
    assert req.update(True, motors_off=True, now_s=1.0)
    assert req.update(False, motors_off=True, now_s=1.05) and not req.pending(1.051)
    req.update(True, motors_off=True, now_s=2.0)
    req.consume()
    assert not req.pending(2.0)


# -- the controller's reaction ---------------------------------------------------------------
def _std(name, **signals):
    msg = DB1.get_message_by_name(name)
    return can.Message(arbitration_id=msg.frame_id, data=msg.encode(signals, strict=False), is_extended_id=False)


def _joint_feedback(motor_id, faults=()):
    msg = DB2.get_message_by_name("CG_Feedback")
    raw = {s.name: truncating_raw(s, 0.0) for s in msg.signals}
    raw["Temp"] = 300
    return can.Message(arbitration_id=cg.reply_id(cg.T_FEEDBACK, motor_id, C.CG_HOST_ID, 2, faults),
                       data=msg.encode(raw, scaling=False), is_extended_id=True)


class Robot:
    """Feeds a Controller the frames of an upright robot, tick by tick, with devices switchable off."""

    def __init__(self):
        self.ctl = Controller()
        self.silent: set = set()
        self.faults: dict = {}
        self.reenable = 0
        self.tick_no = 0
        self.sent: list = []

    def frames(self):
        out = [(CAN2, _joint_feedback(j.motor_id, self.faults.get(j.name, ())))
               for j in C.JOINTS if j.name not in self.silent]
        out += [(CAN1, _std(f"C620_Feedback_{w.esc_id}", RotorAngle=0, RotorSpeed=0, TorqueCurrent=0,
                            MotorTemp=30)) for w in C.WHEELS if w.name not in self.silent]
        if "imu" not in self.silent:
            out += [(CAN1, _std("IMU_Orientation", QuatW=1.0, QuatX=0.0, QuatY=0.0, QuatZ=0.0)),
                    (CAN1, _std("IMU_Gyro", RateX=0.0, RateY=0.0, RateZ=0.0)),
                    (CAN1, _std("IMU_Accel", AccX=0.0, AccY=0.0, AccZ=9.81))]
        if "remote" not in self.silent:
            out.append((CAN1, _std("Operator", Mode=1, Jump=0, JumpForward=0, Reenable=self.reenable,
                                   SpeedX=0.0, YawRate=0.0, LegLength=0.17, Pitch=0.0, Roll=0.0)))
        return out

    def step(self, n: int = 1):
        for _ in range(n):
            now = self.tick_no * P.CONTROL_PERIOD
            for bus, msg in self.frames():
                self.ctl.on_frame(msg, bus, now)
            result = self.ctl.tick(self.tick_no, now)
            self.sent.append(result)
            self.tick_no += 1
        return self.sent[-1]

    def heartbeat(self) -> dict:
        return HEARTBEAT.decode(bytes(self.sent[-1].frames[CAN1][-1].data))


def running_robot() -> Robot:
    robot = Robot()
    robot.step(5)
    assert robot.ctl.mode in ENABLED
    return robot


def _torques(result) -> list:
    return [m for m in result.frames[CAN2] if m.is_extended_id and cg.comm_type(m.arbitration_id) == cg.T_MOTION]


@pytest.mark.parametrize("device", [r.name for r in detect.RULES])
def test_a_needed_device_going_offline_disables_at_its_threshold(device):
    robot = running_robot()
    robot.silent.add(device)
    threshold_ticks = math.floor(detect.RULES[C.DEVICES.index(device)].offline_after_s / P.CONTROL_PERIOD + 1e-9)
    modes = [robot.step().mode for _ in range(threshold_ticks + 2)]
    first_off = modes.index(Mode.DISABLED)
    assert threshold_ticks - 1 <= first_off <= threshold_ticks  # never before the threshold, at once after
    result = robot.sent[-1]
    assert not _torques(result)  # stops only
    assert bytes([m for m in result.frames[CAN1] if m.arbitration_id == 0x200][0].data) == bytes(8)
    hb = robot.heartbeat()
    assert hb["OfflineMask"] == 1 << C.DEVICES.index(device) and hb["OfflineCount"] == 1
    assert hb["MotorsEnabled"] == 0


def test_coming_back_re_enables_only_on_the_operators_command():
    robot = running_robot()
    robot.silent.add("imu")
    robot.step(10)
    robot.silent.clear()
    robot.step(50)
    assert robot.ctl.mode == Mode.DISABLED and robot.heartbeat()["OfflineMask"] == 0
    robot.reenable = 1
    robot.step()
    assert robot.ctl.mode in ENABLED


@pytest.mark.parametrize("fault", ["FaultOverTemp", "FaultOverCurrent", "FaultUnderVoltage", "FaultMagEncoder"])
def test_a_cybergear_fault_bit_disables_at_once_and_one_press_clears_and_enables(fault):
    robot = running_robot()
    robot.faults["left_rear_hip"] = {fault}
    assert robot.step().mode == Mode.DISABLED
    hb = robot.heartbeat()
    assert hb["FaultLatched"] == 1 and hb["OfflineMask"] == 1 << C.DEVICES.index("left_rear_hip")
    robot.step(10)
    assert robot.ctl.mode == Mode.DISABLED  # latched: no re-enable on its own
    robot.reenable = 1
    pressed = robot.step()
    stops = [m for m in pressed.frames[CAN2] if cg.comm_type(m.arbitration_id) == cg.T_STOP]
    assert stops and all(m.data[0] == 1 for m in stops)  # clear-fault stops
    robot.faults.clear()  # the motor answers clean after the clear
    robot.step()
    assert robot.ctl.mode in ENABLED


def test_a_press_while_balancing_is_not_a_standing_order():
    robot = running_robot()
    robot.reenable = 1
    robot.step()
    robot.reenable = 0
    robot.silent.add("left_wheel")
    robot.step(8)
    robot.silent.clear()
    robot.step(5)
    assert robot.ctl.mode == Mode.DISABLED


def test_bad_frames_are_counted_in_the_heartbeat_and_change_nothing():
    robot = running_robot()
    mode = robot.ctl.mode
    for data in (b"\x00\x01", b"\x00" * 8):  # short DLC; zero quaternion
        robot.ctl.on_frame(can.Message(arbitration_id=0x100, data=data, is_extended_id=False), CAN1, 0.01)
    robot.step()
    assert robot.heartbeat()["BadFrames"] == 2 and robot.ctl.mode == mode
