"""The plant's own five-bar geometry: knee angles from hip angles, hip angles for a leg pose.

The physics needs these to place the legs (a standing reset, the knee
angles of a pose); it takes them from the robot description, never from the
controller's kinematics, so the two can disagree when the truth is changed.
The arithmetic follows the robot notes' construction, step for step as the
controller's does, so that at the nominal geometry both give the same floats.

Frame (description.py): origin at the front hip A, x_fb backward towards the
rear hip E at (L5, 0), y_fb down; angles from x_fb towards y_fb, in rad.
"""
from __future__ import annotations

import math

from wheelleg.emulators.robot import description as D

_HALF_L5 = 0.5 * D.L5_M
_CLOSURE_TOL = 1e-9  # relative: a discriminant below -tol means the loop cannot close


def wrap(angle: float) -> float:
    """angle (rad) mapped to (-pi, pi]."""
    return angle - 2.0 * math.pi * math.ceil((angle - math.pi) / (2.0 * math.pi))


def link_angles(phi1: float, phi4: float) -> tuple[float, float]:
    """(phi2, phi3) in rad: the shins BC and DC at hip angles phi1, phi4 (rad).

    The branch with the axle C below the knees. Raises ValueError when the
    angles cannot close the loop.
    """
    xb, yb = D.L1_M * math.cos(phi1), D.L1_M * math.sin(phi1)
    xd, yd = D.L5_M + D.L4_M * math.cos(phi4), D.L4_M * math.sin(phi4)
    a0 = 2.0 * D.L2_M * (xd - xb)
    b0 = 2.0 * D.L2_M * (yd - yb)
    bd_sq = (xd - xb) ** 2 + (yd - yb) ** 2
    c0 = D.L2_M * D.L2_M + bd_sq - D.L3_M * D.L3_M
    disc = a0 * a0 + b0 * b0 - c0 * c0
    if disc < -_CLOSURE_TOL * (a0 * a0 + b0 * b0) or bd_sq == 0.0:
        raise ValueError(f"phi1={phi1:.4f}, phi4={phi4:.4f} rad do not close the five-bar loop")
    phi2 = wrap(2.0 * math.atan2(b0 + math.sqrt(max(disc, 0.0)), a0 + c0))
    xc, yc = xb + D.L2_M * math.cos(phi2), yb + D.L2_M * math.sin(phi2)
    return phi2, math.atan2(yc - yd, xc - xd)


def hip_angles(leg_length_m: float, leg_angle_rad: float) -> tuple[float, float]:
    """(phi1, phi4) in rad that put the axle C at leg_length_m from the hips' midpoint,
    at leg_angle_rad from x_fb (pi/2 straight down); knees outward, as on the robot.

    Raises ValueError out of reach.
    """
    xc, yc = _HALF_L5 + leg_length_m * math.cos(leg_angle_rad), leg_length_m * math.sin(leg_angle_rad)
    return (_hip_angle(xc, yc, D.L1_M, D.L2_M, +1.0),
            _hip_angle(xc - D.L5_M, yc, D.L4_M, D.L3_M, -1.0))


def _hip_angle(dx: float, dy: float, thigh: float, shin: float, side: float) -> float:
    """Angle (rad) of the thigh from a hip to its knee, given the hip-to-C vector (m)."""
    reach = math.hypot(dx, dy)
    cos_knee_side = (thigh * thigh + reach * reach - shin * shin) / (2.0 * thigh * reach) if reach else 2.0
    if not -1.0 <= cos_knee_side <= 1.0:
        raise ValueError(f"wheel axle at ({dx:.4f}, {dy:.4f}) m from a hip is out of the leg's reach")
    return math.atan2(dy, dx) + side * math.acos(cos_knee_side)


def shaft_from_phi(motor: D.HipMotor, phi: float) -> float:
    """Shaft angle (rad) of a hip motor at five-bar angle phi (rad): q = sign (phi - stop)."""
    return motor.sign * (phi - motor.stop_rad)
