"""Controller tuning: every number here is a choice, not a fact about the robot.

Facts live in ``controller/constants.py``. Sources are control_notes.md
sections (the open-source robots each default was scaled from).
"""
from __future__ import annotations

# --- timing ------------------------------------------------------------------
# 2 ms (500 Hz): the norm for CAN joint motors (control_notes §0.2). At 1 kHz the
# four CyberGear command/reply pairs alone would need ~120% of CAN2 at 1 Mbit/s;
# at 500 Hz CAN2 carries ~62% with SYNC and heartbeat (README, bus load).
CONTROL_PERIOD = 0.002  # s

# --- LQR design (controller/design/lqr.py reads these) ------------------------
LQR_Q = (1.0, 10.0, 100.0, 20.0, 1000.0, 1.0)  # theta, theta_dot, x, x_dot, phi, phi_dot (Skythinker/LJW0401)
LQR_R = (1.0, 1.0)  # T (wheel), Tp (virtual hip)
LEG_LENGTH_MIN = 0.12  # m, lower end of the K(L0) fit and of leg commands
LEG_LENGTH_MAX = 0.26  # m, upper end (geometric max 0.28, singular at 0.2865)
LEG_LENGTH_NOMINAL = 0.17  # m
LQR_GRID_POINTS = 50
