"""The balancer controller's tuning, each with its reason (the LQR gains: gains.py, from design.py)."""
from __future__ import annotations

CONTROL_PERIOD = 0.002  # s: the C620s report at 1 kHz, the IMU at 500 Hz
FALLEN_PITCH_RAD = 0.6  # |pitch| past which it cannot recover within the wheels' torque: motors off
MAX_SPEED_M_S = 1.0  # the remote's SpeedX is clamped to it
MAX_YAW_RATE_RAD_S = 2.0  # the remote's YawRate is clamped to it
YAW_RATE_GAIN_NM_S = 0.3  # differential torque per rad/s of yaw-rate error (~0.1 s to follow, body Izz 0.017)
# offline thresholds (s without a good frame): a few periods of each device's rate, as the rig's own robots
ESC_OFFLINE_S = 0.010  # C620 feedback every 1 ms
IMU_OFFLINE_S = 0.010  # 500 Hz
REMOTE_OFFLINE_S = 0.100  # 50 Hz
