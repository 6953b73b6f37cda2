"""The quadruped's trot: the pairs' clock, the swing curve, Raibert's touchdown point, leg
odometry, and whole trot cycles on a robot whose joints follow their set points."""
from __future__ import annotations

import math

import numpy as np
import pytest

from wheelleg.controller.quadruped import constants as C
from wheelleg.controller.quadruped import legs, stance
from wheelleg.controller.quadruped import params as P
from wheelleg.controller.quadruped.gait import (Trot, Velocity, in_stance, leg_phases, odometry_velocity,
                                                raibert_touchdown, swing_point)
from wheelleg.controller.quadruped.getup import stand_pose
from wheelleg.controller.quadruped.sensed import Sensed

DT = P.CONTROL_PERIOD


@pytest.mark.parametrize("clock", np.linspace(0.0, 0.999, 37))
def test_one_diagonal_pair_is_down_at_every_instant(clock):
    down = in_stance(leg_phases(clock))
    assert down[0] == down[3] and down[1] == down[2] and down[0] != down[1]


def test_the_swing_curve_leaves_and_lands_at_rest_and_peaks_mid_swing():
    start, end = np.array([-0.05, 0.1, -0.2]), np.array([0.06, 0.12, -0.2])
    p0, v0 = swing_point(start, end, 0.0, 0.06, 0.2)
    p1, v1 = swing_point(start, end, 1.0, 0.06, 0.2)
    mid, _ = swing_point(start, end, 0.5, 0.06, 0.2)
    assert p0 == pytest.approx(start) and p1 == pytest.approx(end)
    assert v0 == pytest.approx(np.zeros(3)) and v1 == pytest.approx(np.zeros(3))
    assert mid[2] == pytest.approx(-0.2 + 0.06)
    s, ds = 0.3, 1e-6
    numeric = (swing_point(start, end, s + ds, 0.06, 0.2)[0] - swing_point(start, end, s - ds, 0.06, 0.2)[0]) / (
        2 * ds * 0.2)
    assert swing_point(start, end, s, 0.06, 0.2)[1] == pytest.approx(numeric, rel=1e-5)


def test_raibert_lands_half_a_stance_ahead_and_further_when_too_fast():
    hip = np.array([0.164, -0.136, -0.19])
    on_speed = raibert_touchdown(hip, np.array([0.5, 0.0]), np.array([0.5, 0.0]), 0.0, 0.2, 0.03, 0.1)
    assert on_speed == pytest.approx(hip + [0.05, 0.0, 0.0])
    fast = raibert_touchdown(hip, np.array([0.7, 0.0]), np.array([0.5, 0.0]), 0.0, 0.2, 0.03, 0.1)
    assert fast[0] == pytest.approx(hip[0] + 0.07 + 0.03 * 0.2)
    capped = raibert_touchdown(hip, np.array([3.0, 0.0]), np.array([0.0, 0.0]), 0.0, 0.2, 0.03, 0.1)
    assert capped[0] == pytest.approx(hip[0] + 0.1)
    turning = raibert_touchdown(hip, np.zeros(2), np.zeros(2), 1.0, 0.2, 0.03, 0.1)
    assert turning[:2] == pytest.approx(hip[:2] + 0.1 * np.array([-hip[1], hip[0]]))  # along the yaw's circle


def test_leg_odometry_reads_the_body_velocity_from_the_stance_feet():
    q = stand_pose(P.HEIGHT_NOMINAL)
    body_velocity = np.array([0.4, -0.1, 0.0])
    qd = np.array([np.linalg.solve(legs.jacobian_of(q, leg), -body_velocity) for leg in range(4)])
    sensed = Sensed(q, qd, np.zeros((4, 3)), np.zeros(3), np.zeros(3))
    assert odometry_velocity(sensed, np.array([True, False, False, True])) == pytest.approx(body_velocity[:2])
    assert odometry_velocity(sensed, np.zeros(4, dtype=bool)) is None


class FollowingRobot:
    """Joints that reach their set points at their set rates; level, heading as integrated."""

    def __init__(self):
        self.q = stand_pose(P.HEIGHT_NOMINAL)
        self.qd = np.zeros((4, 3))
        self.yaw = 0.0

    def sensed(self) -> Sensed:
        return Sensed(self.q, self.qd, np.zeros((4, 3)), np.array([0.0, 0.0, self.yaw]), np.zeros(3))

    def run(self, trot: Trot, asked: Velocity, seconds: float, yaw_rate_of=None):
        out = []
        for _ in range(round(seconds / DT)):
            commands = trot.step(self.sensed(), asked, P.HEIGHT_NOMINAL)
            self.q, self.qd = commands.q, commands.qd
            if yaw_rate_of is not None:
                self.yaw += yaw_rate_of(trot) * DT
            out.append((commands, trot.feet.copy(), in_stance(leg_phases(trot.clock))))
        return out


def _trotting(asked: Velocity, seconds: float):
    robot = FollowingRobot()
    trot = Trot()
    trot.start(robot.sensed())
    return trot, robot.run(trot, asked, seconds)


def test_stance_feet_travel_back_at_the_set_speed_and_swing_feet_lift_and_land():
    trot, ticks = _trotting(Velocity(vx=0.5), 3.0)
    assert trot.velocity_set[0] == pytest.approx(0.5)
    ground = -(P.HEIGHT_NOMINAL - C.FOOT_RADIUS)
    late = ticks[len(ticks) // 2:]
    for (_, feet, down), (_, after, down_after) in zip(late, late[1:]):
        both = down & down_after
        assert (after - feet)[both, 0] == pytest.approx(np.full(both.sum(), -0.5 * DT), abs=1e-9)
        assert after[both, 2] == pytest.approx(np.full(both.sum(), ground))
        assert np.all(after[:, 2] <= ground + P.SWING_HEIGHT + 1e-9)
        assert np.abs(after - feet).max() < 0.02  # no foot jumps, at lift-off and touchdown too
    peak = max(feet[:, 2].max() for _, feet, _ in late)
    assert peak == pytest.approx(ground + P.SWING_HEIGHT, abs=1e-3)
    # each foot lands ahead of its hip by half a stance's travel and leaves behind it by as much
    xs = np.array([feet[0, 0] for _, feet, down in late if down[0]])
    assert xs.max() == pytest.approx(C.HIP_X + 0.05, abs=0.005)
    assert xs.min() == pytest.approx(C.HIP_X - 0.05, abs=0.005)


def test_only_the_stance_pair_gets_the_weight_s_feed_forward():
    _, ticks = _trotting(Velocity(vx=0.3), 1.0)
    for commands, _, down in ticks[10:]:
        assert np.all(commands.tau[~down] == 0.0)
        assert np.all(commands.tau[down, 2] > 0.5)
        assert np.all(commands.kp[down] == P.STANCE_KP) and np.all(commands.kp[~down] == P.SWING_KP)


@pytest.mark.parametrize("asked", [Velocity(vx=0.5), Velocity(vx=-0.3, vy=0.2), Velocity(yaw_rate=1.0),
                                   Velocity(vx=0.8, yaw_rate=1.5)], ids=str)
def test_the_joints_stay_in_their_ranges(asked):
    _, ticks = _trotting(asked, 2.0)
    for commands, _, _ in ticks:
        assert np.all(commands.q > legs.LOWER + 1e-6) and np.all(commands.q < legs.UPPER - 1e-6)


def test_a_turn_in_place_reaches_the_heading_its_rate_integrates_to():
    """The robot turns 70% as fast as its feet ask (slip): the heading correction makes up for it."""
    robot = FollowingRobot()
    trot = Trot()
    trot.start(robot.sensed())
    turn_s = math.radians(90.0) / 1.0
    robot.run(trot, Velocity(yaw_rate=1.0), turn_s, yaw_rate_of=lambda t: 0.7 * t.feet_yaw_rate)
    robot.run(trot, Velocity(), 2.0, yaw_rate_of=lambda t: 0.7 * t.feet_yaw_rate)
    assert math.degrees(robot.yaw) == pytest.approx(90.0, abs=2.0)


def test_stopping_puts_every_foot_down_within_one_swing_and_keeps_them_down():
    robot = FollowingRobot()
    trot = Trot()
    trot.start(robot.sensed())
    robot.run(trot, Velocity(vx=0.4), 1.1)  # mid-cycle
    assert not trot.settled
    ground = -(P.HEIGHT_NOMINAL - C.FOOT_RADIUS)
    steps = 0
    while not trot.settled:
        trot.step(robot.sensed(), Velocity(vx=0.4), P.HEIGHT_NOMINAL, stopping=True)
        steps += 1
    assert steps * DT <= (1.0 - P.DUTY) * P.GAIT_PERIOD + DT
    for _ in range(100):
        trot.step(robot.sensed(), Velocity(vx=0.4), P.HEIGHT_NOMINAL, stopping=True)
        assert trot.feet[:, 2] == pytest.approx(np.full(4, ground))
    assert trot.velocity_set == pytest.approx(np.zeros(3))  # slowed to rest, whatever is asked
