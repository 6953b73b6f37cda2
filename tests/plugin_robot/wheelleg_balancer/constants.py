"""What the balancer's controller believes about its robot (the plant's truth is description.py).

Each number is the team's CAD model or a datasheet, as the controller was
designed with; a plant override (a heavier body, a weaker motor) moves the
truth, never these.
"""
from __future__ import annotations

import math

GRAVITY_M_S2 = 9.81
BODY_MASS_KG = 2.6  # [CAD] chassis, battery, electronics, motor stators
BODY_PITCH_INERTIA_KG_M2 = 0.0108  # [CAD] about the CoM, y axis
COM_OVER_AXLE_M = 0.10  # [CAD]
WHEEL_RADIUS_M = 0.06  # [CAD] tyre
WHEEL_MASS_KG = 0.25  # [CAD] hub and tyre, each
WHEEL_INERTIA_KG_M2 = 0.5 * WHEEL_MASS_KG * WHEEL_RADIUS_M ** 2  # each, a disc
ROTOR_INERTIA_KG_M2 = 6.0e-6  # [DJI M3508 data] motor side
M3508_GEAR = 3591 / 187  # [DJI] rotor turns per output turn
M3508_TORQUE_CONSTANT_NM_PER_A = 0.3  # [DJI] at the output shaft
C620_MAX_CURRENT_A = 20.0  # [DJI C620 guide] the command's full scale
ESC_IDS = {"left_wheel": 1, "right_wheel": 2}  # [wiring] C620 ids on CAN1
WHEEL_SIGN = {"left_wheel": 1, "right_wheel": -1}  # [mounting] the right motor is mirrored: + is backwards
RPM_TO_RAD_S = 2 * math.pi / 60
