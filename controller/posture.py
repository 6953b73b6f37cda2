"""Is the body on the ground? A kinematic estimate from what the robot measures.

The controller cannot feel the body touch the floor, but it knows its
attitude and both legs: it can place the body box (constants.BODY_SIZE, its
centre at the CoM, the hip midpoint O ``BODY_COM_ABOVE_HIP`` below it) and
each wheel's lowest point in a frame that turns with roll and pitch only, and
take the flat ground through the lower wheel. When the box's lowest corner
comes down to that ground the body is resting on the floor: fallen ("pitch or leg
angle past a limit, body on the ground"), whatever the angles say
(legs collapsed under a load, a slow topple onto the nose).
"""
from __future__ import annotations

import math

from wheelleg.controller import constants as C
from wheelleg.controller.bounds import clamp

_HALF = tuple(0.5 * v for v in C.BODY_SIZE)


def _height(roll: float, pitch: float, point: tuple) -> float:
    """World height (m) of a body-frame point (x fwd, y left, z up; (3,)) relative to
    the CoM under R = Ry(pitch) Rx(roll) (yaw does not change heights)."""
    return _height_in(_height_row(roll, pitch), point)


def _height_row(roll: float, pitch: float) -> tuple[float, float, float]:
    """The world-z row of R = Ry(pitch) Rx(roll): a point's height is its dot product with it."""
    return -math.sin(pitch), math.cos(pitch) * math.sin(roll), math.cos(pitch) * math.cos(roll)


def _height_in(row: tuple[float, float, float], point: tuple) -> float:
    """``_height`` with the row worked out once (three points a tick): the same products, the same sum."""
    x, y, z = point
    return row[0] * x + row[1] * y + row[2] * z


def side_tilt(roll: float, pitch: float) -> float:
    """rad: the body's lean onto its side, how far its left axis rises out of the horizontal,
    asin(cos(pitch) sin(roll)) (the world-z row of R). Defined at any pitch: lying on its nose
    or tail at 90 deg the ZYX roll may take any value (gimbal lock), its side tilt is ~0."""
    return math.asin(clamp(math.cos(pitch) * math.sin(roll), 1.0))


def tilt_from_upright(roll: float, pitch: float) -> float:
    """rad in [0, pi]: the angle between the body's up axis and the world's, acos(cos(pitch) cos(roll));
    on its back ~pi (the ZYX pitch never passes 90 deg: beyond it the roll flips to +-pi)."""
    return math.acos(clamp(math.cos(pitch) * math.cos(roll), 1.0))


def recoverable(roll: float, pitch: float, fallen_rad: float, beyond_rad: float, side_rad: float) -> bool:
    """Lying where the recovery stand can right it (controller/recovery.py): tilted from upright
    past ``fallen_rad`` and up to ``beyond_rad`` (on its nose or tail, not its back), its side
    tilt within ``side_rad`` (not on its side)."""
    tilt = tilt_from_upright(roll, pitch)
    return fallen_rad < tilt <= beyond_rad and abs(side_tilt(roll, pitch)) < side_rad


def axle_in_body(side_y: float, L0: float, phi0: float) -> tuple:
    """Wheel axle C (m, body frame) of the leg in the plane y = side_y, from the
    virtual leg (L0 m, phi0 rad in the five-bar frame: x_fb backward, y_fb down)."""
    return (-L0 * math.cos(phi0), side_y, -C.BODY_COM_ABOVE_HIP - L0 * math.sin(phi0))


def body_clearance(roll: float, pitch: float, legs) -> float:
    """Height (m) of the body box's lowest corner above the flat ground under the lower
    wheel; ``legs`` is an iterable of (side_y m, L0 m, phi0 rad), one per leg.
    < 0 means the box would be below that ground: it rests on something."""
    row = _height_row(roll, pitch)
    ground = min([_height_in(row, axle_in_body(*leg)) for leg in legs]) - C.WHEEL_RADIUS
    return _height_in(row, _lowest_corner(row)) - ground


def _lowest_corner(row: tuple[float, float, float]) -> tuple[float, float, float]:
    """The corner of the body box (m, body frame) lowest under the height row ``row``: on
    each axis the half size against the row's sign. Its height is the least of the eight
    corners' as computed (each product only changes sign between corners, and a rounded sum
    of smaller terms is never larger), so one corner is worked out instead of eight."""
    (hx, hy, hz), (rx, ry, rz) = _HALF, row
    return (-hx if rx > 0.0 else hx, -hy if ry > 0.0 else hy, -hz if rz > 0.0 else hz)
