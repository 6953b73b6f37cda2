"""The controller's last output, typed, and the debug record projected from it.

What one tick computed and the next one reads back lives in ``LastOutput``:
the legs' lengths and angles (the stand-up and body-on-the-ground checks, the
recovery and jump tables) and the axle speed (a forward jump's run-up). The
record the rig writes to the trace (``/controller/debug``) is
``debug_record(last)``, a projection that nothing in the controller reads, so
renaming or dropping one of its keys cannot change what the robot does.
"""
from __future__ import annotations

from typing import NamedTuple

from wheelleg.controller.chassis import ChassisReport
from wheelleg.controller.legs import LEGS
from wheelleg.controller.jump import Phase


class LastOutput(NamedTuple):
    """One run tick's result as the next tick sees it (SI units)."""

    chassis: ChassisReport
    support_n: dict  # leg name -> support force estimate (N) after this tick's update
    jump_phase: Phase  # the jump table's phase after this tick's step

    def leg_lengths_m(self) -> tuple[float, float]:
        """Measured L0 (m) of the left and the right leg."""
        legs = self.chassis.legs
        return legs["left"].length_m, legs["right"].length_m

    def leg_angles_rad(self) -> tuple[float, float]:
        """Measured theta (rad) of the left and the right leg."""
        legs = self.chassis.legs
        return legs["left"].theta_rad, legs["right"].theta_rad


# Every key of ``debug_record`` with its meaning and unit (the trace's schema describes
# the fields from this table; tests check it names exactly the record's keys).
DEBUG_FIELDS = {
    "x": "wheel travel since the last reset (m)",
    "x_ref": "position reference (m)",
    "x_integral": "integral of the position error, the LQR's trim state (m s)",
    "balance_theta": "leg angle of the balance point the LQR holds (estimate.BalancePointObserver) (rad)",
    "hold_torque": "hip torque per leg that holds the body at the balance point (N m)",
    "speed": "axle speed along the ground, mean of both wheels; the IMU's figure while they slip (m/s)",
    "slipping": "1 while the wheels' speed and the IMU's part (estimate.SlipObserver), else 0",
    "blocked": "+1/-1 while held back driving forward/backward, a wall (chassis._blocked_target), else 0",
    "speed_ref": "speed reference after the acceleration limit (m/s)",
    "pitch": "body pitch from the IMU, nose down positive (rad)",
    "roll": "body roll from the IMU, left side up positive (rad)",
    "yaw": "body yaw from the IMU (rad)",
    "yaw_ref": "heading reference (rad)",
    **{f"{leg}_{key}": f"{leg} leg: {text}" for leg in LEGS for key, text in (
        ("L0", "virtual leg length (m)"), ("L0_ref", "leg length reference (m)"),
        ("theta", "virtual leg angle from vertical, wheel behind the hip positive (rad)"),
        ("T", "wheel torque asked of the LQR and yaw control (N m)"),
        ("Tp", "virtual hip torque asked of the LQR and split control (N m)"))},
    **{f"Fn_{leg}": f"{leg} leg: support force estimate (N)" for leg in LEGS},
    "jump_phase": "jump table phase (controller.jump.Phase, 0 = idle)",
}


def debug_record(last: LastOutput) -> dict:
    """The trace's flat debug record (key -> number) of ``last``; read by no control path.

    One dict display, in ``DEBUG_FIELDS``' order (built once a tick: no key-by-key stores)."""
    c = last.chassis
    left, right = c.legs["left"], c.legs["right"]
    fn = last.support_n
    return {"x": c.x_m, "x_ref": c.x_ref_m, "x_integral": c.x_integral_m_s,
            "balance_theta": c.balance_theta_rad, "hold_torque": c.hold_torque_nm, "speed": c.speed_m_s,
            "slipping": float(c.slipping), "blocked": c.blocked, "speed_ref": c.speed_ref_m_s,
            "pitch": c.pitch_rad, "roll": c.roll_rad, "yaw": c.yaw_rad, "yaw_ref": c.yaw_ref_rad,
            "left_L0": left.length_m, "left_L0_ref": left.length_ref_m, "left_theta": left.theta_rad,
            "left_T": left.wheel_torque_nm, "left_Tp": left.leg_torque_nm,
            "right_L0": right.length_m, "right_L0_ref": right.length_ref_m, "right_theta": right.theta_rad,
            "right_T": right.wheel_torque_nm, "right_Tp": right.leg_torque_nm,
            "Fn_left": fn["left"], "Fn_right": fn["right"], "jump_phase": int(last.jump_phase)}
