"""The quadruped controller's tuning: every number here is a choice, not a fact about the robot.

Facts (the controller's belief of its robot) live in ``constants.py``. The
reasons are given beside each; docs/quadruped-control.md collects them.
"""
from __future__ import annotations

import math

# --- timing ------------------------------------------------------------------------------
# 4 ms (250 Hz): 12 CyberGear command/reply pairs on two buses at 1 Mbit/s (the rig's
# bus-load table); MIT mode closes the joint PD inside each motor, so the host's rate
# sets only how often set points and feed-forward change.
CONTROL_PERIOD = 0.004  # s

# --- passive (E-stop, faults, the remote's passive) -----------------------------------------
# damping only: a 10 kg body folding its legs under ~3 N m per knee sinks at ~3 rad/s
PASSIVE_KD = 1.0  # N m s/rad

# --- joint PD in MIT mode ---------------------------------------------------------------------
# stance: ~0.06 rad (a centimetre at the foot) under the full weight without feed-forward;
# damping ratio ~0.4 with a quarter of the body on a leg, overdamped for a swinging leg
STANCE_KP = 60.0  # N m/rad
STANCE_KD = 1.5  # N m s/rad
SWING_KP = 40.0  # N m/rad, a leg in the air: stiff enough to follow the swing curve
SWING_KD = 1.0  # N m s/rad
GETUP_KP = 60.0  # N m/rad, stand-up and recovery trajectories
GETUP_KD = 1.5  # N m s/rad

# --- posture set points ---------------------------------------------------------------------
HEIGHT_NOMINAL = 0.21  # m, body centre over the ground: knees at ~100 deg, and +3 cm with 10 deg of roll and pitch still in reach
HEIGHT_RANGE = (0.16, 0.25)  # m, what the remote may ask
ATTITUDE_LIMIT = math.radians(12.0)  # rad, largest roll/pitch/yaw set point honoured (the task asks +-10 deg)
ATTITUDE_RATE = 1.0  # rad/s, slew of the attitude set points (no jerk on a step from the remote; 20 deg in 0.35 s)
HEIGHT_RATE = 0.15  # m/s, slew of the height set point (6 cm in 0.4 s)

# --- posture integrators (the IMU and leg kinematics correct what PD and belief leave) --------
ATTITUDE_KI = 4.0  # 1/s, roll/pitch/yaw error -> pose trim rate
HEIGHT_KI = 4.0  # 1/s, height error -> pose trim rate
ATTITUDE_TRIM_LIMIT = math.radians(5.0)  # rad
HEIGHT_TRIM_LIMIT = 0.02  # m
# The IMU's mount is not the body's: a board tilted by a degree or so (the tolerance box,
# emulators/quadruped/README.md) would hold every pose off by as much. Standing on four feet, the
# plane through them gives the body's roll and pitch from the encoders alone; their slow
# difference from the IMU's is taken as the mount's tilt (a complementary filter: the IMU for what
# is fast, the legs for what is constant). A level floor is assumed where the robot stands.
MOUNT_TILT_TAU = 0.5  # s, time constant of the tilt estimate (several times the stand's attitude loop)
MOUNT_TILT_LIMIT = math.radians(4.0)  # rad, the largest tilt taken for a mount's (more is a slope or a fault)

# --- force distribution -------------------------------------------------------------------------
ATTITUDE_KP = (40.0, 60.0, 20.0)  # N m/rad, roll, pitch, yaw: body torque asked of the stance feet
ATTITUDE_KD = (2.0, 3.0, 1.0)  # N m s/rad
DISTRIBUTION_REGULARISATION = 1e-3  # alpha: prefer small forces where the wrench leaves a choice
FRICTION = 0.6  # the friction coefficient the reactions are kept under (rubber feet on a floor ~0.8)

# --- falls ---------------------------------------------------------------------------------------
UPRIGHT_LIMIT = math.radians(30.0)  # rad, roll and pitch under which a stand-up needs no roll-over
FALL_LIMIT = math.radians(50.0)  # rad, roll or pitch past which a standing robot has fallen

# --- stand-up (joint-space trajectories, minimum-jerk, seconds) -------------------------------
GATHER_S = 0.6  # s, from wherever the legs are to the crouch: feet under the hips, body low
RISE_S = 1.4  # s, from the crouch to the stand (2 s in all, as the MIT Cheetah's start-up)
CROUCH_HEIGHT = 0.13  # m, body centre over the ground in the crouch (the folded knee's reach)
UNDER_HIP_TOLERANCE = 0.05  # m, feet this close (x and y) to under their hips need no gather

# --- recovery stand (the MIT Cheetah's: roll over if need be, fold the legs, stand) ------------
FOLD_S = 0.8  # s, from wherever the legs are to folded
FOLD_POSE = (0.0, 1.0, -2.4)  # rad, abduction, thigh, calf: knee fully bent, foot ahead of the hip
ROLL_S = 0.6  # s, lever the body off its side
FLIP_S = 0.6  # s, roll it over onto its belly
SETTLE_S = 0.8  # s, holding after a roll-over before looking again
ROLL_ATTEMPTS = 3  # roll-overs before it gives up and lies folded
# The two roll-over poses, (abduction, thigh, calf) in rad for the legs of the side the body
# lies on ("lower") and of the other ("upper"), abduction as for the left side down (mirrored
# when the right side is down). ROLL: the lower legs swing over the back and press their feet
# into the ground behind it, the upper legs reach down toward the belly's side: the body is
# levered up off its side. FLIP: the lower legs fold back under the body while the upper legs
# swing over the back: the body rolls over its lower legs onto its belly. Found by search on
# the rig's model lying on its side (the remaining tilt ~15 deg; +-0.15 rad on any angle, +-30%
# body mass or 2 cm of CoM offset change the outcome by < 5 deg); folding first, or swinging the
# lower legs over the back without the upper legs' counterweight, tips the body onto its back.
ROLL_LOWER = (-0.41, 2.65, -0.98)  # rad
ROLL_UPPER = (-0.19, 1.3, -1.74)  # rad
FLIP_LOWER = (-0.16, 0.76, -2.47)  # rad
FLIP_UPPER = (-0.01, 2.59, -1.93)  # rad

# --- trot ------------------------------------------------------------------------------------------
GAIT_PERIOD = 0.40  # s, one cycle: each diagonal pair in stance for half of it (MIT mini-class trots: 0.3-0.5 s)
DUTY = 0.5  # fraction of the cycle a foot is down: a pure trot, one pair always down
SWING_HEIGHT = 0.06  # m, foot lift at mid-swing: clears a 3 cm step with margin
RAIBERT_GAIN = 0.03  # s (m per m/s), touchdown shift per unit of velocity error
TOUCHDOWN_REACH = 0.10  # m, largest touchdown shift from under the hip
VELOCITY_LIMIT = (0.8, 0.4)  # m/s, forward and lateral speed the trot accepts
YAW_RATE_LIMIT = 1.5  # rad/s
ACCELERATION = 1.0  # m/s^2, slew of the velocity set point
YAW_ACCELERATION = 3.0  # rad/s^2
VELOCITY_FILTER_S = 0.05  # s, time constant of the leg-odometry velocity estimate
HEADING_KP = 2.0  # 1/s, heading error -> yaw rate: a turn ends at the heading its rate integrates to
HEADING_ERROR_LIMIT = 0.3  # rad, largest heading error the correction carries (no wind-up)
FOOT_SETTLE_RATE = 0.3  # m/s, how fast a stand's start brings a raised foot down to the ground
