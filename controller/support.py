"""Ground support force per leg and the off-ground decision (the design document's leg_fn_cal).

``fivebar.support_force`` is the design document's formula; this module feeds it what
the robot measures each tick and turns its output into a debounced
"both wheels off the ground":

- F, Tp (N, N m): the leg's push and hip torque from the hip motors' feedback
  torques (``fivebar.leg_force``), not from what was commanded;
- the hip's vertical acceleration (m/s^2, up positive, 0 at rest) from the
  IMU's specific force turned into the world frame, minus g;
- ddL0 and ddtheta by differencing the leg rates, low-passed.

The estimate is low-passed too (``P.FN_FILTER_TAU``): an impact or a wheel
bounce is a few ms long, the decisions below want tens of ms.

``ContactDebounce`` is a per-robot hysteresis with a counter: airborne only
after both legs have been below ``FN_OFF`` for ``OFF_GROUND_DEBOUNCE``, back on
the ground once either leg has been above ``FN_ON`` for
``TOUCHDOWN_DEBOUNCE`` (docs/control.md: 7 N / 12 N for this 4.6 kg robot,
whose static Fn is ~22.7 N per wheel).
"""
from __future__ import annotations

import math
from typing import NamedTuple

from wheelleg.controller import constants as C
from wheelleg.controller import fivebar
from wheelleg.controller import params as P


def vertical_accel(quat: tuple, specific_force: tuple) -> float:
    """World-vertical acceleration (m/s^2, up positive, 0 at rest) of the IMU.

    quat (w, x, y, z) body->world, specific_force (3,) in the body frame
    (+g on z at rest). a_world = R f - g z.
    """
    w, x, y, z = quat
    fx, fy, fz = specific_force
    r20, r21, r22 = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
    return r20 * fx + r21 * fy + r22 * fz - C.GRAVITY


def measured_leg_force(kin, front: C.Joint, rear: C.Joint, front_tau: float, rear_tau: float) -> tuple[float, float]:
    """(F in N, Tp in N m) the hip motors exert, from their shaft torques (N m).

    Near the leg's singular stretch there is no unique answer: (0, 0) then,
    which reads as "no push", the safe side for a support estimate.
    """
    try:  # fivebar.phi_torque_from_shaft of each, written out (twice a leg a tick)
        return fivebar.leg_force(kin, front.sign * front_tau, rear.sign * rear_tau)
    except ValueError:
        return 0.0, 0.0


class LowPass:
    """First-order low-pass y += (x - y) dt / (tau + dt); starts at the first input."""

    def __init__(self, tau_s: float, dt_s: float):
        self.alpha = dt_s / (tau_s + dt_s)
        self.value: float | None = None

    def __call__(self, x: float) -> float:
        self.value = x if self.value is None else self.value + self.alpha * (x - self.value)
        return self.value


class Derivative:
    """Low-passed backward difference (units of x per s); 0 on the first input."""

    def __init__(self, tau_s: float, dt_s: float):
        self.dt = dt_s
        self.last: float | None = None
        self.filter = LowPass(tau_s, dt_s)

    def __call__(self, x: float) -> float:
        raw = 0.0 if self.last is None else (x - self.last) / self.dt
        self.last = x
        return self.filter(raw)


class LegMeasurement(NamedTuple):
    """One leg this tick, in fivebar's signs."""

    F: float  # N, measured push along the leg
    Tp: float  # N m, measured virtual hip torque
    L0: float  # m
    dL0: float  # m/s
    theta: float  # rad
    dtheta: float  # rad/s


class SupportEstimator:
    """Fn (N) of one leg each tick: ``update(leg, body_accel_z) -> Fn`` (filtered)."""

    def __init__(self, dt_s: float):
        self.ddL0 = Derivative(P.FN_DERIVATIVE_TAU, dt_s)
        self.ddtheta = Derivative(P.FN_DERIVATIVE_TAU, dt_s)
        self.fn = LowPass(P.FN_FILTER_TAU, dt_s)

    def update(self, leg: LegMeasurement, body_accel_z: float) -> float:
        raw = fivebar.support_force(leg.F, leg.Tp, leg.theta, leg.L0, leg.dL0, self.ddL0(leg.dL0),
                                    leg.dtheta, self.ddtheta(leg.dtheta), body_accel_z)
        if not math.isfinite(raw):
            raw = self.fn.value if self.fn.value is not None else 0.0
        return self.fn(raw)


def estimate_trusted(thetas) -> bool:
    """Whether Fn can call the robot airborne: every leg within P.FN_TRUST_THETA of vertical.

    With a leg swung far out (catching a shove, |theta| ~0.5 rad) and a large
    hip torque, the massless-leg estimate reads near zero although the wheel
    carries its full load (seen in the rig: 1 N estimated against 24 N, in a
    30 N push); a robot that leaves the ground does so with its legs near
    vertical (drop, jump, a bump at speed).
    """
    limit = P.FN_TRUST_THETA
    for theta in thetas:  # all(abs(t) < limit for t in thetas), without a generator every tick
        if not abs(theta) < limit:
            return False
    return True


class ContactDebounce:
    """Both wheels off the ground, with hysteresis and debounce (module doc)."""

    def __init__(self, dt_s: float):
        self.off_ticks = max(1, round(P.OFF_GROUND_DEBOUNCE / dt_s))
        self.on_ticks = max(1, round(P.TOUCHDOWN_DEBOUNCE / dt_s))
        self.airborne = False
        self.count = 0

    def reset(self, airborne: bool = False) -> None:
        self.airborne, self.count = airborne, 0

    def update(self, fn_left: float, fn_right: float, trusted: bool = True) -> bool:
        """Feed this tick's Fn (N) of both legs; returns whether the robot is airborne.

        ``trusted`` False (legs far from vertical, see ``estimate_trusted``) keeps a
        robot on the ground from being declared airborne; touchdown is always taken.
        """
        if self.airborne:
            changing = max(fn_left, fn_right) > P.FN_ON
            needed = self.on_ticks
        else:
            changing = trusted and max(fn_left, fn_right) < P.FN_OFF
            needed = self.off_ticks
        self.count = self.count + 1 if changing else 0
        if self.count >= needed:
            self.airborne, self.count = not self.airborne, 0
        return self.airborne


def leg_measurement(joints: dict, leg: str, state) -> LegMeasurement:
    """This tick's measurement of ``leg`` from the joints' feedback (motor id ->
    JointFeedback) and the chassis' LegState of it (kin, L0, dL0, theta, dtheta)."""
    front, rear = C.LEG_JOINTS[leg]
    F, Tp = measured_leg_force(state.kin, front, rear, joints[front.motor_id].torque, joints[rear.motor_id].torque)
    return LegMeasurement(F, Tp, state.L0, state.dL0, state.theta, state.dtheta)
