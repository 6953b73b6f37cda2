"""The quadruped leg's kinematics (Unitree's convention): FK(IK(p)) = p over the workspace,
IK(FK(q)) = q on the knee-back branch, the Jacobian against finite differences, the
mirror signs of both sides, and the sign of tau = J^T F (the sign trap), per leg."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wheelleg.controller.quadruped import constants as C
from wheelleg.controller.quadruped import kinematics as K

GEO = C.GEOMETRY
LEGS = range(4)


def _angles(leg: int):
    """Joint angles within the leg's ranges, on the branch with the foot below the thigh axis."""
    lo = [C.joint_range(leg, j)[0] for j in range(3)]
    hi = [C.joint_range(leg, j)[1] for j in range(3)]
    return st.tuples(*(st.floats(lo[j], hi[j]) for j in range(3))).filter(
        lambda q: GEO.thigh_m * math.cos(q[1]) + GEO.calf_m * math.cos(q[1] + q[2]) > 0.02)


def test_zero_angles_put_the_foot_straight_below_the_abduction_link():
    for leg in LEGS:
        side = C.SIDE[leg]
        foot = K.forward((0.0, 0.0, 0.0), side, GEO)
        assert foot == pytest.approx([0.0, side * C.ABAD_LINK, -(C.THIGH + C.CALF)])


def test_positive_thigh_swings_the_foot_back_and_negative_calf_brings_it_forward():
    straight = K.forward((0.0, 0.0, 0.0), 1.0, GEO)
    assert K.forward((0.0, 0.3, 0.0), 1.0, GEO)[0] < straight[0] - 0.05
    bent = K.forward((0.0, 0.0, -1.0), 1.0, GEO)
    assert bent[0] > 0.1 and bent[2] > straight[2]


def test_positive_abduction_swings_every_foot_to_the_left():
    """About +x for all legs: the foot goes to +y whichever side the leg is on."""
    for leg in LEGS:
        side = C.SIDE[leg]
        assert K.forward((0.2, 0.5, -1.0), side, GEO)[1] > K.forward((0.0, 0.5, -1.0), side, GEO)[1] + 0.03


@settings(max_examples=300, deadline=None)
@given(st.sampled_from(list(LEGS)), st.data())
def test_ik_of_fk_is_the_identity_on_the_knee_back_branch(leg, data):
    q = np.array(data.draw(_angles(leg)))
    side = C.SIDE[leg]
    assert K.inverse(K.forward(q, side, GEO), side, GEO) == pytest.approx(q, abs=1e-9)


def _workspace_grid(side: float) -> list[np.ndarray]:
    """A grid of foot positions around the leg: every reachable one (2 mm inside the reach)."""
    points = []
    for x in np.linspace(-0.28, 0.28, 15):
        for y in np.linspace(-0.3, 0.3, 13):
            for z in np.linspace(-0.3, 0.3, 13):
                h2 = y * y + z * z - GEO.abad_m ** 2
                if h2 <= 0.0:
                    continue
                reach = math.hypot(x, math.sqrt(h2))
                if GEO.reach_min_m + 0.002 < reach < GEO.reach_max_m - 0.002:
                    points.append(np.array([x, y, z]))
    return points


@pytest.mark.parametrize("side", [1.0, -1.0], ids=["left", "right"])
def test_fk_of_ik_is_the_identity_over_the_reachable_workspace(side):
    points = _workspace_grid(side)
    assert len(points) > 1000  # the grid covers the workspace
    worst = max(float(np.max(np.abs(K.forward(K.inverse(p, side, GEO), side, GEO) - p))) for p in points)
    assert worst < 1e-9


def test_ik_of_an_unreachable_point_is_the_nearest_reach_not_nan():
    far = K.inverse((0.0, 0.1, -1.0), 1.0, GEO)
    assert np.all(np.isfinite(far)) and far[2] == pytest.approx(0.0, abs=1e-6)  # leg straight toward it
    near = K.inverse((0.0, GEO.abad_m, -0.01), 1.0, GEO)
    assert np.all(np.isfinite(near)) and near[2] == pytest.approx(-math.pi, abs=1e-6)  # folded flat


@settings(max_examples=200, deadline=None)
@given(st.sampled_from(list(LEGS)), st.data())
def test_jacobian_matches_finite_differences(leg, data):
    q = np.array(data.draw(_angles(leg)))
    side = C.SIDE[leg]
    eps = 1e-6
    numeric = np.column_stack([
        (K.forward(q + eps * e, side, GEO) - K.forward(q - eps * e, side, GEO)) / (2 * eps) for e in np.eye(3)])
    assert K.jacobian(q, side, GEO) == pytest.approx(numeric, abs=1e-7)


@pytest.mark.parametrize("leg", LEGS, ids=C.LEGS)
def test_the_two_sides_are_mirror_images(leg):
    """Mirroring y (and the abduction angle) maps a left leg onto a right one."""
    q = np.array([0.3, 0.7, -1.4])
    mirror = np.array([-q[0], q[1], q[2]])
    side = C.SIDE[leg]
    p, pm = K.forward(q, side, GEO), K.forward(mirror, -side, GEO)
    assert pm == pytest.approx([p[0], -p[1], p[2]])
    assert K.inverse(pm, -side, GEO) == pytest.approx(mirror)
    J, Jm = K.jacobian(q, side, GEO), K.jacobian(mirror, -side, GEO)
    # y flips, and so does the abduction rate (its angle is negated)
    assert Jm == pytest.approx(np.diag([1.0, -1.0, 1.0]) @ J @ np.diag([-1.0, 1.0, 1.0]))


@pytest.mark.parametrize("leg", LEGS, ids=C.LEGS)
def test_holding_the_body_up_extends_the_knee_and_pushes_the_foot_down(leg):
    """The sign trap: the ground's reaction (+z, holding the robot) needs the foot to push DOWN.

    Standing, gravity folds the knee (calf angle toward more negative), so the
    calf motor must push it open: tau_calf > 0. With the reaction passed as
    if it were the foot's force on the ground (J^T R, no minus), the sign
    comes out wrong: this is what the test would catch.
    """
    side = C.SIDE[leg]
    q = K.inverse((0.0, side * C.ABAD_LINK, -0.22), side, GEO)
    reaction = np.array([0.0, 0.0, C.MASS * C.GRAVITY / 4])
    tau = K.torques_for_reaction(q, side, GEO, reaction)
    assert tau[2] > 0.5
    assert np.dot(K.jacobian(q, side, GEO).T @ reaction, tau) < 0  # the trap gives the opposite
    # virtual work: the torques drive the foot down, into the ground (foot force = -reaction)
    assert (K.jacobian(q, side, GEO) @ tau)[2] < 0


@pytest.mark.parametrize("leg", LEGS, ids=C.LEGS)
def test_the_joint_torques_are_the_reaction_s_moments_about_each_axis(leg):
    """Statics by hand: a joint's torque balances the foot force's moment about its axis."""
    side = C.SIDE[leg]
    q = np.array([0.1 * side, 0.6, -1.3])
    foot = K.forward(q, side, GEO)
    reaction = np.array([3.0, -2.0, 25.0])
    tau = K.torques_for_reaction(q, side, GEO, reaction)
    # the foot pushes the ground with -reaction; the motor supplies the moment of that force
    # about its axis through its joint: abduction at the origin (axis x)
    assert tau[0] == pytest.approx(np.cross(foot, -reaction)[0])
    # the knee: at the thigh's end, axis y turned by the abduction
    s1, c1 = math.sin(q[0]), math.cos(q[0])
    rot = np.array([[1, 0, 0], [0, c1, -s1], [0, s1, c1]])
    knee = rot @ np.array([-C.THIGH * math.sin(q[1]), side * C.ABAD_LINK, -C.THIGH * math.cos(q[1])])
    assert tau[2] == pytest.approx(np.dot(np.cross(foot - knee, -reaction), rot @ np.array([0.0, 1.0, 0.0])))
