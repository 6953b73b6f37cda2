"""The terrain scenarios (slope, bump, step-down, turn-fast, sprint) in the rig."""
import math

import numpy as np
import pytest

from wheelleg.controller import constants as C
from wheelleg.controller import params as P
from wheelleg.controller.legs import leg_targets, roll_leg_difference, turn_lean
from wheelleg.hil.run.scenario import RunData
from wheelleg.hil.scenarios import ground

from sharing import each_run, same_run

GROUND = ("slope", "bump", "step-down", "turn-fast", "sprint")


@pytest.mark.parametrize("name", each_run(GROUND))
def test_scenario_passes_its_checks(name, rig_run):
    rig_run(name).assert_passed()


@same_run("slope")
def test_on_the_slope_the_legs_take_up_the_tilt(rig_run):
    """Level body on a 15 deg slope means the legs differ by the slope across the track."""
    run = rig_run("slope")
    t = run.state["t"]
    diff = (run.state["right_leg_length"] - run.state["left_leg_length"])[t > 4.0]
    expected = 2 * C.HALF_TRACK * math.tan(math.radians(15))  # right (downhill) leg longer
    assert np.all(np.abs(diff - expected) < 0.015), (float(diff.min()), float(diff.max()), expected)


def test_turn_lean_leans_into_the_turn():
    assert turn_lean(1.5, 2.0) == pytest.approx(-math.atan(3.0 / C.GRAVITY))  # left turn: left side down
    assert turn_lean(1.5, -2.0) > 0
    assert turn_lean(0.0, 3.0) == 0.0
    assert turn_lean(5.0, 4.0) == -P.TURN_LEAN_LIMIT


def test_roll_leg_difference_is_the_feed_forward_plus_the_integral_clamped():
    assert roll_leg_difference(0.0, 0.02) == pytest.approx(0.02)
    assert roll_leg_difference(0.1, 0.0) == pytest.approx(2 * C.HALF_TRACK * math.tan(0.1))
    assert roll_leg_difference(0.5, 0.1) == P.ROLL_LEVEL_LIMIT


def test_leg_targets_keep_the_difference_inside_the_leg_range():
    t = leg_targets(0.17, 0.12)
    assert t["left"] - t["right"] == pytest.approx(0.12)
    assert t["right"] == pytest.approx(P.LEG_LENGTH_MIN)  # shifted up: 0.11 would be below the range
    t = leg_targets(0.25, -0.04)
    assert (t["left"], t["right"]) == pytest.approx((P.LEG_LENGTH_MAX - 0.04, P.LEG_LENGTH_MAX))
    t = leg_targets(0.17, 0.0)
    assert t == pytest.approx({"left": 0.17, "right": 0.17})


def test_factories_refuse_nonsense_sizes():
    for make in (lambda: ground.slope_scenario(0.0), lambda: ground.bump_scenario(0.0),
                 lambda: ground.step_down_scenario(-0.1), lambda: ground.turn_fast_scenario(0.0),
                 lambda: ground.sprint_scenario(0.0)):
        with pytest.raises(ValueError):
            make()


def test_a_wheel_counts_as_lifted_when_its_load_stays_off_not_for_one_contact_sample():
    """One 2 ms sample of 0 N with the wheel pressed into the floor is MuJoCo's contact; 20 ms off is a tip."""
    t = np.arange(0, 1.0, 0.002)

    def run(right_n):
        return RunData(state={"t": t, "left_normal_force": np.full(len(t), 20.0), "right_normal_force": right_n},
                       heartbeat={}, hip_torque={}, wheel_current={})

    blip = np.full(len(t), 18.0)
    blip[250] = 0.0
    assert ground.both_wheels_down(0.2, 0.8)(run(blip)).passed
    lifted = np.full(len(t), 18.0)
    lifted[250:260] = 0.0
    result = ground.both_wheels_down(0.2, 0.8)(run(lifted))
    assert not result.passed and "least sample 0.0 N" in result.detail
