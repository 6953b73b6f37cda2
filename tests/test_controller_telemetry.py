"""The controller's tick-to-tick state is typed; its debug record is a projection nothing reads.

Two controllers are fed the same scripted robot (legs rising to the commanded
length, then a jump press): one records debug, one does not, and a third
records a debug projection with every key renamed. Their frames must be the
same tick for tick, so no control path reads the debug record.
"""
from __future__ import annotations

import math

import can
import pytest

from controller_feed import DB1, DB2, Robot, _std
from wheelleg.controller import constants as C
from wheelleg.controller import fivebar
from wheelleg.controller import params as P
from wheelleg.controller import telemetry
from wheelleg.controller.modes import Mode
from wheelleg.controller.state import CAN1, CAN2
from wheelleg.dbc import cybergear as cg
from wheelleg.dbc import truncating_raw

TICKS = 900
JUMP_TICKS = range(500, 510)  # the operator holds Jump for 20 ms


def _leg_length(tick: int) -> float:
    """Scripted L0 (m): folded at 0.10, rising to the asked 0.17 over 0.5 s, then a squat and a thrust."""
    t = tick * P.CONTROL_PERIOD
    if tick < 500:
        return min(0.10 + 0.14 * t, 0.17)
    return 0.17 - 0.04 * abs(math.sin(6.0 * (t - 1.0)))


def _joint(joint: C.Joint, tick: int) -> can.Message:
    phi1, phi4 = fivebar.inverse_kinematics(_leg_length(tick), math.pi / 2)
    q = fivebar.shaft_from_phi(joint, phi1 if joint.hip == "A" else phi4)
    msg = DB2.get_message_by_name("CG_Feedback")
    raw = {s.name: truncating_raw(s, 0.0) for s in msg.signals}
    raw["Pos"], raw["Temp"] = truncating_raw(msg.get_signal_by_name("Pos"), q), 300
    return can.Message(arbitration_id=cg.reply_id(cg.T_FEEDBACK, joint.motor_id, C.CG_HOST_ID, 2),
                       data=msg.encode(raw, scaling=False), is_extended_id=True)


class ScriptedRobot(Robot):
    """An upright robot whose legs follow ``_leg_length`` and whose operator presses Jump once."""

    def __init__(self, **controller_options):
        super().__init__()
        self.ctl = type(self.ctl)(**controller_options)

    def frames(self):
        out = [(bus, msg) for bus, msg in super().frames()
               if bus == CAN1 and msg.arbitration_id != DB1.get_message_by_name("Operator").frame_id]
        out += [(CAN2, _joint(j, self.tick_no)) for j in C.JOINTS]
        out.append((CAN1, _std("Operator", Mode=1, Jump=int(self.tick_no in JUMP_TICKS), JumpForward=0,
                               Reenable=0, SpeedX=0.0, YawRate=0.0, LegLength=0.17, Pitch=0.0, Roll=0.0)))
        return out


def _frames(result) -> list:
    return [(bus, m.arbitration_id, bytes(m.data)) for bus in (CAN1, CAN2) for m in result.frames[bus]]


def _renamed(last) -> dict:
    return {f"renamed_{key}": value for key, value in ORIGINAL_RECORD(last).items()}


ORIGINAL_RECORD = telemetry.debug_record


@pytest.mark.slow
def test_commands_do_not_depend_on_the_debug_record(monkeypatch):
    recording, quiet = ScriptedRobot(), ScriptedRobot(record_debug=False)
    recording.step(TICKS)
    quiet.step(TICKS)
    monkeypatch.setattr(telemetry, "debug_record", _renamed)
    monkeypatch.setattr("wheelleg.controller.node.debug_record", _renamed)
    renamed = ScriptedRobot()
    renamed.step(TICKS)
    modes = {r.mode for r in recording.sent}
    assert {Mode.STAND_UP, Mode.BALANCE, Mode.JUMP} <= modes, modes  # the feed exercises what reads ``last``
    for tick, (a, b, c) in enumerate(zip(recording.sent, quiet.sent, renamed.sent)):
        assert _frames(a) == _frames(b) == _frames(c), tick
        assert not b.debug
        assert c.debug.keys() == {f"renamed_{k}" for k in a.debug}
    assert recording.ctl.last == quiet.ctl.last


def test_the_debug_record_is_the_projection_of_the_typed_last_output():
    robot = ScriptedRobot()
    result = robot.step(450)
    last = robot.ctl.last
    assert result.debug == telemetry.debug_record(last)
    assert result.debug["left_L0"] == last.chassis.legs["left"].length_m == last.leg_lengths_m()[0]
    assert result.debug["right_theta"] == last.chassis.legs["right"].theta_rad
    assert result.debug["speed"] == last.chassis.speed_m_s
    assert result.debug["Fn_left"] == last.support_n["left"]
    assert result.debug["jump_phase"] == int(last.jump_phase)
    assert abs(last.leg_lengths_m()[0] - 0.17) < 0.002  # the typed state follows the scripted legs


def test_disabled_ticks_keep_the_last_output_and_record_nothing():
    robot = ScriptedRobot()
    robot.step(300)
    assert robot.ctl.last is not None
    robot.silent.add("imu")  # offline: the controller disables
    while robot.step().mode in (Mode.STAND_UP, Mode.BALANCE):
        assert robot.tick_no < 400, "never disabled"
    last = robot.ctl.last
    for result in (robot.step() for _ in range(50)):
        assert result.mode == Mode.DISABLED and result.debug == {}
    assert robot.ctl.last is last
