"""The quadruped as it is: the plant's own numbers (its truth), each with its source.

The second robot of the rig: a 12-joint quadruped on CyberGear motors, the
class of Xiaomi's CyberDog 2 (which uses twelve CyberGear micro-motors). The
MJCF (robot.xml), the emulators and the ground truth take their numbers from
here and never from the quadruped's controller, which keeps its own belief.

Sources:
  [CD2]   Xiaomi's open CyberDog 2 simulation description (MiRoboticsLab,
          cyberdog_simulator: cyberdog_description/xacro/const.xacro, leg.xacro,
          robot.xacro): hip positions, link lengths, link and rotor masses and
          inertias, joint ranges, the 7.75:1 CyberGear reduction, 0.01 N m s/rad
          damping and 0.1 N m friction per joint, the 0.019 m foot sphere
  [CG]    Xiaomi CyberGear manual (as for the wheel-legged robot,
          emulators/robot/description.py): 12 N m peak, 30 rad/s, 24 V
  [conv]  the leg convention (Unitree's): legs FR, FL, RR, RL; per leg
          abduction (hip roll, about x), thigh (hip pitch, about y), calf (knee,
          about y); x forward, y left, z up; every joint 0 with the legs straight down
  [est]   estimated where no public figure exists (said at each number)

Conventions (SI units, angles in rad): body frame x forward, y left, z up,
origin at the body's centre (the box's centre, where the IMU sits and where
the body's CoM is put). Every joint's angle is its CyberGear's shaft angle,
direct drive, positive about the joint's axis (abduction +x, thigh and calf +y,
the same axes on both sides): a positive thigh angle swings the foot backward,
a positive abduction swings it to the left, the calf bends with negative angles.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

GRAVITY_M_S2 = 9.81

LEGS = ("FR", "FL", "RR", "RL")  # [conv] index 0..3
JOINTS = ("abduction", "thigh", "calf")  # [conv] index 0..2 within a leg

# --- geometry [CD2] ----------------------------------------------------------------------
HIP_X_M = 0.164  # abduction axis from the body centre, forward (front legs) / back (rear)
HIP_Y_M = 0.042  # abduction axis from the body's mid-plane, sideways
ABDUCTION_LINK_M = 0.094  # l1: abduction axis to the thigh's plane, outwards (-y on the right)
THIGH_M = 0.12  # l2: hip pitch axis to knee
CALF_M = 0.174  # l3: knee to the foot sphere's centre [CD2: 0.18341 - 0.019/2 along the calf;
# its 5.5 mm forward offset dropped, so the foot lies on the calf's axis as the leg kinematics assume]
FOOT_RADIUS_M = 0.019
BODY_SIZE_M = (0.236, 0.19, 0.109)  # x, y, z extent of the body box

# --- joint ranges (rad) [CD2] --------------------------------------------------------------
ABDUCTION_RANGE_RAD = (math.radians(-39.0), math.radians(39.0))
THIGH_RANGE_RAD = {"front": (math.radians(-76.0), math.radians(160.0)),
                   "rear": (math.radians(-56.0), math.radians(180.0))}
CALF_RANGE_RAD = (math.radians(-145.0), math.radians(-30.0))

# --- masses (kg) and inertias (kg m^2, about each part's CoM) --------------------------------
MASS_BODY_KG = 4.03  # [CD2]
MASS_PAYLOAD_KG = 1.5  # [est] battery and compute of a research build: brings the robot to 10 kg,
# the low end of the 10-15 kg class the rig is asked to serve (CyberDog 2 alone is ~8.5 kg)
BODY_INERTIA_KG_M2 = (0.0185, 0.0517, 0.0483)  # [CD2] diagonal; products (< 0.0102) dropped [est]
MASS_ABDUCTION_KG = 0.354  # [CD2]
MASS_THIGH_KG = 0.482  # [CD2]
MASS_CALF_KG = 0.116  # [CD2]
MASS_ROTOR_KG = 0.0567  # [CD2] one CyberGear rotor: on the abduction link (its own), two on the thigh
# [est] each rotor's mass is lumped into its link at the link's CoM
ABDUCTION_INERTIA_KG_M2 = (0.00019, 0.000276, 0.000233)  # [CD2]
THIGH_INERTIA_KG_M2 = (0.00101, 0.000983, 0.000347)  # [CD2]
CALF_INERTIA_KG_M2 = (0.000668, 0.000674, 0.0000154)  # [CD2]
ABDUCTION_COM_M = (-0.00392, 0.015, -0.000306)  # [CD2] in the abduction frame, front left leg
# (x mirrored on the rear legs, y on the right ones)
THIGH_COM_M = (-0.00212, -0.0212, -0.0184)  # [CD2] in the thigh frame, left leg (y mirrored on the right)
CALF_COM_M = (0.0006, 0.0, -0.0893)  # [CD2]
ROTOR_INERTIA_KG_M2 = 4.78e-5  # [CD2] about its spin axis; reflected through the gear as armature

# --- CyberGear joint motors [CG, CD2] ------------------------------------------------------------
CG_TORQUE_LIMIT_NM = 12.0  # peak, at the output
CG_GEAR = 7.75
JOINT_ARMATURE_KG_M2 = ROTOR_INERTIA_KG_M2 * CG_GEAR ** 2  # 0.002871
JOINT_DAMPING_NM_S_PER_RAD = 0.01  # [CD2]
JOINT_FRICTION_NM = 0.1  # [CD2] dry friction
FRICTION = 1.0  # [est] foot on floor, sliding: rubber on a hard floor

# --- wiring [the rig's contract] --------------------------------------------------------------------
CONTROL_PERIOD_S = 0.004  # one SYNC and one heartbeat per bus every 4 ms (250 Hz)
REMOTE_PERIOD_S = 0.02  # QuadOperator every 20 ms, as the wheel-legged robot's Operator
IMU_PERIOD_S = 0.002  # the three IMU frames every 2 ms, as on the wheel-legged robot


@dataclass(frozen=True)
class JointMotor:
    """One CyberGear as wired: MJCF joint (and actuator) name, CAN id, bus index, leg and joint."""

    name: str
    motor_id: int
    bus: int  # 0: FR and FL motors, IMU, remote; 1: RR and RL motors
    leg: str
    joint: str

    @property
    def range_rad(self) -> tuple[float, float]:
        if self.joint == "abduction":
            return ABDUCTION_RANGE_RAD
        if self.joint == "thigh":
            return THIGH_RANGE_RAD["front" if self.leg[0] == "F" else "rear"]
        return CALF_RANGE_RAD


def _motor(leg_index: int, joint_index: int) -> JointMotor:
    leg, joint = LEGS[leg_index], JOINTS[joint_index]
    return JointMotor(f"{leg}_{joint}", 1 + 3 * leg_index + joint_index, leg_index // 2, leg, joint)


# Motor CAN id = 1 + 3 * leg + joint; bus 0 carries the front legs, bus 1 the rear.
JOINT_MOTORS = tuple(_motor(leg, joint) for leg in range(4) for joint in range(3))


def hip_position_m(leg: str) -> tuple[float, float, float]:
    """The abduction axis's point in the body frame (m): front legs forward, right legs at -y."""
    return (HIP_X_M if leg[0] == "F" else -HIP_X_M, HIP_Y_M if leg[1] == "L" else -HIP_Y_M, 0.0)


def side_sign(leg: str) -> float:
    """+1 for a left leg, -1 for a right one (the abduction link's direction along y)."""
    return 1.0 if leg[1] == "L" else -1.0


def body_inertia_kg_m2() -> tuple[float, float, float]:
    """Diagonal inertia (kg m^2) of body and payload about the body centre: [CD2]'s body plus the
    payload as a uniform box of the body's size [est]."""
    x, y, z = BODY_SIZE_M
    box = (y * y + z * z, x * x + z * z, x * x + y * y)
    return tuple(i + MASS_PAYLOAD_KG / 12.0 * b for i, b in zip(BODY_INERTIA_KG_M2, box))


def total_mass_kg() -> float:
    """The robot's mass (kg): body, payload, links and rotors."""
    per_leg = MASS_ABDUCTION_KG + MASS_THIGH_KG + MASS_CALF_KG + 3 * MASS_ROTOR_KG
    return MASS_BODY_KG + MASS_PAYLOAD_KG + 4 * per_leg
