"""The robot's chassis task (docs/control.md): LQR on the wheel-legged pendulum, VMC legs.

One ``ChassisController.step`` per control period turns what the buses said
(``BusState``) and what is asked (``Command``) into hip shaft torques and wheel
output torques. The pieces follow the design document's chassis_control(): forward
kinematics, K(L0) fitting, state references, LQR torques, leg-length PID with
gravity feed-forward, VMC to joint torques; plus yaw, split-leg and roll
control scaled from public balance-robot controllers (docs/control.md).

Sign conventions are those of controller/constants.py: theta > 0 with the
wheel behind the hip, phi (body) nose-up positive, T forward-rolling positive.
"""
from __future__ import annotations

import math
import operator
from dataclasses import dataclass, field
from typing import NamedTuple

from wheelleg.controller import constants as C
from wheelleg.controller import estimate
from wheelleg.controller import fivebar
from wheelleg.controller import friction
from wheelleg.controller import lqr
from wheelleg.controller import motion
from wheelleg.controller import params as P
from wheelleg.controller.bounds import clamp, within
from wheelleg.controller.jump import StanceHold
from wheelleg.controller.legs import (LEG_WHEEL, LEGS, Attitude, LegState, attitude, leg_state, leg_targets, legs_under_body,
                                      mean_speed, roll_leg_difference, turn_lean, unwind, wrap)
from wheelleg.controller.motion import Travel
from wheelleg.controller.state import BusState


@dataclass
class Command:
    """What the chassis is asked to do this tick (already limited by the mode)."""

    speed: float = 0.0  # m/s
    yaw_rate: float = 0.0  # rad/s
    leg_length: float = P.LEG_LENGTH_NOMINAL  # m
    pitch: float = 0.0  # rad, nose down positive
    roll: float = 0.0  # rad
    airborne: bool = False  # in the air: wheels unpowered, legs held vertical (``_air_step``)
    leg_force: float | None = None  # N per leg, open-loop push replacing the leg PID (jump)
    hip_torque_limit: float = P.HIP_TORQUE_LIMIT  # N m, raised only for a jump's thrust
    air_leg_hold: bool = True  # in the air, hold the legs vertical (False: Tp 0, legs swing free)
    air_pitch_hold: bool = False  # in the air, level the body with the wheels' reaction (flight only)
    air_tuck: bool = False  # in the air, pull the legs in with the retraction's PD (a jump's RETRACT)
    trim: bool = False  # standing or moving on the wheels: integrate the position error (``_trim``)
    stance_hold: StanceHold | None = None  # a jump in place: the hips over their start (``_lqr_hold``), the lean in the air


def air_leg_force(error_m: float, rate_m_s: float, tuck: bool) -> float:
    """Leg force (N, lengthening positive) of the in-air leg PD: the length error (m, set point
    less measured) and the leg's rate (m/s); ``tuck``: the retraction's stiffer PD."""
    if tuck:
        return clamp(P.JUMP_RETRACT_KP * error_m - P.JUMP_RETRACT_KD * rate_m_s, P.JUMP_RETRACT_FORCE_LIMIT)
    return clamp(P.LEG_KP * error_m - P.LEG_KD * rate_m_s, P.AIR_LEG_FORCE_LIMIT)


class Sensed(NamedTuple):
    """What the chassis reads from the buses in one tick: the attitude and each leg's state."""

    att: Attitude
    legs: dict  # leg name -> LegState


class LegReport(NamedTuple):
    """One leg as the chassis saw and drove it in one tick."""

    length_m: float  # L0 measured
    length_ref_m: float  # L0 set point
    theta_rad: float  # leg angle from vertical, wheel behind hip positive
    wheel_torque_nm: float  # T: LQR plus yaw, before the wheel's limit and sign
    leg_torque_nm: float  # Tp: virtual hip torque, LQR plus split


class ChassisReport(NamedTuple):
    """What one chassis step saw and decided; the next tick's controller reads it."""

    x_m: float  # wheel travel since reset
    x_ref_m: float
    x_integral_m_s: float  # the position error's integral, the LQR's trim state
    balance_theta_rad: float  # leg angle of the balance point (lqr.balance_lean)
    hold_torque_nm: float  # hip torque per leg holding the body there (estimate.BalancePointObserver)
    speed_m_s: float  # mean axle speed along the ground (the IMU's figure while the wheels slip)
    slipping: bool  # the wheels' speed and the IMU's part (estimate.SlipObserver)
    blocked: float  # +1/-1: held back driving forward/backward (``_blocked_target``), 0: free
    speed_ref_m_s: float
    pitch_rad: float  # nose down positive
    roll_rad: float
    yaw_rad: float
    yaw_ref_rad: float
    legs: dict  # leg name ("left", "right") -> LegReport


@dataclass
class Output:
    """Torques for the motors (N m) and what the chassis saw and decided."""

    hip_torque: dict = field(default_factory=dict)  # motor id -> shaft torque
    wheel_torque: dict = field(default_factory=dict)  # esc id -> output torque
    report: ChassisReport | None = None
    legs: dict = field(default_factory=dict)  # leg name -> LegState this tick


_TRAVEL = tuple(lqr.GAIN_NAMES.index(name) for name in ("x", "dx", "ix"))  # LQR states of the travel
_BALANCE = tuple(i for i in range(len(lqr.GAIN_NAMES)) if i not in _TRAVEL)  # the others, in order
# each picks its states, in order, out of a gain row or an error vector
_travel_part, _balance_part = operator.itemgetter(*_TRAVEL), operator.itemgetter(*_BALANCE)
# s: a speed error e (m/s) asks of the wheel what a trim of e times this does (K_dx / K_ix
# of the wheel's row: 0.54 s at the nominal length, 0.54-0.55 over the whole leg range), so
# the trim takes up a steady speed error by growing this much per m/s of it (``_trim``)
_WHEEL_GAINS = dict(zip(lqr.GAIN_NAMES, lqr.gain_matrix(P.LEG_LENGTH_NOMINAL)[0]))
SPEED_TO_TRIM_S = _WHEEL_GAINS["dx"] / _WHEEL_GAINS["ix"]


class ChassisController:
    """The design document's chassis_control(), one call per control period."""

    def __init__(self, dt: float = P.CONTROL_PERIOD):
        self.dt = dt
        self.x = 0.0  # m, wheel travel since reset
        self.in_air = False  # the last tick was an air step
        self.takeoff_speed = 0.0  # m/s, ground speed of the last tick on the ground
        self.takeoff_error = 0.0  # m, x - x_ref as the wheels left the ground
        self.x_ref = 0.0  # m
        self.speed_ref = 0.0  # m/s, slewed
        self.accel_ref = 0.0  # m/s^2, the speed set point's own (motion.speed_set_point)
        self.travel = Travel.STANDING  # what the speed set point does (motion.travel_phase)
        # +1/-1: driving forward/backward the robot was held back (a wall): the command is not
        # followed that way until it stops asking for it (``_blocked_target``); 0: free
        self.blocked = 0.0
        self.unblock_s = 0.0  # s the command has not asked the blocked way
        self.yaw_ref = 0.0  # rad
        self.yaw_rate_ref = 0.0  # rad/s, the commanded turn rate eased in and out (YAW_ACCEL_LIMIT)
        self.leg_ref = {leg: P.LEG_LENGTH_NOMINAL for leg in LEGS}
        self.roll_offset = 0.0  # m, integral levelling: left minus right leg length
        self.lean = 0.0  # rad, roll set point into a turn, lagging the command (TURN_LEAN_TAU)
        self.leg_integral = {leg: 0.0 for leg in LEGS}  # N
        self.x_integral = 0.0  # m s, integral of the position error (the LQR's ix state)
        self.dither_sign = 1.0  # +1/-1, flipped every tick on the ground: the hips' dither (_hips)
        self.dither_size = 0.0  # N m, the dither's amplitude, slewed on and off (HIP_DITHER_RAMP_S)
        self.trim_hold_s = 0.0  # s left before the integral may move again after a stop (TRIM_SETTLE_S)
        self.u_prev = {leg: (0.0, 0.0) for leg in LEGS}  # (T, Tp) N m sent last period (the LQR's delay states)
        self.gyro = estimate.GyroBiasObserver(dt, P.GYRO_BIAS_OMEGA, P.GYRO_BIAS_LIMIT)
        self.slip = estimate.SlipObserver(dt, P.SLIP_GAIN, P.SLIP_ON, P.SLIP_GRIP_WINDOW, P.SLIP_GRIP_TOL)
        self.balance_point = estimate.BalancePointObserver(dt, P.BALANCE_POINT_TAU_LEARN, P.BALANCE_POINT_LEARN_S,
                                                           P.BALANCE_POINT_TAU, P.BALANCE_POINT_STILL,
                                                           P.BALANCE_POINT_SETTLE_S)
        self.speed_prev = 0.0  # m/s, the ground speed a period ago
        # m/s^2, the ground speed's change lagged by BALANCE_POINT_ACCEL_TAU: its lean is taken
        # off the legs' before the balance point learns from them
        self.accel = 0.0
        self.balance_theta = 0.0  # rad, the legs' lean at the balance point (lqr.balance_lean), this tick

    def observe(self, bus: BusState) -> Sensed | None:
        """Every tick, enabled or not: follow the gyro's bias against the IMU's orientation
        and the wheels' grip against its acceleration (so neither is stale on enabling).

        Returns the attitude and legs it saw (None before the IMU was heard): ``step``
        in the same tick, on the same ``bus``, takes them instead of working them out again.
        """
        if not math.isfinite(bus.imu.received_s):
            return None
        self.gyro.update(bus.imu.quat, bus.imu.gyro)
        sensed = self.sense(bus)
        legs = sensed.legs
        self.slip.update(estimate.forward_accel(bus.imu.quat, bus.imu.accel),
                         mean_speed(legs) - legs_under_body(legs))
        return sensed

    def sense(self, bus: BusState) -> Sensed:
        """The body's attitude (gyro bias out) and both legs' states from ``bus`` now."""
        att = self.attitude(bus)
        return Sensed(att, {leg: leg_state(bus, leg, att) for leg in LEGS})

    def attitude(self, bus: BusState) -> Attitude:
        """The body's attitude with the gyro's estimated bias taken out."""
        return attitude(bus.imu, self.gyro.bias)

    def reset(self, bus: BusState) -> None:
        """Take the present pose as the reference (on enable, after a fall)."""
        att = self.attitude(bus)
        self.x = self.x_ref = self.x_integral = self.trim_hold_s = 0.0
        self.u_prev = {leg: (0.0, 0.0) for leg in LEGS}
        self.speed_ref = self.accel_ref = self.blocked = self.unblock_s = 0.0
        self.travel = Travel.STANDING
        self.lean = 0.0
        self.yaw_ref = att.yaw
        self.yaw_rate_ref = 0.0
        for leg in LEGS:
            self.leg_integral[leg] = 0.0
            self.leg_ref[leg] = leg_state(bus, leg, att).L0
        # levelling starts from the legs as they stand (uneven ground: already apart)
        self.roll_offset = clamp(self.leg_ref["left"] - self.leg_ref["right"], P.ROLL_LEVEL_LIMIT)

    def step(self, bus: BusState, cmd: Command, sensed: Sensed | None = None) -> Output:
        """This tick's torques; ``sensed``: what ``observe`` returned this tick for ``bus``
        (None: sensed here), the gyro's bias and the bus unchanged since."""
        att, legs = sensed if sensed is not None else self.sense(bus)
        speed = self._ground_speed(legs)
        self._track_accel(speed)
        if cmd.airborne:
            if not self.in_air:
                self.in_air, self.takeoff_error = True, self.x - self.x_ref
            # the wheels spin free (levelling the body) and say nothing of the ground: the
            # body keeps the speed it left the ground with (a short flight, no drag)
            self.x += self.takeoff_speed * self.dt
            return self._air_step(legs, att, speed, cmd)
        self.in_air, self.takeoff_speed = False, speed
        self.x += speed * self.dt
        mean_length = 0.5 * (legs["left"].L0 + legs["right"].L0)
        self.balance_theta = lqr.balance_lean(self.balance_point.hold_torque, mean_length, P.BALANCE_LEAN_LIMIT,
                                              self.weight_ratio())
        self._track_references(cmd, att, speed)
        standing = self._trim(speed, cmd, mean_length)
        dither = self._dither(standing)
        out = Output(legs=legs)
        wheel_t, tp = {}, {}
        wheel_limit = P.BLOCKED_WHEEL_TORQUE if self.blocked else P.WHEEL_TORQUE_LIMIT
        for leg in LEGS:
            wheel_t[leg], tp[leg] = self._lqr(legs[leg], leg, speed, att, cmd, mean_length)
            self.u_prev[leg] = (clamp(wheel_t[leg], wheel_limit), tp[leg])
        # the legs' lean standing still says where the CoM is, whatever the hips' friction
        # holds (the torque the LQR asks does not: docs/control.md, the balance point);
        # less the lean the robot's acceleration asks for (finding its feet after start-up)
        lean = 0.5 * (legs["left"].theta + legs["right"].theta) - P.LEAN_PER_ACCEL * self.accel
        self.balance_point.update(lqr.lean_hold_torque(lean, mean_length, self.weight_ratio()), speed, standing)
        split = self._split(legs)
        tp["left"] += split
        tp["right"] -= split
        yaw_t = self._yaw(att)
        wheel_t["left"] -= yaw_t
        wheel_t["right"] += yaw_t
        roll_f = self._roll(att, cmd)
        for leg, sign in (("left", 1.0), ("right", -1.0)):
            push = self._leg_force(legs[leg], leg) if cmd.leg_force is None else cmd.leg_force
            force = push + sign * roll_f
            self._hips(out, leg, legs[leg], force, tp[leg], tp[leg] - self.balance_point.hold_torque, dither)
            wheel = LEG_WHEEL[leg]
            out.wheel_torque[wheel.esc_id] = wheel.forward_sign * clamp(wheel_t[leg], wheel_limit)
        self._limit_hips(out, cmd.hip_torque_limit)
        out.report = self._report(legs, att, speed, wheel_t, tp)
        return out

    def _track_accel(self, speed: float) -> None:
        """Follow the ground speed's change (m/s^2), lagged by BALANCE_POINT_ACCEL_TAU (every
        tick, in the air too, so a landing is one step in speed, not a stale one)."""
        accel = (speed - self.speed_prev) / self.dt
        self.speed_prev = speed
        self.accel += (accel - self.accel) * min(1.0, self.dt / P.BALANCE_POINT_ACCEL_TAU)

    def _ground_speed(self, legs: dict) -> float:
        """Mean axle speed along the ground (m/s): the wheels' own while they grip,
        the IMU's (plus the legs' motion) while they slip (``observe`` this tick)."""
        if self.slip.slipping:
            return self.slip.speed_m_s + legs_under_body(legs)
        return mean_speed(legs)

    def _air_step(self, legs: dict, att: Attitude, speed: float, cmd: Command) -> Output:
        """In the air (docs/control.md, in the air): the wheels' torque only levels the body
        (``cmd.air_pitch_hold``, else 0), a leg-angle PD holds each leg vertical
        (theta -> 0; with a jump's ``cmd.stance_hold``, at the lean it stood with), a leg PD
        without gravity feed-forward holds ``cmd.leg_length`` (or ``cmd.leg_force`` pushes);
        no roll, no yaw. The position and heading
        references follow the robot, so nothing winds up."""
        self.x_ref, self.yaw_ref = self.x, att.yaw
        out = Output(legs=legs)
        levelling = self._air_pitch_torque(att, cmd) if cmd.air_pitch_hold else 0.0  # N m, each wheel
        wheel_t, tp = {}, {}
        for leg in LEGS:
            s = legs[leg]
            self.leg_ref[leg] = within(cmd.leg_length, P.LEG_LENGTH_MIN, P.LEG_LENGTH_MAX)
            wheel_t[leg] = levelling
            hold = cmd.stance_hold
            theta_ref, dtheta_ref = (0.0, 0.0) if hold is None else hold.leg_angle(leg, s.L0, s.dL0)
            tp[leg] = -(P.AIR_THETA_KP * (s.theta - theta_ref) + P.AIR_THETA_KD * (s.dtheta - dtheta_ref)) \
                if cmd.air_leg_hold else 0.0
            # the wheel's reaction acts on its leg: the hip passes it on to the body
            tp[leg] += wheel_t[leg]
            self.u_prev[leg] = (0.0, tp[leg])
            force = cmd.leg_force if cmd.leg_force is not None else air_leg_force(
                self.leg_ref[leg] - s.L0, s.dL0, cmd.air_tuck)
            self._hips(out, leg, s, force, tp[leg], tp[leg])
            wheel = LEG_WHEEL[leg]
            out.wheel_torque[wheel.esc_id] = wheel.forward_sign * wheel_t[leg]
        self._limit_hips(out, cmd.hip_torque_limit)
        out.report = self._report(legs, att, speed, wheel_t, tp)
        return out

    @staticmethod
    def _air_pitch_torque(att: Attitude, cmd: Command) -> float:
        """Wheel torque (N m, each wheel) whose reaction turns the body towards ``cmd.pitch``.

        A wheel torque T (forward rolling positive) turns the body nose up by T:
        T = kp (pitch - pitch_ref) + kd pitch_rate, nose down positive."""
        return clamp(P.AIR_PITCH_KP * (att.pitch - cmd.pitch) + P.AIR_PITCH_KD * att.wy, P.WHEEL_TORQUE_LIMIT)

    def follow_position(self) -> None:
        """The position reference jumps to where the robot is (no pull back this tick)."""
        self.x_ref = self.x

    def touchdown(self, bus: BusState, keep_spot: bool = False) -> None:
        """Landing: each leg's set point starts from the length it landed with (it then
        slews back); the position reference resets to where the robot is, or with
        ``keep_spot`` (a flight nobody asked for: a push or a bump threw the wheels off
        the ground) keeps the position error it had at take-off, so a robot pushed off
        its spot still walks back to it. Reset, a 5 N s side push's 60 ms hop in the
        tolerance box made it forget a spot 0.46 m away (`push` ended 0.62 m off)."""
        att = self.attitude(bus)
        self.x_ref = self.x - (self.takeoff_error if keep_spot else 0.0)
        self.yaw_ref = att.yaw
        for leg in LEGS:
            self.leg_ref[leg] = leg_state(bus, leg, att).L0
            self.leg_integral[leg] = 0.0

    # -- pieces ----------------------------------------------------------------
    def _blocked_target(self, target: float, speed: float) -> float:
        """The speed (m/s) to head for instead of ``target``: 0 while the robot is held back
        that way (docs/control.md, collisions); ``speed``: the ground speed (m/s) this tick.

        Cruising, the body (the IMU's speed, which a wheel bouncing off the obstacle does not
        fool) more than BLOCKED_LAG behind the set point is held back: a wall, a kerb. Pushing
        on, the LQR's speed term asks the wheels for a lean into it (at the wheel's 5.5 N m
        travel limit 0.22 rad), and a heavier body or a slipping wheel goes over the wall.
        The axles more than BLOCKED_AXLE_LAG behind it are held back too: they stop at the
        impact, the body's lag builds up only as the legs tip over them (tens of ms later).
        The set point and the spot are then where the robot is (standing, it pushes nothing)
        and stay so until the command stops asking to go that way."""
        way = math.copysign(1.0, self.speed_ref)
        if self.travel is Travel.CRUISING and ((self.speed_ref - self.slip.speed_m_s) * way > P.BLOCKED_LAG
                                               or (self.speed_ref - speed) * way > P.BLOCKED_AXLE_LAG):
            self.blocked = way
            self.speed_ref = self.accel_ref = 0.0
            self.x_ref = self.x
        if target * self.blocked > 0.0:
            self.unblock_s = 0.0
            return 0.0
        # released once the command has not asked that way for BLOCKED_RELEASE_S: the one
        # tick of BALANCE (speed 0) after a wheel's hop off the wall (AIRBORNE) is no release
        self.unblock_s += self.dt
        if self.unblock_s >= P.BLOCKED_RELEASE_S:
            self.blocked = 0.0
        return target

    def _track_references(self, cmd: Command, att: Attitude, speed: float) -> None:
        """Slew the speed, position, heading, lean and leg-length set points one tick;
        ``speed``: the ground speed (m/s) this tick."""
        target = self._blocked_target(clamp(cmd.speed, P.SPEED_LIMIT), speed)
        self.speed_ref, self.accel_ref = motion.speed_set_point(self.speed_ref, self.accel_ref, target, self.dt)
        self.travel = motion.travel_phase(self.speed_ref, self.accel_ref)
        self.x_ref += self.speed_ref * self.dt
        if self.travel in (Travel.SPEEDING_UP, Travel.CRUISING):
            # speed alone is tracked: the robot's lag behind a growing set point, made up
            # along a position reference, would overshoot the speed (and a wall would
            # wind it up); a disturbance is taken up by the trim instead (_trim)
            self.x_ref = self.x
        elif self.travel is Travel.BRAKING or self.trim_hold_s > 0.0:
            # braking, or just stopped: the position is tracked along the braking curve, so
            # the LQR's position term brakes too and the spot is where the curve stops. The
            # robot may still overshoot it; the LQR sees the error clamped (_lqr), so dragging
            # the spot to within the clamp changes no braking torque; it only spares the walk
            # back at the clamp's speed (0.3 m/s), which left `sprint` still moving 3.5 s later
            self.x_ref = self.x - clamp(self.x - self.x_ref, P.POSITION_ERROR_LIMIT)
        # standing, it stays put: pushed away, the robot comes back to its spot, with the
        # error the LQR sees clamped (_lqr), so at a bounded speed
        change = clamp(cmd.yaw_rate, P.YAW_RATE_LIMIT) - self.yaw_rate_ref
        self.yaw_rate_ref += clamp(change, P.YAW_ACCEL_LIMIT * self.dt)
        self.yaw_ref = wrap(self.yaw_ref + self.yaw_rate_ref * self.dt)
        target_lean = turn_lean(self.speed_ref, self.yaw_rate_ref)
        self.lean += (target_lean - self.lean) * min(1.0, self.dt / P.TURN_LEAN_TAU)
        diff = roll_leg_difference(self.roll_set_point(cmd), self.roll_offset)
        targets = leg_targets(cmd.leg_length, diff)
        for leg in LEGS:
            self.leg_ref[leg] += clamp(targets[leg] - self.leg_ref[leg], P.LEG_LENGTH_RATE * self.dt)

    def weight_ratio(self) -> float:
        """The weight the legs carry over the one believed (LEG_GRAVITY_FF): the leg
        integral holds the difference standing. It scales the hold torque's lean, and
        with it a hip torque constant off cancels (the hips under-deliver force and
        torque alike, so both the integral and the hold torque grow by the same factor)."""
        extra = 0.5 * (self.leg_integral["left"] + self.leg_integral["right"])
        return max(0.5, 1.0 + extra / P.LEG_GRAVITY_FF)

    def position_error(self, leg_length: float) -> float:
        """Wheel travel (m) past its set point: the spot is the body's, so with the legs
        leaning at the balance point (``balance_theta``) the wheels stand that lean's
        L0 sin(theta) away from it (ahead of the body when the CoM is forward)."""
        return self.x - self.x_ref + leg_length * math.sin(self.balance_theta)

    def _trim(self, speed: float, cmd: Command, leg_length: float) -> bool:
        """Integrate the position error (standing) or the speed error (cruising) into
        ``x_integral`` (the LQR's ix state); True when it integrated standing still and
        settled (the balance point learns then too).

        A constant disturbance (the CoM off the axle, an IMU mounted tilted, a
        drive's torque constant) is held by this integral instead of a standing
        position error or a cruising speed error; the trim found standing holds
        moving and the other way round. It integrates only settled:
        - standing, the position error inside the LQR's clamp. Outside it (pushed
          away) the robot walks back on the clamp and the integral only unwinds
          (``unwind``): integrating there wound it up to 0.3 m s, and frozen, a trim
          wound up by a steady push that ended with the robot past the clamp held
          the clamped error's pull for good: the robot crept away at 2-3 cm/s (two
          tolerance `push` draws ended 0.5 and 0.6 m off their spot);
        - cruising, the speed error times SPEED_TO_TRIM_S / CRUISE_TRIM_TAU (the
          trim that asks what the speed error asks, taken over in that time), while
          the robot is within CRUISE_TRIM_WINDOW of the set point;
        - on the set point's curve it is frozen, and for CRUISE_SETTLE_S after
          speeding up and TRIM_SETTLE_S after braking: the lag behind the curve, the
          overshoot past the stop and the walk back are the robot's, not a
          disturbance's (the speed-up lag integrated, 0.5 s x 0.5 s^-1, made `drive`
          miss its speed by 0.23 m/s; a stop's overshoot left 0.04 m s, 0.07 m/s);
        - with ``cmd.trim`` off (in the air, jumping, standing up).
        Bounded by POSITION_INTEGRAL_LIMIT (anti-windup).
        """
        if self.travel in (Travel.SPEEDING_UP, Travel.BRAKING):
            self.trim_hold_s = P.CRUISE_SETTLE_S if self.travel is Travel.SPEEDING_UP else P.TRIM_SETTLE_S
            return False
        self.trim_hold_s = max(0.0, self.trim_hold_s - self.dt)
        if not cmd.trim or self.trim_hold_s > 0.0:
            return False
        if self.travel is Travel.CRUISING:
            error = speed - self.speed_ref
            if abs(error) < P.CRUISE_TRIM_WINDOW * abs(self.speed_ref):
                step = SPEED_TO_TRIM_S / P.CRUISE_TRIM_TAU * error * self.dt
                self.x_integral = clamp(self.x_integral + step, P.POSITION_INTEGRAL_LIMIT)
            return False
        error = self.position_error(leg_length)
        if abs(error) >= P.POSITION_ERROR_LIMIT:
            self.x_integral = unwind(self.x_integral, clamp(error, P.POSITION_ERROR_LIMIT) * self.dt)
            return False
        self.x_integral = clamp(self.x_integral + error * self.dt, P.POSITION_INTEGRAL_LIMIT)
        return True

    def roll_set_point(self, cmd: Command) -> float:
        """Roll set point (rad, > 0 left side up): the command plus the lean into a turn."""
        return cmd.roll + self.lean

    def _lqr(self, leg: LegState, name: str, speed: float, att: Attitude, cmd: Command,
             mean_length: float) -> tuple[float, float]:
        """u = u_ref - K (s - s_ref): wheel torque T and virtual hip torque Tp (N m) of leg
        ``name``, about the balance point (theta_ref ``balance_theta``, Tp_ref its hold torque)."""
        if cmd.stance_hold is not None:
            return self._lqr_hold(leg, name, att, cmd)
        k = lqr.gain_matrix(leg.L0)
        phi, dphi = -att.pitch, -att.wy  # nose-up body angle and rate
        hold = self.balance_point.hold_torque
        t_prev, tp_prev = self.u_prev[name]
        err = (leg.theta - self.balance_theta - P.LEAN_PER_ACCEL * self.accel_ref, leg.dtheta,
               clamp(self.position_error(mean_length), P.POSITION_ERROR_LIMIT), speed - self.speed_ref,
               phi - (-cmd.pitch), dphi, self.x_integral, t_prev, tp_prev - hold)
        # the wheel's share for where the robot is and goes (position, speed and their
        # integral) is limited apart: a hard push asks for far more than the wheel has, and
        # saturating the whole sum would give away the torque that keeps the legs upright
        wheel_gains, hip_gains = k
        travel = -lqr.dot(_travel_part(wheel_gains), _travel_part(err))
        t = -lqr.dot(_balance_part(wheel_gains), _balance_part(err))
        t += clamp(travel, P.SLIP_TRAVEL_TORQUE_LIMIT if self.slip.slipping else P.TRAVEL_TORQUE_LIMIT)
        tp = hold - lqr.dot(hip_gains, err)
        return t, tp

    def _lqr_hold(self, leg: LegState, name: str, att: Attitude, cmd: Command) -> tuple[float, float]:
        """The LQR while a jump pushes (jump.StanceHold): its references are the leg angle that
        keeps the hip over its start point and the body's start pitch; no travel terms (the
        trim's integral held the CoM over the axle standing, the hold keeps it there). The
        push along a leaning leg needs Tp = -F L0 tan(theta) to stay vertical, through the CoM
        (the standing trim's Tp, scaled with the push). CoM 3 cm off: 0.028 N m s at
        take-off, 0.09 with the standing references (in-flight pitch 10 deg, 38 deg)."""
        k = lqr.gain_matrix(leg.L0)
        theta_ref, dtheta_ref = cmd.stance_hold.leg_angle(name, leg.L0, leg.dL0)
        err = (leg.theta - theta_ref, leg.dtheta - dtheta_ref, 0.0, 0.0, cmd.stance_hold.pitch_rad - att.pitch,
               -att.wy, 0.0, *self.u_prev[name])
        t = -lqr.dot(k[0], err)
        tp = -lqr.dot(k[1], err)
        if cmd.leg_force is not None:
            tp -= cmd.leg_force * leg.L0 * math.tan(leg.theta)
        return t, tp

    def _split(self, legs: dict) -> float:
        """Tp added to the left leg (and taken from the right) to keep them together."""
        diff = legs["left"].theta - legs["right"].theta
        ddiff = legs["left"].dtheta - legs["right"].dtheta
        return clamp(-(P.SPLIT_KP * diff + P.SPLIT_KD * ddiff), P.SPLIT_LIMIT)

    def _yaw(self, att: Attitude) -> float:
        rate_ref = P.YAW_KP * wrap(self.yaw_ref - att.yaw) + self.yaw_rate_ref
        return clamp(P.YAW_RATE_KP * (rate_ref - att.wz), P.YAW_TORQUE_LIMIT)

    def _roll(self, att: Attitude, cmd: Command) -> float:
        """Force added to the left leg (taken from the right): level the body."""
        err = self.roll_set_point(cmd) - att.roll  # roll > 0: left side up
        # terrain self-levelling: integrate the roll error into a leg-length difference
        self.roll_offset += P.ROLL_LEVEL_KI * err * self.dt
        self.roll_offset = clamp(self.roll_offset, P.ROLL_LEVEL_LIMIT)
        return clamp(P.ROLL_KP * err - P.ROLL_KD * att.wx, P.ROLL_FORCE_LIMIT)

    def _leg_force(self, leg: LegState, name: str) -> float:
        err = self.leg_ref[name] - leg.L0
        self.leg_integral[name] = clamp(self.leg_integral[name] + P.LEG_KI * err * self.dt,
                                         P.LEG_INTEGRAL_LIMIT)
        pid = P.LEG_KP * err - P.LEG_KD * leg.dL0 + self.leg_integral[name]
        return clamp(pid, P.LEG_FORCE_LIMIT) + P.LEG_GRAVITY_FF * math.cos(leg.theta)

    def _dither(self, standing: bool) -> float:
        """This tick's hips' dither (N m, its sign flipped every tick; ``_hips``).

        On only standing still on its spot (``_trim``'s settled standing: not jumping, standing
        up, driving or walking back from a push), where the friction's dead band is what is
        left, and with the wheels' grip (the slip observer's): no shaking of wheels that slip.
        Slewed, not stepped: no torque step, and a tick where Python and C decide apart (a
        threshold's float rounding) differs by one slew step, not the whole dither."""
        self.dither_sign = -self.dither_sign
        target = P.HIP_DITHER if standing and not self.slip.slipping else 0.0
        self.dither_size += clamp(target - self.dither_size, P.HIP_DITHER / P.HIP_DITHER_RAMP_S * self.dt)
        return self.dither_sign * self.dither_size

    def _hips(self, out: Output, leg: str, state: LegState, force: float, tp: float, tp_move: float,
              dither: float = 0.0) -> None:
        """Joint torques for push ``force`` (N) and ``tp`` (N m) on ``leg``, plus the hips' dry
        friction added back (friction.py) in the direction each joint turns or, at rest, is
        asked to turn by ``tp_move`` (N m: the share of ``tp`` that moves the leg, beyond holding it),
        plus ``dither`` (N m) on the front joint and minus it on the rear.

        The dither (HIP_DITHER, its sign flipped every tick) breaks the joints' stiction each
        half period, so the leg follows the LQR's Tp however little it asks beyond holding
        it, instead of sticking within the friction's dead band (docs/control.md, friction).
        Opposite on the two joints (in the same angle sense) its reaction on the body cancels
        (it pitches nothing) and it works the leg's length, not its swing. The same way on
        both joints (swinging the legs, the two legs opposite) it pushed the wheels along the
        floor: on a slippery one (friction 0.3) a pushed robot ended 1.49 m off its spot."""
        t1, t4 = fivebar.joint_torques(state.kin, force, tp)
        m1, m4 = fivebar.joint_torques(state.kin, 0.0, tp_move)
        t1 += friction.coulomb_feed_forward(state.dphi1, m1, C.HIP_FRICTION, P.HIP_FRICTION_BAND, P.HIP_FRICTION_TORQUE_BAND)
        t4 += friction.coulomb_feed_forward(state.dphi4, m4, C.HIP_FRICTION, P.HIP_FRICTION_BAND, P.HIP_FRICTION_TORQUE_BAND)
        t1 += dither
        t4 -= dither
        front, rear = C.LEG_JOINTS[leg]
        out.hip_torque[front.motor_id] = front.sign * t1
        out.hip_torque[rear.motor_id] = rear.sign * t4

    @staticmethod
    def _limit_hips(out: Output, limit: float = P.HIP_TORQUE_LIMIT) -> None:
        """On saturation scale all four hips by one factor (McMaster): keeps direction."""
        peak = max(map(abs, out.hip_torque.values()))  # no generator frame: the same max
        if peak > limit:
            scale = limit / peak
            for key in out.hip_torque:
                out.hip_torque[key] *= scale

    def _report(self, legs: dict, att: Attitude, speed: float, wheel_t: dict, tp: dict) -> ChassisReport:
        return ChassisReport(
            x_m=self.x, x_ref_m=self.x_ref, x_integral_m_s=self.x_integral, balance_theta_rad=self.balance_theta,
            hold_torque_nm=self.balance_point.hold_torque, speed_m_s=speed, slipping=self.slip.slipping,
            blocked=self.blocked, speed_ref_m_s=self.speed_ref,
            pitch_rad=att.pitch, roll_rad=att.roll, yaw_rad=att.yaw, yaw_ref_rad=self.yaw_ref,
            legs={leg: LegReport(legs[leg].L0, self.leg_ref[leg], legs[leg].theta, wheel_t[leg], tp[leg])
                  for leg in LEGS})
