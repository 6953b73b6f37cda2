"""Offline detection and the fail-safe reaction (the design document's detect task), without the rig."""
import math

import can
import pytest
from controller_feed import Robot

from wheelleg.controller import constants as C
from wheelleg.controller import detect
from wheelleg.controller import params as P
from wheelleg.controller.modes import ENABLED, Mode
from wheelleg.controller.state import CAN1, CAN2
from wheelleg.dbc import cybergear as cg

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


def test_an_esc_follows_its_command_within_the_tolerance_or_when_back_emf_caps_it():
    fast = 0.9 * C.M3508_NO_LOAD_SPEED
    assert detect.esc_follows((3.0,), 2.5, 0.0, 1.0, 0.8) and not detect.esc_follows((3.0,), 1.5, 0.0, 1.0, 0.8)
    assert detect.esc_follows((3.0,), 0.0, fast, 1.0, 0.8)  # driving near no-load: the current is capped
    assert not detect.esc_follows((-3.0,), 0.0, fast, 1.0, 0.8)  # braking is never capped


def test_a_late_feedback_within_the_recent_commands_follows():
    """A ramp 0 -> 6 A reported one tick late is inside the range of the last two commands."""
    assert detect.esc_follows((0.0, 6.0), 0.2, 0.0, 1.0, 0.8)
    assert detect.esc_follows((0.0, 6.0), 3.0, 0.0, 1.0, 0.8)
    assert not detect.esc_follows((0.0, 6.0), 7.5, 0.0, 1.0, 0.8)
    assert not detect.esc_follows((0.0, 6.0), -1.5, 0.0, 1.0, 0.8)


def _watch_run(watch, commands, reported, t0=0.0):
    """Feed (command sent, current reported next tick) pairs; True if it latched."""
    latched = False
    for k, (cmd, rep) in enumerate(zip(commands, reported)):
        latched = watch.update(rep, 0.0, t0 + k * P.CONTROL_PERIOD)
        watch.commanded(cmd)
    return latched


def test_an_esc_watch_rides_out_one_tick_of_feedback_latency_but_not_a_held_current():
    ramp = [1.5 * min(k % 24, 24 - k % 24) - 9.0 for k in range(48)]  # +-9 A triangle, 1.5 A a tick
    late = [0.0, 0.0] + ramp[:-2]  # answered two ticks after being sent (one tick late)
    assert _watch_run(detect.EscWatch(1.0, 0.010, 0.8, window=1), ramp, late)  # the old watch: false fault
    assert not _watch_run(detect.EscWatch(1.0, 0.010, 0.8, window=2), ramp, late)
    held = [4.3] * 40
    assert _watch_run(detect.EscWatch(1.0, 0.010, 0.8, window=2), ramp, held)


def test_an_esc_watch_latches_after_a_lasting_mismatch_and_clears_on_command():
    watch = detect.EscWatch(1.0, 0.010, 0.8)
    assert not any(watch.update(4.0, 0.0, k * 0.002) for k in range(5))  # 8 ms: not yet
    assert watch.update(4.0, 0.0, 0.010)
    assert watch.update(0.0, 0.0, 0.012)  # looks well again: still latched
    watch.clear()
    assert not watch.update(0.0, 0.0, 0.014)
    watch.update(4.0, 0.0, 0.016)
    assert not watch.update(0.5, 0.0, 0.018) and not watch.update(4.0, 0.0, 0.026)  # the run restarted


# -- the controller's reaction ---------------------------------------------------------------
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


def test_a_frozen_imu_is_offline_after_its_threshold():
    """Hung IMU firmware repeating its frames: no new data, so offline (the robot would fall unseen)."""
    robot = running_robot()
    robot.imu_frozen = True
    threshold_ticks = round(detect.RULES[C.DEVICES.index("imu")].offline_after_s / P.CONTROL_PERIOD)
    modes = [robot.step().mode for _ in range(threshold_ticks + 2)]
    assert Mode.DISABLED in modes[threshold_ticks - 1:] and Mode.DISABLED not in modes[:threshold_ticks - 1]
    assert robot.heartbeat()["OfflineMask"] == 1 << C.DEVICES.index("imu")


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


def test_a_c620_holding_its_current_is_a_latched_fault_until_reenable():
    robot = running_robot()
    robot.esc_held[2] = 5.0  # right wheel: 5 A whatever it is told
    modes = [robot.step().mode for _ in range(8)]
    assert modes.index(Mode.DISABLED) in (5, 6)  # 10 ms of mismatch, then at once
    hb = robot.heartbeat()
    assert hb["FaultLatched"] == 1 and hb["OfflineMask"] == 1 << C.DEVICES.index("right_wheel")
    robot.esc_held.clear()  # it follows again: still faulted until the operator says so
    robot.step(10)
    assert robot.ctl.mode == Mode.DISABLED and robot.heartbeat()["FaultLatched"] == 1
    robot.reenable = 1
    robot.step(3)
    assert robot.ctl.mode in ENABLED and robot.heartbeat()["FaultLatched"] == 0
