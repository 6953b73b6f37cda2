"""The virtual legs as the chassis sees them, and their set points: pure functions.

The IMU's attitude, each leg's virtual-leg state from its two hip motors (five-bar
forward kinematics, docs/control.md), the wheels' speed along the ground, and the leg
length targets that level the body or lean it into a turn. Sign conventions are those
of controller/constants.py: theta > 0 with the wheel behind the hip, pitch nose down
positive.
"""
from __future__ import annotations

import math
from typing import NamedTuple

from wheelleg.controller import constants as C
from wheelleg.controller import fivebar
from wheelleg.controller import params as P
from wheelleg.controller.attitude import euler_zyx
from wheelleg.controller.bounds import clamp, within
from wheelleg.controller.state import BusState, ImuReading

LEGS = ("left", "right")


class Attitude(NamedTuple):
    """Body attitude from the IMU: ZYX angles (rad), body rates (rad/s).

    The per-tick records are NamedTuples: immutable like a frozen dataclass, made ~3x
    faster (a frozen dataclass sets each field through object.__setattr__)."""

    roll: float
    pitch: float  # nose down positive
    yaw: float
    wx: float
    wy: float
    wz: float


def attitude(imu: ImuReading, gyro_bias: tuple = (0.0, 0.0, 0.0)) -> Attitude:
    """Euler angles of the IMU quaternion (ZYX) and its body rates less ``gyro_bias`` (rad/s, (3,))."""
    roll, pitch, yaw = euler_zyx(imu.quat)
    (gx, gy, gz), (bx, by, bz) = imu.gyro, gyro_bias
    return Attitude(roll, pitch, yaw, gx - bx, gy - by, gz - bz)


class LegState(NamedTuple):
    """One leg's virtual-leg state, from its two hip motors and the IMU."""

    kin: object  # fivebar.LegKinematics
    L0: float  # m
    dL0: float  # m/s
    theta: float  # rad, from vertical, wheel behind hip positive
    dtheta: float  # rad/s
    wheel_speed: float  # m/s, axle speed along the ground, forward positive
    dphi1: float  # rad/s, front hip joint's rate (phi1 of the five-bar, relative to the body)
    dphi4: float  # rad/s, rear hip joint's rate (phi4)


LEG_WHEEL = {w.leg: w for w in C.WHEELS}  # leg name -> its wheel drive (constants.Wheel)
# leg name -> what leg_state reads of its parts, one lookup a leg a tick: (motor id, stop rad,
# sign) of the front and the rear hip (constants.Joint; its ``stop`` is a property), then
# (esc id, forward sign) of the wheel drive
_LEG_PARTS = {leg: (*((j.motor_id, j.stop, j.sign) for j in C.LEG_JOINTS[leg]),
                    (LEG_WHEEL[leg].esc_id, LEG_WHEEL[leg].forward_sign)) for leg in LEGS}
_SHIN_STEP_S = 1e-4  # s, the step of the shin's numerical rate (``leg_state``)
_PI, _HALF_PI, _TWO_PI = math.pi, math.pi / 2, 2 * math.pi


def leg_state(bus: BusState, leg: str, att: Attitude) -> LegState:
    """Virtual-leg state of ``leg`` from its joint feedback and the attitude."""
    (front_id, front_stop, front_sign), (rear_id, rear_stop, rear_sign), (esc_id, forward_sign) = _LEG_PARTS[leg]
    joints = bus.joints
    fa, fe = joints[front_id], joints[rear_id]
    # fivebar.phi_from_shaft and phi_rate_from_shaft, written out (the same operations)
    phi1, phi4 = front_stop + front_sign * fa.position, rear_stop + rear_sign * fe.position
    dphi1, dphi4 = front_sign * fa.speed, rear_sign * fe.speed
    kin = fivebar.forward_kinematics(phi1, phi4)
    (j11, j12), (j21, j22) = kin.jacobian  # fivebar.leg_velocity, written out
    dL0, dphi0 = j11 * dphi1 + j12 * dphi4, j21 * dphi1 + j22 * dphi4
    wy = att.wy
    body_rate = -wy  # nose-up pitch rate
    theta = _HALF_PI - kin.phi0 + att.pitch  # phi = -pitch
    dtheta = -dphi0 - body_rate
    # The wheel motor's stator sits on link BC, so its encoder reads the wheel
    # relative to that link: add the link's own rotation (wy - dphi2).
    phi2_ahead = fivebar.shin_angle(phi1 + _SHIN_STEP_S * dphi1, phi4 + _SHIN_STEP_S * dphi4)
    dphi2 = wrap(phi2_ahead - kin.phi2) / _SHIN_STEP_S
    spin = forward_sign * bus.wheels[esc_id].speed + wy - dphi2
    return LegState(kin, kin.L0, dL0, theta, dtheta, spin * C.WHEEL_RADIUS, dphi1, dphi4)


def mean_speed(legs: dict) -> float:
    """Mean axle speed (m/s) the two wheels report."""
    return 0.5 * (legs["left"].wheel_speed + legs["right"].wheel_speed)


def legs_under_body(legs: dict) -> float:
    """Mean forward speed (m/s) of the axles relative to the hips, from the legs'
    motion: the axle sits L0 sin(theta) behind the hip."""
    left, right = legs["left"], legs["right"]
    # each leg's term in the order sum() added them (from 0.0: the same bits)
    return -0.5 * (0.0 + (left.dL0 * math.sin(left.theta) + left.L0 * math.cos(left.theta) * left.dtheta)
                   + (right.dL0 * math.sin(right.theta) + right.L0 * math.cos(right.theta) * right.dtheta))


def wrap(angle: float) -> float:
    """``angle`` (rad) brought into [-pi, pi)."""
    return (angle + _PI) % _TWO_PI - _PI


def turn_lean(speed: float, yaw_rate: float) -> float:
    """Roll (rad) that leans into a turn: -atan(v w / g), left side down turning left.

    The body's weight and the centripetal force v w then add up along the
    legs, as a cyclist leans (docs/control.md, leaning into turns).
    """
    lean = math.atan(speed * yaw_rate / C.GRAVITY)
    return -clamp(lean, P.TURN_LEAN_LIMIT)


def roll_leg_difference(roll_set_point: float, level_offset: float) -> float:
    """Left minus right leg length (m): the feed-forward that tilts the body by
    ``roll_set_point`` (rad) on flat ground, plus the levelling integral's
    ``level_offset`` (m, the ground's own tilt), together within +-ROLL_LEVEL_LIMIT."""
    feed_forward = 2.0 * C.HALF_TRACK * math.tan(roll_set_point)
    return clamp(feed_forward + level_offset, P.ROLL_LEVEL_LIMIT)


_LEG_LENGTH_RANGE = (P.LEG_LENGTH_MIN, P.LEG_LENGTH_MAX)  # m, read every tick by leg_targets
_LEG_LENGTH_SPAN = P.LEG_LENGTH_MAX - P.LEG_LENGTH_MIN  # m


def leg_targets(length: float, difference: float) -> dict:
    """Leg length targets (m) by leg: mean ``length``, left minus right ``difference``.

    When one leg would leave [LEG_LENGTH_MIN, LEG_LENGTH_MAX] both shift
    together, so the difference (the body's level) is kept over the height.
    """
    shortest, longest = _LEG_LENGTH_RANGE
    length = within(length, shortest, longest)
    apart = abs(difference)
    half = 0.5 * (_LEG_LENGTH_SPAN if _LEG_LENGTH_SPAN < apart else apart)  # min(|difference|, span)
    mean = within(length, shortest + half, longest - half)
    sign = 1.0 if difference >= 0 else -1.0
    return {"left": mean + sign * half, "right": mean - sign * half}


def unwind(integral: float, step: float) -> float:
    """``integral`` moved by ``step`` only towards zero, never past it (anti-windup that
    lets a stale integral go while it must not grow)."""
    if integral * step >= 0.0:  # it would grow, or there is nothing to unwind
        return integral
    moved = integral + step
    return moved if moved * integral > 0.0 else 0.0
