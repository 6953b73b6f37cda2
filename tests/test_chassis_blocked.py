"""The chassis's collision reaction (controller/chassis.py ``_blocked_target``, docs/control.md,
collisions): cruising with the body held back it stops pushing until the command lets go."""
from wheelleg.controller import params as P
from wheelleg.controller.chassis import ChassisController
from wheelleg.controller.motion import Travel

RELEASE_TICKS = round(P.BLOCKED_RELEASE_S / P.CONTROL_PERIOD)


def cruising(body_speed: float, speed_ref: float = 0.4) -> ChassisController:
    chassis = ChassisController()
    chassis.travel, chassis.speed_ref, chassis.x = Travel.CRUISING, speed_ref, 0.3
    chassis.slip.speed_m_s = body_speed
    return chassis


def target(chassis: ChassisController, speed: float, axle_speed: float | None = None) -> float:
    """``_blocked_target`` of ``speed`` with the axles at ``axle_speed`` (None: on the set point)."""
    return chassis._blocked_target(speed, chassis.speed_ref if axle_speed is None else axle_speed)


def test_a_body_lagging_less_than_the_threshold_is_followed():
    chassis = cruising(0.4 - 0.9 * P.BLOCKED_LAG)
    assert target(chassis, 0.4) == 0.4
    assert chassis.blocked == 0.0 and chassis.speed_ref == 0.4


def test_held_back_it_stands_where_it_is_until_the_command_lets_go():
    chassis = cruising(0.4 - 1.1 * P.BLOCKED_LAG)
    assert target(chassis, 0.4) == 0.0
    assert (chassis.blocked, chassis.speed_ref, chassis.accel_ref, chassis.x_ref) == (1.0, 0.0, 0.0, 0.3)
    chassis.travel = Travel.STANDING
    # one tick at speed 0 (BALANCE between AIRBORNE and MOVE after a hop off the wall) is no release
    assert target(chassis, 0.0) == 0.0
    assert target(chassis, 0.4) == 0.0
    # backing away is followed at once; the forward command only once it let go long enough
    for _ in range(RELEASE_TICKS - 1):
        assert target(chassis, -0.2) == -0.2
    assert chassis.blocked == 1.0
    assert target(chassis, -0.2) == -0.2
    assert chassis.blocked == 0.0 and target(chassis, 0.4) == 0.4


def test_held_back_driving_backwards_blocks_that_way_only():
    chassis = cruising(-0.4 + 1.1 * P.BLOCKED_LAG, speed_ref=-0.4)
    assert target(chassis, -0.4) == 0.0
    assert chassis.blocked == -1.0
    assert target(chassis, 0.3) == 0.3


def test_axles_stopped_by_a_wall_are_held_back_before_the_body_lags():
    """At the impact the axles stop within 20 ms; the body's own lag builds up only as the legs
    tip over them (80 ms later with friction 0.5): the axles' lag decides it first."""
    chassis = cruising(0.4)
    assert target(chassis, 0.4, axle_speed=0.4 - 0.9 * P.BLOCKED_AXLE_LAG) == 0.4
    assert chassis.blocked == 0.0
    assert target(chassis, 0.4, axle_speed=0.4 - 1.1 * P.BLOCKED_AXLE_LAG) == 0.0
    assert (chassis.blocked, chassis.speed_ref, chassis.x_ref) == (1.0, 0.0, 0.3)


def test_axles_lagging_while_speeding_up_are_not_held_back():
    chassis = cruising(0.4)
    chassis.travel = Travel.SPEEDING_UP
    assert target(chassis, 0.4, axle_speed=-0.3) == 0.4 and chassis.blocked == 0.0
