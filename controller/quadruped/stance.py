"""Standing on the feet: posture by foot positions through IK, weight by force distribution.

Pure functions (the balance stand's class is in ``balance.py``). Frames: the
ground frame G has its origin on the ground under the body's centre at the
stand's start, z up, x along the heading then; the level frame is G moved to
the body's centre (sensed.py). Arrays: feet (4, 3) m, reactions (4, 3) N,
stance masks (4,) bool, wrenches (6,) = force (N) then torque (N m).

Posture: the body's pose in G (centre (0, 0, h), attitude roll, pitch, yaw)
and the feet's fixed points in G give the feet in the body frame,
b_i = R^T (f_i - p); inverse kinematics turns them into joint set points for
the CyberGear's MIT-mode PD.

Force: the body wrench W (gravity plus an attitude PD) is split over the
stance feet by regularised least squares, min |A f - W|^2 + alpha |f|^2 with
A = [I ...; [r_i]x ...] and r_i the feet from the centre of mass, then kept
inside the friction cone; the reactions become joint torque feed-forward by
tau = -J^T R (legs.torques_for_reactions, the sign trap).
"""
from __future__ import annotations

import functools

import numpy as np

from wheelleg.controller.quadruped import constants as C
from wheelleg.controller.quadruped import legs


def footprint(width_extra_m: float = 0.0, length_extra_m: float = 0.0) -> np.ndarray:
    """Nominal foot centres (m, (4, 3)) in G: under each thigh's plane, one foot radius above the ground.

    ``width_extra_m`` and ``length_extra_m`` widen and lengthen the stance (each side, each end).
    """
    feet = np.array([[C.FRONT[leg] * (C.HIP_X + length_extra_m),
                      C.SIDE[leg] * (C.HIP_Y + C.ABAD_LINK + width_extra_m), C.FOOT_RADIUS] for leg in range(4)])
    return feet


def attitude_over_feet(feet_body: np.ndarray) -> tuple[float, float]:
    """The body's roll and pitch (rad, ZYX) over the plane through the foot centres ``feet_body``
    (m, (n, 3), body frame, n >= 3): the plane z = a x + b y + c fitted by least squares,
    its up normal (-a, -b, 1) the body's view of the ground's z."""
    design = np.column_stack((feet_body[:, 0], feet_body[:, 1], np.ones(len(feet_body))))
    (a, b, _), *_ = np.linalg.lstsq(design, feet_body[:, 2], rcond=None)
    norm = float(np.sqrt(a * a + b * b + 1.0))
    return float(np.arctan2(-b, 1.0)), float(np.arcsin(a / norm))


def feet_in_body_for_pose(feet_ground: np.ndarray, body_position: np.ndarray, body_rotation: np.ndarray) -> np.ndarray:
    """Feet (m, (4, 3), body frame) of feet fixed in G when the body is at ``body_position`` (m, (3,))
    with ``body_rotation`` (body -> G, (3, 3))."""
    return (feet_ground - body_position) @ body_rotation


def cross_matrix(v) -> np.ndarray:
    """[v]x (3, 3): [v]x @ u = v x u."""
    x, y, z = v
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def wrench_matrix(feet: np.ndarray) -> np.ndarray:
    """A (6, 3 n) = [I ...; [r_k]x ...] of the n feet ``feet`` (m, (n, 3)): the wrench A @ f of their reactions f.

    The same entries as ``cross_matrix`` per foot (zeros, each coordinate and its
    negation), written column by column for all feet at once.
    """
    n = len(feet)
    A = np.zeros((6, n, 3))
    A[:3] = np.eye(3)[:, None, :]  # row i, foot k, column j: 1 where i == j
    x, y, z = feet[:, 0], feet[:, 1], feet[:, 2]
    A[3, :, 1], A[3, :, 2] = -z, y
    A[4, :, 0], A[4, :, 2] = z, -x
    A[5, :, 0], A[5, :, 1] = -y, x
    return A.reshape(6, 3 * n)


@functools.lru_cache(maxsize=16)
def _regularisation(alpha: float, n: int) -> np.ndarray:
    """alpha I (n, n), made once per (alpha, n): the same entries every tick (read-only)."""
    matrix = alpha * np.eye(n)
    matrix.flags.writeable = False
    return matrix


def distribute(feet_from_com: np.ndarray, wrench: np.ndarray, stance, regularisation: float,
               friction: float, fz_min_n: float = 0.0) -> np.ndarray:
    """Ground reactions (N, (4, 3)) on the stance feet that best make ``wrench`` (6,) about the centre of mass.

    ``feet_from_com`` (m, (4, 3)) in the wrench's axes. Swing feet get zero. Each
    reaction is then held in the friction cone: fz >= ``fz_min_n``, |f_xy| <=
    ``friction`` fz (a foot cannot pull on the ground).
    """
    stance = np.asarray(stance, dtype=bool)
    reactions = np.zeros((4, 3))
    feet = np.flatnonzero(stance)
    if feet.size == 0:
        return reactions
    A = wrench_matrix(feet_from_com[feet])
    f = np.linalg.solve(A.T @ A + _regularisation(regularisation, A.shape[1]), A.T @ np.asarray(wrench, dtype=float))
    reactions[feet] = f.reshape(-1, 3)
    return friction_cone(reactions, friction, fz_min_n) * stance[:, None]


def friction_cone(reactions: np.ndarray, friction: float, fz_min_n: float) -> np.ndarray:
    """``reactions`` (N, (4, 3)) with fz raised to ``fz_min_n`` and the tangential part scaled into the cone."""
    out = np.array(reactions, dtype=float)
    out[:, 2] = np.maximum(out[:, 2], fz_min_n)
    tangential = np.hypot(out[:, 0], out[:, 1])
    limit = friction * out[:, 2]
    scale = np.where(tangential > limit, limit / np.maximum(tangential, 1e-12), 1.0)
    out[:, :2] *= scale[:, None]
    return out


def attitude_wrench(mass_kg: float, attitude_error: np.ndarray, rates: np.ndarray, kp: np.ndarray,
                    kd: np.ndarray, vertical_n: float = 0.0) -> np.ndarray:
    """The body wrench (6,) of the stance: weight + ``vertical_n``, and a PD torque on the attitude.

    ``attitude_error`` (rad, (3,)): set point minus measured roll, pitch, yaw;
    ``rates`` (rad/s, (3,)) the body rates; gains ``kp`` (N m/rad, (3,)), ``kd``
    (N m s/rad, (3,)). Small angles: the ZYX errors are taken as rotations about the level axes.
    """
    torque = np.asarray(kp) * attitude_error - np.asarray(kd) * rates
    return np.concatenate(([0.0, 0.0, mass_kg * C.GRAVITY + vertical_n], torque))


def stance_torques(q: np.ndarray, feet_level: np.ndarray, level_rotation: np.ndarray, wrench: np.ndarray,
                   stance, regularisation: float, friction: float) -> np.ndarray:
    """Feed-forward joint torques (N m, (4, 3)) that carry ``wrench`` (level axes) on the stance feet.

    ``feet_level`` (m, (4, 3)) the feet in the level frame, ``level_rotation``
    body -> level (3, 3); reactions are found in level axes, turned into body
    axes and through -J^T into torques.
    """
    com = level_rotation @ np.asarray(C.COM)
    reactions_level = distribute(feet_level - com, wrench, stance, regularisation, friction)
    return legs.torques_for_reactions(q, reactions_level @ level_rotation)
