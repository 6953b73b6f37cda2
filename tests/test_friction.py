"""The hips' Coulomb feed-forward (controller/friction.py) and where the chassis adds it."""
import math

import pytest

from wheelleg.controller import chassis as chassis_module
from wheelleg.controller import constants as C
from wheelleg.controller import fivebar
from wheelleg.controller.chassis import ChassisController, Output
from wheelleg.controller.friction import coulomb_feed_forward
from wheelleg.controller.legs import LegState


@pytest.mark.parametrize("speed, move, expected", [
    (0.0, 0.0, 0.0),  # at rest, asked nothing: nothing added
    (3.0, 0.0, 0.2),  # turning: the full friction, in the direction it turns
    (-3.0, 0.0, -0.2),
    (0.0, 1.0, 0.2),  # at rest, asked to turn: the friction it must break, that way
    (0.0, -1.0, -0.2),
    (0.5, 0.0, 0.1),  # half the speed band: half of it
    (0.0, 0.05, 0.05),  # a quarter of the torque band: a quarter of it
    (3.0, -1.0, 0.2),  # turning fast one way, asked to brake: still the way it turns
    (0.5, -1.0, 0.0),  # turning slowly one way, asked the other: half each way, nothing
])
def test_the_feed_forward_follows_the_joint_s_motion_or_what_it_is_asked(speed, move, expected):
    assert coulomb_feed_forward(speed, move, 0.2, 1.0, 0.2) == pytest.approx(expected)


def _leg(dphi1, dphi4):
    kin = fivebar.forward_kinematics(*fivebar.inverse_kinematics(0.17, math.pi / 2))
    return LegState(kin, kin.L0, 0.0, 0.0, 0.0, 0.0, dphi1, dphi4)


def _shaft_torques(monkeypatch, friction, leg_state, tp_move):
    monkeypatch.setattr(chassis_module.C, "HIP_FRICTION", friction)
    out = Output()
    ChassisController()._hips(out, "left", leg_state, 17.0, 0.3, tp_move)
    return [out.hip_torque[j.motor_id] * j.sign for j in C.LEG_JOINTS["left"]]  # on phi1, phi4


def test_the_chassis_adds_the_believed_friction_on_each_hip_the_way_it_turns(monkeypatch):
    turning = _leg(2.0, -2.0)  # the front joint turning up phi1, the rear down phi4
    without = _shaft_torques(monkeypatch, 0.0, turning, 0.0)
    with_friction = _shaft_torques(monkeypatch, 0.15, turning, 0.0)
    assert with_friction[0] - without[0] == pytest.approx(0.15)
    assert with_friction[1] - without[1] == pytest.approx(-0.15)


def test_at_rest_the_chassis_breaks_friction_the_way_the_leg_is_asked_to_swing(monkeypatch):
    resting = _leg(0.0, 0.0)
    swing = 1.0  # N m of Tp beyond what holds the leg: both joints asked to turn
    base = _shaft_torques(monkeypatch, 0.0, resting, swing)
    pushed = _shaft_torques(monkeypatch, 0.15, resting, swing)
    t1, t4 = fivebar.joint_torques(resting.kin, 0.0, swing)
    assert [p - b for p, b in zip(pushed, base)] == pytest.approx([math.copysign(0.15, t1), math.copysign(0.15, t4)])
    assert _shaft_torques(monkeypatch, 0.15, resting, 0.0) == pytest.approx(base)  # asked nothing: nothing
