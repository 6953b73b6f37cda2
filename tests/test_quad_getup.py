"""The quadruped's stand-up and recovery stand: the phase table in time, the trajectories'
ends and continuity, the weight feed-forward, and the roll-over pose's sides."""
from __future__ import annotations

import math

import numpy as np
import pytest

from wheelleg.controller.quadruped import constants as C
from wheelleg.controller.quadruped import kinematics as K
from wheelleg.controller.quadruped import legs
from wheelleg.controller.quadruped import params as P
from wheelleg.controller.quadruped.getup import (GetUp, Phase, fold_pose, has_fallen, is_upright, min_jerk,
                                                 roll_pose, stand_pose)
from wheelleg.controller.quadruped.sensed import Sensed

DT = P.CONTROL_PERIOD


def _sensed(q, rpy=(0.0, 0.0, 0.0)) -> Sensed:
    return Sensed(np.array(q, dtype=float), np.zeros((4, 3)), np.zeros((4, 3)), np.array(rpy), np.zeros(3))


def _run(getup: GetUp, seconds: float, rpy_of=lambda t: (0.0, 0.0, 0.0)):
    """Step ``getup`` on a robot whose joints follow exactly; (times, phases, commands) per tick."""
    q = getup.q_from.copy()
    out = []
    for k in range(round(seconds / DT)):
        commands = getup.step(_sensed(q, rpy_of(k * DT)))
        q = commands.q
        out.append((k * DT, getup.phase, commands))
    return out


def test_min_jerk_starts_and_ends_at_rest():
    assert min_jerk(0.0) == (0.0, 0.0) and min_jerk(1.0) == (1.0, 0.0)
    assert min_jerk(0.5)[0] == pytest.approx(0.5) and min_jerk(2.0) == (1.0, 0.0)


def test_stand_up_gathers_rises_and_holds_the_stand_in_two_seconds():
    lying = fold_pose()
    getup = GetUp()
    getup.start_stand_up(lying, P.HEIGHT_NOMINAL)
    ticks = _run(getup, 2.5)
    phase_at = {round(t, 3): phase for t, phase, _ in ticks}
    assert phase_at[0.0] == Phase.GATHER and phase_at[0.7] == Phase.RISE and phase_at[2.1] == Phase.DONE
    first, last = ticks[0][2], ticks[-1][2]
    assert np.abs(first.q - lying).max() < 0.01  # starts where the legs are
    assert last.q == pytest.approx(stand_pose(P.HEIGHT_NOMINAL))
    feet = legs.feet_in_body(last.q)
    assert -feet[:, 2].mean() + C.FOOT_RADIUS == pytest.approx(P.HEIGHT_NOMINAL, abs=1e-6)
    steps = [np.abs(b[2].q - a[2].q).max() for a, b in zip(ticks, ticks[1:])]
    assert max(steps) < 0.03  # rad a tick: no jump anywhere, phase changes included


def test_the_weight_is_fed_forward_over_the_rise_only():
    getup = GetUp()
    getup.start_stand_up(fold_pose(), P.HEIGHT_NOMINAL)
    ticks = _run(getup, 2.5)
    gather = [c.tau for _, phase, c in ticks if phase == Phase.GATHER]
    done = ticks[-1][2]
    assert all(np.all(t == 0.0) for t in gather)
    assert np.all(done.tau[:, 2] > 0.5)  # the knees pushed open by the full weight's share
    pushed = [np.linalg.solve(K.jacobian(done.q[i], C.SIDE[i], C.GEOMETRY).T, done.tau[i]) for i in range(4)]
    assert sum(p[2] for p in pushed) == pytest.approx(-C.MASS * C.GRAVITY, rel=1e-3)


def _recovering(q, rpy):
    getup = GetUp()
    getup.start_recovery(_sensed(q, rpy), P.HEIGHT_NOMINAL)
    return getup


def test_recovery_of_an_upright_robot_folds_then_stands():
    getup = _recovering(stand_pose(0.18), (0.0, 0.0, 0.0))
    phases = [phase for _, phase, _ in _run(getup, 3.5)]
    assert phases[0] == Phase.FOLD and Phase.ROLL not in phases and phases[-1] == Phase.DONE
    assert getup.done


@pytest.mark.parametrize("roll", [math.pi / 2, -math.pi / 2, 0.9 * math.pi], ids=["right-down", "left-down", "back"])
def test_recovery_from_a_side_rolls_over_first_then_folds_and_stands(roll):
    getup = _recovering(fold_pose(), (roll, 0.0, 0.0))
    rolled_at = P.ROLL_S + P.FLIP_S  # the roll-over turns it onto its belly
    ticks = _run(getup, 7.0, lambda t: (roll if t < rolled_at else 0.1, 0.0, 0.0))
    phases = [phase for _, phase, _ in ticks]
    order = [p for i, p in enumerate(phases) if i == 0 or phases[i - 1] != p]
    assert order == [Phase.ROLL, Phase.FLIP, Phase.SETTLE, Phase.FOLD, Phase.GATHER, Phase.RISE, Phase.DONE]
    rolled = next(c for _, phase, c in ticks if phase == Phase.FLIP).q
    flipped = next(c for _, phase, c in ticks if phase == Phase.SETTLE).q
    assert rolled == pytest.approx(roll_pose(roll, flip=False), abs=1e-3)
    assert flipped == pytest.approx(roll_pose(roll, flip=True))


def test_recovery_gives_up_after_its_attempts_and_lies_folded():
    getup = _recovering(fold_pose(), (math.pi / 2, 0.0, 0.0))
    ticks = _run(getup, 20.0, lambda t: (math.pi / 2, 0.0, 0.0))
    phases = [phase for _, phase, _ in ticks]
    assert getup.attempts == P.ROLL_ATTEMPTS and phases[-1] == Phase.GIVEN_UP
    assert ticks[-1][2].q == pytest.approx(fold_pose())


def test_the_roll_over_levers_with_the_lower_legs_behind_the_back():
    """Lying on the left side (roll < 0, ground toward body +y): in ROLL the left feet are behind the
    back (z > 0) and pressed toward the ground's side past the body; the right ones reach toward the
    belly (z < 0). The right side down is the mirror image."""
    q = roll_pose(-math.pi / 2, flip=False)
    feet = legs.feet_in_body(q)
    for leg in (1, 3):  # FL, RL
        assert feet[leg, 2] > 0.0 and feet[leg, 1] > C.HIP_Y + C.ABAD_LINK
    for leg in (0, 2):
        assert feet[leg, 2] < 0.0
    mirrored = roll_pose(math.pi / 2, flip=False)
    assert mirrored[[0, 2]] == pytest.approx(q[[1, 3]] * [-1, 1, 1])
    for flip in (False, True):
        pose = roll_pose(-math.pi / 2, flip)
        assert np.all(pose >= legs.LOWER) and np.all(pose <= legs.UPPER)


def test_upright_and_fallen():
    assert is_upright((0.1, -0.2, 3.0)) and not is_upright((0.0, 0.6, 0.0))
    assert has_fallen((0.0, 1.0, 0.0)) and has_fallen((-1.0, 0.0, 0.0)) and not has_fallen((0.5, 0.5, 2.0))


def test_a_robot_already_standing_rises_without_crouching_first():
    getup = GetUp()
    getup.start_stand_up(stand_pose(0.18), P.HEIGHT_NOMINAL)
    ticks = _run(getup, 1.6)
    assert ticks[0][1] == Phase.RISE and ticks[-1][1] == Phase.DONE
    lowest = min(-legs.feet_in_body(c.q)[:, 2].mean() + C.FOOT_RADIUS for _, _, c in ticks)
    assert lowest == pytest.approx(0.18, abs=1e-3)  # never lower than where it began
