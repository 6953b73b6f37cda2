"""Body attitude from the IMU's quaternion: the ZYX angles both robots' controllers use."""
from __future__ import annotations

import math

from wheelleg.controller.bounds import clamp


def euler_zyx(quat) -> tuple[float, float, float]:
    """(roll, pitch, yaw) in rad of a unit quaternion (w, x, y, z) body -> world.

    ZYX (yaw about z, then pitch about y, then roll about x), right-handed:
    roll > 0 lifts the left side, pitch > 0 lowers the nose, yaw > 0 turns left.
    """
    w, x, y, z = quat
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(clamp(2 * (w * y - z * x), 1.0))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw
