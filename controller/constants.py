"""The robot's physical constants, in one place, each with its source.

Everything here is a fact about the machine (geometry, masses, motor data,
wiring) as the controller believes it, not a tuning choice; tuning lives in
``controller/params.py``. The LQR design script (``controller/design/lqr.py``)
and the controller read these numbers. The rig's plant has its own (the truth,
``emulators/robot/description.py``), so a run can make the two disagree;
``tests/test_model.py`` checks that they agree at the nominal values.

Sources:
  [seed]   the robot team's design document, mechanical and mass tables
           (docs/robot.md)
  [CG]     Xiaomi CyberGear manual and drivers (docs/protocols.md, Xiaomi CyberGear)
  [DJI]    DJI C620 guide, M3508 data (docs/protocols.md, DJI C620 with M3508 P19)
  [derived] chosen here to fit the design document's totals; marked as such, to be
            replaced by CAD values when the team has them.

Conventions (SI units throughout; angles in rad):
  body frame  x forward, y left, z up; roll/pitch/yaw ZYX, pitch > 0 nose DOWN
              (right hand about +y). The LQR's body angle phi is -pitch
              (nose up positive), as in the design document's ``phi = -pitch_angle``.
  leg plane   the design document's five-bar frame, one per leg, both seen alike ("both
              legs are controlled as seen from the left", seed): origin at hip
              A (front hip), x_fb pointing BACKWARD towards hip E (rear hip,
              at x_fb = L5), y_fb pointing DOWN. phi1 is the angle of link AB,
              phi4 of link ED, measured from x_fb towards y_fb. The wheel
              axle is point C; the virtual leg runs from the midpoint of AE to C.
  leg angle   theta = pi/2 - phi0 - phi: theta > 0 when the wheel is behind
              the hip ("leg swung back positive", seed model table).
  motors      every shaft points outwards from the body. A left shaft turning
              positive (right hand about +y) lowers phi; a right shaft raises
              it. The joint motors were zeroed (CyberGear type 6) with the
              thighs on the mechanical stop, so phi = stop + sign * q.
              A left wheel turning positive rolls forward; a right one rolls
              backward.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

GRAVITY = 9.81  # m/s^2

# --- five-bar leg geometry [seed: 尺寸相关] ---------------------------------
L1 = 0.11  # m, hip A to knee B (front thigh)
L2 = 0.18  # m, knee B to wheel axle C
L3 = 0.18  # m, knee D to wheel axle C
L4 = 0.11  # m, hip E to knee D (rear thigh)
L5 = 0.09  # m, hip A to hip E
WHEEL_RADIUS = 0.05  # m
HALF_TRACK = 0.1577  # m, yaw radius: body centre to wheel contact ("底盘绕Z轴旋转半径")
STOP_ANGLE = 0.10472  # rad, thighs lying on the mechanical stop ("大腿趴下机械限位"):
PHI1_STOP = math.pi - STOP_ANGLE  # rad, front thigh on its stop
PHI4_STOP = STOP_ANGLE  # rad, rear thigh on its stop
HIP_SWEEP = 1.40  # rad, how far each hip turns off its stop before the links
#                   lock (phi1 = 95 deg, the leg's geometric maximum) [derived
#                   from the geometry, docs/robot.md]

# --- masses [seed: 质量相关]: 4.635 = 2.839 + 2 * 0.715 + 2 * 0.183 ---------
MASS_TOTAL = 4.635  # kg
MASS_BODY = 2.839  # kg, includes the four CyberGear hip motors
MASS_LEG = 0.715  # kg per leg: four links plus the M3508 wheel motor at C
MASS_WHEEL = 0.183  # kg per wheel (tyre and hub)
# how one leg's 0.715 kg splits [derived: M3508 0.365 kg (DJI) plus its
# mount at C, the rest in the links]
MASS_LINK_THIGH = 0.05  # kg, each of AB and ED
MASS_LINK_SHIN = 0.075  # kg, each of BC and DC
MASS_WHEEL_MOTOR = MASS_LEG - 2 * MASS_LINK_THIGH - 2 * MASS_LINK_SHIN  # kg at C

# --- body and wheel shape [derived: a box that holds the design document's parts] -----
BODY_SIZE = (0.26, 0.24, 0.08)  # m, x, y, z extent of the body box
BODY_COM_ABOVE_HIP = 0.02  # m, "l" in the design document's model: body CoM above the hip axis
LEG_PLANE_Y = 0.12  # m, each leg's plane from the body's mid-plane
WHEEL_WIDTH = 0.03  # m


def box_inertia(mass: float, size: tuple[float, float, float]) -> tuple[float, float, float]:
    """Principal inertias (kg m^2) of a solid box of ``mass`` kg and ``size`` m."""
    x, y, z = size
    return (mass * (y * y + z * z) / 12, mass * (x * x + z * z) / 12, mass * (x * x + y * y) / 12)


BODY_INERTIA = box_inertia(MASS_BODY, BODY_SIZE)  # kg m^2, (Ixx, Iyy, Izz)
WHEEL_INERTIA = 0.5 * MASS_WHEEL * WHEEL_RADIUS**2  # kg m^2 about the axle (solid disc)


# --- CyberGear hip motors on CAN2 [CG: the motor, type 1] ---------------------------
CG_TORQUE_LIMIT = 12.0  # N m, protocol range and peak torque
CG_SPEED_LIMIT = 30.0  # rad/s, protocol velocity range
CG_POSITION_LIMIT = 12.5  # rad, default position field range (+-4 pi option)
CG_KP_MAX = 500.0
CG_KD_MAX = 5.0
CG_TORQUE_CONSTANT = 0.87  # N m / A
CG_OVER_TEMP = 80.0  # degC, over-temperature fault default
CG_WARN_TEMP = 75.0  # degC, warning
CG_GEAR = 7.75  # reduction (debugger parameter GearRatio 0x200F)
# Rotor inertia: not published; [derived] from a 28-pole pancake rotor of
# about 0.08 kg at 22 mm radius (0.5 m r^2). Reflected through the gear it is
# the hip joint's armature, felt by every fast leg motion.
CG_ROTOR_INERTIA = 2.0e-5  # kg m^2, motor side
HIP_ARMATURE = CG_ROTOR_INERTIA * CG_GEAR**2  # kg m^2 at the joint (1.2e-3)
# Dry friction of a hip joint (gearbox, seals), at the joint: not published for the
# CyberGear, and not yet measured on this robot. A MuJoCo identification of its
# successors (RobStride RS00, RS02, RS05) fits 0.16, 0.16 and 0.38 N m. The hips'
# Coulomb feed-forward (friction.py) adds this much back, so it must never exceed the
# real figure (more is negative friction: believing 0.3 N m of frictionless hips,
# `balance` with the CoM 3 cm back wobbled +-2 deg, 13.9 cm). Off until measured on the
# robot (docs/control.md, friction): 0.1 N m, below every identified figure, held the CoM
# 3 cm off with 0.2 N m hips at 6.8 cm instead of 26.5, but on frictionless hips it lifted
# a wheel in `turn-fast` and a tolerance side push ended 0.54 m off its spot (limit 0.5).
HIP_FRICTION = 0.0  # N m at the joint
CG_HOST_ID = 0xFD  # the host id the controller puts in bits 15..8 (debugger's)

# --- C620 + M3508 wheel drives on CAN1 [DJI: frames, the motor and ESC] ---------------------
M3508_GEAR = 3591 / 187  # reduction, rotor to output shaft
M3508_TORQUE_CONSTANT = 0.3  # N m / A at the output shaft
C620_CURRENT_LIMIT = 20.0  # A, command range -16384..16384 <-> -20..20 A
M3508_NO_LOAD_SPEED = 482 * 2 * math.pi / 60  # rad/s at the output, with a C620
WHEEL_TORQUE_LIMIT = C620_CURRENT_LIMIT * M3508_TORQUE_CONSTANT  # 6 N m
# Rotor inertia: not published; [derived] from the M3508's inrunner rotor,
# about 0.07 kg at 13 mm radius (0.5 m r^2). Through the 19.2:1 gear it is
# ten times the wheel's own inertia, so it dominates how fast a wheel can spin up.
M3508_ROTOR_INERTIA = 6.0e-6  # kg m^2, motor side
WHEEL_ARMATURE = M3508_ROTOR_INERTIA * M3508_GEAR**2  # kg m^2 at the wheel axle (2.2e-3)


@dataclass(frozen=True)
class Joint:
    """One CyberGear hip motor: where it sits and how its shaft maps to phi."""

    name: str  # also the MJCF joint/actuator name and the DBC node name
    motor_id: int  # CyberGear CAN id on CAN2
    leg: str  # "left" | "right"
    hip: str  # "A" (front, phi1) | "E" (rear, phi4)
    sign: int  # phi = stop + sign * q_motor

    @property
    def stop(self) -> float:
        """phi (rad) when the shaft reads 0: the thigh on its mechanical stop."""
        return PHI1_STOP if self.hip == "A" else PHI4_STOP


# Shafts point outwards, so a left shaft turning positive lowers phi (see the
# module docstring); ids follow the design document's cyber_gear_data order, front first.
JOINTS = (
    Joint("left_front_hip", 1, "left", "A", -1),
    Joint("left_rear_hip", 2, "left", "E", -1),
    Joint("right_front_hip", 3, "right", "A", +1),
    Joint("right_rear_hip", 4, "right", "E", +1),
)
# leg -> (front hip A, rear hip E): each five-bar's two driven joints
LEG_JOINTS = {leg: (next(j for j in JOINTS if j.leg == leg and j.hip == "A"),
                    next(j for j in JOINTS if j.leg == leg and j.hip == "E")) for leg in ("left", "right")}


@dataclass(frozen=True)
class Wheel:
    """One M3508 wheel drive behind a C620 on CAN1."""

    name: str
    esc_id: int  # C620 id 1..8: command slot esc_id-1 of 0x200, feedback 0x200+id
    leg: str
    forward_sign: int  # +1 when a positive output turn rolls the robot forward


WHEELS = (Wheel("left_wheel", 1, "left", +1), Wheel("right_wheel", 2, "right", -1))

# Offline-detection device order: bit i of the heartbeat's offline mask.
DEVICES = tuple(j.name for j in JOINTS) + tuple(w.name for w in WHEELS) + ("imu", "remote")
