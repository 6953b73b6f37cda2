"""What the controller knows of the robot in one tick, and what follows from it by kinematics.

``Sensed`` is built by the node from the buses each tick (joint feedback and the
IMU). The level frame used throughout: origin at the body's centre, z up
(gravity's axis), x the body's heading projected on the ground: the body frame
turned by roll and pitch only.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wheelleg.controller.quadruped import constants as C
from wheelleg.controller.quadruped import legs
from wheelleg.controller.quadruped.rotations import rpy_matrix


@dataclass(frozen=True)
class Sensed:
    """Joint feedback (arrays (4, 3): q rad, qd rad/s, tau N m) and the IMU (rpy rad, gyro rad/s body axes)."""

    q: np.ndarray
    qd: np.ndarray
    tau: np.ndarray
    rpy: np.ndarray  # (3,) roll, pitch, yaw
    gyro: np.ndarray  # (3,) body rates

    @property
    def level_rotation(self) -> np.ndarray:
        """Body -> level frame (3, 3): measured roll and pitch."""
        return rpy_matrix(self.rpy[0], self.rpy[1], 0.0)

    def feet_level(self) -> np.ndarray:
        """Foot centres (m, (4, 3)) in the level frame."""
        return legs.feet_in_body(self.q) @ self.level_rotation.T

    def upright_cos(self) -> float:
        """cos of the angle between the body's z and the world's up: 1 upright, -1 upside down."""
        return float(self.level_rotation[2, 2])


def height_over_feet(feet_level: np.ndarray, stance) -> float:
    """Body centre's height (m) over the ground under the stance feet (bool (4,)): their mean depth + the foot radius."""
    stance = np.asarray(stance, dtype=bool)
    if not stance.any():
        return float("nan")
    return float(-feet_level[stance, 2].mean()) + C.FOOT_RADIUS
