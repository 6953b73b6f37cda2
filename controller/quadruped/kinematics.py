"""One leg's kinematics in Unitree's convention: forward, inverse, Jacobian, J^T F.

Pure functions of joint angles q = (abduction, thigh, calf) (rad, shape (3,))
and foot positions p = (x, y, z) (m, shape (3,)) in the leg frame: origin
where the abduction and thigh axes cross (the abduction joint), axes parallel
to the body's (x forward, y left, z up). ``side`` is +1 for a left leg, -1
for a right one: the abduction link of length l1 points to side * y.

With l2, l3 the thigh and calf lengths, h = l2 cos(q2) + l3 cos(q2 + q3) the
leg's reach below the thigh axis and s = -(l2 sin(q2) + l3 sin(q2 + q3)) its
reach forward, the foot is the point (s, side * l1, -h) rotated by q1 about x:

    x = -l2 sin q2 - l3 sin(q2 + q3)
    y = side l1 cos q1 + h sin q1
    z = side l1 sin q1 - h cos q1

The sign trap (docs/quadruped-control.md): by virtual work, tau . qdot =
F . pdot with F the force the foot exerts ON THE GROUND, so tau = J^T F for
that F. A stance controller computes the other one, the ground's reaction on
the foot (what holds the robot up: +z when standing); the torques of a reaction
R are tau = J^T (-R) = -J^T R. ``torques_for_reaction`` takes the reaction and
does the negation in one place.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class LegGeometry:
    """Link lengths of one leg (m): abduction offset l1, thigh l2, calf l3 (knee to foot centre)."""

    abad_m: float
    thigh_m: float
    calf_m: float

    @property
    def reach_max_m(self) -> float:
        """Largest hip-to-foot distance in the thigh's plane (leg straight)."""
        return self.thigh_m + self.calf_m

    @property
    def reach_min_m(self) -> float:
        """Smallest hip-to-foot distance in the thigh's plane (knee folded flat)."""
        return abs(self.thigh_m - self.calf_m)


def forward(q, side: float, geo: LegGeometry) -> np.ndarray:
    """Foot position (m, shape (3,)) of joint angles ``q`` (rad, shape (3,))."""
    return np.array(foot_point(q, side, geo))


def foot_point(q, side: float, geo: LegGeometry) -> tuple[float, float, float]:
    """``forward`` as a tuple (for callers that stack four legs into one array: one numpy call, not five)."""
    q1, q2, q3 = q
    l1, l2, l3 = side * geo.abad_m, geo.thigh_m, geo.calf_m
    h = l2 * math.cos(q2) + l3 * math.cos(q2 + q3)
    x = -l2 * math.sin(q2) - l3 * math.sin(q2 + q3)
    s1, c1 = math.sin(q1), math.cos(q1)
    return x, l1 * c1 + h * s1, l1 * s1 - h * c1


def jacobian(q, side: float, geo: LegGeometry) -> np.ndarray:
    """d foot / d q (shape (3, 3), m/rad): column j is the foot's velocity per unit of joint j's rate."""
    return np.array(jacobian_rows(q, side, geo))


def jacobian_rows(q, side: float, geo: LegGeometry) -> tuple:
    """``jacobian``'s three rows as tuples (for callers that stack four legs into one array)."""
    q1, q2, q3 = q
    l1, l2, l3 = side * geo.abad_m, geo.thigh_m, geo.calf_m
    s1, c1 = math.sin(q1), math.cos(q1)
    s2, c2 = math.sin(q2), math.cos(q2)
    s23, c23 = math.sin(q2 + q3), math.cos(q2 + q3)
    h = l2 * c2 + l3 * c23
    y, z = l1 * c1 + h * s1, l1 * s1 - h * c1
    # thigh and calf turn the sagittal vector (dx, 0, -dh) which the abduction then rotates about x
    dx2, dh2 = -l2 * c2 - l3 * c23, -l2 * s2 - l3 * s23
    dx3, dh3 = -l3 * c23, -l3 * s23
    return (
        (0.0, dx2, dx3),
        (-z, dh2 * s1, dh3 * s1),
        (y, -dh2 * c1, -dh3 * c1),
    )


def inverse(p, side: float, geo: LegGeometry) -> np.ndarray:
    """Joint angles (rad, shape (3,)) that put the foot at ``p`` (m, shape (3,)), knee bent backward
    (``joint_angles``)."""
    return np.array(joint_angles(p, side, geo))


def joint_angles(p, side: float, geo: LegGeometry) -> tuple[float, float, float]:
    """``inverse`` as a tuple (for callers that stack four legs into one array).

    The branch with the foot below the thigh axis (h > 0) and the calf angle
    in [-pi, 0]. A point out of reach gives the angles of the nearest reach
    (leg straight, or folded flat), so a controller is never handed NaN.
    """
    x, y, z = (float(v) for v in p)
    l1, l2, l3 = side * geo.abad_m, geo.thigh_m, geo.calf_m
    # abduction: seen from behind, the thigh's plane is tangent to the circle of radius |l1|
    h = math.sqrt(max(y * y + z * z - l1 * l1, 0.0))
    q1 = math.atan2(z * l1 + y * h, y * l1 - z * h)
    # knee: the law of cosines in the thigh's plane
    reach = min(max(math.hypot(x, h), geo.reach_min_m), geo.reach_max_m)
    cos_knee = (reach * reach - l2 * l2 - l3 * l3) / (2.0 * l2 * l3)
    q3 = -math.acos(min(1.0, max(-1.0, cos_knee)))
    # thigh: (h, -x) is (l2 + l3 cos q3, l3 sin q3) turned by q2
    q2 = math.atan2(-x, h) - math.atan2(l3 * math.sin(q3), l2 + l3 * math.cos(q3))
    return q1, q2, q3


def torques_for_reaction(q, side: float, geo: LegGeometry, reaction_n) -> np.ndarray:
    """Joint torques (N m, shape (3,)) that make the ground push on the foot with ``reaction_n``.

    ``reaction_n`` (N, shape (3,), leg/body axes) is the ground's force ON the
    foot, as a stance force distribution computes it. The virtual-work law
    tau = J^T F holds for the foot's force on the ground, F = -reaction: hence
    the minus (the sign trap).
    """
    return -jacobian(q, side, geo).T @ np.asarray(reaction_n, dtype=float)


def foot_velocity(q, qd, side: float, geo: LegGeometry) -> np.ndarray:
    """Foot velocity (m/s, shape (3,)) relative to the body, from joint rates ``qd`` (rad/s, shape (3,))."""
    return jacobian(q, side, geo) @ np.asarray(qd, dtype=float)
