"""The robot as it is: the plant's own numbers (its truth), each with its source.

The emulators, the MJCF (robot.xml) and the sensors take their numbers from
here and never from the controller: the controller keeps its own constants
(its belief about the robot), and a rig that shared them could not show what
a wrong belief does (a torque constant the controller divides by and the
emulator multiplies by would cancel out). At the nominal values the two agree
today; per-run overrides (emulators/overrides.py) move the truth away.

Sources:
  [design]     the team's robot design document (docs/robot.md): mechanical and mass tables,
             five-bar link lengths, the thighs' mechanical stop
  [CG]       Xiaomi CyberGear manual and its specification table (S1/S2):
             24 V rated (16-28 V), 12 N m peak, 0.87 N m/A, 7.75:1, 30 rad/s
             velocity field, 80 degC fault / 75 degC warning
  [DJI]      C620 user guide (D1) and M3508 P19 data (D3/D4): 20 A command
             range, 0.3 N m/A at the output, 3591/187, 482 rpm no-load with a
             C620 at 24 V
  [derived]  chosen to fit the design document's totals where no CAD value exists (link
             mass split, body box, CoM height, leg plane, rotor inertias)

Conventions (SI units, angles in rad): body frame x forward, y left, z up,
origin at the body's nominal CoM; five-bar frame per leg with origin at the
front hip A, x_fb backward towards the rear hip E at (L5, 0), y_fb down;
phi1 (link AB) and phi4 (link ED) measured from x_fb towards y_fb. Every
motor shaft points outwards from the body, and the hips were zeroed with the
thighs on their mechanical stops, so phi = stop + sign * q.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

GRAVITY_M_S2 = 9.81

# --- five-bar leg geometry [design] ----------------------------------------------
L1_M = 0.11  # hip A to knee B (front thigh)
L2_M = 0.18  # knee B to wheel axle C
L3_M = 0.18  # knee D to wheel axle C
L4_M = 0.11  # hip E to knee D (rear thigh)
L5_M = 0.09  # hip A to hip E
WHEEL_RADIUS_M = 0.05
HALF_TRACK_M = 0.1577  # body centre to wheel contact, sideways
STOP_ANGLE_RAD = 0.10472  # thighs lying on the mechanical stop
PHI1_STOP_RAD = math.pi - STOP_ANGLE_RAD  # front thigh on its stop
PHI4_STOP_RAD = STOP_ANGLE_RAD  # rear thigh on its stop
HIP_SWEEP_RAD = 1.40  # each hip's travel off its stop before the links lock [derived from the geometry]

# --- masses [design; split derived] ---------------------------------------------
MASS_BODY_KG = 2.839  # includes the four CyberGear hip motors
MASS_WHEEL_KG = 0.183  # tyre and hub
MASS_LINK_THIGH_KG = 0.05  # each of AB and ED [derived]
MASS_LINK_SHIN_KG = 0.075  # each of BC and DC [derived]
MASS_WHEEL_MOTOR_KG = 0.465  # M3508 (0.365 kg, DJI) and its mount at C: 0.715 kg per leg in all [derived]

# --- shapes [derived: a box that holds the design document's parts] -------------------------
BODY_SIZE_M = (0.26, 0.24, 0.08)  # x, y, z extent of the body box
BODY_COM_ABOVE_HIP_M = 0.02  # body CoM above the hip axis ("l" in the design document's model)
LEG_PLANE_Y_M = 0.12  # each leg's plane from the body's mid-plane
WHEEL_WIDTH_M = 0.03

# --- CyberGear hip motors [CG] -------------------------------------------------
CG_TORQUE_LIMIT_NM = 12.0  # peak torque
CG_SPEED_LIMIT_RAD_S = 30.0  # velocity field range (no-load ~31 rad/s at 24 V)
CG_TORQUE_CONSTANT_NM_PER_A = 0.87
CG_OVER_TEMP_C = 80.0  # over-temperature fault
CG_WARN_TEMP_C = 75.0  # warning
CG_GEAR = 7.75
CG_ROTOR_INERTIA_KG_M2 = 2.0e-5  # motor side [derived: ~0.08 kg pancake rotor at 22 mm]
HIP_ARMATURE_KG_M2 = CG_ROTOR_INERTIA_KG_M2 * CG_GEAR ** 2  # at the joint, rotor alone (robot.xml's hip armature)
CG_LINE_RESISTANCE_OHM = 0.45  # winding, line to line (+-10 %)

# --- C620 + M3508 wheel drives [DJI] ---------------------------------------------
M3508_GEAR = 3591 / 187  # rotor to output shaft
M3508_TORQUE_CONSTANT_NM_PER_A = 0.3  # at the output shaft
M3508_NO_LOAD_SPEED_RAD_S = 482 * 2 * math.pi / 60  # output, with a C620 at the rated supply
C620_CURRENT_LIMIT_A = 20.0  # command range +-16384
M3508_ROTOR_INERTIA_KG_M2 = 6.0e-6  # motor side [derived: ~0.07 kg inrunner at 13 mm]

# --- supply [CG, DJI] -------------------------------------------------------------
SUPPLY_NOMINAL_V = 24.0  # both motors' rated supply; speed limits scale with it
SUPPLY_RANGE_V = (16.0, 28.0)  # the CyberGear's operating range (the C620 is rated 24 V)


@dataclass(frozen=True)
class HipMotor:
    """One CyberGear as wired: MJCF joint name, CAN id on CAN2, leg, hip and shaft sign."""

    name: str
    motor_id: int
    leg: str  # "left" | "right"
    hip: str  # "A" (front, phi1) | "E" (rear, phi4)
    sign: int  # phi = stop + sign * q

    @property
    def stop_rad(self) -> float:
        """phi (rad) when the shaft reads 0: the thigh on its mechanical stop."""
        return PHI1_STOP_RAD if self.hip == "A" else PHI4_STOP_RAD


@dataclass(frozen=True)
class WheelDrive:
    """One C620 + M3508 as wired: MJCF joint name and ESC id on CAN1."""

    name: str
    esc_id: int
    leg: str


# A left shaft turning positive lowers phi, a right one raises it (shafts point outwards).
HIP_MOTORS = (
    HipMotor("left_front_hip", 1, "left", "A", -1),
    HipMotor("left_rear_hip", 2, "left", "E", -1),
    HipMotor("right_front_hip", 3, "right", "A", +1),
    HipMotor("right_rear_hip", 4, "right", "E", +1),
)
WHEEL_DRIVES = (WheelDrive("left_wheel", 1, "left"), WheelDrive("right_wheel", 2, "right"))
