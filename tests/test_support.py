"""Support force Fn and the off-ground decision (controller/support.py)."""
import math

import pytest

from wheelleg.controller import constants as C
from wheelleg.controller import fivebar
from wheelleg.controller import params as P
from wheelleg.controller.support import (ContactDebounce, Derivative, LegMeasurement, LowPass, SupportEstimator,
                                measured_leg_force, vertical_accel)

DT = P.CONTROL_PERIOD
LEFT_FRONT, LEFT_REAR = C.JOINTS[0], C.JOINTS[1]


def _quat_pitch(pitch):
    return (math.cos(pitch / 2), 0.0, math.sin(pitch / 2), 0.0)


def test_vertical_accel_is_zero_at_rest_whatever_the_tilt():
    for pitch in (0.0, 0.3, -0.5):
        # at rest the specific force is +g straight up, seen in the tilted body frame
        f_body = (-C.GRAVITY * math.sin(pitch), 0.0, C.GRAVITY * math.cos(pitch))
        assert vertical_accel(_quat_pitch(pitch), f_body) == pytest.approx(0.0, abs=1e-9)


def test_vertical_accel_in_free_fall_is_minus_g():
    assert vertical_accel(_quat_pitch(0.2), (0.0, 0.0, 0.0)) == pytest.approx(-C.GRAVITY)


def test_measured_leg_force_inverts_the_vmc():
    k = fivebar.forward_kinematics(*fivebar.inverse_kinematics(0.17, math.pi / 2 + 0.1))
    t1, t4 = fivebar.joint_torques(k, 30.0, -1.5)
    tau1, tau4 = fivebar.shaft_torque(LEFT_FRONT, t1), fivebar.shaft_torque(LEFT_REAR, t4)
    F, Tp = measured_leg_force(k, LEFT_FRONT, LEFT_REAR, tau1, tau4)
    assert (F, Tp) == (pytest.approx(30.0), pytest.approx(-1.5))


def test_low_pass_and_derivative():
    lp = LowPass(0.01, DT)
    assert lp(5.0) == 5.0  # starts at its first input
    for _ in range(200):
        y = lp(1.0)
    assert y == pytest.approx(1.0, abs=1e-6)
    d = Derivative(0.0, DT)
    assert d(0.0) == 0.0
    assert d(0.004) == pytest.approx(2.0)  # 4 mm in 2 ms


def test_estimator_reads_half_the_weight_standing_and_zero_in_free_fall():
    k = fivebar.forward_kinematics(*fivebar.inverse_kinematics(0.17, math.pi / 2))
    half = 0.5 * C.MASS_TOTAL * C.GRAVITY
    standing = LegMeasurement(F=half - fivebar.MASS_AT_AXLE * C.GRAVITY, Tp=0.0, L0=k.L0, dL0=0.0, theta=0.0, dtheta=0.0)
    est = SupportEstimator(DT)
    for _ in range(50):
        fn = est.update(standing, 0.0)
    assert fn == pytest.approx(half, rel=1e-6)
    falling = LegMeasurement(F=0.0, Tp=0.0, L0=k.L0, dL0=0.0, theta=0.0, dtheta=0.0)
    for _ in range(50):
        fn = est.update(falling, -C.GRAVITY)
    assert abs(fn) < 0.1


def test_estimator_survives_a_non_finite_input():
    est = SupportEstimator(DT)
    ok = LegMeasurement(10.0, 0.0, 0.17, 0.0, 0.0, 0.0)
    before = est.update(ok, 0.0)
    assert est.update(LegMeasurement(float("nan"), 0.0, 0.17, 0.0, 0.0, 0.0), 0.0) == pytest.approx(before)


def test_debounce_needs_both_legs_low_for_the_whole_debounce():
    c = ContactDebounce(DT)
    ticks = round(P.OFF_GROUND_DEBOUNCE / DT)
    for _ in range(ticks - 1):
        assert not c.update(1.0, 1.0)
    assert not c.update(1.0, 20.0)  # one leg loaded: the count restarts
    for _ in range(ticks - 1):
        assert not c.update(1.0, 1.0)
    assert c.update(1.0, 1.0)


def test_touchdown_needs_a_leg_above_the_on_threshold_and_hysteresis_holds():
    c = ContactDebounce(DT)
    c.reset(airborne=True)
    between = 0.5 * (P.FN_OFF + P.FN_ON)
    for _ in range(100):
        assert c.update(between, between)  # inside the hysteresis band: stays airborne
    ticks = round(P.TOUCHDOWN_DEBOUNCE / DT)
    for _ in range(ticks - 1):
        assert c.update(P.FN_ON + 1, 0.0)
    assert not c.update(P.FN_ON + 1, 0.0)
    assert P.FN_OFF < P.FN_ON < 0.5 * C.MASS_TOTAL * C.GRAVITY  # thresholds below the static load


def test_an_untrusted_estimate_never_makes_it_airborne_but_touchdown_still_counts():
    from wheelleg.controller.support import estimate_trusted
    assert estimate_trusted((0.1, -0.2)) and not estimate_trusted((0.1, -0.5))
    c = ContactDebounce(DT)
    for _ in range(200):
        assert not c.update(0.0, 0.0, trusted=False)
    c.reset(airborne=True)
    for _ in range(round(P.TOUCHDOWN_DEBOUNCE / DT)):
        c.update(30.0, 30.0, trusted=False)
    assert not c.airborne
