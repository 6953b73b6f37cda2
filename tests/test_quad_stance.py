"""The quadruped's stance: posture by IK, the force distribution and its torques (sign trap
included), and the balance stand closing its posture loop on a kinematic robot."""
from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from wheelleg.controller.quadruped import constants as C
from wheelleg.controller.quadruped import kinematics as K
from wheelleg.controller.quadruped import legs, stance
from wheelleg.controller.quadruped import params as P
from wheelleg.controller.quadruped.balance import BalanceStand, Posture
from wheelleg.controller.quadruped.rotations import rpy_matrix
from wheelleg.controller.quadruped.sensed import Sensed, height_over_feet

WEIGHT = C.MASS * C.GRAVITY
ALL = np.ones(4, dtype=bool)


def _standing_feet(height: float = P.HEIGHT_NOMINAL) -> np.ndarray:
    """The nominal feet in the level frame of a level body at ``height``."""
    feet = stance.footprint()
    feet[:, 2] -= height
    return feet


def _residual(feet, reactions, wrench) -> np.ndarray:
    force = reactions.sum(axis=0)
    torque = sum(np.cross(feet[i], reactions[i]) for i in range(4))
    return np.concatenate((force, torque)) - wrench


def test_the_weight_is_shared_equally_by_four_symmetric_feet():
    wrench = np.array([0.0, 0.0, WEIGHT, 0.0, 0.0, 0.0])
    reactions = stance.distribute(_standing_feet(), wrench, ALL, 1e-6, 0.6)
    assert reactions == pytest.approx(np.tile([0.0, 0.0, WEIGHT / 4], (4, 1)), rel=1e-6, abs=1e-6)


@pytest.mark.parametrize("torque", [(3.0, 0.0, 0.0), (0.0, -4.0, 0.0), (1.0, 2.0, 0.5)])
def test_four_feet_make_the_whole_wrench(torque):
    wrench = np.array([0.0, 0.0, WEIGHT, *torque])
    feet = _standing_feet()
    reactions = stance.distribute(feet, wrench, ALL, 1e-6, 0.6)
    assert np.abs(_residual(feet, reactions, wrench)).max() < 1e-3
    # a roll torque (+x: lift the left side) is made by pushing harder on the left feet
    if torque[0] > 0:
        assert reactions[1, 2] > reactions[0, 2] and reactions[3, 2] > reactions[2, 2]


@pytest.mark.parametrize("pair", C.PAIRS, ids=["FR+RL", "FL+RR"])
def test_a_diagonal_pair_carries_the_weight_alone(pair):
    wrench = np.array([0.0, 0.0, WEIGHT, 0.0, 0.0, 0.0])
    mask = np.zeros(4, dtype=bool)
    mask[list(pair)] = True
    reactions = stance.distribute(_standing_feet(), wrench, mask, 1e-6, 0.6)
    assert reactions[list(pair), 2] == pytest.approx([WEIGHT / 2, WEIGHT / 2], rel=1e-4)
    assert np.all(reactions[~mask] == 0.0)


def test_the_friction_cone_caps_the_tangential_force_and_no_foot_pulls():
    capped = stance.friction_cone(np.array([[30.0, 40.0, 10.0], [1.0, 0.0, -5.0], [0, 0, 20.0], [3, 0, 10]]),
                                  0.5, 0.0)
    assert math.hypot(*capped[0, :2]) == pytest.approx(5.0) and capped[0, 2] == 10.0
    assert capped[0, 0] / capped[0, 1] == pytest.approx(0.75)  # direction kept
    assert capped[1].tolist() == [0.0, 0.0, 0.0]
    assert capped[3].tolist() == [3.0, 0.0, 10.0]  # inside: untouched


def test_stance_torques_extend_every_knee_and_give_back_the_weight():
    """The sign trap end to end: the torques' foot forces (J^-T tau) are the feet pushing DOWN."""
    height = P.HEIGHT_NOMINAL
    feet_body = _standing_feet(height)
    q = legs.joints_for_feet(feet_body)
    wrench = np.array([0.0, 0.0, WEIGHT, 0.0, 0.0, 0.0])
    tau = stance.stance_torques(q, feet_body, np.eye(3), wrench, ALL, 1e-6, 0.6)
    assert np.all(tau[:, 2] > 0.5)  # calf torque opens the knee against gravity
    pushed = np.array([np.linalg.solve(K.jacobian(q[i], C.SIDE[i], C.GEOMETRY).T, tau[i]) for i in range(4)])
    assert pushed.sum(axis=0) == pytest.approx([0.0, 0.0, -WEIGHT], rel=1e-6, abs=1e-6)  # on the ground: -weight


def test_the_pose_puts_the_body_where_asked():
    """IK of the posed feet, FK back, the body's pose applied: the feet are where they were on the ground."""
    feet_ground = stance.footprint()
    position = np.array([0.01, -0.005, 0.25])
    rotation = rpy_matrix(0.1, -0.15, 0.12)
    q = legs.joints_for_feet(stance.feet_in_body_for_pose(feet_ground, position, rotation))
    assert legs.feet_in_body(q) @ rotation.T + position == pytest.approx(feet_ground, abs=1e-9)


class KinematicRobot:
    """A robot whose joints reach their set points and whose feet stay put: its body takes the
    commanded pose, off by ``bias`` (roll, pitch, yaw rad, height m), as a sagging leg or a wrong
    belief would leave it."""

    def __init__(self, bias=(0.0, 0.0, 0.0, 0.0), yaw0: float = 0.3):
        self.bias = np.array(bias)
        self.yaw0 = yaw0
        self.q = legs.joints_for_feet(_standing_feet())
        self.rpy = np.array([0.0, 0.0, yaw0])

    def sensed(self) -> Sensed:
        return Sensed(self.q, np.zeros((4, 3)), np.zeros((4, 3)), self.rpy.copy(), np.zeros(3))

    def take(self, stand: BalanceStand, commands) -> None:
        """The body's pose from the commanded joints: solve where the feet on the ground put it."""
        pose = stand.setpoint + stand.trim + self.bias
        rotation = rpy_matrix(*pose[:3])
        feet = stance.feet_in_body_for_pose(stand.feet_ground, np.array([*stand.body_xy, pose[3]]), rotation)
        self.q = legs.joints_for_feet(feet)
        assert np.max(np.abs(self.q - commands.q)) < 0.01 or np.any(self.bias)
        self.rpy = np.array([pose[0], pose[1], pose[2] + self.yaw0])


TEN = math.radians(10.0)
POSTURES = [Posture(roll=r, pitch=p, yaw=y, height=P.HEIGHT_NOMINAL + h)
            for r, p, y, h in itertools.product((-TEN, TEN), (-TEN, TEN), (-TEN, TEN), (-0.03, 0.03))]


@pytest.mark.parametrize("target", POSTURES[::3] + [Posture()], ids=lambda t: f"{t.roll:+.2f},{t.pitch:+.2f},"
                                                                               f"{t.yaw:+.2f},{t.height:.2f}")
def test_every_posture_within_10_deg_and_3_cm_is_reached_inside_the_joint_ranges(target):
    robot = KinematicRobot()
    stand = BalanceStand()
    stand.start(robot.sensed())
    for _ in range(int(2.0 / stand.period_s)):
        commands = stand.step(robot.sensed(), target)
        robot.take(stand, commands)
        assert np.all(commands.q >= legs.LOWER) and np.all(commands.q <= legs.UPPER)
    assert stand.measured[:3] == pytest.approx([target.roll, target.pitch, target.yaw], abs=1e-4)
    assert stand.measured[3] == pytest.approx(target.height, abs=1e-5)
    feet = legs.feet_in_body(commands.q)
    assert np.all(np.abs(feet - legs.HIPS)[:, 0] < 0.1)  # the feet stay under their hips (fore-aft)


def test_the_trims_take_out_a_steady_sag():
    robot = KinematicRobot(bias=(-0.02, 0.015, 0.01, -0.008))
    stand = BalanceStand()
    stand.start(robot.sensed())
    target = Posture(roll=0.1, pitch=-0.05, yaw=0.0, height=0.24)
    for _ in range(int(4.0 / stand.period_s)):
        robot.take(stand, stand.step(robot.sensed(), target))
    assert stand.measured == pytest.approx([0.1, -0.05, 0.0, 0.24], abs=2e-4)
    assert stand.trim == pytest.approx([0.02, -0.015, -0.01, 0.008], abs=2e-4)


def test_height_over_feet_counts_only_stance_feet():
    feet = _standing_feet(0.2)
    feet[0, 2] += 0.05  # a foot in the air
    mask = np.array([False, True, True, True])
    assert height_over_feet(feet, mask) == pytest.approx(0.2)
    assert math.isnan(height_over_feet(feet, np.zeros(4, dtype=bool)))


def test_a_foot_caught_in_the_air_is_brought_down_before_it_carries_weight():
    robot = KinematicRobot()
    feet = legs.feet_in_body(robot.q)
    feet[1, 2] += 0.04  # FL mid-swing
    robot.q = legs.joints_for_feet(feet)
    stand = BalanceStand()
    stand.start(robot.sensed())
    first = stand.step(robot.sensed(), Posture())
    assert np.all(first.tau[1] == 0.0) and np.all(first.tau[[0, 3], 2] > 0.5)  # FR+RL carry the most
    for _ in range(int(0.5 / stand.period_s)):
        commands = stand.step(robot.sensed(), Posture())
        robot.take(stand, commands)
    assert legs.feet_in_body(commands.q)[1, 2] == pytest.approx(legs.feet_in_body(commands.q)[0, 2], abs=1e-6)
    assert np.all(commands.tau[:, 2] > 0.5)


def test_a_tilted_imu_at_the_start_leaves_no_foot_unsupported():
    """Half a degree of pitch the IMU reads but the body has not: the feet differ in height by
    millimetres in the level frame. All four carry the weight from the first step on (a stand that
    waited for them to be 'exactly' on the ground had no foot down, and no height: NaN)."""
    robot = KinematicRobot()
    sensed = robot.sensed()
    tilted = Sensed(sensed.q, sensed.qd, sensed.tau, sensed.rpy + [0.0, math.radians(0.5), 0.0], sensed.gyro)
    stand = BalanceStand()
    stand.start(tilted)
    commands = stand.step(tilted, Posture())
    assert np.all(np.isfinite(commands.q)) and np.all(np.isfinite(commands.tau))
    assert np.all(commands.tau[:, 2] > 0.5)
