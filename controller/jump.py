"""The jump sequence (docs/control.md, jumps): squat, thrust, retract, flight, land.

``PHASES`` is the table: for each phase, what the chassis does in it and how
it ends (its exit condition, or its timeout, each naming the next phase).
``JumpSequencer.step`` is called once per tick in Mode.JUMP with what the
controller measured; it returns the phase's ``JumpCommand``. The off-ground
check (the support force) is not consulted in SQUAT and THRUST, where the
legs' own pushing makes Fn meaningless. From the thrust's end the legs stay
tucked until the top of the jump its lengthening rate predicts (``apex_delay``);
FLIGHT ends on touchdown past that top: either leg's Fn above ``P.FN_ON`` with
a leg pushed in (shortening faster than ``P.JUMP_TOUCHDOWN_RATE``), as the
in-air PD braking the legs reads as Fn too.

JumpForward is the same table with a forward speed set point held from the
squat to the landing, so the robot carries momentum onto a step; its squat
also waits for a steady run-up (at speed, the legs' lean no longer swinging:
``JumpSequencer._settled``): a thrust while the robot still leans into its
acceleration throws the legs back and, in the air, swinging them upright
pitches the body nose down.

The thrust is sized for the robot as it stands, not as the constants believe it:
``StanceWeight`` averages the legs' support force while balancing (the push each
leg carries, in the hip motors' own torque units, so a heavier body and a weaker
hip motor read the same way: both need more commanded force), and on entering
THRUST ``thrust_amplitude`` picks the Hermite push that does the work for the
commanded rise (``P.JUMP_RISE``) with that weight, every point of the stroke
within the hips' torque limit. In place, the push keeps the hips over the ground
point they stood on and the legs keep that lean in the air (``StanceHold``), so a
CoM off the hips does not send the robot off spinning.
"""
from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from typing import Callable

from wheelleg.controller import constants as C
from wheelleg.controller import fivebar
from wheelleg.controller import params as P
from wheelleg.controller.support import LowPass


class Phase(enum.IntEnum):
    SQUAT = 0  # legs to the squat length, balancing on the wheels
    THRUST = 1  # open-loop push along the legs, decaying towards full stretch
    RETRACT = 2  # pull the wheels up towards the body (leg PD, damped: no slam on the stop)
    FLIGHT = 3  # tucked until the predicted top, then legs vertical at the landing length until touchdown
    LAND = 4  # balancing again, legs absorb from where they touched down
    DONE = 5


@dataclass(frozen=True)
class Thrust:
    """The push of one jump, sized on entering THRUST (``plan_thrust``)."""

    carried_n: float  # N per leg, the weight the legs carried standing (the push's floor)
    amplitude_n: float  # N per leg, the Hermite push on top of it at the bottom of the stroke


@dataclass(frozen=True)
class StanceHold:
    """Where the hips stood over the axles as the thrust began; the thrust keeps them there.

    Standing balanced, the robot's CoM is over the axles (with the CoM off the hips
    the legs lean, ``theta`` off 0). Pushing along leaning legs with the leg angle
    held moves the hips, and the body's CoM, off the axles: the push then turns the
    whole robot (with the CoM 3 cm off, 0.09 N m s at take-off, some 2.6 rad/s, far
    beyond what the wheels can take up in the air). Held over the same ground point
    instead, the push stays under the CoM. The chassis' LQR tracks ``leg_angle`` and
    ``pitch_rad`` while a jump pushes (chassis ``Command.stance_hold``); in the air the
    legs are held at ``leg_angle`` too, so they land with the axles under the CoM (held
    vertical, with the CoM 3 cm forward the robot rolled 0.85 m after landing, 0.05 m so;
    3 cm back it rolls 0.6 m either way)."""

    axle_offset_m: tuple  # (left, right) m, L0 sin(theta) at the start: hip ahead of its axle positive
    pitch_rad: float  # body pitch at the start, nose down positive

    def leg_angle(self, leg: str, length_m: float, rate_m_s: float) -> tuple[float, float]:
        """(theta in rad, its rate in rad/s) that keep ``leg``'s hip over its start point at
        length ``length_m`` (m) growing at ``rate_m_s`` (m/s)."""
        return hold_leg_angle(self.axle_offset_m[0 if leg == "left" else 1], length_m, rate_m_s)


def hold_leg_angle(offset_m: float, length_m: float, rate_m_s: float) -> tuple[float, float]:
    """Leg angle theta (rad) with L0 sin(theta) = ``offset_m`` (m) at L0 = ``length_m`` (m),
    and its rate (rad/s) while L0 grows at ``rate_m_s`` (m/s): d/dt asin(y / L0)."""
    sine = min(max(offset_m / length_m, -P.JUMP_HOLD_SINE_LIMIT), P.JUMP_HOLD_SINE_LIMIT)
    theta = math.asin(sine)
    return theta, -sine * rate_m_s / (length_m * math.cos(theta))


@dataclass(frozen=True)
class JumpView:
    """What a phase's exit (and THRUST's force) looks at this tick."""

    elapsed_s: float  # s in this phase
    leg_length: float  # m, the longer leg in THRUST, the shorter one in every other phase
    touching: bool  # either leg's Fn above P.FN_ON this tick
    steady: bool = True  # a forward jump's run-up: at its speed, the legs' lean settled
    thrust: Thrust | None = None  # THRUST's push (None: sized for the believed weight)
    rate_m_s: float = 0.0  # m/s, the legs' mean lengthening rate (THRUST's tracking)
    rising: bool = False  # in the air before the apex predicted from the take-off (``apex_delay``)
    pressed_m_s: float = 0.0  # m/s, how fast the faster-shortening leg shortens (> 0: pushed in)


@dataclass(frozen=True)
class JumpCommand:
    """What the chassis does this tick of the jump."""

    phase: Phase
    airborne: bool  # wheels unpowered, legs held vertical (air control)
    leg_length: float | None  # m, leg-length set point (None: the operator's)
    leg_force: float | None  # N per leg, open-loop push replacing the leg PID (None: PID)
    hip_torque_limit: float  # N m
    stance_hold: StanceHold | None = None  # pushing and in the air: the legs' lean (StanceHold)
    tuck: bool = False  # in the air, the retraction's stiffer leg PD (in place, RETRACT; P.JUMP_RETRACT_KP)


# --- sizing the thrust ------------------------------------------------------------------
def _hermite(length_m: float) -> float:
    """Smooth decay 1 - 3s^2 + 2s^3 over the stroke (rm_controllers' Hermite), s = 0 at the squat."""
    s = (length_m - P.JUMP_SQUAT_LENGTH) / (P.JUMP_THRUST_END_LENGTH - P.JUMP_SQUAT_LENGTH)
    s = min(max(s, 0.0), 1.0)
    return 1.0 - 3.0 * s * s + 2.0 * s ** 3


def push_limit(length_m: float) -> float:
    """Largest push along an upright leg (N) of length ``length_m`` (m) whose hip torques stay
    within P.JUMP_THRUST_TORQUE_SHARE of P.JUMP_HIP_TORQUE_LIMIT (five-bar statics)."""
    phi1, phi4 = fivebar.inverse_kinematics(length_m, math.pi / 2)
    t1, t4 = fivebar.joint_torques(fivebar.forward_kinematics(phi1, phi4), 1.0, 0.0)
    return P.JUMP_THRUST_TORQUE_SHARE * P.JUMP_HIP_TORQUE_LIMIT / max(abs(t1), abs(t4))


_STROKE_STEPS = 26  # points of the stroke the sizing integrates over (0.005 m apart)
_STROKE = tuple(P.JUMP_SQUAT_LENGTH + (P.JUMP_THRUST_END_LENGTH - P.JUMP_SQUAT_LENGTH) * i / (_STROKE_STEPS - 1)
                for i in range(_STROKE_STEPS))
_LIMITS = tuple(push_limit(length) for length in _STROKE)  # N, push_limit at each _STROKE point


def _push_limit_at(length_m: float) -> float:
    """``push_limit`` interpolated in the table over the stroke (N); its ends outside it."""
    if length_m <= _STROKE[0]:
        return _LIMITS[0]
    if length_m >= _STROKE[-1]:
        return _LIMITS[-1]
    step = _STROKE[1] - _STROKE[0]
    i = min(int((length_m - _STROKE[0]) / step), _STROKE_STEPS - 2)
    w = (length_m - _STROKE[i]) / step
    return _LIMITS[i] + w * (_LIMITS[i + 1] - _LIMITS[i])


def thrust_force(thrust: Thrust, length_m: float) -> float:
    """Push along the leg (N) at ``length_m`` (m): the carried weight plus the Hermite
    push, within ``push_limit``; the carried weight alone past the stroke."""
    return min(thrust.carried_n + thrust.amplitude_n * _hermite(length_m), _push_limit_at(length_m))


def planned_rate(thrust: Thrust, length_m: float) -> float:
    """Lengthening rate (m/s) the push gives the legs by ``length_m`` (m) in ``takeoff_work``'s
    model (the carried mass m = carried_n / g takes all the push's work from the squat,
    P.JUMP_SQUAT_DONE_LENGTH: m v^2 / 2 = W); 0 before the squat's length."""
    work = stroke_work(thrust, P.JUMP_SQUAT_DONE_LENGTH) - stroke_work(thrust, length_m)
    return math.sqrt(2.0 * max(work, 0.0) * C.GRAVITY / max(thrust.carried_n, 1e-3))


def tracked_thrust_force(thrust: Thrust, length_m: float, rate_m_s: float) -> float:
    """``thrust_force`` plus P.JUMP_RATE_KP for each m/s the legs lengthen slower than the push
    planned (``planned_rate``), within ``push_limit``: what the model leaves out (the hips'
    armature, their friction, a sagging battery) takes work the push did not plan for. Not
    faded over the stroke as the plan's push is: faded (x the Hermite), armature 0.014
    cleared 19.4 cm, 0.021 15.9 cm; the thrust ends at JUMP_THRUST_END_LENGTH anyway."""
    behind = max(planned_rate(thrust, length_m) - rate_m_s, 0.0)
    return min(thrust_force(thrust, length_m) + P.JUMP_RATE_KP * behind, _push_limit_at(length_m))


def takeoff_work(carried_n: float) -> float:
    """Work (J per leg) the push must add to carrying ``carried_n`` (N) over the stroke for
    the body to rise P.JUMP_RISE (m) once it has picked the wheels up.

    The legs carry m = carried_n / g each; leaving the ground, the body drags its
    unsprung share (the axle's mass, fivebar.MASS_AT_AXLE) from rest to a common speed
    (momentum kept): the body needs v (m + m_axle) / m at the end of the stroke for
    v = sqrt(2 g rise) after it, and the push's work is m/2 times its square."""
    m = max(carried_n, 1e-3) / C.GRAVITY
    v_after = math.sqrt(2.0 * C.GRAVITY * P.JUMP_RISE)
    v_end = v_after * (m + fivebar.MASS_AT_AXLE) / m
    return 0.5 * m * v_end * v_end


def stroke_work(thrust: Thrust, start_m: float) -> float:
    """Work (J per leg) ``thrust`` adds to carrying its weight from ``start_m`` (m) to the
    stroke's end (midpoint rule over the stroke table)."""
    work = 0.0
    for a, b in zip(_STROKE, _STROKE[1:]):
        lo, hi = max(a, start_m), b
        if hi > lo:
            work += (thrust_force(thrust, 0.5 * (lo + hi)) - thrust.carried_n) * (hi - lo)
    return work


def thrust_amplitude(carried_n: float, start_m: float) -> float:
    """Hermite amplitude (N per leg) whose ``stroke_work`` from ``start_m`` (m) with the legs
    carrying ``carried_n`` (N) is ``takeoff_work(carried_n)``; P.JUMP_AMPLITUDE_MAX when even
    that falls short (the hips' limit then sets the jump). Bisection: the work grows with
    the amplitude."""
    target = takeoff_work(carried_n)
    lo, hi = 0.0, P.JUMP_AMPLITUDE_MAX
    if stroke_work(Thrust(carried_n, hi), start_m) <= target:
        return hi
    for _ in range(30):  # to ~P.JUMP_AMPLITUDE_MAX / 1e9 N
        mid = 0.5 * (lo + hi)
        if stroke_work(Thrust(carried_n, mid), start_m) < target:
            lo = mid
        else:
            hi = mid
    return hi


def plan_thrust(carried_n: float) -> Thrust:
    """The push for a jump with the legs carrying ``carried_n`` (N each), sized over the
    stroke from the squat's P.JUMP_SQUAT_DONE_LENGTH (a deeper squat pushes longer); the
    weight held within P.JUMP_CARRIED_RANGE of the believed one, the believed one for a
    reading that is no number (a bad reading must not size a wild push)."""
    lo, hi = (k * P.LEG_GRAVITY_FF for k in P.JUMP_CARRIED_RANGE)
    carried = min(max(carried_n, lo), hi) if math.isfinite(carried_n) else P.LEG_GRAVITY_FF
    return Thrust(carried, thrust_amplitude(carried, P.JUMP_SQUAT_DONE_LENGTH))


class StanceWeight:
    """The push each leg carries standing (N): a slow low-pass of the legs' mean support
    force less the axle's weight (the leg's push P = Fn - m_axle g at rest), fed while
    balancing on the ground; the believed weight (P.LEG_GRAVITY_FF) until then."""

    def __init__(self, dt_s: float):
        self.filter = LowPass(P.JUMP_WEIGHT_TAU, dt_s)

    def update(self, fn_left_n: float, fn_right_n: float) -> None:
        if math.isfinite(fn_left_n) and math.isfinite(fn_right_n):
            self.filter(0.5 * (fn_left_n + fn_right_n) - fivebar.MASS_AT_AXLE * C.GRAVITY)

    @property
    def carried_n(self) -> float:
        return P.LEG_GRAVITY_FF if self.filter.value is None else self.filter.value


def apex_delay(rate_m_s: float, carried_n: float) -> float:
    """Time (s) from the thrust's end to the top of the jump, from the legs' lengthening
    rate as the thrust ended (m/s: the body's speed up, the wheels still on the ground) and
    the weight they carried (N per leg): leaving the ground the body drags the axle's mass
    (fivebar.MASS_AT_AXLE) from rest, v (m / (m + m_axle)) after it, then it decelerates at
    g. 0 for a legs' rate that is no number or not upwards (a thrust that did not push)."""
    if not (math.isfinite(rate_m_s) and rate_m_s > 0.0):
        return 0.0
    m = max(carried_n, 1e-3) / C.GRAVITY
    return rate_m_s * m / (m + fivebar.MASS_AT_AXLE) / C.GRAVITY


def _thrust_force(view: JumpView) -> float:
    return tracked_thrust_force(view.thrust or plan_thrust(P.LEG_GRAVITY_FF), view.leg_length, view.rate_m_s)


@dataclass(frozen=True)
class PhaseSpec:
    airborne: bool  # in-air control (chassis ``_air_step``)
    leg_length: float | None  # m, leg-length set point; None: the operator's
    force: Callable | None  # fn(view) -> N, or None for the leg PID
    hip_torque_limit: float  # N m
    done: Callable  # fn(view) -> bool: the phase's goal reached
    then: Phase  # next phase when done
    timeout_s: float  # s in the phase before ``on_timeout``
    on_timeout: Phase


PHASES: dict = {
    Phase.SQUAT: PhaseSpec(False, P.JUMP_SQUAT_LENGTH, None, P.HIP_TORQUE_LIMIT,
                           lambda v: (v.leg_length < P.JUMP_SQUAT_DONE_LENGTH and v.elapsed_s > P.JUMP_SQUAT_MIN_S
                                      and v.steady),
                           Phase.THRUST, P.JUMP_SQUAT_TIMEOUT, Phase.THRUST),
    Phase.THRUST: PhaseSpec(False, None, _thrust_force, P.JUMP_HIP_TORQUE_LIMIT,
                            lambda v: v.leg_length > P.JUMP_THRUST_END_LENGTH,
                            Phase.RETRACT, P.JUMP_THRUST_TIMEOUT, Phase.RETRACT),
    Phase.RETRACT: PhaseSpec(True, P.JUMP_RETRACT_TARGET, None, P.JUMP_HIP_TORQUE_LIMIT,
                             lambda v: v.leg_length < P.JUMP_RETRACT_LENGTH,
                             Phase.FLIGHT, P.JUMP_RETRACT_TIMEOUT, Phase.FLIGHT),
    Phase.FLIGHT: PhaseSpec(True, P.JUMP_LAND_LENGTH, None, P.HIP_TORQUE_LIMIT,
                            lambda v: (v.touching and v.elapsed_s > P.JUMP_FLIGHT_MIN_S and not v.rising
                                       and v.pressed_m_s > P.JUMP_TOUCHDOWN_RATE),
                            Phase.LAND, P.JUMP_FLIGHT_TIMEOUT, Phase.LAND),
    Phase.LAND: PhaseSpec(False, None, None, P.HIP_TORQUE_LIMIT,
                          lambda v: False, Phase.DONE, P.JUMP_LAND_TIME, Phase.DONE),
}


def table_next_phase(phases: dict, phase, view):
    """The phase after this tick in a phase table (this ``PHASES``, recovery's): its
    ``done`` goal reached, its timeout, or the same. A phase the table does not
    list (DONE) stays. ``view`` has ``elapsed_s`` and what the ``done`` tests read."""
    spec = phases.get(phase)
    if spec is None:
        return phase
    if spec.done(view):
        return spec.then
    if view.elapsed_s >= spec.timeout_s:
        return spec.on_timeout
    return phase


def next_phase(phase: Phase, view: JumpView) -> Phase:
    """The jump's phase after this tick (``table_next_phase`` on ``PHASES``)."""
    return table_next_phase(PHASES, phase, view)


class JumpSequencer:
    """Runs the table, one ``step`` per tick; ``phase`` is DONE when landed."""

    def __init__(self, dt_s: float):
        self.dt = dt_s
        self.phase = Phase.DONE
        self.elapsed_s = 0.0
        self.forward = False
        self.entered: Phase | None = None  # the phase entered this tick (None: no change)
        self.stance = StanceWeight(dt_s)
        self.thrust: Thrust | None = None  # this jump's push, sized on entering THRUST
        self.hold: StanceHold | None = None  # where the hips stood as THRUST began
        self.mean_length_m = math.nan  # m, the legs' mean length a tick ago (their rate)
        self.lengths_m = (math.nan, math.nan)  # m, both legs' lengths a tick ago
        self.mean_angle_rad = math.nan  # rad, the legs' mean angle a tick ago
        self.swing = LowPass(P.JUMP_RUN_UP_SWING_TAU, dt_s)  # rad/s, the legs' mean angle rate
        self.settled_s = 0.0  # s the legs' swing has stayed within P.JUMP_RUN_UP_SWING_TOL
        self.apex_s = 0.0  # s from the thrust's end to the predicted top of the jump (``apex_delay``)
        self.air_s = 0.0  # s since the thrust ended

    def _settled(self, angles: tuple[float, float]) -> bool:
        """Whether the legs' lean has stopped swinging: the rate (rad/s) of their mean angle,
        low-passed over P.JUMP_RUN_UP_SWING_TAU, within P.JUMP_RUN_UP_SWING_TOL for
        P.JUMP_RUN_UP_SETTLE_S (a swing's turning point passes through a zero rate)."""
        mean = 0.5 * (angles[0] + angles[1])
        rate = (mean - self.mean_angle_rad) / self.dt if math.isfinite(self.mean_angle_rad) else 0.0
        self.mean_angle_rad = mean
        swing = self.swing(rate)
        self.settled_s = self.settled_s + self.dt if abs(swing) < P.JUMP_RUN_UP_SWING_TOL else 0.0
        return self.settled_s >= P.JUMP_RUN_UP_SETTLE_S

    def observe_stance(self, fn_left_n: float, fn_right_n: float) -> None:
        """Each tick balancing on the ground: the legs' support forces (N), for the thrust's size."""
        self.stance.update(fn_left_n, fn_right_n)

    def start(self, forward: bool = False) -> None:
        self.phase, self.elapsed_s, self.forward, self.entered = Phase.SQUAT, 0.0, forward, Phase.SQUAT
        self.thrust = self.hold = None  # sized and taken anew on entering THRUST
        self.apex_s = self.air_s = self.settled_s = 0.0

    @property
    def done(self) -> bool:
        return self.phase == Phase.DONE

    def step(self, lengths: tuple[float, float], touching: bool, steady: bool = True,
             angles: tuple[float, float] = (0.0, 0.0), pitch_rad: float = 0.0) -> JumpCommand:
        """Advance with both legs' lengths (m), touchdown, (forward jumps) whether the
        run-up is steady, and both legs' angles (rad) and the body's pitch (rad) for the
        thrust's ``StanceHold``; the command for this tick."""
        pick = max if self.phase == Phase.THRUST else min
        mean_length = 0.5 * (lengths[0] + lengths[1])
        rate = (mean_length - self.mean_length_m) / self.dt if math.isfinite(self.mean_length_m) else 0.0
        self.mean_length_m = mean_length
        pressed = max((old - new) / self.dt for old, new in zip(self.lengths_m, lengths)) \
            if all(math.isfinite(old) for old in self.lengths_m) else 0.0
        self.lengths_m = tuple(lengths)
        settled = self._settled(angles)  # fed every tick: the run-up's swing filter stays current
        steady = steady and (settled or not self.forward)
        rising = self.phase in (Phase.RETRACT, Phase.FLIGHT) and self.air_s < self.apex_s
        view = JumpView(self.elapsed_s, pick(lengths), touching, steady, rising=rising, pressed_m_s=pressed)
        new = next_phase(self.phase, view)
        self.entered = new if new != self.phase else None
        if self.entered is not None:
            self.phase, self.elapsed_s = new, 0.0
        if self.entered == Phase.THRUST:
            self.thrust = plan_thrust(self.stance.carried_n)
            self.hold = StanceHold(tuple(n * math.sin(a) for n, a in zip(lengths, angles)), pitch_rad)
        if self.entered == Phase.RETRACT:
            carried = self.thrust.carried_n if self.thrust is not None else P.LEG_GRAVITY_FF
            self.apex_s, self.air_s = apex_delay(rate, carried), 0.0
        self.elapsed_s += self.dt
        self.air_s += self.dt
        rising = self.phase in (Phase.RETRACT, Phase.FLIGHT) and self.air_s < self.apex_s
        if self.phase == Phase.DONE:
            return JumpCommand(Phase.DONE, False, None, None, P.HIP_TORQUE_LIMIT)
        spec = PHASES[self.phase]
        # pushing, the hips over the ground point they stood on (StanceHold), a forward jump too:
        # pushed along the run-up's lean, draws with the CoM off took off spinning nose down at
        # 2.7-3.4 rad/s and landed pitched 0.5-0.7 rad (seed 5150 samples 5, 9). In the air only
        # in place: a forward jump's lean is the run-up's, and held in the air the wheels trailed
        # under the body (the step climbed fell from 0.1875 m to 0.1625 m, tools.limits)
        hold = None
        if spec.force or (spec.airborne and not self.forward):
            hold = self.hold or StanceHold((0.0, 0.0), pitch_rad)
        force = None
        if spec.force is not None:
            force = spec.force(JumpView(self.elapsed_s, pick(lengths), touching, thrust=self.thrust, rate_m_s=rate))
        # the legs stay tucked (the retraction's stiff PD at its target) until the top of the
        # jump, the wheels as high as they go while the robot rises; then out to the landing length
        tuck = self.phase == Phase.RETRACT or (self.phase == Phase.FLIGHT and rising)
        length = P.JUMP_RETRACT_TARGET if tuck else spec.leg_length
        return JumpCommand(self.phase, spec.airborne, length, force, spec.hip_torque_limit, hold, tuck)
