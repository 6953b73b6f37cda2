"""The quadruped controller's debug record (the rig's ``/controller/debug``), with every field described.

``debug_record`` projects one tick's summary; nothing in the controller reads
it back, so renaming a key cannot change what the robot does.
"""
from __future__ import annotations

DEBUG_FIELDS = {
    "mode": "operating mode (controller.quadruped.modes.Mode: 0 passive .. 4 recovery stand)",
    "getup_phase": "stand-up/recovery phase (controller.quadruped.getup.Phase, 0 idle)",
    "latched": "1 while an E-stop or a fault keeps the robot passive until the remote asks for passive",
    "roll": "body roll from the IMU, left side up positive (rad)",
    "pitch": "body pitch from the IMU, nose down positive (rad)",
    "yaw": "body yaw from the IMU (rad)",
    "height": "body centre over the ground under the feet, from leg kinematics (m)",
    "roll_ref": "balance stand roll set point after the slew (rad)",
    "pitch_ref": "balance stand pitch set point after the slew (rad)",
    "yaw_ref": "balance stand yaw set point after the slew, relative to its start (rad)",
    "height_ref": "height set point after the slew (m)",
    "vx": "forward velocity from leg odometry, filtered (m/s)",
    "vy": "lateral velocity from leg odometry, filtered (m/s)",
    "vx_ref": "forward velocity set point after the slew (m/s)",
    "vy_ref": "lateral velocity set point after the slew (m/s)",
    "yaw_rate_ref": "yaw rate the stance feet carry, heading correction included (rad/s)",
    "gait_clock": "trot phase clock (cycles, 0..1)",
    "stance_mask": "feet in stance, bit i = leg i (FR, FL, RR, RL)",
}


def debug_record(summary: dict) -> dict:
    """The trace's flat record: ``summary``'s values for exactly the DEBUG_FIELDS keys (numbers)."""
    return {key: float(summary.get(key, 0.0)) for key in DEBUG_FIELDS}
