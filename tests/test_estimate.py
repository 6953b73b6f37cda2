"""The controller's sensor estimators (controller/estimate.py) on synthetic signals."""
import math
import random

import pytest

from wheelleg.controller import estimate
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
