"""The speed set point the chassis tracks, and what it is doing (docs/control.md, motion commands).

The operator's speed command is turned into an S-curve the robot can follow
(``speed_set_point``): its acceleration is bounded by what the legs' lean can give and
ramps at a bounded jerk, so the LQR can be asked for that lean (LEAN_PER_ACCEL) and,
braking, to track the position along the curve. ``travel_phase`` names what the set
point does in a period; the chassis's position reference and trim follow it.
"""
from __future__ import annotations

import enum
import math

from wheelleg.controller import params as P
from wheelleg.controller.bounds import clamp


class Travel(enum.Enum):
    """What the speed set point does in one period, and how the chassis follows it."""

    STANDING = "standing"  # 0: the spot is held (dragged along for TRIM_SETTLE_S after a stop)
    SPEEDING_UP = "speeding up"  # |speed| growing: speed alone is tracked
    CRUISING = "cruising"  # steady, not 0: speed tracked, the trim takes up a steady speed error
    BRAKING = "braking"  # |speed| shrinking: the position is tracked along the curve


# the params the set point reads every tick, and the phases it names, as module names (an
# attribute lookup each, and an Enum member's class lookup costs ~10 globals' in CPython 3.11)
_EASE_JERK, _JERK, _ACCEL_LIMIT = P.SPEED_EASE_JERK, P.SPEED_JERK, P.ACCEL_LIMIT
_EASE_TOP_FROM, _EASE_TOP_SLOPE = P.SPEED_EASE_TOP_FROM, (
    (P.SPEED_EASE_JERK_TOP - P.SPEED_EASE_JERK) / (P.SPEED_LIMIT - P.SPEED_EASE_TOP_FROM))
_STANDING, _SPEEDING_UP, _CRUISING, _BRAKING = Travel.STANDING, Travel.SPEEDING_UP, Travel.CRUISING, Travel.BRAKING


def speed_set_point(speed: float, accel: float, target: float, dt: float) -> tuple[float, float]:
    """The set point one period ``dt`` (s) on: (speed m/s, its acceleration m/s^2), towards
    ``target`` (m/s) from ``speed`` and the ``accel`` it had.

    The acceleration ramps at SPEED_JERK up to ACCEL_LIMIT and eases back to 0 at
    ``ease_jerk(target)`` as the speed arrives (no overshoot); a reversal is one curve through
    0; a target changed midway is headed for from where the curve is.
    """
    gap = target - speed
    direction = math.copysign(1.0, gap) if gap else 0.0
    # the largest acceleration from which easing off at the easing jerk lands on the
    # target: easing off from a gains a^2 / (2 jerk)
    landing = math.sqrt(2.0 * ease_jerk(target) * abs(gap))
    if accel * direction >= landing:
        accel = direction * landing  # easing off along that parabola, at SPEED_EASE_JERK
    else:
        aim = direction * (landing if landing < _ACCEL_LIMIT else _ACCEL_LIMIT)  # min(ACCEL_LIMIT, landing)
        accel += clamp(aim - accel, _JERK * dt)  # the change within +-SPEED_JERK dt
    speed += accel * dt
    if (target - speed) * direction <= 0.0:
        return target, 0.0
    return speed, accel


def ease_jerk(target: float) -> float:
    """m/s^3 the acceleration eases off at onto ``target`` (m/s): SPEED_EASE_JERK, falling
    linearly from SPEED_EASE_TOP_FROM to SPEED_EASE_JERK_TOP at SPEED_LIMIT (params.py: the
    wheels overtake the set point as the lean comes out, and near the top there is no speed
    left for that)."""
    over = abs(target) - _EASE_TOP_FROM
    return _EASE_JERK if over <= 0.0 else _EASE_JERK + _EASE_TOP_SLOPE * min(over, P.SPEED_LIMIT - _EASE_TOP_FROM)


def travel_phase(speed: float, accel: float) -> Travel:
    """What a set point of ``speed`` (m/s) and ``accel`` (m/s^2) is doing."""
    if accel * speed < 0.0:
        return _BRAKING
    if accel != 0.0:
        return _SPEEDING_UP
    return _CRUISING if speed != 0.0 else _STANDING
