"""The four legs at once: feet in the body frame, inverse kinematics, torques, joint commands.

Arrays are per leg and joint, shape (4, 3), in the order of ``constants.LEGS``
and ``constants.JOINTS``; foot positions shape (4, 3) (m) in the body frame
(origin at the body's centre); reactions shape (4, 3) (N), the ground's force
on each foot in body axes.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wheelleg.controller.quadruped import constants as C
from wheelleg.controller.quadruped import kinematics as K

HIPS = np.array([C.hip_position(leg) for leg in range(4)])  # m, (4, 3): the abduction joints in the body frame
LOWER = np.array([[C.joint_range(leg, j)[0] for j in range(3)] for leg in range(4)])  # rad, (4, 3)
SIDES = tuple(C.SIDE[leg] for leg in range(4))  # +1 left, -1 right
UPPER = np.array([[C.joint_range(leg, j)[1] for j in range(3)] for leg in range(4)])  # rad, (4, 3)


def feet_in_body(q: np.ndarray, geo: K.LegGeometry = C.GEOMETRY) -> np.ndarray:
    """Foot centres (m, (4, 3), body frame) of joint angles ``q`` (rad, (4, 3))."""
    # rows as Python floats (tolist: their exact values), the four feet stacked by one numpy call
    return HIPS + np.array([K.foot_point(row, side, geo) for row, side in zip(q.tolist(), SIDES)])


def joints_for_feet(feet_body: np.ndarray, geo: K.LegGeometry = C.GEOMETRY) -> np.ndarray:
    """Joint angles (rad, (4, 3)) that put the feet at ``feet_body`` (m, (4, 3)), within the joint ranges."""
    legs_p = (feet_body - HIPS).tolist()  # each foot from its hip, as Python floats
    q = np.array([K.joint_angles(p, side, geo) for p, side in zip(legs_p, SIDES)])
    return np.clip(q, LOWER, UPPER)


def foot_velocities(q: np.ndarray, qd: np.ndarray, geo: K.LegGeometry = C.GEOMETRY) -> np.ndarray:
    """Foot velocities (m/s, (4, 3)) relative to the body, body axes, of joint rates ``qd`` (rad/s, (4, 3))."""
    # kinematics.foot_velocity per leg: J @ qd with each J a C-ordered (3, 3), as the one it makes
    return np.array([J @ rates for J, rates in zip(jacobians(q, geo), qd)])


def jacobians(q: np.ndarray, geo: K.LegGeometry = C.GEOMETRY) -> np.ndarray:
    """The four legs' Jacobians (m/rad, (4, 3, 3)) at joint angles ``q`` (rad, (4, 3)), made by one numpy call."""
    return np.array([K.jacobian_rows(row, side, geo) for row, side in zip(q.tolist(), SIDES)])


def jacobian_of(q: np.ndarray, leg: int, geo: K.LegGeometry = C.GEOMETRY) -> np.ndarray:
    """Leg ``leg``'s Jacobian (m/rad, (3, 3)) at joint angles ``q`` (rad, (4, 3))."""
    return K.jacobian(q[leg], C.SIDE[leg], geo)


def torques_for_reactions(q: np.ndarray, reactions_body: np.ndarray,
                          geo: K.LegGeometry = C.GEOMETRY) -> np.ndarray:
    """Joint torques (N m, (4, 3)) that make the ground push each foot with ``reactions_body`` (N, (4, 3)).

    tau = -J^T R per leg (``kinematics.torques_for_reaction``: the sign trap).
    """
    # the same -J^T @ R per leg (negated transpose, then the product) on the stacked Jacobians
    reactions = np.asarray(reactions_body, dtype=float)
    return np.array([-J.T @ reaction for J, reaction in zip(jacobians(q, geo), reactions)])


@dataclass
class JointCommands:
    """One MIT command per motor, arrays (4, 3): tau = kp (q - q_meas) + kd (qd - qd_meas) + tau_ff.

    q rad, qd rad/s, kp N m/rad, kd N m s/rad, tau N m (the feed-forward).
    """

    q: np.ndarray
    qd: np.ndarray
    kp: np.ndarray
    kd: np.ndarray
    tau: np.ndarray

    @classmethod
    def damped(cls, kd: float) -> "JointCommands":
        """Passive: no stiffness, no torque, damping ``kd`` on every joint (soft, not limp)."""
        zeros = np.zeros((4, 3))
        return cls(zeros.copy(), zeros.copy(), zeros.copy(), np.full((4, 3), kd), zeros.copy())

    @classmethod
    def hold(cls, q: np.ndarray, kp, kd, tau: np.ndarray | None = None) -> "JointCommands":
        """Joint PD to ``q`` (rad, (4, 3)) at rest, gains scalar or (4, 3), feed-forward ``tau`` or none."""
        shape = (4, 3)
        return cls(np.array(q, dtype=float), np.zeros(shape), _gains(kp, shape), _gains(kd, shape),
                   np.zeros(shape) if tau is None else np.array(tau, dtype=float))


def _gains(gain, shape: tuple) -> np.ndarray:
    """A gain, scalar or array, as a float array of ``shape`` (np.full for a number: cheaper than broadcasting)."""
    if isinstance(gain, (int, float)):
        return np.full(shape, float(gain))
    return np.broadcast_to(gain, shape).astype(float)
