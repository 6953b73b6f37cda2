"""What the quadruped's controller believes about its robot, each number with its source.

Belief, not truth: the rig's plant has its own description; the two may
differ (a run can make them), and the controller must stand the difference.
Tuning choices live in ``params.py``.

Sources:
  [CD2]  Xiaomi CyberDog 2's published model parameters (MiRoboticsLab,
         cyberdog_locomotion, common/config/cyberdog2-description.yaml): a
         CyberGear-class quadruped; geometry and joint ranges are taken from it.
  [CG]   the CyberGear manual as dbc/cybergear.dbc describes it (MIT command
         ranges, 12 N m peak torque).
  [wiring] the rig's quadruped wiring (docs/quadruped-control.md): motor ids,
         buses, host id.
  [derived] chosen here, marked, with the reason.

Conventions (SI units, angles in rad): Unitree's (docs/quadruped-control.md).
Body frame x forward, y left, z up, origin at the body's centre (where the IMU
is). Legs in the order FR, FL, RR, RL (index 0..3); per leg the joints
abduction (about +x), thigh (about +y), calf (about +y), index 0..2. All legs
straight down at zero; thigh > 0 swings the foot backward, calf < 0 bends the
knee (the foot comes forward of the knee). Joint angles are the CyberGear
shaft positions as the motors report them (zeroed with the legs straight down).
"""
from __future__ import annotations

from wheelleg.controller.quadruped.kinematics import LegGeometry

GRAVITY = 9.81  # m/s^2

# --- legs --------------------------------------------------------------------------------
LEGS = ("FR", "FL", "RR", "RL")
JOINTS = ("abduction", "thigh", "calf")
SIDE = (-1.0, 1.0, -1.0, 1.0)  # +1 left, -1 right: the abduction link points to side * y
FRONT = (1.0, 1.0, -1.0, -1.0)  # +1 front, -1 rear
PAIRS = ((0, 3), (1, 2))  # the trot's diagonal pairs: (FR, RL), (FL, RR)

# --- geometry [CD2] ------------------------------------------------------------------------
HIP_X = 0.164  # m, abduction axis ahead of / behind the body centre (body_length)
HIP_Y = 0.042  # m, abduction joint beside the centre line (body_width)
ABAD_LINK = 0.094  # m, abduction axis to the thigh's plane (abad_link_length)
THIGH = 0.12  # m, hip to knee (hip_link_length)
CALF = 0.174  # m, knee to the foot sphere's centre (knee_link_length)
FOOT_RADIUS = 0.019  # m, the foot sphere (foot_radius): the ground touches it this far below its centre
GEOMETRY = LegGeometry(abad_m=ABAD_LINK, thigh_m=THIGH, calf_m=CALF)
BODY_HALF_HEIGHT = 0.05  # m, the body box's half height (CD2 model's body_height 0.1 / 2)

# --- mass [derived] ------------------------------------------------------------------------
# CyberDog 2 weighs 8.9 kg (Xiaomi's figure; its model's parts sum to 8.5 kg); the
# rig's quadruped is of the 10-15 kg class. 10 kg is the belief: the force
# feed-forward carries it, the joint PD and the posture integrators the error.
MASS = 10.0  # kg, whole robot
COM = (0.0, 0.0, 0.0)  # m, centre of mass in the body frame: symmetric body [derived]

# --- joint ranges [CD2], in this convention (the CD2 files count thigh and calf the other way) --
ABDUCTION_RANGE = (-0.68, 0.68)  # rad (abad bounds +-39 deg)
THIGH_RANGE_FRONT = (-1.33, 2.79)  # rad (front hip bounds -2.79 .. 1.33, negated)
THIGH_RANGE_REAR = (-0.98, 3.14)  # rad (rear hip bounds -3.14 .. 0.98, negated)
CALF_RANGE = (-2.53, -0.52)  # rad (knee bounds 0.52 .. 2.53, negated)


def joint_range(leg: int, joint: int) -> tuple[float, float]:
    """(lowest, highest) angle (rad) of ``joint`` (0..2) of ``leg`` (0..3)."""
    if joint == 0:
        return ABDUCTION_RANGE
    if joint == 1:
        return THIGH_RANGE_FRONT if FRONT[leg] > 0 else THIGH_RANGE_REAR
    return CALF_RANGE


def hip_position(leg: int) -> tuple[float, float, float]:
    """The abduction joint (m, body frame) of ``leg``: where its leg frame's origin is."""
    return (FRONT[leg] * HIP_X, SIDE[leg] * HIP_Y, 0.0)


# --- motors [CG] ---------------------------------------------------------------------------
TORQUE_LIMIT = 12.0  # N m, CyberGear peak (the MIT command's torque field spans +-12)
VELOCITY_LIMIT = 30.0  # rad/s, the MIT command's velocity field
KP_MAX = 500.0  # N m/rad, the MIT command's Kp field
KD_MAX = 5.0  # N m s/rad, the MIT command's Kd field
POSITION_LIMIT = 12.5  # rad, the MIT command's position field

# --- wiring [wiring] -------------------------------------------------------------------------
CG_HOST_ID = 0xFD  # the host id every command carries (as the wheel-legged controller's)
FRONT_BUS_LEGS = (0, 1)  # FR, FL on bus 0 (with the IMU and the remote)
REAR_BUS_LEGS = (2, 3)  # RR, RL on bus 1


def motor_id(leg: int, joint: int) -> int:
    """CyberGear CAN id of ``joint`` of ``leg``: 1 + 3 leg + joint (1..12)."""
    return 1 + 3 * leg + joint


MOTOR_IDS = tuple(motor_id(leg, joint) for leg in range(4) for joint in range(3))
MOTOR_OF_ID = {motor_id(leg, joint): (leg, joint) for leg in range(4) for joint in range(3)}
