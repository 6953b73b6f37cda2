"""What the controller knows of the robot in one tick, and what follows from it by kinematics.

``Sensed`` is built by the node from the buses each tick (joint feedback and the
IMU). The level frame used throughout: origin at the body's centre, z up
(gravity's axis), x the body's heading projected on the ground: the body frame
turned by roll and pitch only.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

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

    # The tick reads these several times from the same measurement: each is made once, read-only
    # (a caller that changed one would change it for the others; feet_level hands out copies).
    @cached_property
    def level_rotation(self) -> np.ndarray:
        """Body -> level frame (3, 3): measured roll and pitch."""
        return read_only(rpy_matrix(self.rpy[0], self.rpy[1], 0.0))

    @cached_property
    def feet_body(self) -> np.ndarray:
        """Foot centres (m, (4, 3)) in the body frame (read-only)."""
        return read_only(legs.feet_in_body(self.q))

    @cached_property
    def _feet_level(self) -> np.ndarray:
        return read_only(self.feet_body @ self.level_rotation.T)

    def feet_level(self) -> np.ndarray:
        """Foot centres (m, (4, 3)) in the level frame (a copy the caller may change)."""
        return self._feet_level.copy()

    def upright_cos(self) -> float:
        """cos of the angle between the body's z and the world's up: 1 upright, -1 upside down."""
        return float(self.level_rotation[2, 2])


def read_only(array: np.ndarray) -> np.ndarray:
    """``array``, made read-only in place: for arrays made once and shared (constants, per-tick caches)."""
    array.flags.writeable = False
    return array


def height_over_feet(feet_level: np.ndarray, stance) -> float:
    """Body centre's height (m) over the ground under the stance feet (bool (4,)): their mean depth + the foot radius."""
    # In Python floats: numpy's mean of four or fewer adds them left to right and divides by their
    # count, as here (a numpy call costs more than the sum); sum's start 0 only changes a -0.0 sum
    # to 0.0, which the added foot radius makes the same.
    depths = [foot[2] for foot, down in zip(feet_level.tolist(), np.asarray(stance, dtype=bool).tolist()) if down]
    if not depths:
        return float("nan")
    return -(sum(depths) / len(depths)) + C.FOOT_RADIUS
