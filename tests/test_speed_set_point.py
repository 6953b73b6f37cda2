"""The speed set point (controller/motion.py): an S-curve the robot can follow, and its phases."""
import pytest

from wheelleg.controller import params as P
from wheelleg.controller.motion import Travel, ease_jerk, speed_set_point, travel_phase

DT = P.CONTROL_PERIOD


def curve(speed: float, target: float, ticks: int = 5000, accel: float = 0.0) -> list[tuple[float, float]]:
    """(speed m/s, acceleration m/s^2) of every period until the set point sits at ``target``."""
    out = [(speed, accel)]
    for _ in range(ticks):
        speed, accel = speed_set_point(speed, accel, target, DT)
        out.append((speed, accel))
        if (speed, accel) == (target, 0.0):
            return out
    raise AssertionError(f"not at {target} m/s after {ticks} ticks: {out[-1]}")


def assert_follows_its_acceleration(points):
    """Each period's speed change is that period's acceleration, within the limits (a
    period that starts easing off may meet the parabola from just above it)."""
    for (v0, a0), (v1, a1) in zip(points, points[1:]):
        assert abs(a1) <= P.ACCEL_LIMIT + 1e-12
        assert abs(a1 - a0) <= (P.SPEED_JERK + P.SPEED_EASE_JERK) * DT + 1e-9
        if a1:
            assert (v1 - v0) / DT == pytest.approx(a1, abs=1e-9)


@pytest.mark.parametrize("start, target", [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (2.0, 0.0), (1.0, 0.5)])
def test_an_s_curve_at_the_limits_lands_on_the_target(start, target):
    points = curve(start, target)
    assert_follows_its_acceleration(points)
    speeds = [v for v, _ in points]
    assert speeds == sorted(speeds) or speeds == sorted(speeds, reverse=True)  # no overshoot
    assert (len(points) - 1) * DT == pytest.approx(trapezoid(abs(target - start))[-1], abs=0.01)


def trapezoid(change: float) -> tuple[float, float, float]:
    """Ends (s) of the ramp up, the plateau and the easing of an acceleration trapezoid
    at the limits that changes the speed by ``change`` (m/s), long enough for a plateau."""
    a = P.ACCEL_LIMIT
    up, ease = a / P.SPEED_JERK, a / P.SPEED_EASE_JERK
    plateau = change / a - (up + ease) / 2
    return up, up + plateau, up + plateau + ease


def test_a_stop_from_1_m_s_takes_the_curves_own_distance():
    """Braking from v, the set point travels v times the deceleration's centroid in time."""
    travel = sum(v for v, _ in curve(1.0, 0.0)) * DT
    t1, t2, t3 = trapezoid(1.0)
    a = P.ACCEL_LIMIT
    areas = (a * t1 / 2, a * (t2 - t1), a * (t3 - t2) / 2)  # m/s each, 1 m/s in all
    centroid = (areas[0] * 2 * t1 / 3 + areas[1] * (t1 + t2) / 2 + areas[2] * (t2 + (t3 - t2) / 3)) / sum(areas)
    assert sum(areas) == pytest.approx(1.0)
    assert travel == pytest.approx(1.0 * centroid, rel=0.02)


def test_a_reversal_is_one_curve_through_zero():
    points = curve(1.0, -1.0)
    assert_follows_its_acceleration(points)
    assert all(a <= 0.0 for _, a in points)  # decelerating all the way: no stop on the way
    assert min(a for _, a in points) == pytest.approx(-P.ACCEL_LIMIT)


def test_a_target_changed_midway_is_headed_for_from_where_the_curve_is():
    points = curve(0.0, 1.0)[:100]  # 0.2 s into speeding up
    speed, accel = points[-1]
    assert accel > 0.0
    assert_follows_its_acceleration(points + curve(speed, 0.0, accel=accel)[1:])


def test_standing_or_cruising_it_stays():
    assert speed_set_point(0.0, 0.0, 0.0, DT) == (0.0, 0.0)
    assert speed_set_point(1.3, 0.0, 1.3, DT) == (1.3, 0.0)


def test_the_phases_of_a_drive_and_back():
    """Out at 1 m/s, back at -1 m/s in one reversal, stop: each phase where the curve is."""
    phases = [travel_phase(v, a) for v, a in curve(0.0, 1.0) + curve(1.0, -1.0)[1:] + curve(-1.0, 0.0)[1:]]
    runs = [p for i, p in enumerate(phases) if i == 0 or p is not phases[i - 1]]
    assert runs == [Travel.STANDING, Travel.SPEEDING_UP, Travel.CRUISING, Travel.BRAKING, Travel.SPEEDING_UP,
                    Travel.CRUISING, Travel.BRAKING, Travel.STANDING]


def test_near_the_top_speed_the_acceleration_eases_off_slower():
    """Onto SPEED_LIMIT the easing takes SPEED_EASE_JERK / SPEED_EASE_JERK_TOP times as long (the
    wheels overtake the set point as the lean comes out: headroom a flat battery lacks); onto
    1.5 m/s and lower, and every stop, as before."""
    assert ease_jerk(P.SPEED_LIMIT) == ease_jerk(-P.SPEED_LIMIT) == P.SPEED_EASE_JERK_TOP
    assert ease_jerk(0.0) == ease_jerk(P.SPEED_EASE_TOP_FROM) == P.SPEED_EASE_JERK
    assert P.SPEED_EASE_JERK_TOP < ease_jerk(1.75) < P.SPEED_EASE_JERK
    top = curve(0.0, P.SPEED_LIMIT)
    ease_ticks = sum(1 for (_, a0), (_, a1) in zip(top, top[1:]) if a1 < a0)  # from ACCEL_LIMIT down to 0
    assert ease_ticks * DT == pytest.approx(P.ACCEL_LIMIT / P.SPEED_EASE_JERK_TOP, abs=0.01)  # as the curve's
    speeds = [v for v, _ in top]
    assert speeds == sorted(speeds)  # no overshoot
