"""The balancer's truth, for its plant only (its controller has its own belief: constants.py).

The numbers a team reads off its CAD model and its parts' datasheets:

- body (chassis, battery, electronics, the two motor stators): 2.6 kg, a box
  0.10 x 0.26 x 0.20 m (x forward, y left, z up), its CoM 0.10 m above the
  axle, inertia of a uniform box of those sides [CAD];
- wheels: 0.06 m radius, 0.25 kg each (hub and tyre) on M3508 P19 output
  shafts 0.30 m apart; the rotor reflected through the 3591/187 gearbox adds
  6.0e-6 x 19.2^2 = 0.00221 kg m^2 (the MJCF's armature) [DJI M3508 data];
- C620 ESC ids 1 (left) and 2 (right) on CAN1; the right motor is mounted
  mirrored (its shaft turns about -y: robot.xml);
- the IMU at the body's CoM, 500 Hz; the remote's frame at 50 Hz.
"""
from __future__ import annotations

from pathlib import Path

MODEL_DIR = Path(__file__).resolve().parent  # robot.xml, scene.xml
BODY_MASS_KG = 2.6
BODY_SIZE_M = (0.10, 0.26, 0.20)  # x, y, z
COM_OVER_AXLE_M = 0.10
WHEEL_RADIUS_M = 0.06
WHEEL_MASS_KG = 0.25
TRACK_M = 0.30  # between the wheels' mid-planes
ESC_IDS = {"left_wheel": 1, "right_wheel": 2}
WHEELS = tuple(ESC_IDS)  # the MJCF's wheel joints, actuators and tyre geoms, in the plant's motor order
CONTROL_PERIOD_S = 0.002
IMU_PERIOD_S = 0.002
REMOTE_PERIOD_S = 0.02


def body_inertia_kg_m2() -> tuple[float, float, float]:
    """(Ixx, Iyy, Izz) kg m^2 of the body about its CoM: a uniform box of ``BODY_SIZE_M``."""
    x, y, z = BODY_SIZE_M
    k = BODY_MASS_KG / 12
    return k * (y * y + z * z), k * (x * x + z * z), k * (x * x + y * y)
