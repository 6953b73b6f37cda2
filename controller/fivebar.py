"""Five-bar leg kinematics and VMC (virtual model control), docs/control.md.

Pure functions on floats (``math`` only): the chassis works out each leg's pose
once per 2 ms tick (``forward_kinematics``, its ``jacobian`` kept on the pose).

Frame (controller/constants.py, "leg plane"): the design document's five-bar frame,
origin at the front hip A, x_fb pointing BACKWARD towards the rear hip E at
(L5, 0), y_fb pointing DOWN. phi1 is the angle of link AB, phi4 of link ED,
phi2 of BC, phi3 of DC, all measured from x_fb towards y_fb. Seen in the
body frame, angles in this frame grow nose-up (right hand about -y_body).
The virtual leg runs from O = (L5/2, 0) to the wheel axle C: length L0 (m),
angle phi0 (rad), so C = O + L0 (cos phi0, sin phi0); phi0 = pi/2 is
straight down.

Virtual leg coordinates in the LQR's convention (seed model table):
  theta = pi/2 - phi0 - phi, phi = body pitch nose-up positive (= -pitch).
  F   (N)   push along the virtual leg; F > 0 extends it, i.e. the leg pushes
            the wheel away from the hips (F ~ +17 N holds the robot up).
  Tp  (N m) virtual hip torque acting on the leg from the body; Tp > 0
            drives theta positive (swings the wheel backward), and its
            reaction drives the body's phi positive (nose up), as in the
            design document's (1.6) and (1.9).

Virtual work, derived here. The hip motors act between body and links, so
their power is T1 dphi1 + T4 dphi4 with phi1, phi4 relative to the body. The
leg turns relative to the body by d(theta + phi) = -dphi0, so the same power
written with the virtual leg's generalised forces is F dL0 + Tp (-dphi0):

    T1 dphi1 + T4 dphi4 = F dL0 - Tp dphi0

With J = d(L0, phi0)/d(phi1, phi4):  [T1, T4] = J^T [F, -Tp].  Note the minus
on Tp: it comes from theta = pi/2 - phi0 - phi (repos that define
theta = phi0 - pi/2 - phi write J^T [F, Tp]). T1 and T4 are torques ON the
links AB and ED, positive in the sense that increases phi1 and phi4.
"""
from __future__ import annotations

import math
from math import atan2, ceil, cos, hypot, isfinite, sin, sqrt
from typing import NamedTuple

from wheelleg.controller import constants as C

# the link lengths (m) as module names: the per-tick kinematics reads them without an attribute lookup
_L1, _L2, _L4, _L5 = C.L1, C.L2, C.L4, C.L5
_HALF_L5 = 0.5 * C.L5
_TWO_PI = 2.0 * math.pi
_TWO_L2, _L2_SQ, _L3_SQ = 2.0 * C.L2, C.L2 * C.L2, C.L3 * C.L3  # the loop closure's constants (m, m^2)
# A loop-closure discriminant below -_CLOSURE_TOL (relative) is not noise:
# the angles do not belong to an assembled leg.
_CLOSURE_TOL = 1e-9

# Mass lumped at the wheel axle C for support_force (kg): what the ground
# carries below the virtual (massless) leg's push F. The wheel and its M3508
# sit at C; of the links, the hip torques (hence the measured F) show only the
# part of their weight that moves with L0, about 0.15 kg of the 0.25 kg here.
# Lumping the two shins at C matches that: in static stance the estimate is
# within 1% of the true (MASS_TOTAL/2) g over L0 = 0.12..0.26 m (with the
# wheel and motor alone it reads 6-7% low). tests/test_fivebar.py checks it.
MASS_AT_AXLE = C.MASS_WHEEL + C.MASS_WHEEL_MOTOR + 2 * C.MASS_LINK_SHIN


class LegKinematics(NamedTuple):
    """One five-bar pose. Angles in rad (five-bar frame), lengths in m.

    B, C, D are (x_fb, y_fb) points in m: front knee, wheel axle, rear knee.
    ``jacobian`` is ``_jacobian`` of the pose, made with it: the chassis uses it three
    times a leg a tick (leg velocity, joint torques, the measured leg force).
    """

    phi1: float
    phi4: float
    phi2: float  # link BC
    phi3: float  # link DC
    L0: float  # virtual leg length |OC|
    phi0: float  # virtual leg angle, pi/2 = straight down
    B: tuple[float, float]
    C: tuple[float, float]
    D: tuple[float, float]
    jacobian: tuple[tuple[float, float], tuple[float, float]]  # d(L0, phi0)/d(phi1, phi4)


def _wrap(angle: float) -> float:
    """angle mapped to (-pi, pi]."""
    return angle - _TWO_PI * ceil((angle - math.pi) / _TWO_PI)


def forward_kinematics(phi1: float, phi4: float) -> LegKinematics:
    """Leg pose from the two hip angles (rad, five-bar frame).

    The design document's construction (its C code): B and D from the thighs, then
    phi2 = 2 atan2(B0 + sqrt(A0^2 + B0^2 - C0^2), A0 + C0), the branch with C
    below the knees. Raises ValueError when the angles cannot close the loop
    (a wrong reading, not a pose the leg can take).
    """
    xb, yb, xd, yd, phi2 = _knees_and_phi2(phi1, phi4)
    xc, yc = xb + _L2 * cos(phi2), yb + _L2 * sin(phi2)
    phi3 = atan2(yc - yd, xc - xd)
    dx = xc - _HALF_L5
    L0, phi0 = hypot(dx, yc), atan2(yc, dx)
    return LegKinematics(phi1, phi4, phi2, phi3, L0, phi0, (xb, yb), (xc, yc), (xd, yd),
                         _jacobian(phi1, phi4, phi2, phi3, L0, phi0))


def _knees_and_phi2(phi1: float, phi4: float) -> tuple[float, float, float, float, float]:
    """(xb, yb, xd, yd, phi2): the knees B, D (m) and the angle of link BC (rad), the part of
    ``forward_kinematics`` that ``shin_angle`` needs too (same operations, same bits)."""
    if not (isfinite(phi1) and isfinite(phi4)):
        raise ValueError(f"hip angles must be finite, got phi1={phi1}, phi4={phi4}")
    xb, yb = _L1 * cos(phi1), _L1 * sin(phi1)
    xd, yd = _L5 + _L4 * cos(phi4), _L4 * sin(phi4)
    # the design document's expressions, each part worked out once (the same operations in
    # the same order: the same bits); four calls a tick
    bd_x, bd_y = xd - xb, yd - yb
    a0 = _TWO_L2 * bd_x
    b0 = _TWO_L2 * bd_y
    bd_sq = bd_x ** 2 + bd_y ** 2
    c0 = _L2_SQ + bd_sq - _L3_SQ
    ab_sq = a0 * a0 + b0 * b0
    disc = ab_sq - c0 * c0
    if disc < -_CLOSURE_TOL * ab_sq or bd_sq == 0.0:
        raise ValueError(f"phi1={phi1:.4f}, phi4={phi4:.4f} rad do not close the five-bar loop")
    root = sqrt(0.0 if 0.0 > disc else disc)  # max(disc, 0.0) written out (bounds.py)
    phi2 = 2.0 * atan2(b0 + root, a0 + c0)
    return xb, yb, xd, yd, phi2 - _TWO_PI * ceil((phi2 - math.pi) / _TWO_PI)  # _wrap(phi2) written out: four a tick


def shin_angle(phi1: float, phi4: float) -> float:
    """phi2 (rad), the angle of link BC, of ``forward_kinematics(phi1, phi4)`` without the rest
    of the pose (the leg's numerical shin rate needs only it). Raises ValueError as it does."""
    return _knees_and_phi2(phi1, phi4)[4]


def jacobian(k: LegKinematics) -> tuple[tuple[float, float], tuple[float, float]]:
    """J = d(L0, phi0)/d(phi1, phi4) at pose ``k`` (``_jacobian``, kept on the pose)."""
    return k.jacobian


def _jacobian(phi1: float, phi4: float, phi2: float, phi3: float, L0: float,
              phi0: float) -> tuple[tuple[float, float], tuple[float, float]]:
    """J = d(L0, phi0)/d(phi1, phi4) of the pose with these angles (rad) and L0 (m),
    closed form, as ((j11, j12), (j21, j22)).

    Rows: L0 (m/rad), phi0 (rad/rad); columns: phi1, phi4. From the loop
    closure B + L2 e(phi2) = D + L3 e(phi3) (the form of Reborn's vmc.cpp,
    with L1 and L4 kept apart). Singular when the shins are parallel
    (phi2 = phi3, the loop's full stretch).
    """
    s32 = sin(phi3 - phi2)
    a = _L1 * sin(phi1 - phi2) / s32  # front thigh's lever
    b = _L4 * sin(phi3 - phi4) / s32  # rear thigh's lever
    return ((a * sin(phi0 - phi3), b * sin(phi0 - phi2)),
            (a * cos(phi0 - phi3) / L0, b * cos(phi0 - phi2) / L0))


def leg_velocity(k: LegKinematics, dphi1: float, dphi4: float) -> tuple[float, float]:
    """(dL0 in m/s, dphi0 in rad/s) from the hip rates dphi1, dphi4 (rad/s)."""
    (j11, j12), (j21, j22) = k.jacobian
    return j11 * dphi1 + j12 * dphi4, j21 * dphi1 + j22 * dphi4


def joint_torques(k: LegKinematics, F: float, Tp: float) -> tuple[float, float]:
    """Hip torques (T1, T4) in N m on phi1, phi4 for leg push F (N), torque Tp (N m).

    [T1, T4] = J^T [F, -Tp] (module docstring). Map them to shaft torques
    with ``shaft_torque``.
    """
    (j11, j12), (j21, j22) = k.jacobian
    return j11 * F - j21 * Tp, j12 * F - j22 * Tp


def leg_force(k: LegKinematics, T1: float, T4: float) -> tuple[float, float]:
    """(F in N, Tp in N m) that hip torques T1, T4 (N m on phi1, phi4) exert.

    The inverse of ``joint_torques``; raises ValueError at a singular pose.
    """
    (j11, j12), (j21, j22) = k.jacobian
    det = j11 * j22 - j21 * j12
    if abs(det) < 1e-12:
        raise ValueError(f"singular leg pose (L0={k.L0:.4f} m): no unique leg force")
    force = (j22 * T1 - j21 * T4) / det
    torque_phi0 = (j11 * T4 - j12 * T1) / det
    return force, -torque_phi0


def inverse_kinematics(L0: float, phi0: float) -> tuple[float, float]:
    """Hip angles (phi1, phi4) in rad that put the wheel at (L0 m, phi0 rad).

    The knees-outward branch, as on the robot: the front knee B forward of the
    line AC (phi1 = angle of AC + the knee-side angle), the rear knee D
    behind EC (phi4 = angle of EC - it). Raises ValueError out of reach.
    """
    xc, yc = _HALF_L5 + L0 * math.cos(phi0), L0 * math.sin(phi0)
    phi1 = _hip_angle(xc, yc, C.L1, C.L2, +1.0)
    phi4 = _hip_angle(xc - C.L5, yc, C.L4, C.L3, -1.0)
    return phi1, phi4


def _hip_angle(dx: float, dy: float, thigh: float, shin: float, side: float) -> float:
    """Angle of the thigh from a hip to its knee, given the hip-to-C vector (m)."""
    reach = math.hypot(dx, dy)
    cos_knee_side = (thigh * thigh + reach * reach - shin * shin) / (2.0 * thigh * reach) if reach else 2.0
    if not -1.0 <= cos_knee_side <= 1.0:
        raise ValueError(f"wheel axle at ({dx:.4f}, {dy:.4f}) m from a hip is out of the leg's reach")
    return math.atan2(dy, dx) + side * math.acos(cos_knee_side)


def support_force(F: float, Tp: float, theta: float, L0: float, dL0: float, ddL0: float,
                  dtheta: float, ddtheta: float, body_accel_z: float,
                  axle_mass: float = MASS_AT_AXLE) -> float:
    """Ground's normal force on the wheel Fn (N), the design document's leg_fn_cal.

    Inputs: F (N) and Tp (N m) the leg's push and hip torque, best measured
    (``leg_force`` of the motors' feedback torques), in this module's signs;
    theta (rad), dtheta (rad/s), ddtheta (rad/s^2) the leg angle from vertical;
    L0 (m), dL0 (m/s), ddL0 (m/s^2) the leg length; body_accel_z (m/s^2) the
    hip's vertical acceleration in the world, up positive, gravity removed
    (0 at rest); axle_mass (kg) the mass at C that the leg does not carry.

    The leg's vertical push on the wheel is P = F cos(theta) - Tp sin(theta)/L0
    (Tp > 0 swings the wheel back and, for theta > 0, up: it unloads it; the
    document writes +Tp with its opposite Tp). The wheel sits L0 cos(theta) below
    the hip, so (docs/control.md, tulingzt's form)
      zdd_w = zdd_body - ddL0 cos + 2 dL0 dtheta sin + L0 ddtheta sin + L0 dtheta^2 cos
      Fn = P + m (g + zdd_w).
    """
    if not L0 > 0.0:
        raise ValueError(f"leg length must be positive, got {L0}")
    s, c = math.sin(theta), math.cos(theta)
    push = F * c - Tp * s / L0
    wheel_accel_z = (body_accel_z - ddL0 * c + 2.0 * dL0 * dtheta * s
                     + L0 * ddtheta * s + L0 * dtheta * dtheta * c)
    return push + axle_mass * (C.GRAVITY + wheel_accel_z)


# --- hip motor shaft <-> five-bar angle ---------------------------------------
# phi = stop + sign * q (constants.Joint). The stator is fixed to the body, so
# by virtual work T dphi = tau dq: a torque T on phi is tau = sign * T on the
# shaft (sign is +-1, its own inverse).


def phi_from_shaft(joint: C.Joint, q: float) -> float:
    """Five-bar angle (rad) of ``joint`` whose shaft reads q (rad)."""
    return joint.stop + joint.sign * q


def shaft_from_phi(joint: C.Joint, phi: float) -> float:
    """Shaft angle (rad) of ``joint`` at five-bar angle phi (rad)."""
    return joint.sign * (phi - joint.stop)


def phi_rate_from_shaft(joint: C.Joint, dq: float) -> float:
    """dphi/dt (rad/s) from the shaft speed dq (rad/s)."""
    return joint.sign * dq


def shaft_torque(joint: C.Joint, T: float) -> float:
    """Shaft torque (N m, the CyberGear's sign) that puts torque T (N m) on phi."""
    return joint.sign * T


def phi_torque_from_shaft(joint: C.Joint, tau: float) -> float:
    """Torque on phi (N m) that the shaft torque tau (N m) exerts."""
    return joint.sign * tau
