"""The controller's sensor estimators (controller/estimate.py) on synthetic signals."""
import math
import random

import pytest

from wheelleg.controller import estimate, lqr
from wheelleg.controller import params as P

DT = P.CONTROL_PERIOD


def _run_bias(true_rate, bias, seconds, noise_rad=0.0, seed=1):
    """Feed the observer a body turning at ``true_rate`` (rad/s, (3,)) and a gyro reading bias on top."""
    rng = random.Random(seed)
    obs = estimate.GyroBiasObserver(DT, P.GYRO_BIAS_OMEGA, P.GYRO_BIAS_LIMIT)
    q = (1.0, 0.0, 0.0, 0.0)
    for _ in range(int(seconds / DT)):
        measured = estimate.quat_mul(q, estimate.quat_exp(tuple(rng.gauss(0, noise_rad) for _ in range(3))))
        obs.update(measured, tuple(w + b for w, b in zip(true_rate, bias)))
        q = estimate.quat_mul(q, estimate.quat_exp(tuple(w * DT for w in true_rate)))
    return obs.bias


@pytest.mark.parametrize("bias", [(0.0, 0.1, 0.0), (-0.05, 0.05, 0.03)])
def test_gyro_bias_is_found_standing_still(bias):
    found = _run_bias((0.0, 0.0, 0.0), bias, 8.0)
    assert found == pytest.approx(bias, abs=2e-3)


def test_gyro_bias_is_found_while_turning_with_a_noisy_orientation():
    bias = (0.02, -0.05, 0.04)
    found = _run_bias((0.3, -0.2, 0.5), bias, 10.0, noise_rad=0.002)
    assert found == pytest.approx(bias, abs=5e-3)


def test_an_unbiased_gyro_gives_no_bias():
    assert _run_bias((0.1, 0.4, -0.2), (0.0, 0.0, 0.0), 5.0) == pytest.approx((0.0, 0.0, 0.0), abs=1e-4)


def test_bias_estimate_is_bounded():
    found = _run_bias((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), 10.0)
    assert found[1] == pytest.approx(P.GYRO_BIAS_LIMIT)


def test_rotation_vector_inverts_quat_exp():
    r = (0.3, -0.2, 1.1)
    assert estimate.rotation_vector(estimate.quat_exp(r)) == pytest.approx(r)
    q = estimate.quat_exp(r)
    assert estimate.rotation_vector(tuple(-v for v in q)) == pytest.approx(r)  # the same rotation
    assert math.isclose(sum(v * v for v in q), 1.0)


# -- slip -------------------------------------------------------------------------------------
def _slip_observer():
    return estimate.SlipObserver(0.002, gain=10.0, on_m_s=0.3, window_s=0.1, grip_m_s=0.05)


def test_forward_accel_is_the_heading_component_with_gravity_removed():
    level = (1.0, 0.0, 0.0, 0.0)
    assert estimate.forward_accel(level, (2.0, 0.0, 9.81)) == pytest.approx(2.0)
    yawed = estimate.quat_exp((0.0, 0.0, math.pi / 2))  # facing +y: its own x is still forward
    assert estimate.forward_accel(yawed, (2.0, 0.5, 9.81)) == pytest.approx(2.0)
    pitch = 0.2  # nose down, at rest: the specific force is g tilted into the body frame
    tilted = estimate.quat_exp((0.0, pitch, 0.0))
    at_rest = (-9.81 * math.sin(pitch), 0.0, 9.81 * math.cos(pitch))
    assert estimate.forward_accel(tilted, at_rest) == pytest.approx(0.0, abs=1e-9)


def test_gripping_wheels_that_agree_with_the_imu_never_slip():
    obs = _slip_observer()
    speed = 0.0
    for k in range(2000):  # 4 s of 1 m/s^2 forth and back
        accel = 1.0 if (k // 500) % 2 == 0 else -1.0
        speed += accel * 0.002
        assert not obs.update(accel, speed)
    assert obs.speed_m_s == pytest.approx(speed, abs=0.01)


def test_a_spinning_wheel_is_slip_and_the_speed_follows_the_imu():
    obs = _slip_observer()
    wheels = 0.0
    for k in range(100):  # the wheel spins up at 20 m/s^2, the body does not move
        wheels += 20.0 * 0.002
        slipping = obs.update(0.0, wheels)
    assert slipping
    assert abs(obs.speed_m_s) < 0.35, "the estimate was not dragged along past the threshold"
    for _ in range(10):  # the wheel grips again: it slows to the body's speed
        slipping = obs.update(0.0, 0.0)
    assert not slipping


def test_an_estimate_that_drifted_while_slipping_does_not_hold_the_flag():
    obs = _slip_observer()
    assert obs.update(0.0, 1.0)  # a jolt: the wheels jump 1 m/s from the estimate
    for _ in range(100):  # the wheels now move as the IMU says, at a speed 1 m/s off it
        slipping = obs.update(0.0, 1.0)
    assert not slipping
    assert obs.speed_m_s == pytest.approx(1.0, abs=0.01)


# -- balance point ------------------------------------------------------------------
def test_balance_point_learns_fast_after_start_up_then_slowly():
    obs = estimate.BalancePointObserver(0.002, tau_learn_s=0.05, learn_s=0.6, tau_s=0.3)
    for _ in range(50):  # 0.1 s = 2 lags
        obs.update(0.4, 0.0, standing=True)
    assert 0.4 * 0.8 < obs.hold_torque < 0.4 * 0.9  # 1 - e^-2 = 0.86
    for _ in range(250):  # to 0.6 s: learnt
        obs.update(0.4, 0.0, standing=True)
    held = obs.hold_torque
    for _ in range(50):  # 0.1 s of another torque, at the slow lag
        obs.update(-2.0, 0.0, standing=True)
    assert held - obs.hold_torque == pytest.approx(2.4 * (1 - math.exp(-0.1 / 0.3)), rel=0.01)


def test_balance_point_learns_nothing_moving_nor_just_after():
    obs = estimate.BalancePointObserver(0.002, 0.05, 0.6, 0.3, still_m_s=0.5, settle_s=0.5)
    obs.update(1.0, 0.0, standing=False)  # not standing (moving, in the air, beyond the clamp)
    assert obs.hold_torque == 0.0
    obs.update(1.0, 0.6, standing=True)  # a push has it rolling
    for _ in range(248):  # 0.496 s after: still settling
        obs.update(1.0, 0.1, standing=True)
    assert obs.hold_torque == 0.0
    for _ in range(2):
        obs.update(1.0, 0.1, standing=True)
    assert obs.hold_torque > 0.0


def test_balance_lean_puts_the_com_over_the_axle():
    """sin(theta) = -Tp / arm, the arm the design's static moment balance (fitted)."""
    from wheelleg.controller.design import lqr as design

    for L0 in (0.12, 0.17, 0.26):
        arm = design.static_arm(L0)
        theta = lqr.balance_lean(0.3, L0, limit=1.0)
        assert math.sin(theta) == pytest.approx(-0.3 / arm, rel=1e-3)
    assert lqr.balance_lean(0.0, 0.17, 0.35) == 0.0
    assert lqr.balance_lean(5.0, 0.17, 0.35) == -0.35  # a hold torque past belief is bounded
    assert lqr.balance_lean(-5.0, 0.17, 0.35) == 0.35


def test_the_hold_torque_of_a_lean_is_balance_leans_inverse():
    """The balance point is learnt from the legs' lean: the hold torque that goes with a lean
    must give that lean back, at every length and weight ratio, and lean and torque have
    opposite signs (CoM forward: hold torque > 0, wheels ahead of the hips: theta < 0)."""
    for L0 in (0.12, 0.17, 0.26):
        for theta in (-0.2, -0.05, 0.1):
            for ratio in (0.8, 1.0, 1.3):
                hold = lqr.lean_hold_torque(theta, L0, ratio)
                assert hold * theta < 0.0
                assert lqr.balance_lean(hold, L0, 1.0, ratio) == pytest.approx(theta, abs=1e-12)
    assert lqr.lean_hold_torque(0.0, 0.17) == 0.0


def test_static_arm_is_the_moment_of_body_and_leg_about_the_axle():
    """A 1.42 kg half body 3 cm off its hip needs 0.42 N m at the hip and ~0.16 rad of lean at 0.17 m."""
    from wheelleg.controller.design import lqr as design

    hold = design.BODY_MASS_SIDE * 9.81 * 0.03
    assert 0.13 < -lqr.balance_lean(hold, 0.17, 1.0) < 0.19


def test_a_heavier_body_needs_less_lean_for_the_same_hold_torque():
    """The hold torque M g d grows with the true mass M: the lean it implies is divided by
    the weight the legs carry over the believed one, so d (the CoM) comes out the same."""
    nominal = lqr.balance_lean(0.4, 0.17, 1.0)
    heavy = lqr.balance_lean(0.4 * 1.4, 0.17, 1.0, weight_ratio=1.4)
    assert heavy == pytest.approx(nominal, rel=1e-9)
