"""Body-on-the-ground estimate (controller/posture.py)."""
import math

import pytest

from wheelleg.controller import constants as C
from wheelleg.controller.posture import body_clearance

UPRIGHT = math.pi / 2  # phi0 of a leg straight down the body


def _legs(L0, phi0=UPRIGHT):
    return ((C.LEG_PLANE_Y, L0, phi0), (-C.LEG_PLANE_Y, L0, phi0))


def test_standing_upright_the_body_is_well_clear():
    # wheel bottom 0.02 + L0 + R below the CoM, box bottom 0.04 below it
    expected = C.BODY_COM_ABOVE_HIP + 0.17 + C.WHEEL_RADIUS - C.BODY_SIZE[2] / 2
    assert body_clearance(0.0, 0.0, _legs(0.17)) == pytest.approx(expected)


def test_pitching_nose_down_with_short_legs_brings_the_nose_to_the_ground():
    assert body_clearance(0.0, 0.3, _legs(0.12)) > 0.02
    assert body_clearance(0.0, 1.0, _legs(0.12)) < 0.0


def test_legs_swung_back_under_a_nose_down_body_put_it_on_the_ground():
    # lying on its nose, legs limp and swung back (theta ~1.3 rad from the world vertical)
    pitch, theta = 0.77, 1.31
    phi0 = math.pi / 2 - theta + pitch
    assert body_clearance(0.0, pitch, _legs(0.217, phi0)) < 0.01


def test_roll_on_one_side():
    assert body_clearance(0.5, 0.0, _legs(0.17)) < body_clearance(0.1, 0.0, _legs(0.17))


def test_the_lowest_corner_is_the_least_of_all_eight_bit_for_bit():
    # body_clearance works out one corner picked by the height row's signs; every corner's
    # height, as the sum is rounded, must never come out below it
    import itertools
    import random

    from wheelleg.controller import posture

    rng = random.Random(7)
    half = tuple(0.5 * v for v in C.BODY_SIZE)
    corners = list(itertools.product(*((-h, h) for h in half)))
    for _ in range(2000):
        roll, pitch = rng.uniform(-math.pi, math.pi), rng.uniform(-math.pi, math.pi)
        row = posture._height_row(roll, pitch)
        least = min(posture._height_in(row, corner) for corner in corners)
        assert posture._height_in(row, posture._lowest_corner(row)) == least


def test_the_side_tilt_is_defined_lying_on_the_nose_where_the_euler_roll_is_not():
    """At 90 deg of pitch the ZYX roll may read anything (gimbal lock): `fall` on seed 1 ended
    standing on its nose with both wheels down and the roll test called it on its side."""
    from wheelleg.controller.posture import side_tilt, tilt_from_upright
    assert side_tilt(2.9, math.pi / 2) == pytest.approx(0.0, abs=1e-9)
    assert side_tilt(0.3, 0.0) == pytest.approx(0.3)
    assert tilt_from_upright(math.pi, 0.0) == pytest.approx(math.pi)
    assert tilt_from_upright(0.2, 0.0) == pytest.approx(0.2)


@pytest.mark.parametrize("roll, pitch, expected", [
    (2.9, math.pi / 2, True),  # standing on its nose, the roll arbitrary
    (0.0, -1.0, True),  # on its tail
    (3.1, 0.1, False),  # on its back
    (1.5, 0.5, False),  # on its side
    (0.0, 0.3, False),  # upright enough: no recovery
])
def test_recoverable_lying_is_on_the_nose_or_tail_only(roll, pitch, expected):
    from wheelleg.controller import params as P
    from wheelleg.controller.posture import recoverable
    assert recoverable(roll, pitch, P.FALL_PITCH, P.RECOVERY_LYING_MAX, P.FALL_ROLL) is expected
