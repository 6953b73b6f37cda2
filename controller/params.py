"""Controller tuning: every number here is a choice, not a fact about the robot.

Facts live in ``controller/constants.py``. The open-source robots each default was
scaled from are named in docs/control.md.
"""
from __future__ import annotations

# --- timing ------------------------------------------------------------------
# 2 ms (500 Hz): the norm for CAN joint motors (docs/control.md). At 1 kHz the
# four CyberGear command/reply pairs alone would need ~120% of CAN2 at 1 Mbit/s;
# at 500 Hz CAN2 carries ~62% with SYNC and heartbeat (docs/measurements.md, bus load).
CONTROL_PERIOD = 0.002  # s

# --- LQR design (controller/design/lqr.py reads these) ------------------------
LQR_Q = (1.0, 5.0, 100.0, 20.0, 1000.0, 1.0)  # theta, theta_dot, x, x_dot, phi, phi_dot (Skythinker/LJW0401; theta_dot 10 -> 5, below)
# ix, the position error's integral (m s): the weight sets how fast a constant
# disturbance (CoM off the axis, IMU tilt) is trimmed out. Tuned with the CoM 3 cm
# off: 1000 leaves no creep (10.8 cm in the first second, then back); 20000 keeps that
# under 4.1 cm but its stiffer position/speed gains saturate the wheel in `push` (FALLEN).
# With the balance point taking the CoM, what is left for the integral is an IMU mounted
# tilted (the hold torque's lean is the gravity frame's, the legs' angle is measured in the
# IMU's: they differ by the tilt). Tolerance-box balance samples with the IMU 1.6-2.9 deg
# off, max drift (`wheelleg campaign balance --preset tolerance --seed 3`, reruns):
# 1000: 5.4/3.9/4.1/3.8 cm; 3000: 4.3/3.2/3.4/3.1; 5000: 3.8/2.9 but nominal `fall`
# toppled again in its recovery; 10000: 3.3/2.6/2.7/2.5 but `jump-step` landed short.
LQR_Q_INTEGRAL = 3000.0
# theta_dot 10 -> 5: with the integral in the design the leg's rate weight slowed the
# lean back that brakes a stop ( `drive` travelled 0.502 m past its stop command, limit
# 0.5; 0.474 m with 5, 0.454 m with 3; a linear model of the stop gives 0.563/0.536/0.518)
LQR_R = (1.0, 1.0)  # T (wheel), Tp (virtual hip)
LEG_LENGTH_MIN = 0.12  # m, lower end of the K(L0) fit and of leg commands
LEG_LENGTH_MAX = 0.26  # m, upper end (geometric max 0.28, singular at 0.2865)
LEG_LENGTH_NOMINAL = 0.17  # m
LQR_GRID_POINTS = 50

# --- leg length (VMC force along the leg) [scaled from Reborn, docs/control.md] --
LEG_KP = 400.0  # N/m
LEG_KD = 25.0  # N s/m
LEG_KI = 1500.0  # N/(m s): removes the feed-forward's error (the design document's pid_calc is a full PID)
LEG_INTEGRAL_LIMIT = 15.0  # N
LEG_FORCE_LIMIT = 80.0  # N, PID output clamp (feed-forward comes on top)
LEG_GRAVITY_FF = 17.0  # N per leg: (M_body/2 + m_leg/2) g
LEG_LENGTH_RATE = 0.25  # m/s, slew of the leg-length set point (a servo tutorial's compliant height change)

# --- roll levelling ------------------------------------------------------------
ROLL_KP = 400.0  # N/rad, force difference between the legs (McMaster 600/10 at 5 kg)
ROLL_KD = 15.0  # N s/rad
ROLL_FORCE_LIMIT = 25.0  # N
ROLL_LEVEL_KI = 0.5  # (m/s)/rad: terrain self-levelling, the roll error integrated into the leg-length difference
# m, largest left/right leg-length difference (levelling + lean): 0.13 of the legs'
# 0.14 m range levels a side slope up to atan(0.13 / 0.315) = 22 deg (aim: 15 deg)
ROLL_LEVEL_LIMIT = 0.13
# rad, largest lean into a turn (roll set point -atan(v w / g)): 20 deg is
# 2 m/s at 1.8 rad/s; beyond it the leg difference (0.115 m) nears ROLL_LEVEL_LIMIT
TURN_LEAN_LIMIT = 0.35
# rad/s^2, the commanded turn rate is eased in and out at this rate (the heading and the
# yaw loop follow the eased rate), and the lean follows the eased rate through
# TURN_LEAN_TAU. A stepped lean (and 0.2 s on a stepped rate) lifted the inner, then the
# outer wheel at 1.5 m/s, 2 rad/s (turn-fast); 0.3 s on the lean alone kept both >= 10 N
# nominal, but the yaw loop stopped the turn in ~0.1 s while the lean still held 17 deg: the
# outer wheel lifted for a moment at the turn's end on sourced tolerance plants. Eased
# (6 rad/s^2: 2 rad/s in 0.33 s) with the lean 0.1 s behind: the least wheel load 14.4 N
# nominal (11.1 before), 14.7 N on the plant that lifted; 10 rad/s^2 lifted it again. A
# 0.3 s lag on the rate instead kept the loads but its tail left `pose`'s 45 deg turn 2.4 deg
# short at the check; a ramp ends when the command's area is done. The measured yaw rate is
# no better: lean -> leg difference -> yaw closes a loop that toppled a straight sprint.
YAW_ACCEL_LIMIT = 6.0
TURN_LEAN_TAU = 0.1

# --- split legs (keep both legs at the same angle) ------------------------------
SPLIT_KP = 12.0  # N m/rad on Tp (Reborn 8/2, SZTU 10/1)
SPLIT_KD = 1.0  # N m s/rad
SPLIT_LIMIT = 3.0  # N m

# --- yaw ------------------------------------------------------------------------
YAW_KP = 6.0  # (rad/s)/rad, heading hold -> rate set point
YAW_RATE_KP = 1.0  # N m per (rad/s) of wheel torque difference
YAW_TORQUE_LIMIT = 2.0  # N m

# --- motion commands --------------------------------------------------------------
SPEED_LIMIT = 2.0  # m/s
# The speed set point is an S-curve the robot can follow (motion.speed_set_point), the
# legs are asked to lean for its acceleration (LEAN_PER_ACCEL) and, braking, the position
# is tracked along it. Before, it slewed at 4 m/s^2 (Reborn) with no lean asked: the LQR
# leaned the legs on its travel share alone, which saturates (TRAVEL_TORQUE_LIMIT /
# K_theta = 0.26 rad, ~1.8 m/s^2, where the thighs also near their stops), and `drive`
# took 0.474 m to stop from 1 m/s, 0.5-1 m with the CoM 2-3 cm off.
# m/s^2: asks a lean of 0.35 rad (0.2 g: grip down to friction 0.5 has 2.5x margin); past
# the thighs' stops (0.33 rad from the body at 0.17 m) the body pitches 5-10 deg with them
ACCEL_LIMIT = 2.0
# m/s^3: the lean reaches ACCEL_LIMIT's in 0.1 s, near the leg pendulum's own time,
# sqrt(L0 / g) = 0.13 s; a step asked the wheel's full 5.5 N m to swing the legs (linear model)
SPEED_JERK = 20.0
# m/s^3, easing off as the speed arrives: the lean comes back over 0.4 s, three leg
# pendulum times, so the legs come upright without swinging past it. At 20 m/s^3 they
# overshot upright by 0.2 rad and surged the speed; a forward jump's run-up then
# launched mid-swing and `jump-step` landed 21 cm short of the step's edge (10 m/s^3:
# 9 cm short; 5 m/s^3: 23 cm past it, 17 cm with the old 4 m/s^2 slew). A stop from
# 1 m/s takes 0.01 m longer.
SPEED_EASE_JERK = 5.0
# Near the top speed the easing is slower. Taking the lean out swings the legs back under the
# body, so the wheels overtake the set point while it eases: by 0.26 m/s easing onto 2 m/s at
# 5 m/s^3 (nominal `sprint`: 2.26 m/s at the wheels). The M3508 turns at most 482 rpm on 24 V
# through a C620 (constants.M3508_NO_LOAD_SPEED), 2.21 m/s on a 50 mm wheel at a flat 6S
# pack's 21 V: there the wheels had no torque left, the legs stayed leaning and the robot
# fell forward (3 of 10 sourced `sprint` draws, 21.35-21.42 V). At 2.5 m/s^3 the wheels
# overtake by 0.19 m/s and the same draws pass. From SPEED_EASE_TOP_FROM (m/s, the target's
# size) the easing jerk falls linearly to SPEED_EASE_JERK_TOP at SPEED_LIMIT; below it, and
# every stop, are as before (drive, turn-fast at 1.5 m/s, the forward jump's 0.8 m/s run-up).
# 2 m/s^3 (2026-12-06): a heavy body (x1.14, CoM 1.8 cm forward) on 21.1 V through
# 0.1 ohm tops out at 2.20 m/s; at 2.5 its wheels overtook onto that and it fell forward
# (seed 5150's sample 22); at 2 they peak at 2.19 and it stands. A thin margin: the set point
# cannot know the top speed before the wheels reach it (docs/control.md), and slower easing
# lands later in `sprint`'s window (seed 5150's sample 17 now misses 0.1 m/s by 0.012).
SPEED_EASE_TOP_FROM = 1.5
SPEED_EASE_JERK_TOP = 2.0
# rad per m/s^2: leg angle theta of the model accelerating steadily with the body level
# (controller/design/lqr.py acceleration_equilibrium: 0.1765 at L0 = 0.17 m, 0.206 at 0.12,
# 0.151 at 0.26; the LQR's position and speed terms take up the rest at other lengths)
LEAN_PER_ACCEL = 0.1765
POSITION_ERROR_LIMIT = 0.15  # m, position error fed to the LQR is clamped (Skythinker)
# m s, bound of the position error's integral (the LQR's ix state, anti-windup): holds
# a CoM ~5 cm off the axle (3 cm needs ~0.6 m s with the designed gains)
POSITION_INTEGRAL_LIMIT = 1.0
# s after the speed set point returns to 0 before the position integral moves again:
# the stop's overshoot and the walk back (~1.5 s from 1 m/s in `drive`) are left out
TRIM_SETTLE_S = 2.0
# Cruising (the set point steady, not 0) the trim takes up a steady speed error, the same
# constant disturbance it holds standing (chassis._trim; a CoM 3 cm off left `drive`
# 0.1-0.5 m/s off its speed with the trim frozen while moving):
# s after the set point's curve before it starts: the robot settles on the speed ~0.5 s
# after the curve (`drive`, 1 m/s); the lag and the overshoot are no disturbance
CRUISE_SETTLE_S = 0.75
# s, time constant of that take-over, slower than the balance's own ~0.2 s (0.3 s with the
# settling at 0.25 s integrated the overshoot after the curve: 0.25 m/s speed error)
CRUISE_TRIM_TAU = 0.5
# a speed error over this fraction of the set point is no trim's: held back (a wall) or
# pushed along, the robot is not where a disturbance would leave it
CRUISE_TRIM_WINDOW = 0.5
YAW_RATE_LIMIT = 4.0  # rad/s
# Collisions (chassis._blocked_target, docs/control.md): driving into a wall, the LQR's speed
# term asks the blocked wheels for a lean into it (at the 5.5 N m travel limit ~0.22 rad) and
# its balance terms for far more torque than the floor can carry; the wheel spins, climbs the
# wall's face, lifts off and the body goes over (9 of 10 sourced `wall` draws).
# m/s: cruising, the body (the IMU's speed) this far behind the set point is held back. Cruising,
# nominal drive, sprint and bump lag < 0.01 m/s, turn-fast 0.13 (its heading swings); the wall 0.4+
BLOCKED_LAG = 0.25
# m/s: cruising, the axles (the ground speed the LQR sees) this far behind the set point are held
# back too. The body's lag builds up only as the legs tip over the stopped wheels (80 ms after the
# wall's impact in `wall` with friction 0.5); the axles' drops to <= 0 within 20 ms of it. Cruising
# at nominal the axles lag at most: step-down 0.27 (3 ticks of its landing), bump and turn-fast 0.16
BLOCKED_AXLE_LAG = 0.35
# s the command must stop asking that way before it is followed again: the one tick of BALANCE
# (speed 0) after a wheel's hop off the wall (AIRBORNE) is no release
BLOCKED_RELEASE_S = 0.1
# N m per wheel while held back: about what the floor carries, mu Fn R = 0.85 x 23 N x 0.05 m
# = 1.0 N m, plus the wall's own friction on the wheel. More spins the wheel up the wall (it
# lifts off: no grip, no righting torque); less rights the lean too slowly. Sourced draws
# 0, 3, 4 (python): 1.0 N m passed 1/3, 1.5 N m 2/3, 2.0 N m 2/3; 1.5 passed 8 of the 9
BLOCKED_WHEEL_TORQUE = 1.5
# N m per wheel, largest LQR wheel torque for the travel (position, speed, their integral),
# limited before the balance terms are added: a 5 N s push asks for far more there, and
# summed first the balance terms drowned in the saturation (push FALLEN with a stiffer
# integral). 3 N m kept it upright but too slow to walk back; the wheel's own limit
# keeps the nominal push and lets balance win when they disagree.
TRAVEL_TORQUE_LIMIT = 5.5

# The hips' Coulomb feed-forward (constants.HIP_FRICTION, friction.coulomb_feed_forward):
# rad/s, slower than this it fades from the way the joint turns to the way it is asked to.
# Its slope HIP_FRICTION / band is a negative damping on a frictionless joint: with 0.2 rad/s
# (0.5 N m s/rad, near the LQR's own 0.72 on the leg's rate) nominal `balance` wobbled
# +-0.94 deg (+-0.07 now)
HIP_FRICTION_BAND = 1.0
# N m, the torque asked beyond the hold (mapped onto the joint) that takes the full friction
# at rest: the LQR's corrections standing are a few tenths of a N m
HIP_FRICTION_TORQUE_BAND = 0.2
# N m at each hip joint: a dither flipped every 2 ms tick (chassis._hips), front joint +,
# rear joint - (its reaction on the body cancels), while standing still on its spot with
# the wheels' grip. The hips' dry friction (CyberGear not published; its successors
# RS00/RS02/RS05 fit 0.16-0.38 N m, the sourced box 0.15-0.435) held the legs stuck to the
# body within ~2 deg of a pitch set point (`pose` 4/10 on the tolerance box, seed 5150).
# Broken every half period, the stiction no longer holds. Its size, between two bounds:
# - the friction after the current loop's first-order lag: a square wave of half period
#   T = 2 ms peaks at A tanh(T / (2 tau)), 0.354 A at the box's 2.7 ms, 0.68 A at 1.2 ms;
#   to break 0.435 N m, A >= 1.23 at 2.7 ms, 0.64 at 1.2 ms;
# - the wheels' load: it works the legs' length, and 1.5 N m dipped the wheels' 23 N to
#   4 N every tick (nominal `jump` failed its 5 N); 1.1 to 8.3 N, 0.8 to 11.6 N.
# 1.1 N m: the friction of the whole box up to a 2.4 ms lag. Measured (docs/measurements.md,
# 2026-12-06); with longer lags the -0.1 rad pose still ends ~1 deg past its set point.
HIP_DITHER = 1.1
# s to slew the dither's amplitude on or off: stepped, a tick where Python and C judged the
# robot's standing apart (a threshold's rounding) differed by the whole dither (4.6 % of full
# scale in nominal `push`)
HIP_DITHER_RAMP_S = 0.1

# --- torque limits ----------------------------------------------------------------
HIP_TORQUE_LIMIT = 10.0  # N m, normal clamp below the CyberGear's 12 (docs/control.md)
WHEEL_TORQUE_LIMIT = 5.5  # N m, below the C620's 20 A x 0.3 N m/A

# --- sensor estimators (controller/estimate.py) ----------------------------------------
# rad/s, the gyro-bias observer's natural frequency: a bias is found in ~5 s;
# the IMU orientation's noise enters the bias only below it
GYRO_BIAS_OMEGA = 1.0
GYRO_BIAS_LIMIT = 0.2  # rad/s, largest bias believed (a calibrated MEMS gyro is within ~0.05)
# Slip: the wheels' speed against the IMU's integrated acceleration (estimate.SlipObserver).
SLIP_GAIN = 10.0  # 1/s, pull of the IMU speed towards the wheels' while they grip
SLIP_ON = 0.3  # m/s apart: slipping (a hard stop's ~0.1 m/s of leg swing stays below)
SLIP_GRIP_WINDOW = 0.1  # s; gripping again when over it the wheels' speed changed as the IMU's ...
SLIP_GRIP_TOL = 0.05  # m/s ... did, within this
# N m, while slipping the wheel's share for position and speed (the LQR's travel) is held
# to this: the floor cannot take more, and asking more only spins the wheel further
SLIP_TRAVEL_TORQUE_LIMIT = 1.0

# Balance point (estimate.BalancePointObserver, lqr.balance_lean): learnt from the legs'
# lean standing still. It was learnt from the hip torque the LQR asked, at 0.05 s for the
# first 0.6 s: through the hips' dry friction that lag is an integrator on the hips'
# error, it wound up against the stuck joints and left a lean of the wrong sign (sourced
# tolerance sample: CoM 0.9 cm forward, hips 0.34/0.40 N m: hold -0.66 N m, lean
# +0.28 rad, the robot ran away at 2 m/s in `pose`, 10.7 m in `balance`). The lean itself
# has no such loop; learnt at 0.3 s for 1.5 s and 1.5 s after, with the acceleration's lean
# taken off (below): `balance --plant com_x_m=+-0.03` and the three sourced samples'
# balance, drive and push pass. 3 cm of CoM offset needs ~0.15 rad of lean at 0.17 m.
BALANCE_POINT_TAU_LEARN = 0.3  # s, lag of the learnt lean after start-up
# s from the first standing tick learnt at that pace, in time: counted in standing time, a
# slippery-floor sudden push (tolerance: friction 0.56-0.59) walked the robot back outside
# the position clamp for 3 s, the window was still open when the steady push came and
# learnt its lean (hold -0.49 N m, 0.23 rad); past the clamp nothing relearns it and the
# robot crept 2.4 m off (docs/control.md, the balance point)
BALANCE_POINT_LEARN_S = 1.5
BALANCE_POINT_TAU = 1.5  # s, lag afterwards
# s, lag of the acceleration whose lean is taken off the legs' (LEAN_PER_ACCEL): without
# it the com 3 cm `balance` drifted 5.6 cm (it learnt the lean of finding its feet); taken
# per period, the wheels' speed swings with the legs' and the learnt lean rocked nominal
# `balance` (+-0.07 rad, the speed +-0.14 m/s, `jump-step` missed its step); 0.1 s: none
BALANCE_POINT_ACCEL_TAU = 0.1
# m/s: nothing learnt faster than this nor for SETTLE_S after. A 5 N s sudden push in the
# learning window (tolerance sample: CoM 2.4 cm back, mass x0.83) took the hold torque from
# -0.27 to -0.11 N m and `push` ended 1.15 m from its spot; gated, 0.32 m. Start-up with
# the CoM 3 cm off moves at ~0.3 m/s and keeps learning.
BALANCE_POINT_STILL = 0.5
BALANCE_POINT_SETTLE_S = 0.5  # s
BALANCE_LEAN_LIMIT = 0.35  # rad, largest lean believed (a CoM ~7 cm off the hip)

# --- safety -------------------------------------------------------------------------
FALL_PITCH = 0.6  # rad, beyond it the robot has fallen (rm_controllers)
FALL_THETA = 0.9  # rad
FALL_ROLL = 0.8  # rad
# A Reenable press is remembered this long while the motors are off: one press
# sends the clear-fault stop and enables on the clean reply a tick later (2 ms),
# with room for a lost reply; short, so a press is never a standing order.
REENABLE_WINDOW_S = 0.05  # s
# A C620 whose reported current stays off its command is faulted (hung ESC holding
# its last current): 1 A is well above the feedback's noise and a tick's change while
# balancing (+-0.7 A peak in place); 10 ms (5 ticks) rides out one late feedback frame.
ESC_CURRENT_TOLERANCE_A = 1.0  # A
ESC_MISMATCH_S = 0.010  # s
# The feedback answers a command sent 1 tick ago, or 2 when a frame is late (2 ms of
# feedback latency): the reported current is checked against the range of this many
# last commands, so a fast current ramp seen late is no fault.
ESC_COMMAND_WINDOW = 2
ESC_BACK_EMF_FRACTION = 0.8  # above 0.8 x no-load speed, driving, the current may be capped

# --- support force and off-ground detection (controller/support.py) ------------------
# Teams use 10-20 N on 10-15 kg robots; this one's static Fn is
# ~22.7 N per wheel, so thresholds scale to 7 N (off) / 12 N (on). The gap is the
# hysteresis; the debounce rides out a wheel bouncing off a bump.
FN_OFF = 7.0  # N, both legs below it ...
FN_ON = 12.0  # N, either leg above it: touching
OFF_GROUND_DEBOUNCE = 0.030  # s below FN_OFF before airborne (20-60 ms, tulingzt 60 ms)
TOUCHDOWN_DEBOUNCE = 0.006  # s above FN_ON before landed: short, the wheels need power soon
FN_FILTER_TAU = 0.008  # s, low-pass of the Fn estimate (an impact is a few ms long)
FN_DERIVATIVE_TAU = 0.010  # s, low-pass on the differenced ddL0 and ddtheta
FN_TRUST_THETA = 0.3  # rad, legs further from vertical: Fn may not call it airborne (support.estimate_trusted)

# --- in the air (docs/control.md) ------------------------------------------------------------
AIR_THETA_KP = 5.0  # N m/rad, leg-angle PD on Tp (I ~0.014 kg m^2 -> ~20 rad/s)
AIR_THETA_KD = 0.4  # N m s/rad
AIR_LEG_LENGTH = 0.20  # m, long legs in the air leave stroke to absorb the landing
AIR_LEG_FORCE_LIMIT = 40.0  # N, leg PD clamp in the air (no gravity feed-forward there)
# The wheels as reaction wheels in flight: a spin picked up at take-off (a jump with the CoM
# off the hips: lifting the wheels pulls below and behind it) would land the robot on its
# tail. Whole robot ~0.035 kg m^2 about its pitch axis at ~15 rad/s: kp = I w^2, kd = 2 I w,
# split over two wheels. What they can take up is small: a wheel's own 0.00023 kg m^2 plus
# its rotor's J_rotor G ~0.0001 (the reflected J_rotor G^2 = 0.0022 only slows its spin-up)
# holds ~0.015 N m s at the M3508's ~50 rad/s no-load speed: both wheels together take up
# less than 1 rad/s of the whole robot's spin (docs/control.md, in the air).
AIR_PITCH_KP = 4.0  # N m/rad per wheel
AIR_PITCH_KD = 0.5  # N m s/rad per wheel

# --- jump (controller/jump.py; public jumps mapped to this robot) ---------------------------
JUMP_SQUAT_LENGTH = 0.12  # m, lowest leg length of the K(L0) fit: the longest stroke
JUMP_SQUAT_DONE_LENGTH = 0.13  # m, the squat is deep enough below this (the thrust is sized from here)
JUMP_SQUAT_MIN_S = 0.15  # s, settle in the squat before pushing
JUMP_SQUAT_TIMEOUT = 1.5  # s, push anyway if the squat (and a forward run-up) is not reached
JUMP_THRUST_END_LENGTH = 0.25  # m, thrust ends near full stretch (K fit ends at 0.26)
JUMP_THRUST_TIMEOUT = 0.25  # s
JUMP_HIP_TORQUE_LIMIT = 12.0  # N m, the CyberGear's peak, only while thrusting/retracting
# The thrust is sized for the weight measured standing (controller/jump.py, plan_thrust):
# m, the body's rise once the wheels are off. With the nominal robot's measured 15.0 N per
# leg its work from JUMP_SQUAT_DONE_LENGTH is 6.0 J per leg, the open-loop thrust's (a 100 N
# Hermite on 17 N) 5.7 J and a little more: the nominal jump as high as before. A deeper
# squat (a forward jump's run-up waits in it, ~0.11 m) pushes longer: the work grows
JUMP_RISE = 0.172
# s, low-pass of the standing support force: balancing sways it (0.14 N std nominal, 1.3 N with
# the body x1.4 and hips x0.85, over 0.4-0.8 s of `jump`); settled 4 tau before `jump` presses at 0.8 s
JUMP_WEIGHT_TAU = 0.2
JUMP_CARRIED_RANGE = (0.5, 2.5)  # x LEG_GRAVITY_FF: a weight read outside this is held to it
JUMP_THRUST_TORQUE_SHARE = 0.85  # of JUMP_HIP_TORQUE_LIMIT for the push; the rest for balance (Tp) and roll
# N per m/s the legs lengthen slower than the push planned (jump.tracked_thrust_force):
# the plan knows the body, not the hips' armature (0.0012 kg m^2 believed, the rotor
# alone; the sourced box goes to 0.014). Armature 0.014: clearance 13.7 cm untracked,
# 19.1 at 100, 21.1 at 400, 24.6 at 1500; at 0.021, 21.0 at 400 but 16.4 at 1500 (the
# push saturates early and the legs hit the stroke's end still accelerating); nominal
# 25.8 -> 26.3 cm at 400
JUMP_RATE_KP = 400.0
JUMP_AMPLITUDE_MAX = 1000.0  # N, bisection bound: far above every push_limit (125-182 N over the stroke)
# |sin(theta)| the thrust's leg-angle hold asks at most (jump.hold_leg_angle): 0.5 is 30 deg,
# far past the ~0.15 rad a 3 cm CoM offset leans the legs at the squat
JUMP_HOLD_SINE_LIMIT = 0.5
# retract with the in-air leg PD towards a short target (its damping stops the legs
# before the mechanical stop: an open-loop pull slammed them into it at 0.105 m)
JUMP_RETRACT_TARGET = 0.13  # m
JUMP_RETRACT_LENGTH = 0.14  # m, retract until the legs are this short
JUMP_RETRACT_TIMEOUT = 0.15  # s
# The retraction's leg PD (chassis ``_air_step`` with ``air_tuck``), stiffer than the holding
# one (LEG_KP, LEG_KD within AIR_LEG_FORCE_LIMIT): the rotors of hips reflect up to
# 0.014 kg m^2 in the sourced box (0.0012 the rotor alone), and with the holding PD the
# retraction ran out its 0.15 s in every jump traced, the legs still up to 0.16-0.20 m long
# at the top: a draw with a heavy body, weak hips and a 21.8 V battery cleared 19.2 cm (need
# 20). Measured (`wheelleg run jump`, that draw's plant): 1000 N/m, 40 N s/m within 100 N
# reaches 0.14 m in 0.11 s (nominal) and 0.12 s (the draw), the legs' shortest 0.121 m
# (stop 0.105), the draw clearing 22.5 cm, nominal 26.0 (27.2 before; firmware 25.4, 26.5); 1500/50/150 cleared
# 23.0 but came to 0.115 m of the stop. Held through FLIGHT until the jump's top (jump.apex_delay).
JUMP_RETRACT_KP = 1000.0  # N/m
JUMP_RETRACT_KD = 40.0  # N s/m
JUMP_RETRACT_FORCE_LIMIT = 100.0  # N
JUMP_LAND_LENGTH = 0.18  # m, legs held here in flight: stroke to absorb the landing
JUMP_FLIGHT_MIN_S = 0.05  # s, ignore the retraction's own Fn transient
# m/s, past the top a touchdown is Fn above FN_ON with a leg shortening faster than this (the
# ground pushing it in): the in-air PD braking the legs also reads as Fn (seed 5150 sample 0's
# FLIGHT ended on its 0.05 s minimum), but lengthens them or holds them; a landing from the
# top of a jump pushes them in at 1-2 m/s
JUMP_TOUCHDOWN_RATE = 0.2
JUMP_FLIGHT_TIMEOUT = 1.0  # s
JUMP_LAND_TIME = 0.4  # s balancing before the jump counts as done
JUMP_FORWARD_SPEED = 0.8  # m/s held from squat to landing by JumpForward
JUMP_RUN_UP_SPEED_TOL = 0.1  # m/s, a forward jump thrusts only at its speed ...
# ... with the legs' lean settled (no acceleration's lean left): the rate of their mean angle,
# low-passed over JUMP_RUN_UP_SWING_TAU, within JUMP_RUN_UP_SWING_TOL for JUMP_RUN_UP_SETTLE_S
# (a swing's turning point passes through a zero rate: the hold). Judged against the balance
# point's lean before (within 0.05 rad): that lean is the standing hold torque over the arm at
# the squat's length, and the squat shortens the arm: seed 5150 sample 8's lean grew 0.056 ->
# 0.142 rad while its legs settled at 0.08-0.10, so the run-up never counted as steady and the
# robot drove into the step's face. The rate needs no model: it settled there at 1.65 s.
# 0.3 rad/s over 0.05 s for 0.1 s: the run-ups of seeds 5150 and 3141 (20 draws) settle
# 0.44-0.54 m on; 0.2 rad/s: 0.48-0.58 m and two never (the speed hovers at its tolerance's
# edge, noise resets the hold), their wheels struck the step's face; over 0.1 s with 0.35-0.4
# rad/s, or held 0.05 s, it fired at a swing's turning point 0.1 m on
JUMP_RUN_UP_SWING_TOL = 0.3  # rad/s
JUMP_RUN_UP_SWING_TAU = 0.05  # s
JUMP_RUN_UP_SETTLE_S = 0.1  # s
BODY_GROUND_CLEARANCE = 0.01  # m, body box this close to the floor under the wheels: on the ground,
#                               fallen (controller/posture.py); standing it is ~0.2 m clear
FALL_PITCH_AIR = 1.2  # rad, in JUMP/AIRBORNE: the body swings more in the air, a tumble is past this
FALL_ROLL_AIR = 1.2  # rad

# --- recovery stand from lying (controller/recovery.py) -----------------------------------
RECOVERY_TUCK_LENGTH = 0.12  # m, legs pulled short (lowest of the K fit): hips down to the wheels
RECOVERY_TUCK_MIN_S = 0.3  # s, the first ticks after enabling still see the fall's leg data
RECOVERY_TUCK_TIMEOUT = 1.0  # s
# rad/s, the pitch set point's fastest ramp from lying (~0.8 rad) to level (~1.6 s); a body that
# rises faster takes the set point with it (recovery.next_pitch_ref): `fall` is level ~0.5 s after TILT_UP begins
RECOVERY_PITCH_RATE = 0.5
RECOVERY_TILT_TIMEOUT = 4.0  # s
# rad from upright (posture.tilt_from_upright): while recovering only a body past this has fallen again
RECOVERY_FALL_PITCH = 1.3
# rad from upright, the furthest a lying body may be for a recovery to start: `fall` (seed 1, Python
# program, 2026-12-06) ended standing on its nose, the body vertical with both wheels loaded, and
# stands up from there; beyond ~95 deg it is going over onto its back
RECOVERY_LYING_MAX = 1.65
# rad: a recovery begun further over than RECOVERY_FALL_PITCH has fallen again this far past its
# start; one begun from the usual ~50 deg keeps RECOVERY_FALL_PITCH, the limit every earlier
# campaign measured (a tail fall that does not lift and rolls on over onto its back, seed 6160's
# draws 21 and 25, does so at either limit)
RECOVERY_TILT_MARGIN = 0.1
